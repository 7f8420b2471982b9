"""Print the README's results table (means per day, next to the paper's numbers) from a
daily.csv written by `cacas simulate`: the closed-loop method's success rate (CACAS where it has
one), every method's preference accuracy, and, for a run with `--loop each`, every other
method's success rate too (the ceiling and feedback columns are then the first one's, and say so).

    python3 scripts/results_table.py results/daily.csv
"""

import sys

import pandas as pd

# The paper's Fig. 3 (human study, CACAS success rate) quoted in its text: day 1 30 %, day 7 85 %;
# Fig. 4, day 7 preference accuracy: CACAS 89 %, 19 / 36 / 68 points above w/o PR, ORL, NN.
PAPER = {"success day 1": 0.30, "success day 7": 0.85, "cacas day 7": 0.89,
         "cacas-no-pr day 7": 0.89 - 0.19, "orl day 7": 0.89 - 0.36, "nn day 7": 0.89 - 0.68}


REQUIRED = ("participant", "method", "day", "success_rate", "preference_accuracy", "cumulative_feedback")


def _fail(message: str) -> None:
    print(f"results_table: {message}", file=sys.stderr)
    sys.exit(2)


def read_daily(path: str) -> pd.DataFrame:
    """daily.csv, or exit code 2 with one line naming the file and what is wrong."""
    try:
        # a missing value is an empty cell in what CACAS writes: pandas' default NA strings made participant
        # "NA" (a valid code) missing
        daily = pd.read_csv(path, dtype={"participant": str}, keep_default_na=False, na_values=[""])
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        _fail(f"{path}: cannot be read as a daily.csv ({exc.__class__.__name__}: "
                 f"{getattr(exc, 'strerror', None) or exc})")
    missing = [c for c in REQUIRED if c not in daily.columns]
    if missing:
        _fail(f"{path}: not a daily.csv of cacas simulate or cacas export (no column "
                 f"{missing[0]!r}); valid: columns {', '.join(REQUIRED)}, ...")
    return daily


def main(path: str) -> None:
    daily = read_daily(path)
    if "success_ceiling" not in daily.columns:  # written before the column existed
        daily["success_ceiling"] = float("nan")
    methods = list(dict.fromkeys(daily["method"]))
    acc = daily.pivot_table(index="day", columns="method", values="preference_accuracy", aggfunc="mean")[methods]
    looped = list(dict.fromkeys(daily.loc[daily["success_rate"].notna(), "method"]))  # --loop each: all of them
    loop = "cacas" if "cacas" in looped else looped[0] if looped else methods[0]  # as plots.loop_method
    looped = [loop] + [m for m in looped if m != loop]
    whose = f" ({loop})" if len(looped) > 1 else ""
    succ = daily[daily["method"] == loop].groupby("day").agg(
        success_rate=("success_rate", "mean"), success_min=("success_rate", "min"),
        success_max=("success_rate", "max"), cumulative_feedback=("cumulative_feedback", "mean"),
        ceiling=("success_ceiling", "mean"))
    others = daily.pivot_table(index="day", columns="method", values="success_rate", aggfunc="mean")
    with_ceiling = bool((succ["ceiling"] < 1).any())  # shown where participants want the robot quiet somewhere
    head = ["day", f"success rate ({loop}) mean [min-max]"] + [f"success rate {m}" for m in looped[1:]] + \
        ([f"success ceiling{whose}"] if with_ceiling else []) + [f"cumulative feedback{whose}"] + \
        [f"accuracy {m}" for m in methods]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for day in acc.index:
        s = succ.loc[day]
        cells = [str(day), f"{s.success_rate:.2f} [{s.success_min:.2f}-{s.success_max:.2f}]"] + \
            [f"{others.loc[day, m]:.2f}" for m in looped[1:]] + ([f"{s.ceiling:.2f}"] if with_ceiling else []) + \
            [f"{s.cumulative_feedback:.1f}"] + [f"{acc.loc[day, m]:.3f}" for m in methods]
        print("| " + " | ".join(cells) + " |")
    last = acc.index.max()
    paper = ["paper", f"{PAPER['success day 1']:.2f} (day 1), {PAPER['success day 7']:.2f} (day 7)"] + \
        ["-"] * (len(looped[1:]) + with_ceiling) + ["104 (day 7)"] + \
        [f"{PAPER[m + ' day 7']:.2f} (day 7)" if m + " day 7" in PAPER else "-" for m in methods]
    print("| " + " | ".join(paper) + " |")
    print(f"\nparticipants: {daily['participant'].nunique()}, days: {last}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        _fail("usage: python3 scripts/results_table.py DAILY_CSV")
    main(sys.argv[1])
