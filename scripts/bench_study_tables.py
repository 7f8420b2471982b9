"""Benchmark of a human study's tables (what the Results page computes on every rerun).

    python3 scripts/bench_study_tables.py [--sizes 8,24,48] [--days 7] [--keep DIR]

Builds a study database of PARTICIPANTS x DAYS study days of 15 interactions each, with a CACAS
adaptation after every day (policy version, Fig. 4 metrics by preference) and three baseline
runs of a method comparison, the way the app records them (no training: the policy files are a
few bytes, which the tables do not read), then times ``export.export_tables`` (every table of
the export and the Results page), ``export.runs_in_force`` (which policy each method had in
force each day) and ``app_support.open_days`` once each, and prints a Markdown table in seconds.
The large-study walkthrough measured the Results page at 4.5 s for 24 participants x 7 days,
most of it ``runs_in_force`` (a scan of the adaptation runs per participant-day, made twice).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one
from cacas import app_support, export  # noqa: E402
from cacas.store import StudyStore  # noqa: E402

PREFERENCES = [{"activity": ["cough"], "action": "pain check"},
               {"activity": ["use stove"], "scene": ["kitchen"], "action": "remind to turn off"}]
ANSWERS = [("cough", "bedroom", "pain check", "accept"), ("cough", "bedroom", "chitchat", "reject"),
           ("use stove", "kitchen", "remind to turn off", "accept"), ("use stove", "kitchen", "set a timer", "reject")]


def build(path: Path, participants: int, days: int, seed: int = 0, comparison: bool = True) -> StudyStore:
    """The study database (``comparison``: with the baselines' runs of a method comparison)."""
    rng = np.random.default_rng(seed)
    store = StudyStore(path)
    for p in range(participants):
        code = f"P{p:03d}"
        store.add_participant(code)
        store.save_preferences(code, PREFERENCES)
        store.record_adaptation(code, 0, "cacas", {}, 0.0, {"preference_accuracy": 0.2})
        version = None
        for _ in range(days):
            day = store.open_day(code)
            for i in range(15):
                act, scene, robot, resp = ANSWERS[int(rng.integers(len(ANSWERS)))]
                store.record_interaction(code, day, activity=act, scene=scene, hour=8 + i % 12,
                                         interval_minutes=30, robot_action=robot, response=resp,
                                         policy_version=version, method="cacas")
            store.close_day(code, day)
            version = store.save_policy(code, day, "cacas", f"{code} day {day}".encode())
            metrics = {"preference_accuracy": float(rng.random()), "by_preference": [
                {"preference": k + 1, "label": f"{pref['activity'][0]} -> {pref['action']}",
                 "activity": pref["activity"][0], "action": pref["action"], "states": 400,
                 "correct": int(rng.integers(400))} for k, pref in enumerate(PREFERENCES)]}
            store.record_adaptation(code, day, "cacas", {}, 1.0, metrics, policy_version=version)
            for method in ("cacas-no-pr", "orl", "nn") if comparison else ():  # runs without a policy version
                store.record_adaptation(code, day, method, {"comparison": True}, 1.0,
                                        {"preference_accuracy": float(rng.random())})
    return store


def timed(fn, *args) -> float:
    t = time.perf_counter()
    fn(*args)
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="8,24,48", help="numbers of participants, comma-separated")
    ap.add_argument("--days", type=int, default=7)
    ap.add_argument("--keep", help="build the databases in this folder (kept) instead of a temporary one")
    args = ap.parse_args()
    print("| participants x days | interactions | adaptation runs | export_tables (s) | runs_in_force (s) "
          "| open_days (s) |")
    print("|---|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(args.keep or tmp)
        for n in (int(x) for x in args.sizes.split(",")):
            path = folder / f"bench-{n}x{args.days}.sqlite"
            store = StudyStore(path) if path.exists() else build(path, n, args.days)
            tables = export.export_tables(store)
            found = (tables["interactions"], tables["adaptations"], tables["days"])
            t_all = timed(export.export_tables, store)
            t_rif = timed(export.runs_in_force, *found)
            t_open = timed(app_support.open_days, store)
            print(f"| {n} x {args.days} | {len(tables['interactions']):,} | {len(tables['adaptations']):,} "
                  f"| {t_all:.2f} | {t_rif:.2f} | {t_open:.2f} |")
            store.close()


if __name__ == "__main__":
    main()
