"""Benchmark of the app's pages on a study database, with Streamlit's AppTest (no browser).

    python3 scripts/bench_pages.py DB [--repeats 5] [--pages overview,results] [--participant P000]
                                      [--profile PAGE --out FILE]

DB: e.g. one built by ``scripts/bench_pages_db.py`` (24 participants x 7 days x 15 interactions).
For each page: a new AppTest session opens the app at ?participant=..., then switches to the page;
"first" times that page's first run (Streamlit's caches cleared before it, as after a server start),
"repeat" the same session's next run of it (a widget change or a refresh of a page already
open). Medians over ``--repeats`` runs, with min and max, in seconds, as a Markdown table. The
component-manifest scan that a server makes once at its start is made once here too (as in
tests/app/conftest.py). ``--profile PAGE`` writes a cProfile of that page's first and repeat runs.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this checkout's cacas, not an installed one

PAGES = {"overview": "pages/overview.py", "participants": "pages/participants.py", "session": "pages/session.py",
         "adaptation": "pages/adaptation.py", "results": "pages/results.py", "simulation": "pages/simulation.py",
         "sounds": "pages/sounds.py"}


def setup() -> None:
    from streamlit.components.v2 import manifest_scanner
    from streamlit.runtime.pages_manager import PagesManager
    from streamlit.testing.v1 import app_test

    found = manifest_scanner.scan_component_manifests()
    manifest_scanner.scan_component_manifests = lambda *a, **k: list(found)

    class NavigationPagesManager(PagesManager):  # a server after its first request (tests/app/conftest.py)
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            PagesManager.uses_pages_directory = False

    app_test.PagesManager = NavigationPagesManager


def open_page(page: str, participant: str):
    import streamlit as st
    from streamlit.testing.v1 import AppTest

    st.cache_data.clear()
    st.cache_resource.clear()
    at = AppTest.from_file(str(ROOT / "app.py"), default_timeout=300)
    at.query_params["participant"] = participant
    at.run()
    at.switch_page(PAGES[page])
    return at


def timed_run(at) -> float:
    t = time.perf_counter()
    at.run()
    dt = time.perf_counter() - t
    if at.exception:
        raise RuntimeError([e.value for e in at.exception])
    return dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("db")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--pages", default=",".join(PAGES))
    ap.add_argument("--participant", default="P000")
    ap.add_argument("--profile", help="a page to profile (cProfile) instead of timing every page")
    ap.add_argument("--out", default="page.prof")
    args = ap.parse_args()
    os.environ["CACAS_DB"] = str(Path(args.db).resolve())
    os.chdir(ROOT)
    setup()
    t = time.perf_counter()
    warm = open_page("overview", args.participant)  # imports (torch, pandas, plotly, the pages' modules)
    timed_run(warm)
    print(f"warm-up (imports, first ever run): {time.perf_counter() - t:.2f} s", file=sys.stderr)
    # Streamlit's "No runtime found" / "missing ScriptRunContext" warnings (the caches cleared outside a server,
    # open_page) came between the table's rows (README audit); set once its loggers exist, after the warm-up
    import streamlit.logger

    streamlit.logger.set_log_level("error")
    if args.profile:  # the script runs in AppTest's script thread: profiled there
        from streamlit.runtime.scriptrunner import script_runner

        real = script_runner.exec_func_with_error_handling
        at = open_page(args.profile, args.participant)
        for run in ("first", "repeat"):
            prof = cProfile.Profile()

            def profiled(*a, **k):
                prof.enable()
                try:
                    return real(*a, **k)
                finally:
                    prof.disable()
            script_runner.exec_func_with_error_handling = profiled
            timed_run(at)
            script_runner.exec_func_with_error_handling = real
            prof.dump_stats(f"{args.out}.{run}")
        print(f"wrote {args.out}.first and {args.out}.repeat")
        return
    print(f"| page | first run (s) median [min-max] | repeat run (s) median [min-max] |")
    print("|---|---:|---:|")
    for page in args.pages.split(","):
        first, repeat = [], []
        for _ in range(args.repeats):
            at = open_page(page, args.participant)
            first.append(timed_run(at))
            repeat.append(timed_run(at))
        f = lambda xs: f"{statistics.median(xs):.2f} [{min(xs):.2f}-{max(xs):.2f}]"  # noqa: E731
        print(f"| {page} | {f(first)} | {f(repeat)} |", flush=True)


if __name__ == "__main__":
    main()
