"""Which preferences each method learnt: a day's Fig. 4 accuracy broken down by described
preference, from the by_preference.csv that `cacas simulate --out DIR` writes.

    cacas simulate --personas study_data/personas/example_leave_me_alone.json --out results
    python3 scripts/accuracy_by_preference.py results/by_preference.csv [--day 7]

Prints, per method, the mean over participants of the accuracy on the test states of "do
nothing" preferences ("leave me alone"), on those of the other preferences, and on all of them
(state-weighted, so "all" equals that day's preference_accuracy in daily.csv where no two
preferences of a participant cover the same state). --day defaults to the last day.
"""
from __future__ import annotations

import argparse
import sys

import pandas as pd

COLUMNS = ("participant", "method", "day", "action", "states", "correct")


def load(path: str) -> pd.DataFrame:
    """A by_preference.csv, checked for the columns this script needs."""
    # a missing value is an empty cell in what CACAS writes: pandas' default NA strings made participant "NA"
    # (a valid code) missing, and the means over participants left them out
    rows = pd.read_csv(path, dtype={"participant": str}, keep_default_na=False, na_values=[""])
    missing = [c for c in COLUMNS if c not in rows.columns]
    if missing:
        raise ValueError(f"{path}: not a by_preference.csv; missing columns: {', '.join(missing)}")
    return rows


def summary(rows: pd.DataFrame) -> pd.DataFrame:
    """State-weighted accuracy per method on 'do nothing' preferences, the others, and all."""
    rows = rows.assign(group=(rows["action"] == "do nothing").map({True: "do nothing", False: "other actions"}))
    per_participant = rows.groupby(["method", "participant", "group"])[["correct", "states"]].sum()
    acc = (per_participant["correct"] / per_participant["states"]).unstack("group")
    total = rows.groupby(["method", "participant"])[["correct", "states"]].sum()
    acc["all"] = total["correct"] / total["states"]
    return acc.groupby("method").mean().reindex(list(dict.fromkeys(rows["method"])))


def markdown(table: pd.DataFrame) -> str:
    lines = ["| method | " + " | ".join(table.columns) + " |", "|---|" + "---|" * len(table.columns)]
    for method, r in table.iterrows():
        lines.append(f"| {method} | " + " | ".join("-" if pd.isna(v) else f"{v:.3f}" for v in r) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("by_preference", help="by_preference.csv written by cacas simulate --out DIR")
    ap.add_argument("--day", type=int, default=None, help="study day (default: the last)")
    args = ap.parse_args(argv)
    try:
        rows = load(args.by_preference)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        print(f"accuracy_by_preference: {exc}", file=sys.stderr)
        return 2
    days = sorted(rows["day"].unique())
    day = days[-1] if args.day is None else args.day
    if day not in days:
        print(f"accuracy_by_preference: --day {day} is not in {args.by_preference}; valid: "
              f"{', '.join(str(d) for d in days)}", file=sys.stderr)
        return 2
    rows = rows[rows["day"] == day]
    print(f"day {day}: mean over {rows['participant'].nunique()} participants of the accuracy on each group's "
          "test states")
    print(markdown(summary(rows)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
