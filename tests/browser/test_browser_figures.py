"""Fig. 3 beside Fig. 4 as the Simulation lab shows them, drawn by plotly.js in Chromium: Fig. 3's legend
of three or four rows pushed its bottom margin past Fig. 4's one row, so that its x axis sat 30-45 px above
Fig. 4's (the titles were aligned already: ``plots.title_block``). Both now reserve one legend block
(``plots.LEGEND_BLOCK``): the plot areas are at one height, and no legend overlaps its axis."""

from __future__ import annotations

import pandas as pd
import pytest

from cacas import plots

pytestmark = pytest.mark.browser

#: per figure: its plot area's top and bottom, its legend's top and bottom, the x axis title's bottom
BOXES_JS = """() => [...document.querySelectorAll('.js-plotly-plot')].map(c => {
  const box = e => e.getBoundingClientRect();
  const plot = box(c.querySelector('.nsewdrag')), legend = box(c.querySelector('.legend'));
  return {plot: [Math.round(plot.top), Math.round(plot.bottom)], legend: [Math.round(legend.top), Math.round(legend.bottom)],
          axis_title: Math.round(box(c.querySelector('.xtitle')).bottom), height: Math.round(box(c).height)};
})"""


def _daily(ceiling: bool, uneven: bool) -> pd.DataFrame:
    """A run of CACAS, ORL and NN; ``ceiling``: daily.csv's success ceiling (Fig. 3's fourth legend row);
    ``uneven``: days averaging different numbers of participants (day labels on two lines)."""
    rows = [{"participant": who, "method": m, "day": d, "success_rate": 0.5 + 0.1 * d if m == "cacas" else None,
             "preference_accuracy": 0.4 + 0.1 * d, "cumulative_feedback": 15 * d, "interactions": 15,
             **({"success_ceiling": 0.9 if m == "cacas" else None} if ceiling else {})}
            for who in (("P01", "P02") if uneven else ("P01",)) for m in ("cacas", "orl", "nn")
            for d in range(1, 4 if who == "P01" else 3)]
    return pd.DataFrame(rows)


@pytest.mark.parametrize("ceiling, uneven, width", [(False, False, 560), (True, False, 560), (True, True, 440)])
def test_fig3_and_fig4_plot_areas_sit_at_one_height_side_by_side(browser, ceiling, uneven, width):
    from plotly.offline import get_plotlyjs

    daily = _daily(ceiling, uneven)
    figs = [plots.success_figure(daily), plots.methods_figure(daily)]
    each = "".join(f'<div style="width:{width}px;display:inline-block">'
                   f'{f.to_html(full_html=False, include_plotlyjs=False, default_height=450)}</div>' for f in figs)
    page = browser.new_page(viewport={"width": 2 * width + 20, "height": 480})
    try:
        page.set_content(f"<html><head><script>{get_plotlyjs()}</script></head><body style='margin:0'>{each}"
                         "</body></html>")
        page.wait_for_function("document.querySelectorAll('.js-plotly-plot .legend').length == 2")
        fig3, fig4 = page.evaluate(BOXES_JS)
    finally:
        page.close()
    assert fig3["plot"] == fig4["plot"], (fig3, fig4)
    for fig in (fig3, fig4):  # each legend below its axis' title, inside the figure
        assert fig["axis_title"] <= fig["legend"][0] and fig["legend"][1] <= fig["height"], fig
