"""Profile one day's CACAS adaptation (the app's "close the day") and print cProfile's top items.

Usage: python3 scripts/profile_adapt.py [--method cacas] [--top 25]
"""
from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one


def day_of_interactions(seed: int = 0):
    from cacas import records
    from cacas.adaptation import load_initial_policy
    from cacas.experiment import simulated_day
    from cacas.preferences import load_personas
    from cacas.paths import study_data_dir

    person = load_personas(study_data_dir() / "personas" / "example.json")[0]
    initial = load_initial_policy()
    rows = simulated_day(initial, person, 1, 15, np.random.default_rng(seed), 0.1, "cacas")
    return initial, pd.DataFrame(rows, columns=records.INTERACTION_COLUMNS)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--method", default="cacas")
    ap.add_argument("--top", type=int, default=25)
    args = ap.parse_args()
    torch.set_num_threads(1)
    from cacas.adaptation import adapt_policy

    initial, data = day_of_interactions()
    adapt_policy(initial, data, args.method)  # warm-up
    t = time.perf_counter()
    adapt_policy(initial, data, args.method)
    print(f"adapt_policy({args.method}) {time.perf_counter() - t:.2f} s (unprofiled)")
    prof = cProfile.Profile()
    prof.enable()
    adapt_policy(initial, data, args.method)
    prof.disable()
    pstats.Stats(prof).sort_stats("tottime").print_stats(args.top)


if __name__ == "__main__":
    main()
