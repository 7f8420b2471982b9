"""Benchmark of reading policy files: what the tablet waits for when it loads a policy, and what an import of a
study bundle spends checking the policy files it brings.

    python3 scripts/bench_policy_io.py [--participants 8] [--days 7] [--repeat 3]

Prints a Markdown table (medians of ``--repeat`` runs): ``policy_checkpoint`` (the import's check of one file:
weights-only unpickle and a known policy kind), ``policy_from_bytes`` (the tablet's load: the policy built), both
on the shipped initial policy (~620 KB), and ``cacas import`` of a bundle of participants x days policy versions
of that size (a study of 8 x 7 holds 56). Timings on a shared machine are noisy: compare figures of one run.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one

from cacas import export  # noqa: E402
from cacas.paths import study_data_dir  # noqa: E402
from cacas.policy import policy_checkpoint, policy_from_bytes  # noqa: E402
from cacas.store import StudyStore  # noqa: E402


def _ms(fn, data: bytes, n: int = 10) -> float:
    fn(data)  # the first call pays for imports
    start = time.perf_counter()
    for _ in range(n):
        fn(data)
    return (time.perf_counter() - start) / n * 1000


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--participants", type=int, default=8)
    parser.add_argument("--days", type=int, default=7)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    data = (study_data_dir() / "models" / "initial_policy.pt").read_bytes()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        with StudyStore(tmp / "a" / "study.sqlite") as store:
            for i in range(args.participants):
                code = f"P{i + 1:02d}"
                store.add_participant(code)
                for _ in range(args.days):
                    day = store.open_day(code)
                    store.close_day(code, day)
                    store.save_policy(code, day, "cacas", data)
            bundle = export.export_study(store, tmp / "out").bundle
        rows = {"policy_checkpoint (ms a file)": [], "policy_from_bytes (ms a file)": [],
                f"import of {args.participants} x {args.days} policies (s)": []}
        for k in range(args.repeat):
            rows["policy_checkpoint (ms a file)"].append(_ms(policy_checkpoint, data))
            rows["policy_from_bytes (ms a file)"].append(_ms(policy_from_bytes, data))
            start = time.perf_counter()
            export.import_bundle(bundle, tmp / f"import{k}" / "study.sqlite")
            rows[f"import of {args.participants} x {args.days} policies (s)"].append(time.perf_counter() - start)
    print(f"policy file {len(data) / 1024:.0f} KB; load average {os.getloadavg()[0]:.1f}")
    print("| what | median | runs |\n|---|---:|---|")
    for name, values in rows.items():
        print(f"| {name} | {statistics.median(values):.2f} | {', '.join(f'{v:.2f}' for v in values)} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
