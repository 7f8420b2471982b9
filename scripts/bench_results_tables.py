"""Benchmark of Fig. 4's tables on large daily.csv tables (an uploaded file on the Results page).

    python3 scripts/bench_results_tables.py [--sizes 100x7,1000x7,2000x150]

Builds a daily.csv of PARTICIPANTS x DAYS x 2 methods (5 % of the accuracies missing, so some
participant-days are incomplete comparisons), times ``plots.incomplete_comparisons`` and
``plots.accuracy_table`` (which the Results page calls for Fig. 4) once each, and prints a
Markdown table in seconds. Before the joins of ``incomplete_comparisons`` (a scan of the whole
table per participant-day) 14,000 rows took 20 s and 600,000 rows did not finish.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one
from cacas import plots  # noqa: E402


def daily(participants: int, days: int, seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = [(f"P{p:04d}", m, d, rng.random()) for p in range(participants) for d in range(1, days + 1)
            for m in ("cacas", "nn")]
    df = pd.DataFrame(rows, columns=["participant", "method", "day", "preference_accuracy"])
    df.loc[rng.random(len(df)) < 0.05, "preference_accuracy"] = np.nan
    return df


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="100x7,1000x7,2000x150", help="PARTICIPANTSxDAYS, comma-separated")
    args = ap.parse_args()
    print("| participants x days | rows | incomplete_comparisons (s) | accuracy_table (s) |")
    print("|---|---:|---:|---:|")
    for size in args.sizes.split(","):
        participants, days = (int(x) for x in size.lower().split("x"))
        d = daily(participants, days)
        t = time.perf_counter()
        plots.incomplete_comparisons(d)
        a = time.perf_counter() - t
        t = time.perf_counter()
        plots.accuracy_table(d)
        b = time.perf_counter() - t
        print(f"| {participants} x {days} | {len(d):,} | {a:.2f} | {b:.2f} |")


if __name__ == "__main__":
    main()
