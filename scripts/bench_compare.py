"""Benchmark of the Results page's "Compare methods" (``method_comparison.compare_methods``) in one process
and in worker processes.

    python3 scripts/bench_compare.py [--participants 4] [--days 3] [--jobs 1,2]

Builds a study database as ``bench_study_tables.py`` does (PARTICIPANTS x DAYS, CACAS adapted
after every day) without the baselines' runs, then compares CACAS w/o PR, ORL and NN on it once
for each number of worker processes (each on its own copy), and prints a Markdown table:
runs recorded and seconds. The runs are the same whatever the number (tests/test_method_comparison.py).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_study_tables import build  # noqa: E402
from cacas.method_comparison import compare_methods  # noqa: E402

BASELINES = ("cacas-no-pr", "orl", "nn")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--participants", type=int, default=4)
    ap.add_argument("--days", type=int, default=3)
    ap.add_argument("--jobs", default="1,2", help="numbers of worker processes, comma-separated")
    args = ap.parse_args()
    print("| participants x days | methods | worker processes | runs | seconds |")
    print("|---|---|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base.sqlite"
        build(base, args.participants, args.days, comparison=False).close()
        for jobs in (int(x) for x in args.jobs.split(",")):
            copy = Path(tmp) / f"jobs{jobs}" / "study.sqlite"
            copy.parent.mkdir()
            shutil.copy(base, copy)
            shutil.copytree(Path(tmp) / "policies", copy.parent / "policies")
            t = time.perf_counter()
            n = compare_methods(copy, methods=BASELINES, jobs=jobs)
            print(f"| {args.participants} x {args.days} | {', '.join(BASELINES)} | {jobs} | {n.runs} "
                  f"| {time.perf_counter() - t:.1f} |")


if __name__ == "__main__":
    main()
