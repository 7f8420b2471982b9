import pytest
import numpy as np
import pandas as pd

from cacas.plots import (CEILING_NAME, accuracy_by_day, data_points, describe, methods_figure, participants_reached,
                         preference_days_figure, preference_methods_figure, preference_rows, success_by_day, success_figure,
                         success_methods_figure)


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


def test_fig3_draws_the_success_ceiling_where_daily_has_one():
    assert CEILING_NAME not in [t.name for t in success_figure(daily()).data]
    d = daily()
    d["success_ceiling"] = np.where(d["method"] == "cacas", np.where(d["participant"] == "P01", 1.0, 0.6), np.nan)
    d.loc[(d["participant"] == "P02") & (d["day"] == 3), "success_ceiling"] = 0.8
    assert np.allclose(success_by_day(d)["ceiling"], [0.8, 0.8, 0.9])
    line = [t for t in success_figure(d).data if t.name == CEILING_NAME]
    assert len(line) == 1 and np.allclose(line[0].y, [0.8, 0.8, 0.9]) and line[0].line.dash == "dash"


def test_fig4_one_line_per_method():
    a = accuracy_by_day(daily())
    assert np.allclose(a[a.method == "cacas"]["mean"], [0.5, 0.7, 0.9])
    fig = methods_figure(daily())
    assert [t.name for t in fig.data] == ["CACAS", "NN"]
    assert np.allclose(fig.data[1].y, [0.3, 0.3, 0.3])
    # where methods score the same (day 1, one initial policy), the later ones' smaller markers show
    # the earlier ones around them (walkthrough: one red NN dot stood for the four methods)
    assert fig.data[0].marker.size > fig.data[1].marker.size


def test_the_day_axis_spans_the_days_drawn():
    one_day = daily()[daily()["day"] == 1]
    for fig in (success_figure(one_day), methods_figure(one_day), success_methods_figure(one_day)):
        assert list(fig.layout.xaxis.range) == [0.5, 1.5]  # day 1 alone: not an axis from day 0 to day 2
        assert fig.layout.xaxis.dtick == 1
    assert list(methods_figure(daily()).layout.xaxis.range) == [0.75, 3.25]


def by_preference():
    rows = []
    for method, learnt in (("cacas", 0.9), ("nn", 0.0)):
        for day in (1, 2):
            rows.append({"participant": "P02", "method": method, "day": day, "preference": 1,
                         "label": "TV: leave me alone", "activity": "watch TV", "action": "do nothing",
                         "states": 40, "correct": 0, "accuracy": learnt * (day - 1)})
            rows.append({"participant": "P01", "method": method, "day": day, "preference": 2,
                         "label": "Many sounds", "activity": "cough/sneeze/sniff/clear throat/yawn/burp",
                         "action": "show compassion", "states": 0, "correct": 0, "accuracy": np.nan})
            rows.append({"participant": "P01", "method": method, "day": day, "preference": 1,
                         "label": "Stove: timer", "activity": "use stove", "action": "set a timer",
                         "states": 20, "correct": 10, "accuracy": 0.5})
    return pd.DataFrame(rows)


def test_preference_rows_name_participant_preference_and_shorten_long_activity_lists():
    labels = preference_rows(by_preference().head(3))
    assert labels.iloc[0] == "P02 · 1. watch TV → do nothing"
    assert labels.iloc[1] == "P01 · 2. cough/sneeze/sniff/clear th… → show compassion"


def test_accuracy_by_preference_heatmaps():
    days = preference_days_figure(by_preference(), "nn")
    heat = days.data[0]
    assert list(heat.x) == [1, 2] and heat.y[0].startswith("P01 · 1.") and heat.y[2].startswith("P02 · 1.")
    assert np.allclose(heat.z[0], [0.5, 0.5]) and np.isnan(heat.z[1]).all() and np.allclose(heat.z[2], [0, 0])
    assert "no test state" in heat.hovertext[1][0] and "50% of 20 test states" in heat.hovertext[0][0]
    methods = preference_methods_figure(by_preference())  # the last day by default
    heat = methods.data[0]
    assert list(heat.x) == ["CACAS", "NN"] and "day 2" in methods.layout.title.text
    assert np.allclose(heat.z[2], [0.9, 0.0])
    # on a narrow page Plotly tilts the column labels: the title keeps the margin above them (walkthrough:
    # the tilted labels ran into the title at 800 px)
    for fig in (days, methods):
        assert fig.layout.title.automargin and fig.layout.title.yref == "container" and fig.layout.xaxis.automargin


def test_a_phones_preference_heatmap_names_rows_by_number_and_puts_the_colour_bar_under_the_grid():
    """Phone's left-alone item: at 390 px the row labels ("P01 · 1. use stove → set a timer") took 300 of 360 px,
    the cells were 16 px wide, the labels and the title cut at both edges. Narrow: rows "P01 · 1" (the long label
    first in each cell's hover), method names on two lines, not tilted; the title on two lines; the colour bar
    under the grid. The laptop's figure is as it was."""
    rows = pd.concat([by_preference(), by_preference().assign(method="cacas-no-pr")])
    methods_narrow = preference_methods_figure(rows, narrow=True)
    for wide, narrow in ((preference_methods_figure(rows), methods_narrow),
                         (preference_days_figure(rows, "nn"), preference_days_figure(rows, "nn", narrow=True))):
        assert list(narrow.data[0].y) == ["P01 · 1", "P01 · 2", "P02 · 1"]
        assert list(wide.data[0].y) == list(preference_rows(by_preference().iloc[[2, 1, 0]]))
        assert narrow.data[0].hovertext[0][0].startswith("P01 · 1. use stove → set a timer<br>Stove: timer<br>")
        assert wide.data[0].hovertext[0][0].startswith("Stove: timer<br>")
        assert narrow.data[0].colorbar.orientation == "h" and wide.data[0].colorbar.orientation in (None, "v")
        assert "<br>by described preference" in narrow.layout.title.text
        assert "<br>" not in wide.layout.title.text
        assert narrow.layout.xaxis.tickangle == 0
        assert narrow.layout.xaxis.title.text == (None if narrow is methods_narrow else "day")  # the days need it
        assert np.allclose(np.nan_to_num(narrow.data[0].z), np.nan_to_num(wide.data[0].z))
    narrow = preference_methods_figure(rows, narrow=True)
    assert list(narrow.data[0].x) == ["CACAS", "CACAS<br>w/o PR", "NN"]
    assert "(method: CACAS, CACAS w/o PR, NN)" in describe(preference_methods_figure(rows))
    assert "A grid of 3 rows by 3 columns (CACAS, CACAS w/o PR, NN)" in describe(narrow)


def test_a_long_description_in_a_heatmap_hover_is_wrapped_and_its_words_kept():
    """A participant's words in the by-preference heatmap's hover were one line: at 1280 px the Results page cut a
    German description of 140 characters at both edges ("ens im Schlafzimmer: ... Grö"). Lines of at most 60
    columns (a Japanese character takes two), a compound longer than a line broken, and "<" or "&" kept as words."""
    import html

    from cacas.plots import HOVER_COLUMNS, _columns

    words = {1: "Morgens im Schlafzimmer: Erinnere mich an die Allergietablette. "
                "Donaudampfschifffahrtsgesellschaftskapitänsmützenaufbewahrungsschrank, Größe ÄÖÜ",
             2: "夜に咳をしたら咳止めシロップを思い出させてください。ベッドの横にあります",
             3: "weniger als <5 min & <b>nie</b> laut"}
    rows = by_preference()
    rows["label"] = rows["preference"].map(words).where(rows["participant"] == "P01", rows["label"])
    rows.loc[rows["participant"] == "P01", "preference"] = rows["label"].map({v: k for k, v in words.items()})
    extra = rows[rows["preference"] == 1].assign(preference=3, label=words[3])
    heat = preference_methods_figure(pd.concat([rows, extra[extra["participant"] == "P01"]])).data[0]
    for row, said in zip(heat.y, heat.hovertext):
        if not row.startswith("P01"):
            continue
        lines = said[0].split("<br>")[:-1]  # the last line: the method's accuracy
        assert all(_columns(line) <= HOVER_COLUMNS for line in lines), lines
        number = int(row.split(" · ")[1].split(".")[0])
        assert html.unescape("".join(lines)).replace(" ", "") == words[number].replace(" ", "")
        assert "<b>" not in said[0]
    assert len([1 for row in heat.y if row.startswith("P01")]) == 3


def test_loop_method_is_the_one_with_a_success_rate():
    from cacas.plots import loop_method

    assert loop_method(daily()) == "cacas"
    only_nn = daily().assign(success_rate=lambda d: np.where(d["method"] == "nn", 0.5, np.nan))
    assert loop_method(only_nn) == "nn"  # cacas adapted offline here: no success rate of its own
    assert loop_method(daily().assign(success_rate=np.nan)) is None


def test_fig3_for_every_method_in_its_own_closed_loop():
    from cacas.plots import closed_loop_methods, success_methods_figure

    assert closed_loop_methods(daily()) == ["cacas"]
    each = daily().assign(success_rate=lambda d: np.where(d["method"] == "nn", 0.1, d["success_rate"]))
    assert closed_loop_methods(each) == ["cacas", "nn"]
    fig = success_methods_figure(each)
    assert [t.name for t in fig.data] == ["CACAS", "NN"]
    assert fig.data[0].marker.size > fig.data[1].marker.size  # equal scores show as rings (lab walkthrough)
    assert np.allclose(fig.data[0].y, [0.4, 0.5, 0.6]) and np.allclose(fig.data[1].y, [0.1, 0.1, 0.1])
    assert [t.name for t in success_methods_figure(daily()).data] == ["CACAS"]


def test_a_figure_of_methods_names_its_method_also_when_it_has_one():
    """Plotly hides the legend of a one-trace figure: Fig. 4 of CACAS alone said nothing of which
    method its dots are (walkthrough)."""
    from cacas.plots import methods_figure, success_methods_figure

    alone = daily()[daily()["method"] == "cacas"]
    for fig in (methods_figure(alone), success_methods_figure(alone)):
        assert [t.name for t in fig.data] == ["CACAS"] and fig.layout.showlegend is True


def test_a_line_breaks_on_days_its_method_was_not_in_force():
    from cacas.plots import success_methods_figure

    d = pd.DataFrame({"participant": ["P01"] * 3, "method": ["cacas", "nn", "cacas"], "day": [1, 2, 3],
                      "success_rate": [0.2, 0.5, 0.9], "preference_accuracy": [0.1, 0.2, 0.3],
                      "cumulative_feedback": [5, 10, 15], "interactions": [5, 5, 5]})
    cacas = success_figure(d).data
    mean = next(t for t in cacas if t.name == "success rate (mean)")
    assert list(mean.x) == [1, 2, 3] and mean.y[0] == 0.2 and np.isnan(mean.y[1]) and mean.y[2] == 0.9
    assert not mean.connectgaps  # a gap, not a line through day 2
    by_method = {t.name: t for t in success_methods_figure(d).data}
    assert np.isnan(by_method["NN"].y[0]) and by_method["NN"].y[1] == 0.5 and np.isnan(by_method["NN"].y[2])
    assert success_figure(d, "nn").layout.title.subtitle.text == "NN, 1 participant"
    assert success_figure(d.assign(method="cacas"), "orl").layout.title.subtitle.text == "ORL, 0 participants"  # no row
    assert success_figure(d, "nn").layout.title.text == "Success rate and cumulative feedback"
    assert success_figure(d, "nn", title="Mine").layout.title.text == "Mine"


def test_accuracy_table_is_fig4_as_a_table():
    from cacas.plots import accuracy_table

    d = daily()
    d = pd.concat([d[d["day"] == 2], d[d["day"] != 2]])  # days out of order in the file
    table = accuracy_table(d.assign(day=d["day"].astype(float)))
    assert list(table.index) == ["CACAS", "NN"] and list(table.columns) == ["day 1", "day 2", "day 3"]
    assert np.allclose(table.loc["CACAS"], [0.5, 0.7, 0.9]) and np.allclose(table.loc["NN"], [0.3, 0.3, 0.3])
    assert accuracy_table(daily().assign(preference_accuracy=np.nan)).empty


def test_methods_come_in_one_order_whatever_the_tables_order():
    """A human study's export is sorted by name (nn before orl): Fig. 4's table and legend, the
    heatmap and the next-day table listed NN before ORL, the Simulation lab after it."""
    from cacas.plots import accuracy_table, in_method_order

    assert in_method_order(["nn", "zeta", "orl", "cacas", "bandit", "nn", "alpha", "cacas-no-pr"]) == [
        "cacas", "cacas-no-pr", "orl", "nn", "bandit", "zeta", "alpha"]
    d = daily()
    by_name = pd.concat([d, d.assign(method="orl"), d.assign(method="cacas-no-pr")]).sort_values("method")
    assert list(accuracy_table(by_name).index) == ["CACAS", "CACAS w/o PR", "ORL", "NN"]
    assert [t.name for t in methods_figure(by_name).data] == ["CACAS", "CACAS w/o PR", "ORL", "NN"]
    rows = pd.DataFrame([{"participant": "P01", "method": m, "day": 1, "preference": 1, "label": "x",
                          "activity": "cough", "action": "pain check", "states": 5, "correct": 1, "accuracy": 0.2}
                         for m in ("nn", "orl", "cacas")])
    assert list(preference_methods_figure(rows).data[0].x) == ["CACAS", "ORL", "NN"]


def test_success_by_day_has_whole_days_for_a_table_read_with_float_days():
    s = success_by_day(daily().assign(day=lambda d: d["day"].astype(float)))
    assert s["day"].tolist() == [1, 2, 3] and s["day"].dtype.kind == "i"
    assert s["participants"].tolist() == [2, 2, 2]


def test_fig4_compares_methods_on_the_same_participants():
    """A comparison run for some participants only (or stopped part-way): a participant-day
    without every method's score is left out, so no method's mean differs by who was averaged."""
    from cacas.plots import accuracy_table, incomplete_comparisons
    d = daily()
    d = d[~((d["participant"] == "P02") & (d["method"] == "nn") & (d["day"] >= 2))]
    left = incomplete_comparisons(d)
    assert left.to_dict("records") == [{"participant": "P02", "day": 2, "missing": ["nn"]},
                                       {"participant": "P02", "day": 3, "missing": ["nn"]}]
    a = accuracy_by_day(d).set_index(["method", "day"])
    assert np.allclose(a.loc["cacas", "mean"], [0.5, 0.6, 0.8])  # day 1 both; days 2-3 P01 alone
    assert list(a.loc["cacas", "participants"]) == [2, 1, 1] and list(a.loc["nn", "participants"]) == [2, 1, 1]
    assert np.allclose(accuracy_table(d).loc["CACAS"], [0.5, 0.6, 0.8])
    assert [row[2] for row in methods_figure(d).data[0].customdata] == ["2 participants", "1 participant",
                                                                          "1 participant"]  # in the hover
    # a method scored for nobody on a day asks nothing of that day's participants
    only_cacas = d[~((d["method"] == "nn") & (d["day"] == 3))]
    assert incomplete_comparisons(only_cacas).to_dict("records") == [
        {"participant": "P02", "day": 2, "missing": ["nn"]}]
    assert incomplete_comparisons(daily()).empty


def test_the_success_change_is_paired_over_participants_with_both_days():
    from cacas.plots import success_change
    d = daily()
    d = d[~((d["participant"] == "P02") & (d["day"] == 3))]  # P02 has not reached day 3
    change, n = success_change(d, "cacas", 1, 3)
    assert n == 1 and np.isclose(change, 0.2)  # P01: 0.3 -> 0.5; not the means 0.4 -> 0.5
    assert success_change(daily(), "cacas", 1, 3) == (pytest.approx(0.2), 2)
    change, n = success_change(d, "cacas", 1, 4)
    assert n == 0 and np.isnan(change)


def test_fig3_hover_says_how_many_participants_each_days_mean_has():
    d = daily()
    d = d[~((d["participant"] == d["participant"].iloc[0]) & (d["day"] == 3))]  # one has not reached day 3
    mean = next(t for t in success_figure(d).data if t.name == "success rate (mean)")
    assert [str(n) for n in [row[0] for row in mean.customdata]] == ["2 participants", "2 participants", "1 participant"]
    assert "mean of %{customdata[2]})" in mean.hovertemplate
    assert mean.customdata[2][2].startswith("1 participant, ")  # with the interactions it rests on


def test_fig3_hover_without_interaction_counts_says_only_over_whom():
    """A daily.csv without the interactions column (an uploaded one may lack it) read "(mean of 2 participants, )"
    in Fig. 3's hover: the participants alone."""
    mean = next(t for t in success_figure(daily().drop(columns="interactions")).data if t.name == "success rate (mean)")
    assert [row[2] for row in mean.customdata] == ["2 participants"] * 3


def test_fig4_points_at_0_percent_are_drawn_whole():
    """Fig. 4's points at 0 % were cut in half by the axis (Fig. 3's were drawn whole)."""
    assert all(t.cliponaxis is False for t in methods_figure(daily()).data)


def test_day_labels_say_how_many_participants_a_day_averages_when_they_differ():
    d = daily()
    assert "ticktext" not in success_figure(d).layout.xaxis.to_plotly_json()  # every day the same two
    d = d[~((d["participant"] == "P01") & (d["day"] == 3))]  # P01 has not reached day 3
    for fig in (success_figure(d), methods_figure(d)):
        assert list(fig.layout.xaxis.ticktext) == ["1<br>n = 2", "2<br>n = 2", "3<br>n = 1"]
        assert list(fig.layout.xaxis.tickvals) == [1, 2, 3] and "participants averaged" in fig.layout.xaxis.title.text
    assert participants_reached(d).to_dict() == {"P01": 2, "P02": 3}
    scored_only = d.assign(success_rate=np.nan, interactions=np.nan)  # Fig. 4's scores alone count too
    assert participants_reached(scored_only).to_dict() == {"P01": 2, "P02": 3}


def few_labels(fig) -> list[str]:
    """Fig. 3's few-answers label of each day drawn ("" for none), from its annotations."""
    mean = next(t for t in fig.data if t.name == "success rate (mean)")
    said = {a.x: a.text for a in fig.layout.annotations}
    return [said.get(x, "") for x in mean.x]


def test_fig3_labels_a_day_whose_rate_rests_on_few_interactions():
    """Walkthrough: a day begun with 2 answers plotted at 50 % like a full day beside one at 0 % on a
    single answer; nothing on the figure said so. A review: the label and the hollow marker came
    from the mean count (1 and 6 answers labelled "4 interactions"; 1 and 15 not flagged, though
    the band's edge rests on one answer), and the hover said "3.5 recorded interactions each"."""
    d = daily()
    d.loc[d["day"] == 3, "interactions"] = [2, 2, 1, 1]  # cacas, nn of P01; cacas, nn of P02
    fig = success_figure(d)
    mean = next(t for t in fig.data if t.name == "success rate (mean)")
    assert few_labels(fig) == ["", "", "fewest 1 interaction"]
    assert [str(n) for n in [row[1] for row in mean.customdata]] == [
        "15 recorded interactions each", "15 recorded interactions each", "1-2 recorded interactions each"]
    d.loc[d["day"] == 3, "interactions"] = [15, 15, 1, 1]  # the mean, 8, was not "few"
    fig = success_figure(d)
    mean = next(t for t in fig.data if t.name == "success rate (mean)")
    assert few_labels(fig) == ["", "", "fewest 1 interaction"] and mean.marker.symbol[2] == "circle-open"
    one = d[d["participant"] == d["participant"].iloc[0]].assign(interactions=lambda x: x["day"].map({1: 15, 2: 15, 3: 3}))
    fig = success_figure(one)
    mean = next(t for t in fig.data if t.name == "success rate (mean)")
    assert few_labels(fig) == ["", "", "3 interactions"] and mean.marker.symbol[:2] == ("circle", "circle")
    assert mean.customdata[2][1] == "3 recorded interactions"  # one participant: no "each"
    assert few_labels(success_figure(daily().drop(columns="interactions"))) == ["", "", ""]  # no column: as before


def test_fig3_counts_a_day_begun_with_nothing_recorded_in_its_feedback_not_its_rate():
    """Review: a participant whose day holds only unanswered proposals (daily.csv: no rate,
    interactions 0) was left out of Fig. 3 altogether: their feedback so far left the day's mean
    cumulative feedback, and a day where nobody had answered yet was not drawn."""
    d = daily()
    first = d["participant"] == "P01"
    d.loc[first & (d["day"] == 3) & (d["method"] == "cacas"), ["success_rate", "interactions", "cumulative_feedback"]] = \
        [float("nan"), 0, 20]  # day 3 begun, nothing recorded: feedback as after day 2
    s = success_by_day(d).set_index("day")
    assert s.loc[3, "mean"] == pytest.approx(0.4 + 0.3)  # P02's alone
    assert (s.loc[3, "participants"], s.loc[3, "on_day"]) == (1, 2)
    assert s.loc[3, "cumulative_feedback"] == (20 + 30) / 2  # P01's 20 counts
    mean = next(t for t in success_figure(d).data if t.name == "success rate (mean)")
    assert mean.customdata[2][0] == "1 participant; 1 more with nothing recorded yet"
    nobody = pd.concat([d[d["day"] < 3], d[(d["day"] == 3) & first]])  # day 3: only P01, nothing recorded
    s = success_by_day(nobody).set_index("day")
    assert pd.isna(s.loc[3, "mean"]) and s.loc[3, "cumulative_feedback"] == 20
    cumulative = next(t for t in success_figure(nobody).data if t.name == "cumulative feedback (mean)")
    assert list(cumulative.x) == [1, 2, 3]  # the day is drawn
    # a method not in force that day (a Fig. 4 row: no rate, the day's count) is not "on the day"
    assert success_by_day(d, "nn").empty


def test_fig3_cumulative_feedback_hover_keeps_the_half():
    """The mean cumulative feedback 12.5: the hover said 13, the metric above it 12."""
    d = daily()
    d.loc[(d["day"] == 2) & (d["participant"] == d["participant"].iloc[0]), "cumulative_feedback"] = 15
    cumulative = next(t for t in success_figure(d).data if t.name == "cumulative feedback (mean)")
    assert list(cumulative.customdata) == ["10 data points", "17.5 data points", "30 data points"]
    assert "%{customdata}" in cumulative.hovertemplate
    assert data_points(1.0) == "1 data point" and data_points(104.04) == "104 data points"


def test_fig3_by_method_and_fig4_hovers_say_what_the_page_says():
    """Fig. 3 for every method (--loop each): the hover rounded the mean cumulative feedback to a whole number ("20
    data points" where the Results page's metric and the Simulation lab's table say 19.5), as Fig. 3's own hover did
    before; Fig. 4's said "1 participants" for a day of one participant."""
    d = daily().assign(success_rate=lambda x: x["success_rate"].fillna(0.5))  # both methods in a loop of their own
    d.loc[(d["day"] == 2) & (d["participant"] == "P01"), "cumulative_feedback"] = 19  # 19.5 on day 2
    for trace in success_methods_figure(d).data:
        assert [row[2] for row in trace.customdata] == ["10 data points", "19.5 data points", "30 data points"]
        assert "%{customdata[2]}" in trace.hovertemplate and ":.0f" not in trace.hovertemplate
    one = d[~((d["participant"] == "P02") & (d["day"] == 3))]
    fig4 = methods_figure(one).data[0]
    assert [row[2] for row in fig4.customdata] == ["2 participants", "2 participants", "1 participant"]
    assert "%{customdata[2]})" in fig4.hovertemplate


def test_a_day_at_100_percent_is_drawn_whole():
    """The rate axes leave room above 100 % for a marker (at 1.02 the top of the plot cut it in half):
    the top of the axis is at least a marker's radius (8 px of a 400 px plot) above 100 %."""
    d = daily().assign(success_rate=1.0, preference_accuracy=1.0)
    for fig in (success_figure(d), success_methods_figure(d), methods_figure(d)):
        top = fig.layout.yaxis.range[1]
        assert fig.layout.yaxis.range[0] == 0 and top >= 1 + 8 / 400 * 2, top


def test_fig3_labels_stay_inside_the_plot():
    """Walkthrough: "fewest 2 interactions" on day 1 was cut on the left, and "1 interaction" at
    100 % lost its top: labels go right of the first day, left of the last, below a point near the
    top, and are not clipped at the axes."""
    d = daily()
    d["interactions"] = 1
    d.loc[d["day"] == 3, "success_rate"] = 1.0
    fig = success_figure(d)
    assert few_labels(fig) == ["fewest 1 interaction"] * 3
    where = [(a.xanchor, a.yanchor, a.yshift) for a in fig.layout.annotations]
    # below the point at 100 %, and days next to it alternating (walk1: adjacent labels drew over each other)
    assert where == [("left", "top", -9), ("center", "bottom", 9), ("right", "top", -9)]
    # on a white ground: the cumulative feedback's line, drawn above the first axis, crossed the label out
    assert all(a.bgcolor and a.showarrow is False for a in fig.layout.annotations)
    one_day = success_figure(d[d["day"] == 1])
    assert [(a.xanchor, a.yanchor) for a in one_day.layout.annotations] == [("center", "bottom")]


def test_fig3_labels_of_days_next_to_each_other_alternate_above_and_below():
    """Walkthrough: a pilot's run of 1-interaction days drew "fewest 1 interaction" labels of neighbouring
    days over each other and over the band. Labels of adjacent days alternate sides, from the side a day near
    the top (below its point) or the bottom (above it) must take; a day without a label breaks the run."""
    from cacas.plots import _label_positions

    sides = lambda days, means, labelled=None: [w.split()[0] for w in _label_positions(days, means, labelled)]
    assert sides([1, 2, 3, 4], [0.5, 0.5, 0.5, 0.5]) == ["top", "bottom", "top", "bottom"]
    assert sides([1, 2, 3, 4], [0.5, 0.5, 0.95, 0.5]) == ["bottom", "top", "bottom", "top"]  # from day 3's side
    assert sides([1, 2, 3], [0.0, 0.5, 0.5]) == ["top", "bottom", "top"]  # above a point at 0 %: not on the axis
    # day 2 has no label: days 1 and 3 are not neighbours, both above
    assert sides([1, 2, 3], [0.5, 0.5, 0.5], [True, False, True]) == ["top", "top", "top"]
    d = daily()
    d["interactions"] = 1
    d["success_rate"] = 0.5
    fig = success_figure(d)
    assert [a.yanchor for a in fig.layout.annotations] == ["bottom", "top", "bottom"]


def test_incomplete_comparisons_agrees_with_a_participant_day_at_a_time_count():
    """The joins that replaced a scan of the table per participant-day (review: a 20,000-row upload
    kept the server busy for minutes) name the same participant-days and methods, in method order."""
    from cacas.plots import in_method_order, incomplete_comparisons

    rng = np.random.default_rng(3)
    methods = ["nn", "orl", "cacas", "bandit", "cacas-no-pr"]
    rows = [(f"P{p}", m, day, 0.5) for p in range(12) for day in range(1, 6) for m in methods
            if rng.random() < (0.9 if day < 5 else 0.5) and not (m == "bandit" and day == 2)]
    d = pd.DataFrame(rows, columns=["participant", "method", "day", "preference_accuracy"])
    expected = []
    for (who, day), g in d.groupby(["participant", "day"]):
        on_day = set(d.loc[d["day"] == day, "method"])
        missing = [m for m in in_method_order(d["method"]) if m in on_day and m not in set(g["method"])]
        if missing:
            expected.append({"participant": who, "day": day, "missing": missing})
    got = incomplete_comparisons(d)
    assert len(got) > 10 and got.to_dict("records") == expected
    assert all("bandit" not in m for m in got.loc[got["day"] == 2, "missing"])  # not scored that day at all


def test_fig3_and_fig4_titles_sit_at_one_height_side_by_side():
    """Simulation lab (Fig. 3 beside Fig. 4): Fig. 3's subtitle put its title and plot 20 px below Fig. 4's
    (top margins 80 and 60, each title in the middle of its margin). Every figure of the two has the same
    title block now: the same top margin, the title's top at the same height; what the titles say is as it was."""
    d = pd.concat([daily(), daily().assign(method="orl")])
    figs = {"fig3": success_figure(d), "fig4": methods_figure(d), "fig3 each": success_methods_figure(d),
            "fig3 titled": success_figure(d, title="Success rate"), "fig4 titled": methods_figure(d, title="Fig. 4")}
    blocks = {name: (f.layout.margin.t, f.layout.title.y, f.layout.title.yanchor, f.layout.title.yref,
                     f.layout.title.pad.t) for name, f in figs.items()}
    assert len(set(blocks.values())) == 1, blocks
    assert blocks["fig3"][:3] == (80, 1, "top")  # the room Fig. 3's title and subtitle take, and from the top down
    said = {name: (f.layout.title.text, f.layout.title.subtitle.text) for name, f in figs.items()}
    assert said == {"fig3": ("Success rate and cumulative feedback", "CACAS, 2 participants"),
                    "fig4": ("Preference prediction by method", "2 participants, each in its own closed loop"),
                    "fig3 each": ("Success rate by method, each in its own closed loop", "2 participants"),
                    "fig3 titled": ("Success rate", None), "fig4 titled": ("Fig. 4", None)}


def test_the_heatmaps_list_participants_by_code_whatever_its_letter_case():
    """Rows by participant as a person reads the codes ("p01, R01, r02"; sorted as stored: "R01, p01, r02")."""
    rows = pd.concat([by_preference().assign(participant=p) for p in ("r02", "R01", "p01")])
    heat = preference_days_figure(rows, "nn").data[0]
    who = [y.split(" · ")[0] for y in heat.y]
    assert list(dict.fromkeys(who)) == ["p01", "R01", "r02"] and who == sorted(who, key=str.lower)
    rows = pd.concat([by_preference().assign(participant=p) for p in ("P10", "P_1", "p2", "PA")])
    who = [y.split(" · ")[0] for y in preference_days_figure(rows, "nn").data[0].y]
    assert list(dict.fromkeys(who)) == ["P_1", "p2", "P10", "PA"]  # natural order (records.code_order)


def test_the_note_on_fig3s_hollow_points_is_there_while_one_is():
    from cacas.plots import few_interactions_note

    d = daily()
    assert few_interactions_note(d, "cacas") == ""
    d.loc[(d["day"] == 3) & (d["method"] == "cacas"), "interactions"] = [15, 4]
    assert few_interactions_note(d, "cacas").startswith("A hollow point is a day where a participant's success "
                                                        "rate rests on fewer than 5 recorded interactions")
    assert few_interactions_note(d, "nn") == ""  # another method's days


def test_fig4_says_over_whom_and_from_which_interactions():
    """Fig. 4's subtitle, as Fig. 3's says whose rate it is: how many participants, and whether the methods adapted
    from the same interactions (the paper's Fig. 4, a human study) or each acted in a loop of its own (--loop each,
    whose Fig. 4 was titled as the paper's)."""
    from cacas.plots import own_loops
    first = daily()  # cacas acted, nn adapted from its interactions
    each = first.assign(success_rate=first["success_rate"].fillna(0.5))
    # a human study adapted with two methods: one in force on each participant's day
    human = first.assign(success_rate=np.where((first["participant"] == "P02") == (first["method"] == "nn"),
                                               0.5, np.nan))
    assert (own_loops(first), own_loops(each), own_loops(human)) == (False, True, False)
    said = {name: methods_figure(d).layout.title.subtitle.text
            for name, d in (("first", first), ("each", each), ("human", human))}
    assert said == {"first": "2 participants, all from the same interactions",
                    "each": "2 participants, each in its own closed loop",
                    "human": "2 participants, all from the same interactions"}
    alone = first[(first["method"] == "cacas") & (first["participant"] == "P01")]
    assert methods_figure(alone).layout.title.subtitle.text == "1 participant"  # one method: from what, unsaid
    assert methods_figure(first, title="Fig. 4").layout.title.subtitle.text is None  # a title of one's own


def test_fig3_by_method_lists_the_methods_in_the_papers_order_as_fig4_does():
    """A --loop each run of nn, orl, cacas (daily.csv in the order given): Fig. 3 for every method listed NN, ORL,
    CACAS beside Fig. 4's CACAS, ORL, NN, against the one order of every page and figure (in_method_order)."""
    d = pd.concat([daily().assign(method=m) for m in ("nn", "orl", "cacas")], ignore_index=True)
    assert [t.name for t in success_methods_figure(d).data] == ["CACAS", "ORL", "NN"]
    assert [t.name for t in methods_figure(d).data] == ["CACAS", "ORL", "NN"]


def test_fig3_by_method_says_over_whom_and_marks_days_on_few_answers_as_fig3_does():
    """walk2: Fig. 3 by method (--loop each; a human study's method in force) had no participant count and no
    hollow points, where Fig. 3 of one method says both: the subtitle and, as Fig. 3's, the hover say over how
    many participants and on how many recorded interactions each; a day resting on few answers is hollow."""
    from cacas.plots import few_interactions_note

    d = daily().assign(success_rate=lambda x: x["success_rate"].fillna(0.5))  # both methods in a loop of their own
    d.loc[(d["day"] == 3) & (d["method"] == "nn"), "interactions"] = [15, 2]
    d = d[~((d["participant"] == "P02") & (d["day"] == 3) & (d["method"] == "cacas"))]
    fig = success_methods_figure(d)
    assert fig.layout.title.subtitle.text == "2 participants"
    by_name = {t.name: t for t in fig.data if t.showlegend is not False}
    lines = {t.name: t for t in fig.data if t.x[0] is not None}
    assert [row[3] for row in lines["CACAS"].customdata] == [
        "2 participants, 15 recorded interactions each", "2 participants, 15 recorded interactions each",
        "1 participant, 15 recorded interactions"]
    assert lines["NN"].customdata[2][3] == "2 participants, 2-15 recorded interactions each"
    assert "mean of %{customdata[3]}" in lines["NN"].hovertemplate
    assert list(lines["NN"].marker.symbol) == ["circle", "circle", "circle-open"]
    assert list(lines["CACAS"].marker.symbol) == ["circle"] * 3 and set(by_name) == {"CACAS", "NN"}
    assert few_interactions_note(d).startswith("A hollow point is a day where a participant's success rate rests "
                                               "on fewer than 5 recorded interactions (its hover gives the fewest)")
    assert few_interactions_note(daily().assign(success_rate=0.5)) == ""
    # every day has both participants (P02's day 3 under NN alone): no day says its number
    assert list(fig.layout.xaxis.ticktext or []) == []
    human = daily().assign(success_rate=np.where((daily()["participant"] == "P02") == (daily()["method"] == "nn"),
                                                 0.5, np.nan))  # one method in force on each participant's day
    human = human[~((human["participant"] == "P01") & (human["day"] == 3))]
    assert list(success_methods_figure(human, title="Mine").layout.xaxis.ticktext) == \
        ["1<br>n = 2", "2<br>n = 2", "3<br>n = 1"]
    assert success_methods_figure(human, title="Mine").layout.title.subtitle.text == "2 participants"


def test_fig3s_points_are_opaque_as_its_line():
    """Fig. 3's success-rate dots were drawn paler than their line: sizes given day by day make plotly.js draw a
    bubble chart's markers, at 0.7 opacity with a white outline (figs' left-alone item; Fig. 3 by method was set
    opaque already). Both figures' markers are opaque, without an outline."""
    d = daily()
    mean = next(t for t in success_figure(d).data if t.name == "success rate (mean)")
    by_method = [t for t in success_methods_figure(d).data if t.x is not None and t.x[0] is not None]
    for trace in [mean, *by_method]:
        assert trace.marker.opacity == 1 and trace.marker.line.width == 0, trace.name


def test_the_legend_shows_a_lines_filled_marker_when_day_1_is_hollow():
    """walk2: plotly.js draws a legend entry's marker as its trace's first point, so Fig. 3's legend showed a
    hollow "success rate (mean)" when day 1 rested on few answers. The entry is a trace of its own, with the filled
    marker, in the line's legend group; a figure without a hollow point is as it was."""
    d = daily()
    d.loc[d["day"] == 1, "interactions"] = 2
    for fig, name in ((success_figure(d), "success rate (mean)"),
                      (success_methods_figure(d.assign(success_rate=d["success_rate"].fillna(0.5))), "NN")):
        shown = [t for t in fig.data if t.name == name and t.showlegend is not False]
        line = [t for t in fig.data if t.name == name and t.showlegend is False]
        assert len(shown) == 1 and len(line) == 1, fig.data
        assert line[0].marker.symbol[0] == "circle-open"
        assert shown[0].marker.symbol == "circle" and list(shown[0].y) == [None]
        assert shown[0].legendgroup == line[0].legendgroup == name and shown[0].line.color == line[0].line.color
    assert [t.showlegend for t in success_figure(daily()).data if t.name == "success rate (mean)"] == [None]


def test_the_captions_say_the_dashed_line_and_the_hollow_points_where_the_figure_has_them():
    """One text under Fig. 3 for the Results page and ``cacas simulate --plot``'s page (walk2: the CLI's pages had
    none): the band and what a success is always; the dashed line with daily.csv's success ceiling; the hollow
    points where a day rests on few answers."""
    from cacas.plots import CEILING_WORDS, SUCCESS_WORDS, few_interactions_note, success_caption, success_methods_caption

    d = daily()
    plain = success_caption(d)
    assert plain.startswith("Mean over participants; the band spans") and SUCCESS_WORDS in plain
    assert CEILING_WORDS not in plain and "hollow" not in plain
    d["success_ceiling"] = 0.8
    d.loc[d["day"] == 2, "interactions"] = 3
    said = success_caption(d)
    assert CEILING_WORDS in said and said.endswith(few_interactions_note(d, "cacas"))
    each = d.assign(success_rate=0.5)
    assert success_methods_caption(each).endswith(few_interactions_note(each)) and "its hover gives" in \
        success_methods_caption(each)

def test_a_figure_is_described_in_words_for_a_screen_reader():
    """st.plotly_chart's alt: a chart was read as its tick labels run together, then unnamed images."""
    from cacas.plots import describe

    assert describe(success_figure(daily())) == (
        "Success rate and cumulative feedback. CACAS, 2 participants. Drawn: min-max across participants; "
        "success rate (mean); cumulative feedback (mean).")
    assert describe(methods_figure(daily())).startswith("Preference prediction by method. 2 participants")
    heat = describe(preference_methods_figure(by_preference(), 2))
    assert heat == "Accuracy by described preference and method, day 2. A grid of 3 rows by 2 columns (method: CACAS, NN)."
    assert describe(preference_days_figure(by_preference(), "nn")).endswith("A grid of 3 rows by 2 columns (day: 1, 2).")
    every = [success_figure(daily()), methods_figure(daily()), success_methods_figure(daily()),
             preference_days_figure(by_preference()), preference_methods_figure(by_preference())]
    assert all("<" not in describe(f) and describe(f).endswith(".") for f in every)


def test_contrast_ratio_is_wcags():
    from cacas.plots import contrast_ratio

    assert contrast_ratio("#000000") == pytest.approx(21) and contrast_ratio("#ffffff") == pytest.approx(1)
    assert contrast_ratio("#777777") == pytest.approx(4.48, abs=0.01)  # the usual example just under 4.5
    assert contrast_ratio("#ffffff", "#2f6f8f") == contrast_ratio("#2f6f8f", "#ffffff")


def test_every_methods_line_stands_out_3_to_1_against_the_white_figure():
    """WCAG 1.4.11 (graphics): CACAS w/o PR's orange was 2.68:1 on plotly_white's background."""
    from cacas.plots import METHOD_COLOURS, contrast_ratio

    pale = {m: round(contrast_ratio(c), 2) for m, c in METHOD_COLOURS.items() if contrast_ratio(c) < 3}
    assert pale == {}
