import numpy as np
import pandas as pd

from cacas.plots import accuracy_by_day, methods_figure, success_by_day, success_figure


def daily():
    rows = []
    for p, base in (("P01", 0.2), ("P02", 0.4)):
        for d in (1, 2, 3):
            rows.append({"participant": p, "method": "cacas", "day": d, "success_rate": base + 0.1 * d,
                         "preference_accuracy": base + 0.2 * d, "cumulative_feedback": 10 * d, "interactions": 15})
            rows.append({"participant": p, "method": "nn", "day": d, "success_rate": np.nan,
                         "preference_accuracy": base, "cumulative_feedback": 10 * d, "interactions": 15})
    return pd.DataFrame(rows)


def test_fig3_mean_and_min_max_band_and_feedback_axis():
    s = success_by_day(daily())
    assert np.allclose(s["mean"], [0.4, 0.5, 0.6]) and np.allclose(s["min"], [0.3, 0.4, 0.5])
    assert np.allclose(s["max"], [0.5, 0.6, 0.7]) and list(s["cumulative_feedback"]) == [10, 20, 30]
    fig = success_figure(daily())
    names = [t.name for t in fig.data]
    assert "success rate (mean)" in names and "cumulative feedback (mean)" in names
    band = [t for t in fig.data if getattr(t, "fill", None) == "tonexty"][0]
    assert np.allclose(band.y, [0.3, 0.4, 0.5])
    assert fig.data[-1].yaxis == "y2"


def test_fig4_one_line_per_method():
    a = accuracy_by_day(daily())
    assert np.allclose(a[a.method == "cacas"]["mean"], [0.5, 0.7, 0.9])
    fig = methods_figure(daily())
    assert [t.name for t in fig.data] == ["CACAS", "NN"]
    assert np.allclose(fig.data[1].y, [0.3, 0.3, 0.3])
