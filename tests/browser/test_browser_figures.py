"""Fig. 3 and Fig. 4 drawn by plotly.js in Chromium. Beside each other (Simulation lab): Fig. 3's legend
of three or four rows pushed its bottom margin past Fig. 4's one row, so that its x axis sat 30-45 px above
Fig. 4's (the titles were aligned already: ``plots.title_block``); ``plots.side_by_side`` gives them one
bottom margin. Alone (Results, ``cacas simulate --plot``): one block shared by every figure left Fig. 4's
one-row legend ~80 px below its axis title; Plotly now makes each margin what its legend needs
(``plots.legend_block``)."""

from __future__ import annotations

import pandas as pd
import pytest

from cacas import plots
from conftest import close_page, open_page

pytestmark = pytest.mark.browser

#: per figure: its plot area's top and bottom, its legend's top and bottom, the x axis title's bottom
BOXES_JS = """() => [...document.querySelectorAll('.js-plotly-plot')].map(c => {
  const box = e => e.getBoundingClientRect();
  const plot = box(c.querySelector('.nsewdrag')), legend = box(c.querySelector('.legend'));
  return {plot: [Math.round(plot.top), Math.round(plot.bottom)], legend: [Math.round(legend.top), Math.round(legend.bottom)],
          axis_title: Math.round(box(c.querySelector('.xtitle')).bottom), height: Math.round(box(c).height)};
})"""


def _daily(ceiling: bool, uneven: bool, methods=("cacas", "orl", "nn")) -> pd.DataFrame:
    """A run of ``methods`` (CACAS, ORL and NN); ``ceiling``: daily.csv's success ceiling (Fig. 3's fourth legend row);
    ``uneven``: days averaging different numbers of participants (day labels on two lines)."""
    rows = [{"participant": who, "method": m, "day": d, "success_rate": 0.5 + 0.1 * d if m == "cacas" else None,
             "preference_accuracy": 0.4 + 0.1 * d, "cumulative_feedback": 15 * d, "interactions": 15,
             **({"success_ceiling": 0.9 if m == "cacas" else None} if ceiling else {})}
            for who in (("P01", "P02") if uneven else ("P01",)) for m in methods
            for d in range(1, 4 if who == "P01" else 3)]
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def figure_page(browser):
    """One page with plotly.js loaded, on which :func:`_boxes` draws every figure here: a page of its own for each
    took 4.0-4.6 s to load plotly.js's 4.6 MB (the figures then drew in 0.1-0.4 s; measured here), 4-5 minutes of
    this file's."""
    from plotly.offline import get_plotlyjs

    page = open_page(browser, viewport={"width": 1000, "height": 480})
    page.set_content(f"<html><head><script>{get_plotlyjs()}</script></head><body style='margin:0'></body></html>")
    yield page
    close_page(page)


#: the figures before go (Plotly.purge: their listeners too), ``html`` in their place, its scripts run (innerHTML
#: runs none)
DRAW_JS = """html => { document.querySelectorAll('.js-plotly-plot').forEach(p => Plotly.purge(p));
  document.body.innerHTML = html;
  for (const old of document.body.querySelectorAll('script')) {
    const s = document.createElement('script'); s.text = old.text; old.replaceWith(s); } }"""


def _boxes(page, figs, width: int, height: int = 450, js: str = BOXES_JS, ready: str = ".legend") -> list:
    """BOXES_JS (or another ``js``) of ``figs`` drawn side by side on ``page`` (:func:`figure_page`), each ``width``
    px wide and ``height`` px tall, once each has drawn its ``ready`` element (its legend)."""
    each = "".join(f'<div style="width:{width}px;display:inline-block;vertical-align:top">'
                   f'{f.to_html(full_html=False, include_plotlyjs=False, default_height=height)}</div>' for f in figs)
    page.set_viewport_size({"width": len(figs) * width + 20, "height": height + 30})
    page.evaluate(DRAW_JS, each)
    page.wait_for_function(f"document.querySelectorAll('.js-plotly-plot {ready}').length == {len(figs)}")
    return page.evaluate(js)


@pytest.mark.parametrize("ceiling, uneven, width", [(False, False, 560), (True, False, 560), (True, True, 400)])
def test_fig3_and_fig4_plot_areas_sit_at_one_height_side_by_side(figure_page, ceiling, uneven, width):
    daily = _daily(ceiling, uneven)
    figs = plots.side_by_side(plots.success_figure(daily), plots.methods_figure(daily), width=width)
    fig3, fig4 = _boxes(figure_page, figs, width)
    assert fig3["plot"] == fig4["plot"], (fig3, fig4)
    for fig in (fig3, fig4):  # each legend below its axis' title, inside the figure
        assert fig["axis_title"] <= fig["legend"][0] and fig["legend"][1] <= fig["height"], fig


#: the methods of a run, fewest to most (a method legend of one to two rows)
RUNS = [("cacas", "orl"), ("cacas", "cacas-no-pr", "orl", "nn"),
        ("cacas", "cacas-no-pr", "orl", "nn", "bandit", "sac-user-data")]


@pytest.mark.parametrize("width", [400, 560, 820, 1000])
@pytest.mark.parametrize("methods", RUNS, ids=len)
def test_a_figure_alone_keeps_its_legend_just_below_its_axis_title(figure_page, methods, width):
    """Fig. 3 and Fig. 4 alone, two to six methods (a legend of one to four rows), on a narrow page to a
    wide one: the legend is about 10 px below the axis title, never on it, never cut. Before, Fig. 4's one
    row of CACAS, ORL and NN was 84 px below its axis title (the block kept for Fig. 3's four rows)."""
    daily = _daily(True, False, methods)
    figs = [plots.success_figure(daily), plots.methods_figure(daily)]
    if len(methods) > 1:
        figs.append(plots.success_methods_figure(daily.assign(success_rate=0.5)))
    for fig in _boxes(figure_page, figs, width):
        gap = fig["legend"][0] - fig["axis_title"]
        assert 5 <= gap <= 16, fig
        assert fig["legend"][1] <= fig["height"], fig


@pytest.mark.parametrize("ceiling", [False, True])
@pytest.mark.parametrize("methods", RUNS, ids=len)
def test_the_labs_two_figures_sit_at_one_height_at_every_width_it_draws_them(figure_page, methods, ceiling):
    """The Simulation lab draws Fig. 3 beside Fig. 4 in columns of 274 px at 1024, 402 at 1280 and 482 at 1440
    (``side_by_side`` counted their legends at 400): at 1024 px the ui helpers saw Fig. 4's plot 19 px above
    Fig. 3's (four methods without a success ceiling: its legend took four rows, Fig. 3's three), 38 px with
    six methods. The lab's figures, as the page makes them (Fig. 3 of the looping method), at each width."""
    daily = _daily(ceiling, False, methods)
    for width in (274, 402, 482):
        fig3, fig4 = _boxes(figure_page, plots.side_by_side(plots.success_figure(daily), plots.methods_figure(daily)),
                            width)
        assert fig3["plot"] == fig4["plot"], (width, fig3, fig4)
        for fig in (fig3, fig4):
            assert fig["axis_title"] <= fig["legend"][0] and fig["legend"][1] <= fig["height"], (width, fig)


def test_a_figure_page_of_its_own_shows_the_whole_legend(browser, tmp_path):
    """``cacas simulate --plot``'s page, as tall as the window: the legend at the figure's bottom
    is in view (the browser's body margin put the figure's last 8 px below the window)."""
    from cacas.cli.simulate import figure_files

    files = figure_files({"fig4.html": plots.methods_figure(_daily(False, False))})
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    page = open_page(browser, viewport={"width": 1000, "height": 568})
    try:
        page.goto((tmp_path / "fig4.html").as_uri())
        page.wait_for_selector(".js-plotly-plot .legend")
        legend = page.evaluate("() => document.querySelector('.legend').getBoundingClientRect().bottom")
        scrolls = page.evaluate("() => document.documentElement.scrollHeight > innerHeight")
    finally:
        close_page(page)
    assert legend <= 568 and not scrolls, (legend, scrolls)


#: a figure page's caption and what is drawn above it: the figure's SVG (plotly.js draws it at the size it reads from
#: the page, which can be taller than its element), its legend, and whether the page scrolls
CAPTION_JS = """() => { const box = e => e ? e.getBoundingClientRect() : null;
  const svg = [...document.querySelectorAll('.js-plotly-plot .main-svg')].map(e => box(e).bottom);
  const c = box(document.querySelector('.caption')), legend = box(document.querySelector('.legend'));
  return {caption: c && [c.top, c.bottom, c.height], svg: Math.max(...svg), legend: legend && legend.bottom,
          scrolls: document.documentElement.scrollHeight > innerHeight, inner: innerHeight}; }"""


def test_a_figure_pages_caption_is_in_view_under_its_figure(browser, tmp_path):
    """walk2: ``cacas simulate --plot``'s pages had no caption (the app's figures say what the band, the dashed
    line and the hollow points are). At 1280 x 800 each page's caption, Fig. 3's of seven lines the longest, is in
    view without scrolling, under the figure: the figure takes the window less the caption."""
    from cacas.cli.simulate import figure_files

    daily = _daily(True, True, ("cacas", "nn")).assign(interactions=lambda d: d["day"].map({1: 2, 2: 15, 3: 15}))
    each = daily.assign(success_rate=0.5)
    rows = pd.DataFrame([{"participant": "P01", "method": m, "day": 3, "preference": k, "label": f"{act} -> x",
                          "activity": act, "action": "x", "states": 10, "correct": c, "accuracy": c / 10}
                         for m in ("cacas", "nn") for k, (act, c) in enumerate((("cough", 10), ("sneeze", 5)))])
    files = figure_files({"fig3.html": plots.success_figure(daily), "fig3_methods.html": plots.success_methods_figure(each),
                          "fig4.html": plots.methods_figure(daily), "heatmap.html": plots.preference_methods_figure(rows)},
                         {"fig3.html": plots.success_caption(daily), "fig3_methods.html": plots.success_methods_caption(each),
                          "fig4.html": plots.METHODS_CAPTION, "heatmap.html": plots.preferences_caption(3)})
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    page = open_page(browser, viewport={"width": 1280, "height": 800})
    try:
        seen = {}
        for name in ("fig3.html", "fig3_methods.html", "fig4.html", "heatmap.html"):
            page.goto((tmp_path / name).as_uri())
            page.wait_for_selector(".js-plotly-plot .main-svg")
            seen[name] = page.evaluate(CAPTION_JS)
    finally:
        close_page(page)
    assert seen["fig3.html"]["caption"][2] > 100, seen  # the dashed line's and the hollow points' words too
    for name, s in seen.items():
        top, bottom, _ = s["caption"]
        assert bottom <= s["inner"] and not s["scrolls"], (name, s)
        assert s["svg"] <= top and (s["legend"] is None or s["legend"] <= top), (name, s)


#: per figure: its legend's entries as drawn (left to right, top to bottom), its width, and the right edges of its
#: title and subtitle
LEGEND_JS = """() => [...document.querySelectorAll('.js-plotly-plot')].map(c => {
  const at = e => e.getBoundingClientRect();
  const entries = [...c.querySelectorAll('.legend .traces')].map(e => [at(e).top, at(e).left, e.textContent.trim()]);
  entries.sort((a, b) => a[0] - b[0] || a[1] - b[1]);
  const right = sel => { const e = c.querySelector(sel); return e ? Math.round(at(e).right - at(c).left) : null; };
  return {legend: entries.map(e => e[2]), width: Math.round(at(c).width), title: right('.gtitle'),
          subtitle: right('.gtitle-subtitle')};
})"""


def test_fig3s_legend_begins_with_the_success_rate(figure_page):
    """Fig. 3's legend, as plotly.js draws it: the min-max band's fill ("tonexty") made it list the traces last
    first, the cumulative feedback before the success rate, which came third of four (walkthrough)."""
    fig3, = _boxes(figure_page, [plots.success_figure(_daily(True, False))], 1000, js=LEGEND_JS)
    assert fig3["legend"] == ["success rate (mean)", "min-max across participants", plots.CEILING_NAME,
                              "cumulative feedback (mean)"], fig3


@pytest.mark.parametrize("methods", RUNS[1:], ids=len)
def test_fig4s_subtitle_fits_the_labs_narrowest_column(figure_page, methods):
    """Fig. 4's subtitle (how many participants, from which interactions: ``plots.methods_subtitle``) on one line
    inside the figure at the lab's narrowest column (274 px, at 1024), in both loops (the longer words)."""
    daily = _daily(True, True, methods)
    for d in (daily, daily.assign(success_rate=0.5)):
        fig4, = _boxes(figure_page, [plots.methods_figure(d)], 274, js=LEGEND_JS)
        assert fig4["subtitle"] is not None and fig4["subtitle"] <= fig4["width"], fig4


#: the heatmap's colorbar: its title's box and its tick labels' boxes
COLORBAR_JS = """() => { const c = document.querySelector('.js-plotly-plot .colorbar');
  const box = e => { const b = e.getBoundingClientRect(); return [b.left, b.top, b.right, b.bottom]; };
  return {title: box(c.querySelector('.cbtitle')), ticks: [...c.querySelectorAll('.cbaxis text')].map(box)}; }"""


@pytest.mark.parametrize("width", [800, 1280])
def test_the_preference_heatmaps_colorbar_title_touches_no_tick_label(figure_page, width):
    """walk2's walkthrough: the heatmap's colorbar title "accuracy", above the bar, touched its "100%" label (the
    top label is centred on the bar's end); it stands at the bar's side."""
    rows = pd.DataFrame([{"participant": "P01", "method": m, "day": 3, "preference": k, "label": f"{act} -> x",
                          "activity": act, "action": "x", "states": 10, "correct": c, "accuracy": c / 10}
                         for m in ("cacas", "orl", "nn") for k, (act, c) in enumerate((("cough", 10), ("sneeze", 5)))])
    bar = _boxes(figure_page, [plots.preference_methods_figure(rows)], width, js=COLORBAR_JS, ready=".colorbar")
    title = bar["title"]
    assert len(bar["ticks"]) >= 3
    overlapping = [t for t in bar["ticks"]
                   if t[0] < title[2] and title[0] < t[2] and t[1] < title[3] and title[1] < t[3]]
    assert overlapping == [], (title, bar["ticks"])


#: per figure: each legend entry's text and its marker's fill as drawn ("none": hollow)
SWATCH_JS = """() => [...document.querySelectorAll('.js-plotly-plot')].map(c => Object.fromEntries(
  [...c.querySelectorAll('.legend .traces')].map(e => { const p = e.querySelector('.legendpoints path');
    return [e.textContent.trim(), p ? getComputedStyle(p).fill : null]; })))"""


def test_a_legends_marker_is_filled_when_day_1_rests_on_few_answers(figure_page):
    """walk2: plotly.js draws a legend entry's marker as the trace's first point: day 1 resting on few answers
    (a hollow point) made Fig. 3's "success rate (mean)" swatch hollow. Fig. 3, and Fig. 3 by method (whose
    points are hollow on such days too), show the filled marker."""
    daily = _daily(False, False, ("cacas", "nn")).assign(
        interactions=lambda d: d["day"].map({1: 2, 2: 15, 3: 15}), success_rate=0.5)
    fig3, by_method = _boxes(figure_page, [plots.success_figure(daily), plots.success_methods_figure(daily)], 800,
                             js=SWATCH_JS)
    assert fig3["success rate (mean)"].startswith("rgb"), fig3  # before: "none"
    assert all(fill.startswith("rgb") for fill in by_method.values()) and set(by_method) == {"CACAS", "NN"}, by_method
