"""Benchmark of a study's export and import: what a researcher waits for, and the memory it takes.

    python3 scripts/bench_export.py DB [--study default] [--keep DIR]

DB: e.g. one built by ``scripts/bench_pages_db.py`` (``--participants 60 --days 21`` for the scale walk).
Each step runs in a process of its own (its peak memory is the process's maximum resident set size, the
imports' ~0.3 GB included), one after another:

* ``tables``: ``export.export_tables`` (every table, as the Results page reads them);
* ``csvs``: every table's CSV bytes (the Results page's "Download <table>.csv", all of them);
* ``bundle``: ``export.bundle_bytes`` (the Results page's "Download everything", made in memory);
* ``export``: ``export.export_study`` into an empty folder (``cacas export``: the CSVs and the zip, on disk);
* ``import``: ``export.import_bundle`` of that zip into an empty folder (``cacas import``).

Prints a Markdown table (seconds of wall time and of CPU, peak memory, what was made), then the sizes on disk
of the database, its policies/ folder (files and versions) and the export. Timings on a shared machine are
noisy (the CPU seconds less so): run it a few times.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this checkout's cacas, not an installed one
STEPS = ("tables", "csvs", "bundle", "export", "import")


def _mib(n: float) -> str:
    return f"{n / 2**20:.0f} MiB"


def du(path: Path) -> int:
    """Bytes of the files under ``path`` (or of the file)."""
    if path.is_file():
        return path.stat().st_size
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())


def step(name: str, db: str, study: str | None, work: Path) -> dict:
    """Run one step here (a child process); what it made, in words."""
    from cacas import export
    from cacas.store import StudyStore

    made = ""
    wall, cpu = time.perf_counter(), time.process_time()
    if name in ("tables", "csvs", "bundle"):
        store = StudyStore(db, readonly=True)
        if name == "tables":
            made = f"{sum(len(t) for t in export.export_tables(store, study).values())} rows"
        elif name == "csvs":
            made = _mib(sum(len(b) for b in export.export_contents(store, study, bundle=False).values()))
        else:
            made = f"zip of {_mib(len(export.bundle_bytes(store, study)))}"
        store.close()
    elif name == "export":
        done = export.export_study(db, work / "export", study)
        made = f"zip of {_mib(done.bundle.stat().st_size)}"
    else:
        export.import_bundle(work / "export" / export.BUNDLE_NAME, work / "imported" / "study.db")
        made = f"database of {_mib(du(work / 'imported' / 'study.db'))}"
    return {"wall": time.perf_counter() - wall, "cpu": time.process_time() - cpu, "made": made,
            "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("db")
    ap.add_argument("--study", default=None, help="one study of the database (default: all)")
    ap.add_argument("--keep", help="a folder for the export and the import (default: a temporary one, removed)")
    ap.add_argument("--step", choices=STEPS, help=argparse.SUPPRESS)  # a child process's one step
    ap.add_argument("--work", help=argparse.SUPPRESS)
    args = ap.parse_args()
    db = str(Path(args.db).resolve())
    if args.step:
        print(json.dumps(step(args.step, db, args.study, Path(args.work))))
        return
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench-export-"))
    for folder in ("export", "imported"):
        if (work / folder).exists():
            sys.exit(f"{work / folder} exists")
    try:
        print(f"load average {os.getloadavg()[0]:.1f}")
        print("| step | wall (s) | CPU (s) | peak memory | made |")
        print("|---|---:|---:|---:|---|")
        for name in STEPS:
            cmd = [sys.executable, __file__, db, "--step", name, "--work", str(work)]
            if args.study:
                cmd += ["--study", args.study]
            out = subprocess.run(cmd, capture_output=True, text=True)
            if out.returncode:
                sys.exit(out.stderr[-2000:])
            r = json.loads(out.stdout.splitlines()[-1])
            print(f"| {name} | {r['wall']:.1f} | {r['cpu']:.1f} | {_mib(r['peak'])} | {r['made']} |", flush=True)
        policies = Path(db).parent / "policies"
        n = sum(1 for _ in policies.rglob("*.pt")) if policies.is_dir() else 0
        print(f"\ndatabase {_mib(du(Path(db)))}; policies/ {_mib(du(policies)) if policies.is_dir() else '-'} "
              f"({n} files); export folder {_mib(du(work / 'export'))}; imported study "
              f"{_mib(du(work / 'imported'))}")
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
