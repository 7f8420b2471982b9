"""Before/after check of an optimisation: time a small simulated study and compare its
preference accuracy (Fig. 4) per method, for the code in a given source tree.

Usage: python3 scripts/profile_study_quality.py SOURCE_TREE [--participants 4] [--days 4] [--seeds 0,1] [--jobs 1]
(run it from outside the repository so that SOURCE_TREE's cacas is the one imported)

Prints one JSON line: seconds per study and mean preference accuracy per method and seed.
"""
from __future__ import annotations

import argparse
import json
import sys
import time


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("tree")
    ap.add_argument("--participants", type=int, default=4)
    ap.add_argument("--days", type=int, default=4)
    ap.add_argument("--seeds", default="0,1")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (the bench uses one per core)")
    args = ap.parse_args()
    sys.path.insert(0, args.tree)
    import torch

    torch.set_num_threads(1)
    from cacas.experiment import PAPER_METHODS, simulate_study
    from cacas.paths import study_data_dir
    from cacas.preferences import load_personas

    people = load_personas(study_data_dir() / "personas" / "example.json")[: args.participants]
    out = {"tree": args.tree, "runs": []}
    for seed in (int(s) for s in args.seeds.split(",")):
        t = time.perf_counter()
        res = simulate_study(people, days=args.days, methods=PAPER_METHODS, seed=seed, jobs=args.jobs)
        secs = time.perf_counter() - t
        d = res.daily
        acc = d[d["day"] > 1].groupby("method")["preference_accuracy"].mean().round(4).to_dict()
        last = d[d["day"] == args.days].groupby("method")["preference_accuracy"].mean().round(4).to_dict()
        sr = float(d["success_rate"].mean())
        out["runs"].append({"seed": seed, "seconds": round(secs, 1), "accuracy_days_2_on": acc,
                            "accuracy_last_day": last, "success_rate": round(sr, 4)})
    print(json.dumps(out))


if __name__ == "__main__":
    main()
