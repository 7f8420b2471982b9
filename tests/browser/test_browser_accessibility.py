"""The app as a screen reader and a keyboard meet it (accessibility walkthrough, headless Chromium): what the
accessibility tree names, and what the keyboard's focus shows. Participants are older adults on the tablet view."""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from cacas.plots import contrast_ratio
from cacas.store import StudyStore
from cacas.study_day import Context
from conftest import _run_app, close_page, open_page
from test_browser_mini_study import goto

pytestmark = pytest.mark.browser

#: how Streamlit names a ``:material/...`` icon written in text: its ligature ("check icon")
ICON_NAME = re.compile(r"^[a-z_]+ icon$")


@pytest.fixture(scope="module")
def day_1(tmp_path_factory, initial_policy):
    """The app over P01, with a described preference, on an open day 1 with one interaction; P02 on an open day 1."""
    tmp = tmp_path_factory.mktemp("accessibility")
    db = tmp / "study.sqlite"
    with StudyStore(db) as s:
        s.add_participant("P01")
        s.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
        day = s.open_day("P01")
        s.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=25,
                             robot_action="pain check", response="accept")
        s.add_participant("P02")  # on the form (P01's tablet is left on a proposal, to which its address returns)
        s.save_preferences("P02", [{"activity": ["cough"], "action": "pain check"}])
        s.open_day("P02")
    for url in _run_app(tmp, CACAS_DB=str(db)):
        yield url


def icon_names(page) -> list[str]:
    """The names of the images in the page's main area that a screen reader reads as an icon's ligature."""
    return [n for n in page.locator("[data-testid='stMain'] [role='img']").evaluate_all(
        "els => els.filter(e => !e.closest('[aria-hidden=true]')).map(e => e.getAttribute('aria-label') || '')")
        if ICON_NAME.match(n)]


def test_the_tablet_reads_its_headings_and_marks_in_words(browser, day_1):
    """The tablet's heading was read "smart_toy icon Hello, P01", and the robot's recognition "The robot heard: cough
    check icon" ("help icon" where it heard something else than was chosen); the researcher's sidebar title
    "smart_toy icon CACAS Studio"."""
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    goto(page, f"{day_1}/?participant=P02&view=tablet")  # its form
    expect(page.get_by_role("heading", name="Hello, P02", exact=True)).to_be_visible()
    expect(page.get_by_role("button", name="Do it")).to_be_visible()
    assert icon_names(page) == []
    # a proposal, opened at its address (a reload's way back to it): cough in the bedroom, 08:00-10:00, 20-30 min
    token = Context.from_choices(4, 6, "cough", "bedroom").to_token()
    goto(page, f"{day_1}/?participant=P01&view=tablet&ctx={token}&at=1.2")
    heard = page.get_by_role("heading", name=re.compile(r"^The robot heard: "))
    expect(heard).to_be_visible(timeout=120_000)
    # what the check (or question) mark says: that the robot heard (and saw) what was chosen, or not
    expect(heard).to_have_accessible_name(re.compile(r"^The robot heard: [a-zA-Z ]+ (as chosen|not as chosen)$"))
    expect(page.get_by_text(re.compile(r"^and sees the "))).to_be_visible()
    assert icon_names(page) == []
    goto(page, f"{day_1}/adaptation?participant=P01")
    expect(page.get_by_role("heading", name="CACAS Studio", exact=True)).to_be_visible()
    close_page(page)


def headings(page) -> list[tuple[int, str, int]]:
    """The page's headings as a screen reader lists them: (level, text without hidden icons, links inside it), the
    sidebar's first."""
    return [tuple(h) for h in page.locator("h1, h2, h3, h4, h5, h6").evaluate_all(
        "els => els.map(h => { const c = h.cloneNode(true); c.querySelectorAll('[aria-hidden=true]').forEach(e => "
        "e.remove()); return [Number(h.tagName[1]), c.textContent.trim(), h.querySelectorAll('a').length] })")]


def test_headings_go_down_one_level_at_a_time_without_link_tab_stops(browser, day_1):
    """Accessibility walkthrough: the researcher's pages went h1 -> h3 (st.subheader), the tablet h2 -> h4 -> h5,
    and every researcher heading had a 'Link to heading' anchor, a Tab stop of no use. Each page has one h1, its
    sections h2; the sidebar's title is an h2 as well."""
    page = open_page(browser, viewport={"width": 1280, "height": 900})
    seen = {}
    for name, url, wait in (("overview", "/?participant=P01", "Recent activity"),
                            ("adaptation", "/adaptation?participant=P01", "Policy versions"),
                            ("tablet form", "/?participant=P02&view=tablet", "What are you doing?"),
                            ("proposal", f"/?participant=P01&view=tablet&ctx="
                                         f"{Context.from_choices(4, 6, 'cough', 'bedroom').to_token()}&at=1.2",
                             "Your activity: cough")):
        goto(page, day_1 + url)
        expect(page.get_by_role("heading", name=wait)).to_be_visible(timeout=120_000)
        seen[name] = found = headings(page)
        main = [level for level, text, _ in found if text != "CACAS Studio"]
        assert main[0] == 1 and main.count(1) == 1, (name, found)
        assert all(b <= a + 1 for a, b in zip(main, main[1:])), (name, found)
        assert all(links == 0 for _, _, links in found), (name, found)
    assert seen["adaptation"][:3] == [(2, "CACAS Studio", 0), (1, "Adaptation\u00a0· P01", 0), (2, "Close the day and adapt", 0)]
    assert [h[:2] for h in seen["proposal"]] == [(1, "Hello, P01"), (2, "Your activity: cough"),
                                                 (2, "The robot heard: cough")]
    close_page(page)


def test_a_chart_is_named_for_a_screen_reader(browser, day_1):
    """Fig. 3 was read as its tick labels run together ("1 0% 20% 40% ..."), then a row of unnamed images."""
    page = open_page(browser, viewport={"width": 1280, "height": 900})
    goto(page, f"{day_1}/results?participant=P01")
    expect(page.get_by_role("figure", name=re.compile(r"^Success rate and cumulative feedback\. CACAS, 1 participant\. "
                                                       r"Drawn: .*success rate \(mean\)"))).to_be_visible()
    close_page(page)


#: the focused element's ring as drawn: its outline, and Streamlit's own box-shadow ring
RING = """() => { const s = getComputedStyle(document.activeElement);
  return {name: document.activeElement.innerText, style: s.outlineStyle, width: parseFloat(s.outlineWidth),
          colour: s.outlineColor, shadow: s.boxShadow}; }"""


def _hex(rgb: str) -> str:
    r, g, b = (int(float(x)) for x in re.findall(r"[\d.]+", rgb)[:3])
    return f"#{r:02x}{g:02x}{b:02x}"


def test_the_tablets_keyboard_focus_is_a_ring_that_stands_out(browser, day_1):
    """Streamlit's focus ring is the primary colour at half strength (rgba(47, 111, 143, 0.5): #97b7c7 on white,
    2.1:1), under WCAG 1.4.11's 3:1 for what shows a state: faint beside a chip's own grey border."""
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    goto(page, f"{day_1}/?participant=P02&view=tablet")
    first = page.get_by_role("radio", name="00:00-02:00")
    expect(first).to_be_visible()
    for _ in range(10):  # the keyboard's way in: the skip link, the main area, then the first chip
        page.keyboard.press("Tab")
        if first.evaluate("e => e === document.activeElement"):
            break
    ring = page.evaluate(RING)
    assert ring["name"] == "00:00-02:00" and ring["style"] == "solid" and ring["width"] >= 2, ring
    assert contrast_ratio(_hex(ring["colour"])) >= 3, ring
    close_page(page)


#: the focused element's ring, or its label's (a checkbox's input is drawn by its label)
LABEL_RING = """() => { const e = document.activeElement, l = e.closest('label') || e, s = getComputedStyle(l);
  return {name: (l.innerText || '').trim(), tag: e.tagName, style: s.outlineStyle, width: parseFloat(s.outlineWidth),
          colour: s.outlineColor}; }"""


def test_the_researchers_keyboard_focus_is_a_ring_that_stands_out(browser, day_1):
    """The tablet's ring came to the researcher's pages: there the sidebar's page links showed Streamlit's faint
    2.1:1 ring and the 'Close day 1 ...' checkbox none at all (accessibility walkthrough)."""
    page = open_page(browser, viewport={"width": 1280, "height": 900})
    goto(page, f"{day_1}/adaptation?participant=P01")
    expect(page.get_by_text(re.compile(r"^Close day 1 with "))).to_be_visible(timeout=120_000)
    rings = {}
    for _ in range(40):
        page.keyboard.press("Tab")
        ring = page.evaluate(LABEL_RING)
        if ring["name"].endswith("Overview") or ring["name"].startswith("Close day 1 with"):
            rings[ring["name"].split()[-1] if ring["name"].endswith("Overview") else "checkbox"] = ring
        if len(rings) == 2:
            break
    assert set(rings) == {"Overview", "checkbox"}, rings
    for ring in rings.values():
        assert ring["style"] == "solid" and ring["width"] >= 2 and contrast_ratio(_hex(ring["colour"])) >= 3, ring
    close_page(page)


#: A caption's text colour as drawn (its colour blended by the opacity of it and its parents) and the background under
#: it (the first ancestor's that is not transparent)
_DRAWN = """e => { let opacity = 1, n = e, ground = null;
    for (; n; n = n.parentElement) {
        const style = getComputedStyle(n);
        opacity *= parseFloat(style.opacity);
        if (!ground && n !== e && !/rgba\\(.*, 0\\)|transparent/.test(style.backgroundColor)) ground = style.backgroundColor;
    }
    return {colour: getComputedStyle(e.querySelector('p') || e).color, opacity, ground: ground || 'rgb(255, 255, 255)'}; }"""


def caption_contrast(caption) -> tuple[float, dict]:
    """WCAG's contrast ratio of ``caption``'s text as drawn on its background."""
    drawn = caption.evaluate(_DRAWN)
    ink, ground = ([int(float(x)) for x in re.findall(r"[\d.]+", drawn[k])[:3]] for k in ("colour", "ground"))
    seen = "#" + "".join(f"{round(drawn['opacity'] * c + (1 - drawn['opacity']) * g):02x}" for c, g in zip(ink, ground))
    return contrast_ratio(seen, "#" + "".join(f"{g:02x}" for g in ground)), drawn


def test_the_tablets_captions_are_dark_enough_to_read(browser, day_1):
    """A caption (the proposal's "in the bedroom · 08:00-10:00 · 20-30 min since your last activity") was Streamlit's
    text colour faded to 0.6 on white: #828180, 3.89:1, under WCAG 1.4.3's 4.5:1 for text of its 15 px."""
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    token = Context.from_choices(4, 6, "cough", "bedroom").to_token()
    goto(page, f"{day_1}/?participant=P01&view=tablet&ctx={token}&at=1.2")
    caption = page.locator("[data-testid='stCaptionContainer']").filter(has_text="since your last activity")
    expect(caption).to_be_visible(timeout=120_000)
    ratio, drawn = caption_contrast(caption)
    assert ratio >= 4.5, (ratio, drawn)
    close_page(page)


def test_the_researchers_captions_are_dark_enough_to_read(browser, day_1):
    """The researcher's captions (the explanations under the title, every figure and table; the sidebar's day line)
    were faded as the tablet's were: 3.89:1 on white, under WCAG 1.4.3's 4.5:1 for their 14 px."""
    page = open_page(browser, viewport={"width": 1280, "height": 800})
    goto(page, f"{day_1}/adaptation?participant=P01")
    main = page.locator("[data-testid='stMain'] [data-testid='stCaptionContainer']").filter(
        has_text="After each study day the robot's policy is adapted")
    side = page.locator("[data-testid='stSidebar'] [data-testid='stCaptionContainer']").filter(has_text="Day 1 (open)")
    for caption in (main, side):
        expect(caption).to_be_visible(timeout=120_000)
        ratio, drawn = caption_contrast(caption)
        assert ratio >= 4.5, (ratio, drawn)
    close_page(page)


def _ink(box) -> tuple[float, float]:
    """Where the text typed in a text field is drawn across it: the first and last column of dark pixels inside its
    border, as shares of its width (0 its left edge, 1 its right)."""
    import io

    import numpy as np
    from PIL import Image

    pixels = np.asarray(Image.open(io.BytesIO(box.screenshot())).convert("L"))[6:-6, 6:-6]
    columns = np.flatnonzero((pixels < 110).any(axis=0))
    assert columns.size, "no text drawn in the field"
    return columns[0] / pixels.shape[1], columns[-1] / pixels.shape[1]


def test_a_request_typed_in_arabic_reads_from_the_right(browser, day_1):
    """A lab outside the English-speaking world: Streamlit's text fields are left to right, so a participant's request
    typed in Arabic stood at the field's left edge, and its closing "!" at its right, where an Arabic sentence
    starts. A field takes the direction of what is typed (app.APP_STYLE); English stays at the left."""
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    token = Context.from_choices(4, 6, "cough", "bedroom").to_token()
    goto(page, f"{day_1}/?participant=P01&view=tablet&ctx={token}&at=1.2")
    field = page.get_by_role("textbox", name="Or type your request", exact=True)
    expect(field).to_be_visible(timeout=120_000)
    field.fill("من فضلك اضبط مؤقتا!")
    page.wait_for_timeout(300)
    left, right = _ink(field)
    assert left > 0.5 and right > 0.9, (left, right)
    field.fill("please set a timer!")
    page.wait_for_timeout(300)
    left, right = _ink(field)
    assert left < 0.05 and right < 0.5, (left, right)
    close_page(page)
