"""Benchmark of the study database (issue 4: writing one interaction should take under 20 ms).

    python3 scripts/bench_store.py [--writes 500] [--dir DIR]

Times, on a fresh database in DIR (default: a temporary folder), each call from the caller's
side (validation + one committed BEGIN IMMEDIATE transaction, synchronous=FULL in WAL mode):

* ``record_interaction`` alone;
* ``record_interaction`` while a second process writes interactions as fast as it can;
* ``resume``, ``interactions_frame`` and ``open_day``/``close_day``;

and prints a Markdown table (median, p95, max in milliseconds). Timings on a shared machine are
noisy: run it a few times.
"""

from __future__ import annotations

import argparse
import os
import platform
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one
ROOT = Path(__file__).resolve().parents[1]

from cacas import spaces  # noqa: E402
from cacas.store import StudyStore  # noqa: E402

RIVAL = r"""
import sys, time
from cacas.store import StudyStore
s = StudyStore(sys.argv[1]); day = s.open_day("RIVAL")
print("ready", flush=True)
end = time.time() + float(sys.argv[2])
while time.time() < end:
    s.record_interaction("RIVAL", day, activity="sneeze", scene="kitchen", hour=9, interval_minutes=5,
                         robot_action="chitchat", response="reject")
"""


def interaction(store: StudyStore, who: str, day: int, i: int, rng: np.random.Generator) -> None:
    p = rng.dirichlet(np.ones(spaces.N_ACTIONS))
    store.record_interaction(
        who, day, activity=spaces.ACTIVITIES[i % spaces.N_ACTIVITIES], scene=spaces.SCENES[i % spaces.N_SCENES],
        hour=float(i % 24), interval_minutes=float(i % 250), robot_action=spaces.ACTIONS[int(p.argmax())],
        response=spaces.RESPONSES[i % 3], probabilities=p, recognised_activity="cough")


def timed(fn, n: int) -> list[float]:
    out = []
    for i in range(n):
        t = time.perf_counter()
        fn(i)
        out.append((time.perf_counter() - t) * 1000)
    return out


def row(name: str, ms: list[float]) -> str:
    a = np.asarray(ms)
    return (f"| {name} | {len(a)} | {statistics.median(a):.2f} | {np.percentile(a, 95):.2f} | "
            f"{a.max():.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--writes", type=int, default=500)
    ap.add_argument("--dir", default=None, help="folder for the benchmark database (default: a temp folder)")
    args = ap.parse_args()
    folder = Path(args.dir) if args.dir else Path(tempfile.mkdtemp(prefix="cacas-bench-"))
    path = folder / "bench.sqlite"
    for p in (path, Path(f"{path}-wal"), Path(f"{path}-shm")):
        p.unlink(missing_ok=True)
    rng = np.random.default_rng(0)
    store = StudyStore(path)
    store.add_participant("P01")
    store.add_participant("RIVAL")
    day = store.open_day("P01")
    rows = [row("record_interaction, one writer", timed(lambda i: interaction(store, "P01", day, i, rng),
                                                         args.writes))]

    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    rival = subprocess.Popen([sys.executable, "-c", RIVAL, str(path), "600"], stdout=subprocess.PIPE,
                             text=True, env=env)
    try:
        rival.stdout.readline()
        rows.append(row("record_interaction, a second process writing too",
                        timed(lambda i: interaction(store, "P01", day, i, rng), args.writes)))
    finally:
        rival.kill()
        rival.wait()
    rows.append(row("resume", timed(lambda i: store.resume("P01"), 100)))
    rows.append(row(f"interactions_frame ({2 * args.writes} rows)",
                    timed(lambda i: store.interactions_frame("P01"), 20)))

    def day_cycle(i):
        store.close_day("P01", store.current_day("P01"))
        store.open_day("P01")
    rows.append(row("close_day + open_day", timed(day_cycle, 50)))
    store.close()

    print(f"Study database benchmark: {platform.platform()}, Python {platform.python_version()}, "
          f"SQLite {sqlite3.sqlite_version}, {os.cpu_count()} CPUs; database in {folder}")
    print("WAL mode, synchronous=FULL, one BEGIN IMMEDIATE transaction per write; times in ms.\n")
    print("| operation | calls | median | p95 | max |")
    print("|---|---:|---:|---:|---:|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
