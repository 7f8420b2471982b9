"""Which preferences each method learnt: the last day's Fig. 4 accuracy broken down by described
preference, for the same simulated study `cacas simulate` runs (same seed, same policies).

    python3 scripts/accuracy_by_preference.py --personas study_data/personas/example_leave_me_alone.json \
        [--methods cacas,cacas-no-pr,orl,nn] [--days 7] [--interactions 15] [--seed 0] [--jobs 2] [--out FILE.csv]

Prints, per method, the accuracy on the test states of "do nothing" preferences ("leave me
alone"), on those of the other preferences, and on all of them (state-weighted, so "all" equals
the last day's preference_accuracy in daily.csv); --out writes every participant's
per-preference rows.
"""
from __future__ import annotations

import argparse
import os
from concurrent.futures import ProcessPoolExecutor
import multiprocessing as mp

import pandas as pd


def participant_rows(p_i: int, personas: str, methods: tuple[str, ...], days: int, interactions: int,
                     seed: int) -> pd.DataFrame:
    import torch

    torch.set_num_threads(1)
    from cacas.adaptation import accuracy_by_preference, load_initial_policy
    from cacas.d4a import load_d4a
    from cacas.experiment import participant_test_states, policies_in_force
    from cacas.preferences import load_personas

    person = load_personas(personas)[p_i]
    in_force = None
    for _, in_force, _ in policies_in_force(load_initial_policy(), person, p_i, days, interactions, methods, seed,
                                            0.1, None, load_d4a()):
        pass
    states = participant_test_states(person, p_i, seed, 400)
    return pd.concat([accuracy_by_preference(in_force[m], person, states).assign(participant=person.id, method=m)
                      for m in methods], ignore_index=True)


def summary(rows: pd.DataFrame) -> pd.DataFrame:
    """State-weighted accuracy per method on 'do nothing' preferences, the others, and all."""
    rows = rows.assign(group=(rows["action"] == "do nothing").map({True: "do nothing", False: "other actions"}))
    per_participant = rows.groupby(["method", "participant", "group"])[["correct", "states"]].sum()
    acc = (per_participant["correct"] / per_participant["states"]).unstack("group")
    total = rows.groupby(["method", "participant"])[["correct", "states"]].sum()
    acc["all"] = total["correct"] / total["states"]
    return acc.groupby("method").mean().reindex(list(dict.fromkeys(rows["method"])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--personas", required=True)
    ap.add_argument("--methods", default="cacas,cacas-no-pr,orl,nn")
    ap.add_argument("--days", type=int, default=7)
    ap.add_argument("--interactions", type=int, default=15)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    from cacas.cli.progress import ProgressBar
    from cacas.experiment import check_methods
    from cacas.preferences import load_personas

    methods = check_methods(args.methods.split(","))
    n = len(load_personas(args.personas))
    jobs = [(i, args.personas, methods, args.days, args.interactions, args.seed) for i in range(n)]
    frames = []
    with ProgressBar("participants") as bar, \
            ProcessPoolExecutor(max(1, min(args.jobs, n)), mp_context=mp.get_context("spawn")) as pool:
        for k, frame in enumerate(pool.map(participant_rows, *zip(*jobs)), start=1):
            frames.append(frame)
            bar(k / n, f"{k}/{n} participants")
    rows = pd.concat(frames, ignore_index=True)
    if args.out:
        rows.to_csv(args.out, index=False)
    table = summary(rows)
    print(f"day {args.days}, seed {args.seed}: mean over {n} participants of the accuracy on each group's test states")
    print("| method | " + " | ".join(table.columns) + " |")
    print("|---|" + "---|" * len(table.columns))
    for method, r in table.iterrows():
        print(f"| {method} | " + " | ".join("-" if pd.isna(v) else f"{v:.3f}" for v in r) + " |")


if __name__ == "__main__":
    main()
