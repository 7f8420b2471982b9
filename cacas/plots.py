"""Plotly figure builders for the paper's Fig. 3 and Fig. 4, from a daily.csv table.

The same builders serve human studies (the study database's daily table) and simulated ones
(``cacas simulate``), the app and ``cacas simulate --plot``.
"""

from __future__ import annotations

import html
import re
import unicodedata

import pandas as pd
import plotly.graph_objects as go
from plotly.subplots import make_subplots

from cacas import records

#: Fig. 3's dashed line, daily.csv's success_ceiling: the share of the day's interactions in a context where a
#: described preference names an action (the success rate proposing the described preferences would reach there)
CEILING_NAME = "where a described preference names an action (mean)"
METHOD_LABELS = {"cacas": "CACAS", "cacas-no-pr": "CACAS w/o PR", "orl": "ORL", "nn": "NN",
                 "bandit": "Bandit (TS)", "sac-user-data": "SAC on user data"}
#: each method's line; every one at least 3:1 against the figures' white (WCAG 2.1 1.4.11, graphics: CACAS w/o PR's
#: orange #e08a2c was 2.68:1, a pale line beside the others; :func:`contrast_ratio`)
METHOD_COLOURS = {"cacas": "#2f6f8f", "cacas-no-pr": "#cc7a1f", "orl": "#5a9e4b", "nn": "#c0504d",
                  "bandit": "#8064a2", "sac-user-data": "#7f7f7f"}


def method_names(methods) -> str:
    """``methods`` (their codes, as ``--methods`` takes them) as the figures name them, in the order given:
    "CACAS, CACAS w/o PR, NN". A run's caption said "methods cacas, cacas-no-pr" beside figures saying
    "CACAS w/o PR" (walk2); the codes stay where a researcher types them."""
    return ", ".join(METHOD_LABELS.get(m, m) for m in methods)


def _luminance(colour: str) -> float:
    """A "#rrggbb" colour's relative luminance (WCAG 2.1's definition)."""
    rgb = [int(colour.lstrip("#")[i:i + 2], 16) / 255 for i in (0, 2, 4)]
    r, g, b = (c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4 for c in rgb)
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def contrast_ratio(colour: str, background: str = "#ffffff") -> float:
    """WCAG 2.1's contrast ratio of two "#rrggbb" colours, 1 to 21: text needs 4.5 (3 when large), lines and
    other graphics 3."""
    lighter, darker = sorted((_luminance(colour), _luminance(background)), reverse=True)
    return (lighter + 0.05) / (darker + 0.05)


def in_method_order(methods) -> list[str]:
    """The methods given, each once, in one order on every page and figure: the paper's (CACAS,
    w/o PR, ORL, NN; :data:`cacas.records.METHOD_ORDER`), then ours, then any other as given.
    (Each table took its data's order: a human study's export was sorted by name, so NN came
    before ORL there and after it elsewhere.)"""
    rank = {m: i for i, m in enumerate(records.METHOD_ORDER)}
    given = list(dict.fromkeys(methods))
    return sorted(given, key=lambda m: (rank.get(m, len(rank)), given.index(m)))


def loop_method(daily: pd.DataFrame) -> str | None:
    """The method whose success rate Fig. 3 shows: the one that ran in closed loop (the others
    adapted from its interactions and have no success rate). "cacas" when it has a success rate,
    else the first method that has one; None when no day has one."""
    methods = closed_loop_methods(daily)
    if not methods:
        return None
    return "cacas" if "cacas" in methods else methods[0]


def closed_loop_methods(daily: pd.DataFrame) -> list[str]:
    """The methods with a success rate, in daily's order: those that ran in closed loop (one in
    the paper's Fig. 4 protocol; every method with ``cacas simulate --loop each``)."""
    return list(dict.fromkeys(daily.loc[daily["success_rate"].notna(), "method"]))


def _on_the_day(daily: pd.DataFrame) -> pd.Series:
    """daily's rows of a day a participant had under that method: with a success rate, or begun
    with nothing recorded yet (no rate, ``interactions`` 0), as opposed to a method not in force."""
    rated = daily["success_rate"].notna()
    if "interactions" not in daily.columns:
        return rated
    return rated | (pd.to_numeric(daily["interactions"], errors="coerce") == 0)


def success_by_day(daily: pd.DataFrame, method: str = "cacas") -> pd.DataFrame:
    """Per day: mean, min and max success rate across the participants with one (``participants``),
    the mean success ceiling (NaN where daily.csv has none) and the mean, fewest and most of the
    day's recorded interactions they rest on (``interactions``, ``fewest``, ``most``; NaN where
    daily.csv has none); and over every participant who had the day (``on_day``: a day begun with
    nothing recorded yet has no rate), the mean cumulative feedback."""
    d = daily[(daily["method"] == method) & _on_the_day(daily)]
    rated = d["success_rate"].notna()
    ceiling = pd.to_numeric(d["success_ceiling"], errors="coerce") if "success_ceiling" in d.columns else float("nan")
    count = pd.to_numeric(d["interactions"], errors="coerce").where(rated) if "interactions" in d.columns \
        else float("nan")
    g = d.assign(day=d["day"].astype(int), _ceiling=ceiling, _count=count,
                 _rated=d["participant"].where(rated)).groupby("day")
    return pd.DataFrame({
        "mean": g["success_rate"].mean(), "min": g["success_rate"].min(), "max": g["success_rate"].max(),
        "cumulative_feedback": g["cumulative_feedback"].mean().astype(float),
        "participants": g["_rated"].nunique(), "on_day": g["participant"].nunique(), "ceiling": g["_ceiling"].mean(),
        "interactions": g["_count"].mean().astype(float), "fewest": g["_count"].min().astype(float),
        "most": g["_count"].max().astype(float),
    }).reset_index()


#: Fig. 3 labels a day where a participant's success rate rests on fewer recorded interactions
#: than this (a day begun: one or two answers swing its rate from 0 to 100 %, and the band's
#: edge with it).
FEW_INTERACTIONS = 5


def _few(daily: pd.DataFrame, method: str) -> bool:
    """Whether some day of ``method`` in Fig. 3 rests on fewer than :data:`FEW_INTERACTIONS` recorded
    interactions for some participant (a hollow point)."""
    return bool((success_by_day(daily, method)["fewest"] < FEW_INTERACTIONS).any())


def few_interactions_note(daily: pd.DataFrame, method: str | None = None) -> str:
    """The sentence that says what Fig. 3's hollow points and their labels are, for the caption under
    the figure ("" when no day of ``method`` has one): a day where some participant's success rate
    rests on fewer than :data:`FEW_INTERACTIONS` recorded interactions, labelled with the fewest
    (walkthrough: "fewest 2 interactions" beside a hollow point was said nowhere but in its hover).
    ``method`` None: Fig. 3 by method (:func:`success_methods_figure`), whose hover gives the fewest
    (several methods' labels on one day would be drawn over each other)."""
    if method is not None and not _few(daily, method):
        return ""
    if method is None and not any(_few(daily, m) for m in closed_loop_methods(daily)):
        return ""
    where = "its label gives the fewest" if method is not None else "its hover gives the fewest"
    return (f"A hollow point is a day where a participant's success rate rests on fewer than {FEW_INTERACTIONS} "
            f"recorded interactions ({where}): one answer more or less moves it a lot.")


#: What Fig. 3's success rate counts, as the captions under it say (Results, ``cacas simulate --plot``'s pages).
SUCCESS_WORDS = ("A success is a robot-initiated action the participant accepted, of the recorded interactions "
                 "(proposals answered, and requests, which are not successes); as in the paper, a proposal left "
                 "unanswered, the robot quiet with nothing asked, or a request while doing nothing (no sound "
                 "activity), is not recorded.")

#: What Fig. 3's dashed line is (daily.csv's success_ceiling), for its caption.
CEILING_WORDS = ("The dashed line (daily.csv's success_ceiling) is the share of the interactions where a described "
                 "preference names an action: the success rate proposing the described preferences reaches there. "
                 "It is not a bound: where no preference names an action (or the participant wants the robot to do "
                 "nothing) a participant may still accept what the robot offers.")


def success_caption(daily: pd.DataFrame, method: str = "cacas") -> str:
    """The caption under Fig. 3 (:func:`success_figure`), one text for the Results page and ``cacas simulate
    --plot``'s page: the band, what a success is, the dashed line where the figure has one, and the hollow
    points where it has some (:func:`few_interactions_note`)."""
    ceiling = success_by_day(daily, method)["ceiling"].notna().any()
    return " ".join(filter(None, [
        "Mean over participants; the band spans the minimum and maximum participant (Fig. 3).", SUCCESS_WORDS,
        CEILING_WORDS if ceiling else "", few_interactions_note(daily, method)]))


def success_methods_caption(daily: pd.DataFrame) -> str:
    """The caption under Fig. 3 by method (:func:`success_methods_figure`): over whom, what the hover gives, what a
    success is, and the hollow points where it has some."""
    return " ".join(filter(None, [
        "Mean success rate over participants, per method and day (Fig. 3 for each method); the hover gives how many "
        "participants and recorded interactions a day's mean rests on, and its minimum and maximum participant.",
        SUCCESS_WORDS, few_interactions_note(daily)]))


#: The caption under Fig. 4 (:func:`methods_figure`); the Results page adds who is left out, and what is not
#: compared yet.
METHODS_CAPTION = ("Mean preference accuracy over participants, per method and day (Fig. 4): each day's policies, "
                   "those in force that day.")


def preferences_caption(day: int | None = None) -> str:
    """The caption of Fig. 4 by described preference: under the app's two views (:func:`preference_methods_figure`
    on a day chosen, :func:`preference_days_figure`), or, given ``day``, under the methods on that day alone
    (``cacas simulate --plot``'s page of the last day)."""
    what = "Fig. 4's accuracy on each described preference's own test states: which preferences each method learnt"
    if day is None:
        return what + ", and when. A row that stays pale is a preference the method never learnt."
    return what + f" by day {day}. A pale cell is a preference the method had not learnt by then."


def success_change(daily: pd.DataFrame, method: str, first: int, last: int) -> tuple[float, int]:
    """The mean change in success rate from day ``first`` to day ``last``, paired: over the
    participants who have both days (one who has not reached ``last`` yet does not move it), and
    their number (NaN, 0 if nobody has both)."""
    d = daily[(daily["method"] == method) & daily["success_rate"].notna()]
    rate = d.assign(day=d["day"].astype(int)).set_index(["participant", "day"])["success_rate"]
    a = rate.xs(int(first), level="day") if int(first) in rate.index.get_level_values("day") else rate.iloc[:0]
    b = rate.xs(int(last), level="day") if int(last) in rate.index.get_level_values("day") else rate.iloc[:0]
    both = a.index.intersection(b.index)
    return (float((b[both] - a[both]).mean()), len(both)) if len(both) else (float("nan"), 0)


def _gaps_for_missing_days(s: pd.DataFrame, daily: pd.DataFrame) -> pd.DataFrame:
    """``s`` (one row per day) with empty rows for the study's other days, so that a line breaks
    where its method was not in force (a human study adapted with another method that day)
    instead of joining the days around it."""
    days = sorted(int(d) for d in daily.loc[_on_the_day(daily), "day"].unique())
    return s.set_index("day").reindex(days).rename_axis("day").reset_index()


def _day_axis(fig: go.Figure, days, participants: dict | None = None) -> bool:
    """The x axis of days: whole days, spanning the days drawn with a margin (one day alone is
    drawn at its own place, not in the middle of an axis from day 0 to day 2). ``participants``
    (day -> how many a day's points average): when days average different numbers, each day's
    label says its number ("3<br>n = 1"), so that a line that moves because someone has not
    reached a day yet is not read as a change (walkthrough: 49 % -> 67 % from one participant fewer).
    Returns whether it did (the labels take two lines: a legend below needs more room)."""
    d = pd.to_numeric(pd.Series(list(days)), errors="coerce").dropna()
    lo, hi = (float(d.min()), float(d.max())) if len(d) else (1.0, 1.0)
    pad = 0.5 if lo == hi else 0.25
    fig.update_xaxes(title_text="day", dtick=1, range=[lo - pad, hi + pad])
    counts = {int(k): int(v) for k, v in (participants or {}).items() if pd.notna(v)}
    if len(set(counts.values())) > 1:
        ticks = sorted(counts)
        fig.update_xaxes(tickmode="array", tickvals=ticks, ticktext=[f"{t}<br>n = {counts[t]}" for t in ticks],
                         title_text="day (n: participants averaged)")
        return True
    return False


def participants_reached(daily: pd.DataFrame) -> pd.Series:
    """Each participant's last day in ``daily`` (index: participant): a day with a success rate,
    begun with nothing recorded yet, or scored for Fig. 4, under any method."""
    had = _on_the_day(daily) | daily["preference_accuracy"].notna()
    return daily[had].assign(day=daily["day"].astype(int)).groupby("participant")["day"].max()


#: The y range of a rate (success rate, preference accuracy): room above 100 % for a whole marker
#: there (at 1.02 a day at 100 % was cut in half by the top of the plot).
RATE_RANGE = [0, 1.06]

#: The height (px) of the title block above Fig. 3's and Fig. 4's plots: a title and a subtitle's line, whether
#: or not the figure has a subtitle. Side by side (Simulation lab) Fig. 3, with a subtitle, sat 20 px lower than
#: Fig. 4, title and plot; every figure now places its title at the same height (:func:`title_block`).
TITLE_BLOCK = 80


def legend_block() -> dict:
    """A figure's legend at the bottom of the figure, in the figure's own coordinates: Plotly then
    makes the bottom margin as tall as the day axis and the legend need at the width drawn, the legend
    ~10 px below the axis title (measured in Chromium: one row or four, 400 to 1000 px wide, in the app
    and in ``cacas simulate --plot``'s page). Fig. 3 and Fig. 4 reserved one block of 165 px, Fig. 3's
    four rows: Fig. 4's one row sat ~80 px below its axis title. Side by side, :func:`side_by_side`."""
    return dict(yref="container", y=0, yanchor="bottom", x=0, xanchor="left")


#: The bottom margin (px) a figure asks for: Plotly makes it what the day axis and the legend need (:func:`legend_block`).
BOTTOM = 20

#: What Plotly's bottom margin holds above a legend (px): the day axis, its title and ~10 px, in the app (Streamlit's
#: theme; 53 in a page of its own), 16 px more with the day labels on two lines ("3<br>n = 1"). Then the legend:
#: rows of :data:`LEGEND_ROW` and :data:`LEGEND_PAD` around them (one row 29 px, four 86). Measured in Chromium.
DAY_AXIS = {False: 67, True: 83}
LEGEND_ROW = 19
LEGEND_PAD = 10

#: The width (px) of each of two figures side by side: the Simulation lab's columns at 1280 px (402; 482 at 1440),
#: and the narrowest it draws them at, its columns at 1024 px (274).
SIDE_BY_SIDE_WIDTH = 400
NARROWEST_SIDE_BY_SIDE = 274


def _text_width(text: str) -> float:
    """A legend entry's text width (px) in Plotly's 12-px Open Sans, from above: capitals and digits
    8.5 px, other characters 6.5 (measured: "CACAS w/o PR" 84 px, estimated 89.5; the app's font is
    narrower)."""
    return sum(8.5 if c.isupper() or c.isdigit() else 6.5 for c in text)


def legend_rows(fig: go.Figure, width: float) -> int:
    """How many rows ``fig``'s legend takes in a figure ``width`` px wide: one entry a row in a
    vertical legend; a horizontal one takes one row if every entry fits at its own width across the
    plot, else a grid of columns as wide as its widest entry (plotly.js's legend layout; an entry is
    40 px of line and marker and its text, 5 px apart): Fig. 3's four long entries take two rows at
    1000 px, four at 560."""
    names = [t.name for t in fig.data if t.showlegend is not False and t.name]
    if fig.layout.legend.orientation == "v" or not names:
        return len(names)
    across = width - (fig.layout.margin.l or 0) - (fig.layout.margin.r or 0)
    entries = [40 + _text_width(str(n)) for n in names]
    if sum(entries) + 5 * len(entries) < across:
        return 1
    per_row = max(1, int(across // (max(entries) + 5)))
    return -(-len(entries) // per_row)


def side_by_side(*figs: go.Figure, width: float = SIDE_BY_SIDE_WIDTH,
                 narrowest: float = NARROWEST_SIDE_BY_SIDE) -> tuple[go.Figure, ...]:
    """``figs`` (built here, each with :func:`legend_block`) to be drawn side by side, each ``width``
    px wide (Simulation lab: Fig. 3 beside Fig. 4): one bottom margin, the tallest their day axes and
    legends need there (:data:`DAY_AXIS`, :func:`legend_rows`), so that their plot areas are at one
    height (Fig. 3's legend of three or four rows lifted its plot 40-60 px above Fig. 4's). Narrower, a
    legend of more rows than counted makes its figure's margin taller, never over the axis title: the
    plots stay at one height if every figure's margin grows alike. Where they would not at ``narrowest``
    (the lab at 1024 px: Fig. 4's four methods took four rows, Fig. 3's legend without a success ceiling
    three, and Fig. 4's plot sat 19 px above Fig. 3's; 38 px with six methods: the ui helper), the margin
    is what they need there, the most, and a wider figure leaves room between axis title and legend.
    Their titles are at one height already (:func:`title_block`)."""
    def needs(w: float) -> list[int]:
        return [DAY_AXIS[any("<br>" in str(t) for t in (f.layout.xaxis.ticktext or ()))]
                + LEGEND_ROW * legend_rows(f, w) + LEGEND_PAD for f in figs]

    bottom = max(needs(width))
    narrow = needs(min(width, narrowest))
    if len({max(bottom, n) for n in narrow}) > 1:  # there the margins would grow apart
        bottom = max(narrow)
    for f in figs:
        f.update_layout(margin=dict(b=bottom))
    return figs


def title_block(text: str, subtitle: str | None = None) -> dict:
    """A figure's title (and subtitle), for a top margin of :data:`TITLE_BLOCK` px: the title's top
    at the same height in every figure, however tall the figure, with or without a subtitle (its
    line left empty)."""
    title = dict(text=text, yref="container", y=1, yanchor="top", pad=dict(t=20))
    if subtitle:
        title["subtitle"] = dict(text=subtitle)
    return title


def success_figure(daily: pd.DataFrame, method: str = "cacas", title: str | None = None) -> go.Figure:
    """Fig. 3: mean success rate per day, a min-max band across participants, the mean success
    ceiling where daily.csv has one (dashed), and the mean cumulative number of feedback on a
    second axis."""
    s = _gaps_for_missing_days(success_by_day(daily, method), daily)
    fig = make_subplots(specs=[[{"secondary_y": True}]])
    colour = METHOD_COLOURS.get(method, "#2f6f8f")
    fig.add_trace(go.Scatter(x=s["day"], y=s["max"], mode="lines", line=dict(width=0), hoverinfo="skip",
                             showlegend=False), secondary_y=False)
    fig.add_trace(go.Scatter(x=s["day"], y=s["min"], mode="lines", line=dict(width=0), fill="tonexty",
                             fillcolor="rgba(47,111,143,0.18)", name="min-max across participants",
                             hoverinfo="skip", legendrank=2), secondary_y=False)
    # each day's mean is over the participants who had that day: the hover says how many (a study in
    # progress has fewer on its later days), and on how many recorded interactions each
    few = s["fewest"] < FEW_INTERACTIONS
    fig.add_trace(go.Scatter(x=s["day"], y=s["mean"], mode="lines+markers", name="success rate (mean)",
                             line=dict(color=colour, width=3), cliponaxis=False, legendrank=1,
                             # the two joined here: a daily.csv without interactions has no count, and the
                             # hover read "(mean of 2 participants, )" (as Fig. 3 by method joins them)
                             customdata=[[who, each, ", ".join(filter(None, [who, each]))]
                                         for who, each in ((_participants(n, on), _interactions_each(n, lo, hi))
                                                           for n, on, lo, hi in zip(s["participants"], s["on_day"],
                                                                                    s["fewest"], s["most"]))],
                             marker=few_markers(few, 7, 11),  # hollow: a rate on few answers
                             hovertemplate="day %{x}: %{y:.0%} (mean of %{customdata[2]})<extra></extra>"),
                  secondary_y=False)
    legend_entry(fig, fig.data[-1], 7, secondary_y=False)
    # the few-answers labels as annotations on a white ground: a trace's text lay under the cumulative
    # feedback's line and markers (its axis is drawn above the first), which crossed it out (walkthrough)
    for day, mean, where, label in zip(s["day"], s["mean"], _label_positions(s["day"], s["mean"], few),
                                       [_few_label(n, lo) if f else "" for n, lo, f in zip(s["participants"],
                                                                                            s["fewest"], few)]):
        if label and pd.notna(mean):
            vertical, horizontal = where.split()
            fig.add_annotation(x=day, y=mean, text=label, showarrow=False, yref="y",
                               yanchor="top" if vertical == "bottom" else "bottom",
                               yshift=-9 if vertical == "bottom" else 9,
                               xanchor={"right": "left", "left": "right"}.get(horizontal, "center"),
                               bgcolor="rgba(255,255,255,0.85)", font=dict(size=12, color="#404040"))
    if s["ceiling"].notna().any():  # daily.csv's success_ceiling: where staying quiet is what they want
        # not a bound: where no preference names an action a participant may still accept what the robot offers
        fig.add_trace(go.Scatter(x=s["day"], y=s["ceiling"], mode="lines+markers", name=CEILING_NAME, legendrank=3,
                                 line=dict(color=colour, width=1.5, dash="dash"),
                                 marker=dict(symbol="line-ew-open", size=14, color=colour),  # seen on day 1 alone
                                 hovertemplate="day %{x}: %{y:.0%} of the interactions were where a described "
                                               "preference names an action (elsewhere a participant may still "
                                               "accept)<extra></extra>"), secondary_y=False)
    fig.add_trace(go.Scatter(x=s["day"], y=s["cumulative_feedback"], name="cumulative feedback (mean)",
                             mode="lines+markers", line=dict(color="#8a8a8a", width=2, dash="dot"), legendrank=4,
                             marker=dict(symbol="square", size=7),
                             customdata=[data_points(x) for x in s["cumulative_feedback"]],
                             hovertemplate="day %{x}: %{customdata}<extra></extra>"), secondary_y=True)
    fig.update_yaxes(title_text="success rate", range=RATE_RANGE, tickformat=".0%", secondary_y=False)
    top = float(s["cumulative_feedback"].max()) if s["cumulative_feedback"].notna().any() else 1.0
    fig.update_yaxes(title_text="cumulative feedback", range=[0, max(top, 1.0) * 1.1], showgrid=False,
                     tickmode="auto", nticks=6, secondary_y=True)
    _day_axis(fig, s["day"], dict(zip(s["day"], s["on_day"])))
    n = int(s["participants"].max()) if s["participants"].notna().any() else 0
    # who it is about as a subtitle: on one line with the title, half the page's width cut it
    # ("... (CACAS, 1 participa")
    fig.update_layout(title=title_block(title) if title else title_block(
                          "Success rate and cumulative feedback",
                          f"{METHOD_LABELS.get(method, method)}, {n} participant{'s' if n != 1 else ''}"),
                      # the success rate first, then its band, the ceiling and the feedback (legendrank): the band's
                      # fill ("tonexty") made plotly.js list the legend last trace first, the cumulative feedback
                      # first and the success rate third (walkthrough)
                      legend=dict(orientation="h", traceorder="normal", **legend_block()),
                      margin=dict(l=60, r=60, t=TITLE_BLOCK, b=BOTTOM), template="plotly_white")
    return fig


def _label_positions(days, means, labelled=None) -> list[str]:
    """Where each point's label goes so that the plot's edges do not cut it (walkthrough: "fewest 2
    interactions" on day 1 lost its first letter, "1 interaction" at 100 % its top): below a point
    near the top, above one near the bottom, to the right of the first day and to the left of the
    last. Labels of days next to each other (``labelled``: which days have one; all by default)
    alternate above and below, from the side a day near the top or bottom must take (walkthrough: a
    pilot's run of 1-interaction days drew "fewest 1 interactionfewest 1 interaction" over each other)."""
    days, means = list(days), list(means)
    labelled = [True] * len(days) if labelled is None else list(labelled)
    first, last = (min(days), max(days)) if days else (None, None)
    forced = ["bottom" if pd.notna(m) and m >= 0.9 else "top" if pd.notna(m) and m <= 0.1 else None for m in means]
    vertical = ["top"] * len(days)
    order = sorted(range(len(days)), key=lambda i: days[i])
    runs, run = [], []  # runs of labelled days next to each other
    for i in order:
        if labelled[i] and run and days[i] == days[run[-1]] + 1:
            run.append(i)
        else:
            if run:
                runs.append(run)
            run = [i] if labelled[i] else []
    if run:
        runs.append(run)
    other = {"top": "bottom", "bottom": "top"}
    for run in runs:
        fixed = [k for k, i in enumerate(run) if forced[i]]
        for k, i in enumerate(run):
            if forced[i]:
                vertical[i] = forced[i]
                continue
            if not fixed:  # nothing near an edge: above first, then alternating
                vertical[i] = "top" if k % 2 == 0 else "bottom"
                continue
            near = min(fixed, key=lambda f: abs(f - k))
            side = forced[run[near]]
            vertical[i] = side if (k - near) % 2 == 0 else other[side]
    return [v + " " + ("right" if d == first and d != last else "left" if d == last and d != first else "center")
            for v, d in zip(vertical, days)]


def data_points(mean_feedback: float) -> str:
    """A mean cumulative feedback as Fig. 3's hover and the Results page say it: "104 data points",
    "12.5 data points" (a mean over participants keeps its half; whole numbers stay whole)."""
    if pd.isna(mean_feedback):
        return ""
    n = f"{mean_feedback:.1f}".removesuffix(".0")
    return f"{n} data point{'' if n == '1' else 's'}"


def _participants(n, on_day=None) -> str:
    """The hover's "2 participants" (and those on the day with nothing recorded yet, whose rate is to come)."""
    if pd.isna(n):
        return ""
    more = 0 if on_day is None or pd.isna(on_day) else int(on_day - n)
    return f"{n:.0f} participant{'' if n == 1 else 's'}" + (f"; {more} more with nothing recorded yet" if more else "")


def _interactions_each(participants, fewest, most) -> str:
    """The hover's "6 recorded interactions each" ("1-6 ... each"; one participant's: "6 recorded
    interactions"); "" where daily.csv has no count."""
    if pd.isna(fewest):
        return ""
    count = f"{fewest:.0f}" if fewest == most else f"{fewest:.0f}-{most:.0f}"
    return f"{count} recorded interaction{'' if count == '1' else 's'}" + (" each" if participants > 1 else "")


def _few_label(participants, fewest) -> str:
    """A hollow day's label: the fewest recorded interactions a participant's rate rests on."""
    n = f"{fewest:.0f} interaction{'' if fewest == 1 else 's'}"
    return n if participants == 1 else f"fewest {n}"


def few_markers(few, filled: float, hollow: float) -> dict:
    """Fig. 3's markers of a line (``few``: each day's rate rests on few answers): hollow
    ("circle-open", ``hollow`` px) on such a day, filled (``filled`` px) on the others; opaque and without an
    outline, as the line's other markers (sizes given day by day make plotly.js draw them as a bubble chart's, at
    0.7 opacity with a white outline: Fig. 3's dots were paler than its line)."""
    return dict(size=[hollow if f else filled for f in few], symbol=["circle-open" if f else "circle" for f in few],
                opacity=1, line=dict(width=0))


def legend_entry(fig: go.Figure, line: go.Scatter, size: float, **where) -> None:
    """``line``'s legend entry with its filled marker (``size`` px), drawn by a trace of its own
    when some point of ``line`` is hollow: plotly.js draws a legend's marker with the symbol of the
    trace's first point, so day 1 resting on few answers made the legend's swatch hollow (walk2). The two
    share a legend group (a click on the entry hides both); ``where``: add_trace's
    (``secondary_y``)."""
    if "circle-open" not in (line.marker.symbol or ()):
        return
    line.update(showlegend=False, legendgroup=line.name)
    fig.add_trace(go.Scatter(x=[None], y=[None], mode="lines+markers", name=line.name, legendgroup=line.name,
                             legendrank=line.legendrank, line=line.line,
                             marker=dict(size=size, symbol="circle", color=line.line.color), hoverinfo="skip"),
                  **where)


def ringed(i: int) -> dict:
    """The markers of the ``i``-th method drawn: smaller than those drawn before, so that where
    methods score the same (day 1: one initial policy; two closed loops alike) they show as rings
    of every colour, not as the last method's dot alone (walkthroughs)."""
    return dict(size=max(5, 14 - 3 * i))


def success_methods_figure(daily: pd.DataFrame, title: str | None = None) -> go.Figure:
    """Fig. 3 for every method that ran in a closed loop of its own (``--loop each``; a human study
    adapted with several methods: the method in force): each method's mean success rate per day, with
    how many participants and recorded interactions it rests on and its min-max across participants in
    the hover, and as Fig. 3 (:func:`success_figure`) a hollow point where a participant's rate rests on
    few answers, the participants in the subtitle and, when days average different numbers, under each day."""
    fig = go.Figure()
    looped = in_method_order(closed_loop_methods(daily))
    # in the paper's order, as Fig. 4 beside it (daily.csv's, the order chosen, listed NN, ORL, CACAS there)
    for i, method in enumerate(looped):
        s = _gaps_for_missing_days(success_by_day(daily, method), daily)
        size = ringed(i)["size"]
        fig.add_trace(go.Scatter(
            x=s["day"], y=s["mean"], mode="lines+markers", name=METHOD_LABELS.get(method, method),
            line=dict(color=METHOD_COLOURS.get(method), width=3 if method == "cacas" else 2),
            # hollow: a rate on few answers (few_markers: opaque, without an outline)
            marker=few_markers(s["fewest"] < FEW_INTERACTIONS, size, max(size, 9)),
            cliponaxis=False,  # a point at 0 % whole, as Fig. 3's (hollow: a ring)
            # the feedback as the page's metric and the lab's table say it ("19.5 data points"; ":.0f" said 20);
            # over whom, on how many answers each, as Fig. 3's hover says it
            customdata=[[lo, hi, data_points(n), ", ".join(filter(None, [_participants(who, on),
                                                                           _interactions_each(who, fewest, most)]))]
                        for lo, hi, n, who, on, fewest, most in zip(s["min"], s["max"], s["cumulative_feedback"],
                                                                    s["participants"], s["on_day"], s["fewest"],
                                                                    s["most"])],
            hovertemplate="day %{x}: %{y:.0%} (mean of %{customdata[3]}; min %{customdata[0]:.0%}, "
                          "max %{customdata[1]:.0%}; %{customdata[2]})<extra></extra>"))
        legend_entry(fig, fig.data[-1], size)
    fig.update_yaxes(title_text="success rate", range=RATE_RANGE, tickformat=".0%")
    # each day's participants, under whichever method (a human study's day counts under the method in force)
    on = daily[daily["method"].isin(looped) & _on_the_day(daily)]
    _day_axis(fig, [x for trace in fig.data for x in trace.x],
              on.assign(day=on["day"].astype(int)).groupby("day")["participant"].nunique().to_dict())
    n = daily.loc[daily["method"].isin(looped) & daily["success_rate"].notna(), "participant"].nunique()
    # the participants said with a title of one's own too (Results' human study: the method in force)
    fig.update_layout(title=title_block(title or "Success rate by method, each in its own closed loop",
                                        f"{n} participant{'s' if n != 1 else ''}"),
                      template="plotly_white", legend=dict(orientation="h", **legend_block()),
                      margin=dict(l=60, r=30, t=TITLE_BLOCK, b=BOTTOM),
                      showlegend=True)  # Plotly hides a one-trace legend: which method it is, unsaid
    return fig


def _scored(daily: pd.DataFrame) -> pd.DataFrame:
    d = daily[daily["preference_accuracy"].notna()]
    return d.assign(day=d["day"].astype(int))


def incomplete_comparisons(daily: pd.DataFrame) -> pd.DataFrame:
    """participant, day, missing: the participant-days Fig. 4 leaves out because some method
    scored that day for other participants has no preference accuracy for them (``missing``: those
    methods, in the table's order). A human study's methods are compared only for the
    participants the comparison has been run for; a stopped comparison leaves some out."""
    d = _scored(daily)
    rank = {m: i for i, m in enumerate(in_method_order(d["method"]))}
    scored = d[["participant", "day", "method"]].drop_duplicates()
    # each participant-day against every method scored that day (joins, not a scan of the table per
    # participant-day: a 20,000-row upload took minutes)
    every = scored[["participant", "day"]].drop_duplicates().merge(
        scored[["day", "method"]].drop_duplicates(), on="day")
    gaps = every.merge(scored, how="left", indicator=True).query("_merge == 'left_only'")
    gaps = gaps.assign(rank=gaps["method"].map(rank)).sort_values(["participant", "day", "rank"], kind="stable")
    rows = [{"participant": who, "day": int(day), "missing": list(g["method"])}
            for (who, day), g in gaps.groupby(["participant", "day"], sort=True)]
    return pd.DataFrame(rows, columns=["participant", "day", "missing"])


def accuracy_by_day(daily: pd.DataFrame) -> pd.DataFrame:
    """Per method and day: mean, min and max preference accuracy across participants, and their
    number. Methods are compared on the same participants: a participant-day without a score
    for every method scored that day is left out (:func:`incomplete_comparisons`), so that no
    method's mean differs from another's by who was averaged."""
    d = _scored(daily)
    out = incomplete_comparisons(daily)
    if len(out):
        left = set(zip(out["participant"], out["day"]))
        d = d[[(p, day) not in left for p, day in zip(d["participant"], d["day"])]]
    g = d.groupby(["method", "day"], sort=False)["preference_accuracy"]
    out = pd.DataFrame({"mean": g.mean(), "min": g.min(), "max": g.max(),
                        "participants": d.groupby(["method", "day"], sort=False)["participant"].nunique()}
                       ).reset_index()
    rank = {m: i for i, m in enumerate(in_method_order(out["method"]))}
    return out.sort_values(["method", "day"], key=lambda c: c.map(rank) if c.name == "method" else c,
                           kind="stable").reset_index(drop=True)


def accuracy_table(daily: pd.DataFrame) -> pd.DataFrame:
    """Fig. 4 as a table: the mean preference accuracy of each method (rows, by label, in the
    table's order) on each day (columns "day 1", "day 2", ...)."""
    a = accuracy_by_day(daily)
    table = a.pivot(index="method", columns="day", values="mean")
    table = table.reindex(index=list(dict.fromkeys(a["method"])), columns=sorted(table.columns))
    table.index = [METHOD_LABELS.get(m, m) for m in table.index]
    table.columns = [f"day {int(d)}" for d in table.columns]
    return table


def own_loops(daily: pd.DataFrame) -> bool:
    """Whether the methods of ``daily`` acted each in a closed loop of its own (``--loop each``): some participant's
    day has a success rate under two methods or more. In the paper's Fig. 4 protocol (and a human study, even one
    adapted with several methods) one method acted on each participant's day and every method adapted from its
    interactions."""
    rated = daily[daily["success_rate"].notna()]
    return bool(len(rated)) and bool(rated.groupby(["participant", "day"])["method"].nunique().max() > 1)


def methods_subtitle(daily: pd.DataFrame, by_day: pd.DataFrame | None = None) -> str:
    """Fig. 4's subtitle, as Fig. 3's says whose rate it is: how many participants its means are over and, with
    two methods or more, what they adapted from. A --loop each run's Fig. 4 was titled as the paper's, whose
    methods all adapt from the same interactions (walkthrough: an uploaded example_each_daily.csv's Fig. 4 said
    nothing of its protocol). ``by_day``: :func:`accuracy_by_day` of ``daily``, if made already."""
    a = accuracy_by_day(daily) if by_day is None else by_day
    n = int(a["participants"].max()) if len(a) else 0
    who = f"{n} participant{'s' if n != 1 else ''}"
    if a["method"].nunique() < 2:
        return who
    # short: on one line in the lab's narrowest column (274 px, at 1024; tests/browser/test_browser_figures.py)
    return who + (", each in its own closed loop" if own_loops(daily) else ", all from the same interactions")


def methods_figure(daily: pd.DataFrame, title: str | None = None) -> go.Figure:
    """Fig. 4: each method's preference accuracy (mean over participants) per day; the subtitle
    (:func:`methods_subtitle`) says over how many participants and from which interactions."""
    a = accuracy_by_day(daily)
    fig = go.Figure()
    for i, (method, d) in enumerate(a.groupby("method", sort=False)):
        fig.add_trace(go.Scatter(
            x=d["day"], y=d["mean"], mode="lines+markers", name=METHOD_LABELS.get(method, method),
            line=dict(color=METHOD_COLOURS.get(method), width=3 if method == "cacas" else 2),
            marker=ringed(i), cliponaxis=False,  # a point at 0 % whole, as Fig. 3's (the axis cut it in half)
            customdata=[[lo, hi, _participants(n)] for lo, hi, n in zip(d["min"], d["max"], d["participants"])],
            hovertemplate="day %{x}: %{y:.0%} (min %{customdata[0]:.0%}, max %{customdata[1]:.0%}; "
                          "%{customdata[2]})<extra></extra>"))  # "1 participant", not "1 participants"
    fig.update_yaxes(title_text="preference accuracy", range=RATE_RANGE, tickformat=".0%")
    _day_axis(fig, a["day"], a.groupby("day")["participants"].max().to_dict())
    fig.update_layout(title=title_block(title) if title else title_block("Preference prediction by method",
                                                                           methods_subtitle(daily, a)),
                      template="plotly_white",
                      legend=dict(orientation="h", **legend_block()), margin=dict(l=60, r=30, t=TITLE_BLOCK, b=BOTTOM),
                      showlegend=True)  # Plotly hides a one-trace legend: which method it is, unsaid
    return fig


def preference_rows(by_preference: pd.DataFrame) -> pd.Series:
    """The heatmaps' row label of each by_preference row: participant, preference number,
    activities -> action (activities shortened to fit)."""
    act = by_preference["activity"].astype(str)
    act = act.where(act.str.len() <= 28, act.str.slice(0, 27) + "…")
    return (by_preference["participant"].astype(str) + " · " + by_preference["preference"].astype(str) + ". "
            + act + " → " + by_preference["action"].astype(str))


#: A participant's words in a heatmap's hover, wrapped at this many columns (a CJK character takes two): on one line,
#: a description of 140 characters ran past both edges of the Results page's heatmap at 1280 px
#: ("ens im Schlafzimmer: ... Grö"; English ones of 130 characters as well).
HOVER_COLUMNS = 60


def _columns(text: str) -> int:
    """How many columns ``text`` takes: a wide or full-width character (Japanese, Chinese, Korean) two, another one."""
    return sum(2 if unicodedata.east_asian_width(c) in "WF" else 1 for c in text)


def hover_words(text, columns: int = HOVER_COLUMNS) -> str:
    """``text`` (a participant's words) for a Plotly hover: lines of at most ``columns`` columns (:func:`_columns`)
    joined by ``<br>``, broken at spaces, and a word longer than a line (a German compound, a sentence of Japanese,
    which has no spaces) where the line is full; ``&``, ``<`` and ``>`` escaped (Plotly reads tags and entities in
    a hover: "weniger als <5 min" lost its words)."""
    lines: list[str] = []
    line = ""
    for word in str(text).split():
        if line and _columns(line) + 1 + _columns(word) <= columns:
            line += " " + word
            continue
        if line:
            lines.append(line)
        while _columns(word) > columns:
            cut = next(i for i in range(len(word), 0, -1) if _columns(word[:i]) <= columns)
            lines.append(word[:cut])
            word = word[cut:]
        line = word
    if line:
        lines.append(line)
    return "<br>".join(html.escape(x, quote=False) for x in lines)


def preference_row_numbers(by_preference: pd.DataFrame) -> pd.Series:
    """A narrow screen's row label of each by_preference row: participant and preference number
    ("P01 · 2"); the activities and action are in the cell's hover (:func:`preference_rows` took
    300 of a phone's 360 px, and the cells were 16 px wide)."""
    return by_preference["participant"].astype(str) + " · " + by_preference["preference"].astype(str)


def _preference_heatmap(rows: pd.DataFrame, column: str, columns: list, title: str, x_title: str,
                        narrow: bool = False) -> go.Figure:
    """``narrow`` (a phone): rows named by :func:`preference_row_numbers`, each cell's hover naming the
    preference, column labels on two lines rather than tilted, the title on two, the colour bar under
    the grid."""
    rows = rows.assign(_row=preference_row_numbers(rows) if narrow else preference_rows(rows),
                       _long=preference_rows(rows))
    # participants as a person reads them (records.code_order: "p01, R01, r02", "P2, P10"), each one's
    # preferences in order
    order = list(dict.fromkeys(rows.assign(_who=rows["participant"].map(records.code_order))
                               .sort_values(["_who", "preference"], kind="stable")["_row"]))
    grid = rows.pivot_table(index="_row", columns=column, values="accuracy", aggfunc="first").reindex(
        index=order, columns=columns)
    info = rows.drop_duplicates("_row").set_index("_row").reindex(order)
    named = (lambda r: f"{html.escape(info.loc[r, '_long'], quote=False)}<br>") if narrow else (lambda r: "")
    hover = [[f"{named(r)}{hover_words(info.loc[r, 'label'])}<br>{x_title} {c}: " + (
        "no test state" if pd.isna(grid.loc[r, c]) else f"{grid.loc[r, c]:.0%} of {int(info.loc[r, 'states'])} test states")
        for c in columns] for r in order]
    labels = [METHOD_LABELS.get(c, c) if column == "method" else c for c in columns]
    if narrow:  # "CACAS<br>w/o PR": side by side at 70 px a column, where Plotly tilted them into the title
        labels = [str(x).replace(" ", "<br>", 1) if column == "method" else x for x in labels]
    bar = dict(title=dict(text="accuracy", side="right"), tickformat=".0%")
    if narrow:  # under the grid: at the side it took 80 of a phone's 360 px
        bar = dict(title=dict(text="accuracy", side="top"), tickformat=".0%", orientation="h", y=-0.02,
                   yanchor="top", thickness=12, len=1)
    fig = go.Figure(go.Heatmap(
        z=grid.to_numpy(dtype=float), x=labels,
        y=order, zmin=0, zmax=1, colorscale=[[0, "#f4f1ea"], [0.5, "#9cc3d5"], [1, "#2f6f8f"]],
        texttemplate="%{z:.0%}", hovertext=hover, hovertemplate="%{hovertext}<extra></extra>",
        colorbar=bar, xgap=2, ygap=2))
    fig.update_yaxes(autorange="reversed", title_text=None, automargin=True)
    # narrow: the method names say what they are; "1 2 3" needs its "day"
    fig.update_xaxes(title_text=None if narrow and column == "method" else x_title, type="category", side="top",
                     automargin=True,
                     tickangle=0 if narrow else None)
    if narrow:  # one line of the title was cut at both edges of a phone
        title = title.replace(" by described preference", "<br>by described preference", 1)
    # the title pushes the margin above the column labels (yref "container"): on a narrow page Plotly
    # tilts the labels, which grew into the title (walkthrough, Results at 800 px)
    fig.update_layout(title=dict(text=title, automargin=True, yref="container", pad=dict(t=12)), template="plotly_white",
                      height=max(320, 140 + 26 * len(order)) + (70 if narrow else 0),
                      margin=dict(l=20, r=20, t=100, b=80 if narrow else 20))
    return fig


def preference_days_figure(by_preference: pd.DataFrame, method: str = "cacas", narrow: bool = False) -> go.Figure:
    """Fig. 4 by described preference, for one method: each preference's accuracy on its test
    states, day by day (which preferences the method learnt, and when). ``narrow``: a phone's
    layout (:func:`_preference_heatmap`)."""
    rows = by_preference[by_preference["method"] == method]
    days = sorted(int(d) for d in rows["day"].unique())
    return _preference_heatmap(rows.assign(day=rows["day"].astype(int)), "day", days,
                               f"Accuracy by described preference, day by day ({METHOD_LABELS.get(method, method)})",
                               "day", narrow)


def preference_methods_figure(by_preference: pd.DataFrame, day: int | None = None, narrow: bool = False) -> go.Figure:
    """Fig. 4 by described preference on one day (default the last): each method's accuracy on
    each preference's test states, side by side. ``narrow``: a phone's layout."""
    day = int(by_preference["day"].max()) if day is None else int(day)
    rows = by_preference[by_preference["day"].astype(int) == day]
    methods = in_method_order(rows["method"])
    return _preference_heatmap(rows, "method", methods, f"Accuracy by described preference and method, day {day}",
                               "method", narrow)


def _plain(text) -> str:
    """A Plotly text as words: its HTML tags (``<br>``, ``<sup>``) gone, entities read, spaces single."""
    words = re.sub(r"<br\s*/?>", " ", str(text or ""), flags=re.I)
    return " ".join(html.unescape(re.sub(r"<[^>]+>", "", words)).split())


#: a heatmap's columns named in its description up to this many (a confusion matrix has one per class: 33)
DESCRIBED_COLUMNS = 8


def describe(fig: go.Figure) -> str:
    """A short description of ``fig`` for a screen reader (``st.plotly_chart``'s ``alt``): its title and subtitle,
    then what it draws: the legend's entries, or a heatmap's rows and columns. Without it a chart was read as its
    tick labels run together ("1 0% 20% 40% ...") followed by a row of unnamed images (accessibility walkthrough)."""
    title = fig.layout.title
    said = [t for t in (_plain(title.text), _plain(title.subtitle.text) if title.subtitle else "") if t]
    shown = [_plain(t.name) for t in fig.data if t.name and t.showlegend is not False]
    if shown:
        said.append("Drawn: " + "; ".join(dict.fromkeys(shown)))
    for t in fig.data:
        if t.type == "heatmap" and t.x is not None and t.y is not None:
            columns = [_plain(x) for x in t.x]
            axis = _plain(fig.layout.xaxis.title.text)
            said.append(f"A grid of {len(t.y)} rows by {len(columns)} columns"
                        + (f" ({axis + ': ' if axis else ''}{', '.join(columns)})" if len(columns) <= DESCRIBED_COLUMNS
                           else ""))
    return ". ".join(x.rstrip(".") for x in said) + "."

