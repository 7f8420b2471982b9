"""The researcher's pages at 800 px (a laptop's half screen, the sidebar open) and at 1280 px: no
metric's label or value is cut. In ``st.columns`` the Overview's four metrics had 105 px each
("Interaction…", "Mean success r…"), the Results' "9.7 dat…"; in ``ui.metric_row`` a metric that
does not fit goes on to the next line whole, and at 1280 px every row is one line, as before."""

from __future__ import annotations

import random
import re
import time

import pytest

from cacas import spaces
from cacas.store import StudyStore
from conftest import _run_app, close_page, open_page
from test_browser_mini_study import goto

pytestmark = pytest.mark.browser

#: per metric: its label, whether its label or value is cut (an element narrower than its text,
#: which Streamlit ends with an ellipsis), and its top on the page
METRICS_JS = """() => [...document.querySelectorAll('[data-testid=stMetric]')].filter(m => m.offsetParent).map(m => {
  const parts = [...m.querySelectorAll('[data-testid=stMetricLabel] *, [data-testid=stMetricValue] *')];
  return {label: m.querySelector('[data-testid=stMetricLabel]').innerText,
          cut: parts.some(e => e.scrollWidth > e.clientWidth + 1),
          top: Math.round(m.getBoundingClientRect().top)};
})"""


@pytest.fixture(scope="module")
def study_server(tmp_path_factory, initial_policy):
    """The app over a study: 4 participants on day 1 with 12 interactions each, 2 of the days closed; on the 2
    open days one more, not counted."""
    from cacas.study_day import Context, answer, policy_in_force, previous_interaction, propose, start_day

    tmp = tmp_path_factory.mktemp("narrow")
    db = tmp / "study.sqlite"
    rng = random.Random(0)
    with StudyStore(db) as s:
        for i, code in enumerate(("P01", "P02", "P03", "P04")):
            s.add_participant(code)
            # P01's at five times of day (the Participants page's field of them, on a phone)
            s.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}
                                      | ({"hours": [[8, 18]]} if code == "P01" else {})])
            day = start_day(s, code)
            policy, version = policy_in_force(s, code)
            for k in range(12):
                ctx = Context.from_choices(rng.randrange(12), rng.randrange(12), rng.choice(spaces.ACTIVITIES[:6]),
                                           rng.choice(spaces.SCENES))
                p = propose(policy, ctx, previous_interaction(s, code, day), policy_version=version)
                answer(s, code, day, p, response=rng.choice(["accept", "reject"]) if p.robot_speaks else "no response",
                       index=k + 1)
            if i < 2:
                s.close_day(code, day)
            else:  # and one not counted (no response): the researcher's counter says it apart
                p = propose(policy, ctx, previous_interaction(s, code, day), policy_version=version)
                answer(s, code, day, p, response="no response", index=13)
    yield from _run_app(tmp, CACAS_DB=str(db))


@pytest.mark.parametrize("width", [800, 1280])
def test_no_metric_is_cut_beside_the_sidebar(browser, study_server, width):
    page = open_page(browser, viewport={"width": width, "height": 900})
    page.set_default_timeout(60_000)
    try:
        seen = {}
        for path, last in (("", "Mean success rate so far"), ("results", "Participants on day 1"),
                           ("adaptation", "Policy in force")):
            goto(page, f"{study_server}/{path}?participant=P01")
            # the row drawn to its last metric (on a loaded machine the first alone was read), and no element
            # still a placeholder: with Chromium slowed 4 times, the Overview's first three metrics were grey
            # skeletons after the run was over, while its last was drawn (CACAS_BROWSER_SLOWDOWN)
            page.wait_for_function(f"() => [...document.querySelectorAll('[data-testid=stMetricLabel]')]"
                                   f".some(e => e.innerText.includes({last!r}))"
                                   f" && !document.querySelector('[data-testid=stMain] [data-testid=stSkeleton]')")
            page.wait_for_timeout(300)
            metrics = page.evaluate(METRICS_JS)
            assert metrics, path
            seen[path or "overview"] = metrics
        cut = {p: [m["label"] for m in ms if m["cut"]] for p, ms in seen.items()}
        assert not any(cut.values()), cut
        assert [m["label"] for m in seen["overview"]] == ["Participants", "Started", "Interactions on open days",
                                                          "Mean success rate so far"]
        if width == 1280:  # room enough: each page's metrics side by side on one line
            assert all(len({m["top"] for m in ms}) == 1 for ms in seen.values()), seen
    finally:
        close_page(page)


#: the Study session's counter: its text and the lines it takes (the distinct tops of its text's boxes)
COUNTER_JS = """() => { const p = document.querySelector('[data-testid=stProgress] p');
  const r = document.createRange(); r.selectNodeContents(p);
  return {text: p.innerText, lines: new Set([...r.getClientRects()].map(b => Math.round(b.top))).size}; }"""


@pytest.mark.parametrize("width", [1024, 1280, 1440])
def test_the_researchers_counter_is_one_line_when_some_interactions_are_not_counted(browser, study_server, width):
    """The ui helpers saw the Study session's counter run to two lines at 1280 px (and 1024) when some of the
    day's interactions were not counted: it gave the reasons too ("(no response, nothing needed while the
    robot was quiet, or a request while doing nothing)"), which the day's table now gives."""
    page = open_page(browser, viewport={"width": width, "height": 900})
    page.set_default_timeout(60_000)
    try:
        goto(page, f"{study_server}/session?participant=P03")
        page.wait_for_function("() => [...document.querySelectorAll('[data-testid=stProgress] p')]"
                               ".some(p => p.innerText.includes('not counted'))")
        counter = page.evaluate(COUNTER_JS)
        assert counter["lines"] == 1, counter
        assert re.fullmatch(r"Day 1 of 7 · \d+ of about 15 interactions today; 13 in all with \d+ not counted",
                            counter["text"]), counter
    finally:
        close_page(page)


#: the "Every photo of one room" grid: each caption's text, the lines it takes, and its photo's top (a row's)
PHOTO_GRID_JS = """() => [...document.querySelectorAll("[data-testid='stExpander'] [data-testid='stImage']")].map(i => {
  const p = i.querySelector("[data-testid='stImageCaption'] p"); const r = document.createRange(); r.selectNodeContents(p);
  return {text: p.innerText, lines: new Set([...r.getClientRects()].map(b => Math.round(b.top))).size,
          top: Math.round(i.getBoundingClientRect().top)}; })"""


@pytest.mark.parametrize("width", [1024, 1280, 1440])
def test_every_photo_s_name_is_on_one_line(browser, study_server, width):
    """The ui helpers saw the photo grid's captions break mid-name at 1024 px ("synthetic_0_00" / "0.jpg"): its
    columns were fitted to 1280 px (five of 144 px; at 1024 five of 93). The photos now stand in a row that wraps,
    each as wide as its longest name needs (table_layouts.photo_width): as many side by side as the window
    holds, five at 1280 px as before, every name on one line."""
    from test_browser_mini_study import ran, runs

    page = open_page(browser, viewport={"width": width, "height": 900})
    page.set_default_timeout(60_000)
    try:
        goto(page, f"{study_server}/sounds")
        page.get_by_role("tab", name="Scene library").click()
        before = runs(page)
        page.get_by_text("Every photo of one room", exact=True).click()  # drawn while open: a run
        ran(page, before)
        page.wait_for_function("() => document.querySelectorAll(`[data-testid='stExpander'] "
                               "[data-testid='stImageCaption'] p`).length >= 40")
        photos = page.evaluate(PHOTO_GRID_JS)
        assert sorted(p["text"] for p in photos) == [f"synthetic_0_{k:03d}.jpg" for k in range(40)]  # the bedroom's
        assert [p["text"] for p in photos if p["lines"] != 1] == [], width
        in_first_row = sum(p["top"] == photos[0]["top"] for p in photos)
        assert in_first_row >= {1024: 3, 1280: 5, 1440: 5}[width], in_first_row
    finally:
        close_page(page)


#: a phone held upright by a researcher between rooms: touch, no hover (Streamlit and Plotly show their toolbars always)
PHONE = dict(viewport={"width": 390, "height": 844}, is_mobile=True, has_touch=True)

#: what stands over something else on a touch screen: each table's toolbar over the element before the table, each
#: chart's modebar over the chart's title (boxes as [left, top, right, bottom])
TOOLBARS_JS = """() => {
  const box = e => { const r = e.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; };
  const meet = (a, b) => a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3];
  const shown = e => e.getBoundingClientRect().height > 0;
  const over = [];
  for (const t of document.querySelectorAll('[data-testid=stMain] [data-testid=stDataFrame] [data-testid=stElementToolbar]')) {
    const container = t.closest('.stElementContainer'); const before = container.previousElementSibling;
    if (shown(t) && before && shown(before) && meet(box(t), box(before)))
      over.push('a table toolbar over: ' + before.innerText.slice(0, 60));
  }
  let charts = 0;
  for (const c of document.querySelectorAll('[data-testid=stMain] .js-plotly-plot')) {
    const bar = c.querySelector('.modebar'); const title = c.querySelector('.gtitle');
    if (!shown(c) || !bar || !title) continue;
    charts += 1;
    if (meet(box(bar), box(title))) over.push('a modebar over the title ' + title.textContent);
  }
  return {over, tables: document.querySelectorAll('[data-testid=stMain] [data-testid=stDataFrame]').length, charts};
}"""

#: the pages where a table or a chart follows words, and what to wait for on each
WITH_TOOLBARS = (("", "[data-testid=stDataFrame]"), ("participants", "[data-testid=stDataFrame]"),
                 ("results", ".js-plotly-plot .gtitle"))


@pytest.mark.parametrize("path, wait", WITH_TOOLBARS, ids=["overview", "participants", "results"])
def test_on_a_phone_no_toolbar_covers_words_or_a_chart_s_title(browser, study_server, path, wait):
    """A touch screen has no hover: Streamlit shows a table's toolbar (44 px above the table) and Plotly a chart's
    modebar always. On a phone the toolbar covered the last line of the words before a table (Adaptation's "before
    and after are shares of ...", the Overview's "Recent activity") and the modebar the chart's title (Fig. 3's
    "Success rate and cumulative feedback"); each now stands in a row of its own (app.APP_STYLE)."""
    page = open_page(browser, **PHONE)
    page.set_default_timeout(60_000)
    try:
        goto(page, f"{study_server}/{path}?participant=P01")
        page.wait_for_selector(f"[data-testid=stMain] {wait}")
        page.wait_for_timeout(300)
        found = page.evaluate(TOOLBARS_JS)
        assert found["tables"] or found["charts"], found
        assert found["over"] == [], found
    finally:
        close_page(page)


#: the least height and width (px) of what is tapped, per kind, among those in view (the sidebar's only while it is open)
TARGETS_JS = """() => {
  const kinds = {open: "[data-testid=stExpandSidebarButton]", close: "[data-testid=stSidebarCollapseButton] button",
                 link: "[data-testid=stPageLink-NavLink]", tab: "[data-testid=stMain] [data-testid=stTab]",
                 choice: "[data-testid=stMain] [data-testid=stButtonGroup] button",
                 button: "[data-testid=stMain] button[data-testid^=stBaseButton]",
                 stepper: "[data-testid=stMain] [data-testid^=stNumberInputStep]"};
  // Streamlit's table toolbar (its icons 24 px wide, in a row 44 high on a touch screen) is not counted
  const least = {};
  for (const [kind, selector] of Object.entries(kinds)) {
    const boxes = [...document.querySelectorAll(selector)].filter(e => !e.closest('[data-testid=stElementToolbar]'))
      .map(e => e.getBoundingClientRect())
      .filter(r => r.width > 0 && r.height > 0 && r.right > 0);
    if (boxes.length) least[kind] = [Math.min(...boxes.map(r => Math.round(r.height))),
                                     Math.min(...boxes.map(r => Math.round(r.width)))];
  }
  return least;
}"""
#: the main area's tabs: each one's edges and whether its label is whole (no wider than the tab)
TABS_JS = """() => [...document.querySelectorAll('[data-testid=stMain] [data-testid=stTab]')].map(t => {
  const r = t.getBoundingClientRect();
  return {text: t.innerText, left: Math.round(r.left), right: Math.round(r.right), whole: t.scrollWidth <= t.clientWidth};
})"""
#: how far (px) the page's title stands below the top of the page's column: nothing comes before it
TITLE_OFFSET_JS = """() => { const column = document.querySelector('[data-testid=stMainBlockContainer]');
  return Math.round(document.querySelector('[data-testid=stMain] h1').getBoundingClientRect().top
                    - column.getBoundingClientRect().top - parseFloat(getComputedStyle(column).paddingTop)); }"""
#: from the page's load on, the most the title ever stood below its place (TITLE_OFFSET_JS at every frame drawn)
TITLE_LOWEST_INIT = """window.__cacasTitleLowest = 0;
const cacasLook = () => { const column = document.querySelector('[data-testid=stMainBlockContainer]');
  const title = document.querySelector('[data-testid=stMain] h1');
  if (column && title) window.__cacasTitleLowest = Math.max(window.__cacasTitleLowest, Math.round(
    title.getBoundingClientRect().top - column.getBoundingClientRect().top - parseFloat(getComputedStyle(column).paddingTop)));
  requestAnimationFrame(cacasLook); };
requestAnimationFrame(cacasLook);"""
SIDEBAR_OPEN_JS = "() => document.querySelector('[data-testid=stSidebar]').getBoundingClientRect().right > 0"


def test_on_a_phone_what_is_tapped_is_44_px_and_a_page_link_closes_the_sidebar(browser, study_server):
    """At 390 x 844 with touch the sidebar's open and close buttons were 28 x 28, its page links 28 px high, buttons
    and tabs 40, Results' choice of data 32, a number's "-" and "+" 32 x 38 (Participants' "Preferences on the form")
    (app.TOUCH_STYLE: 44 at least, WCAG 2.5.5); and a page link tapped in the
    sidebar, which lies over the page there, left it open over the page it opened (app.CLOSE_SIDEBAR_SCRIPT)."""
    from test_browser_mini_study import ran, runs

    page = open_page(browser, **PHONE)
    page.set_default_timeout(60_000)
    try:
        goto(page, f"{study_server}/?participant=P01")
        # the header's buttons take their size in a transition (200 ms; later on a loaded machine): given 5 s
        grown = "() => document.querySelector('[data-testid=stExpandSidebarButton]').getBoundingClientRect().height >= 44"
        page.wait_for_function(grown, timeout=5_000)
        sizes = page.evaluate(TARGETS_JS)  # the sidebar closed: its open button
        page.locator("[data-testid=stExpandSidebarButton]").tap()
        page.wait_for_function(SIDEBAR_OPEN_JS)
        page.wait_for_timeout(400)  # its slide
        sizes.update(page.evaluate(TARGETS_JS))
        before = runs(page)
        page.locator("[data-testid=stSidebar] [data-testid=stPageLink-NavLink]", has_text="Results").tap()
        ran(page, before)
        page.wait_for_selector("[data-testid=stMain] [data-testid=stTab]")
        assert "/results" in page.url
        page.wait_for_timeout(400)
        assert not page.evaluate(SIDEBAR_OPEN_JS), "the sidebar stayed over the page"
        sizes.update({k: v for k, v in page.evaluate(TARGETS_JS).items() if k in ("tab", "choice")})
        goto(page, f"{study_server}/participants?participant=P01")  # "Save preferences", "Add a participant"
        page.wait_for_selector("[data-testid=stMain] button[data-testid=stBaseButton-primary]")
        sizes.update({k: v for k, v in page.evaluate(TARGETS_JS).items() if k in ("button", "stepper")})
        # four tabs, wider together than the phone: each whole, beside the next (a least width alone let them shrink
        # into one another, "Preferences of P01Details of P01"), the rest a swipe away as before
        tabs = page.evaluate(TABS_JS)
        assert len(tabs) == 4 and all(t["whole"] for t in tabs), tabs
        assert all(a["right"] <= b["left"] for a, b in zip(tabs, tabs[1:])), tabs
        assert set(sizes) >= {"open", "close", "link", "tab", "choice", "button", "stepper"}, sizes
        assert {k: v for k, v in sizes.items() if min(v) < 44} == {}, sizes
    finally:
        close_page(page)


def test_on_a_laptop_the_sidebar_stays_open_and_buttons_are_as_before(browser, study_server):
    """Beside the page (1280 px, a mouse) a page link leaves the sidebar open, the buttons keep Streamlit's 40 px
    (the touch style is for a coarse pointer only), and the page's title stands where it stood, from the first frame
    drawn: the script's placeholder, while Streamlit loaded its st.html, held it 56 px lower for up to a second."""
    from test_browser_mini_study import ran, runs

    page = open_page(browser, viewport={"width": 1280, "height": 800})
    page.set_default_timeout(60_000)
    page.add_init_script(TITLE_LOWEST_INIT)
    try:
        goto(page, f"{study_server}/?participant=P01")
        assert page.evaluate(SIDEBAR_OPEN_JS)
        # the script's element takes no room: with it shown, the title stood 16 px lower (a gap of the page's column)
        assert page.evaluate(TITLE_OFFSET_JS) == 0
        assert page.evaluate("() => window.__cacasTitleLowest") == 0
        before = runs(page)
        page.locator("[data-testid=stSidebar] [data-testid=stPageLink-NavLink]", has_text="Results").click()
        ran(page, before)
        page.wait_for_selector("[data-testid=stMain] [data-testid=stTab]")
        page.wait_for_timeout(400)
        assert page.evaluate(SIDEBAR_OPEN_JS)
        sizes = page.evaluate(TARGETS_JS)
        assert sizes["tab"][0] == 40 and sizes["choice"][0] == 32, sizes
    finally:
        close_page(page)


#: each multi-choice field of the page: its label, and the chosen options (chips) not wholly inside it
CHIPS_JS = """() => [...document.querySelectorAll('[data-testid=stMain] [data-testid=stMultiSelect]')].map(m => {
  const field = m.querySelector('[data-testid=stMultiSelectTagsContainer]').getBoundingClientRect();
  const chips = [...m.querySelectorAll('[aria-label^=Remove]')].map(x => x.parentElement);
  return {label: m.querySelector('label').innerText, chips: chips.map(c => c.innerText.trim()),
          out: chips.filter(c => { const r = c.getBoundingClientRect();
                                   return r.left < field.left || r.right > field.right + 0.5 || r.bottom > field.bottom + 0.5; })
                    .map(c => c.innerText.trim())};
})"""


def test_on_a_phone_every_chosen_time_of_day_is_in_view(browser, study_server):
    """Outside a form Streamlit keeps a multi-choice field's chips on one line that scrolls sideways: on a phone the
    preference form's "Time of day (S3)" showed two and a half of P01's five times, the third cut and faded at the
    field's edge ("16:00-18"), the rest out of sight. They now wrap (app.APP_STYLE), as in a form."""
    page = open_page(browser, **PHONE)
    page.set_default_timeout(60_000)
    try:
        goto(page, f"{study_server}/participants?participant=P01")
        page.wait_for_selector("[data-testid=stMain] [data-testid=stMultiSelect] [aria-label^=Remove]")
        page.wait_for_timeout(300)
        fields = page.evaluate(CHIPS_JS)  # Preference 1's fields first (P01's saved one), then the four empty ones
        assert fields[2]["label"] == "Time of day (S3)" and fields[2]["chips"] == ["08:00-10:00", "10:00-12:00", "12:00-14:00", "14:00-16:00",
                                                      "16:00-18:00"], fields
        assert [(f["label"], f["out"]) for f in fields if f["out"]] == [], fields
    finally:
        close_page(page)


def test_a_page_is_read_once_its_elements_whose_code_loads_late_are_drawn(browser, study_server):
    """The browser loads the code of most of Streamlit's elements (a multi-choice field's among them) once a page,
    when the page first draws one; meanwhile a placeholder (stSkeleton) stands in for it, after the run is over.
    The phone test above read the Participants page then at load 7-10 (CI, two browser tests at a time) and found
    its fields out of order. Here the multi-choice field's code is held back 3 s: the tests' ``goto`` waits for it
    (``headless.drawn``), and every field is drawn when it returns."""
    page = open_page(browser, **PHONE)
    page.set_default_timeout(60_000)
    held = []

    def hold(route):
        held.append(route.request.url)
        time.sleep(3)
        route.continue_()

    try:
        page.route(re.compile(r"/static/js/Multiselect\.[^/]*\.js$"), hold)
        goto(page, f"{study_server}/participants?participant=P01")
        assert len(held) == 1, held
        assert page.locator("[data-testid=stSkeleton]").count() == 0
        fields = page.evaluate(CHIPS_JS)
        assert [f["label"] for f in fields[:3]] == ["Activities (S1)", "Rooms (S2)", "Time of day (S3)"], fields
    finally:
        close_page(page)


#: the page's title, its code written as ``code`` (a longer one than the study's): its top, the header's sidebar
#: button's bottom, and whether a "·" in it begins a line (the character before it is on a line above)
TITLE_JS = """code => { const h1 = document.querySelector('[data-testid=stMain] h1');
  const button = document.querySelector('[data-testid=stExpandSidebarButton]').getBoundingClientRect();
  const walker = document.createTreeWalker(h1, NodeFilter.SHOW_TEXT); let dot_first = null, node;
  while ((node = walker.nextNode())) { const at = node.data.indexOf('·'); if (at < 1) continue;
    node.data = node.data.replace('P01', code);
    const rect = (i) => { const r = document.createRange(); r.setStart(node, i); r.setEnd(node, i + 1);
                          return r.getBoundingClientRect(); };
    dot_first = rect(at).top > rect(at - 1).top + 1; }
  return {top: Math.round(h1.getBoundingClientRect().top), button: Math.round(button.bottom), dot_first}; }"""


@pytest.mark.parametrize("path", ["session", "adaptation"])
def test_on_a_phone_the_title_starts_under_the_header_and_its_dot_never_begins_a_line(browser, study_server, path):
    """Phone walkthrough: Streamlit's 6rem above every page put the title at 120 px of 844 (4rem at most 640 px wide,
    below the header's sidebar button), and "Study session · P002" broke before its "·", which began the second
    line (a no-break space before it)."""
    page = open_page(browser, **PHONE)
    page.set_default_timeout(60_000)
    try:
        goto(page, f"{study_server}/{path}?participant=P01")
        page.wait_for_selector("[data-testid=stMain] h1")
        page.wait_for_timeout(300)  # the header's buttons take their size in a transition
        title = page.evaluate(TITLE_JS, "P002")  # the walkthrough's "Study session · P002"
        assert title["button"] < title["top"] <= 90, title
        assert title["dot_first"] is False, title
    finally:
        close_page(page)
