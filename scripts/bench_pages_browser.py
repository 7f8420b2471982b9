"""Benchmark of the app's pages through the real server, in headless Chromium (Playwright).

    python3 scripts/bench_pages_browser.py DB [--repeats 5] [--participant P000] [--pages ...] [--after S]
    python3 scripts/bench_pages_browser.py DB --tablet [--repeats 3] [--after S]

Starts ``streamlit run app.py`` on DB (e.g. from ``scripts/bench_pages_db.py``), opens "/" once
(the server's first request), then for each page: opens it in a new browser tab (a new session) at
?participant=..., timing from the navigation until the script run is over (counted from the messages
the server sends over the page's websocket, as the browser tests count them: tests/browser/headless.py;
then Streamlit's data-test-script-state notRunning) and until every Plotly chart is drawn.
"cold" is the page's first visit after the server's start (modules imported on first use: torch
for the Adaptation page, the recognisers for Sounds), "load" the median [min-max] of ``--repeats``
later visits. Then, on Results, times a change of participant in the sidebar, a change of the
"Data" source and back, and on Adaptation a change of the "Before" policy, until the page is idle.
Prints Markdown tables in seconds; the machine's load average is printed with them.

``--tablet`` times the tablet's first proposal after a server's start instead, on a copy of DB with a
participant of its own (one described preference, day 1 open): a new server for each of ``--repeats``
rounds; the researcher's first page ("/") is the server's first request, then, ``--after`` seconds later,
the tablet view opens (its form drawn, then the page's warm-up of the recognisers runs on), a context is
set at once and "Do it" pressed: "first proposal" is from that press until the proposal's answers are
shown (the warm-up's end included), "next proposal" the same for a second context.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this checkout's cacas, not an installed one (--tablet's database)
# The browser tests' Chromium and their count of a page's script runs (tests/browser/headless.py), imported, not
# copied: stApp's data-test-script-state missed runs of ~100-200 ms, and the bench then waited 60 s for one that
# was over. The folder goes on sys.path, as pytest puts it there for the tests (tests/ is no package).
sys.path.insert(1, str(ROOT / "tests" / "browser"))
from headless import CHROMIUM, FLAGS, free_port, run_over, wait_until, wait_until_up, watch_runs  # noqa: E402

PAGES = {"overview": "", "participants": "participants", "session": "session", "adaptation": "adaptation",
         "results": "results", "simulation": "simulation", "sounds": "sounds"}
CHARTS = ("() => [...document.querySelectorAll(\"[data-testid='stPlotlyChart']\")].every("
          "c => c.querySelector('.main-svg'))")


def start_server(db: str, log: Path):
    """``streamlit run app.py`` on ``db``: (the process, its base URL), once it answers."""
    port = free_port()
    env = dict(os.environ, PYTHONUNBUFFERED="1", CACAS_DB=db,
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.Popen([sys.executable, "-m", "streamlit", "run", "app.py", "--server.port", str(port),
                             "--server.headless", "true", "--server.address", "127.0.0.1",
                             "--browser.gatherUsageStats", "false", "--server.fileWatcherType", "none"],
                            cwd=ROOT, env=env, stdout=open(log, "w"), stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    wait_until_up(proc, base, log, 90)
    return proc, base


def visit(browser, url: str) -> tuple[float, float, object]:
    """(seconds to idle, seconds to charts drawn, the open page)."""
    ctx = browser.new_context(viewport={"width": 1360, "height": 900})
    pg = ctx.new_page()
    pg.set_default_timeout(60_000)
    watch_runs(pg)
    t = time.perf_counter()
    pg.goto(url)
    run_over(pg, 0)
    idle = time.perf_counter() - t
    pg.wait_for_function(CHARTS, polling=20)
    return idle, time.perf_counter() - t, pg


def rerun_time(pg, action) -> float:
    """Seconds from ``action`` until the run it starts is over (the page then idle)."""
    before = watch_runs(pg).started
    t = time.perf_counter()
    action()
    run_over(pg, before)
    pg.wait_for_function(CHARTS, polling=20)
    return time.perf_counter() - t


def choose(pg, label: str, option: str) -> None:
    box = pg.locator("[data-testid='stSelectbox']").filter(has=pg.locator("label", has_text=label)).first
    box.locator("input").click()
    pg.keyboard.type(option)
    pg.get_by_role("option", name=option, exact=True).first.click()


def fmt(xs) -> str:
    return f"{statistics.median(xs):.2f} [{min(xs):.2f}-{max(xs):.2f}]"


#: The tablet's own participant (``--tablet``), added to the copy of the database.
TABLET = "TAB01"
#: The contexts of the first and the next proposal (activity, room).
TABLET_CONTEXTS = [("cough", "bedroom"), ("use stove", "kitchen")]


def tablet_database(db: str, folder: Path) -> str:
    """A copy of ``db`` in ``folder`` with :data:`TABLET`, who has a described preference and day 1 open."""
    from cacas.store import StudyStore
    from cacas.study_day import start_day

    copy = folder / "tablet.sqlite"
    shutil.copy(db, copy)
    with StudyStore(copy) as store:
        store.add_participant(TABLET)
        store.save_preferences(TABLET, [{"activity": ["cough"], "action": "pain check"}])
        start_day(store, TABLET)
    return str(copy)


def propose(pg, activity: str, room: str) -> float:
    """Set a context on the tablet, press "Do it": seconds until the proposal's answers are shown."""
    def tap(label: str, option: str) -> None:
        group = pg.locator("[data-testid='stButtonGroup']").filter(has=pg.locator("label", has_text=label)).first
        group.get_by_role("radio", name=option, exact=True).click()

    tap("Time of day", "08:00-10:00")
    tap("Time since", "20-30 min")
    choose(pg, "Activity", activity)
    tap("Room", room)
    t = time.perf_counter()
    pg.locator("button").filter(has_text=re.compile(r"Do it$")).first.click()
    pg.locator("button").filter(has_text=re.compile(r"(Accept|Nothing needed)$")).first.wait_for(timeout=300_000)
    return time.perf_counter() - t


def bench_tablet(browser, db: str, args) -> None:
    """``--tablet``: the tablet's first proposal after the server's start, a new server a round."""
    form, first, later = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeats):
            proc, base = start_server(tablet_database(db, Path(tmp)), Path(args.log))
            try:
                _, _, pg = visit(browser, f"{base}/")  # the researcher's first page: the server's first request
                pg.context.close()
                time.sleep(args.after)
                ctx = browser.new_context(viewport={"width": 1024, "height": 768})
                pg = ctx.new_page()
                pg.set_default_timeout(300_000)
                runs = watch_runs(pg)
                t = time.perf_counter()
                pg.goto(f"{base}/?participant={TABLET}&view=tablet")
                pg.locator("button").filter(has_text=re.compile(r"Do it$")).first.wait_for()
                form.append(time.perf_counter() - t)
                first.append(propose(pg, *TABLET_CONTEXTS[0]))
                wait_until(pg, lambda: not runs.busy, 300_000)
                pg.locator("button").filter(has_text=re.compile(r"Choose a different activity$")).first.click()
                pg.locator("button").filter(has_text=re.compile(r"Do it$")).first.wait_for()
                later.append(propose(pg, *TABLET_CONTEXTS[1]))
                ctx.close()
            finally:
                stop_server(proc)
    print(f"load average {os.getloadavg()[0]:.1f}")
    print("| tablet, after the server's start | form drawn (s) | first proposal (s) | next proposal (s) |")
    print("|---|---:|---:|---:|")
    print(f"| researcher's first page, then the tablet {args.after:g} s later | {fmt(form)} | {fmt(first)} "
          f"| {fmt(later)} |", flush=True)


def stop_server(proc) -> None:
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()


def main() -> None:
    from playwright.sync_api import sync_playwright

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("db")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--participant", default="P000")
    ap.add_argument("--pages", default=",".join(PAGES))
    ap.add_argument("--log", default="/tmp/bench_pages_browser.log")
    ap.add_argument("--no-interactions", action="store_true", help="time the page loads only")
    ap.add_argument("--after", type=float, default=0.0, metavar="SECONDS",
                    help="wait this long after the server's first request (a researcher reading the first page)")
    ap.add_argument("--tablet", action="store_true",
                    help="time the tablet's first proposal after a server's start instead (see above)")
    args = ap.parse_args()
    if args.tablet:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
            bench_tablet(browser, str(Path(args.db).resolve()), args)
            browser.close()
        return
    proc, base = start_server(str(Path(args.db).resolve()), Path(args.log))
    print(f"server pid {proc.pid}", file=sys.stderr, flush=True)
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
            q = f"?participant={args.participant}"
            _, _, pg = visit(browser, f"{base}/{q}")  # the server's first request
            pg.context.close()
            time.sleep(args.after)
            print(f"load average {os.getloadavg()[0]:.1f}")
            print("| page | cold: idle / charts drawn (s) | load: idle (s) | load: charts drawn (s) |")
            print("|---|---:|---:|---:|")
            for page in args.pages.split(","):
                url = f"{base}/{PAGES[page]}{q}"
                cold_idle, cold_drawn, pg = visit(browser, url)
                pg.context.close()
                idle, drawn = [], []
                for _ in range(args.repeats):
                    a, b, pg = visit(browser, url)
                    pg.context.close()
                    idle.append(a)
                    drawn.append(b)
                print(f"| {page} | {cold_idle:.2f} / {cold_drawn:.2f} | {fmt(idle)} | {fmt(drawn)} |", flush=True)
            if args.no_interactions:
                return
            print(f"\nload average {os.getloadavg()[0]:.1f}")
            print("| interaction | median [min-max] (s) |")
            print("|---|---:|")
            _, _, pg = visit(browser, f"{base}/results{q}")
            others = ["P001", args.participant]
            times = [rerun_time(pg, lambda: choose(pg, "Participant", others[i % 2])) for i in range(args.repeats)]
            print(f"| Results: another participant in the sidebar | {fmt(times)} |", flush=True)
            times = []
            for i in range(args.repeats):
                times.append(rerun_time(pg, lambda: pg.get_by_role("radio", name="A simulated run", exact=True).click()))
                times.append(rerun_time(pg, lambda: pg.get_by_role(
                    "radio", name="Human study (this database)", exact=True).click()))
            print(f"| Results: Data source to 'A simulated run' and back to the human study (each) "
                  f"| {fmt(times[1::2])} (back) / {fmt(times[0::2])} (away) |", flush=True)
            pg.context.close()
            _, _, pg = visit(browser, f"{base}/adaptation{q}")
            from cacas.plots import method_names  # the page's words for the method (099d9c4: 'CACAS', not the code)

            opts = [f"version {v} (after day {v}, {method_names(['cacas'])})" for v in (3, 5)]
            times = [rerun_time(pg, lambda: choose(pg, "Before", opts[i % 2])) for i in range(args.repeats)]
            print(f"| Adaptation: another 'Before' policy | {fmt(times)} |", flush=True)
            pg.context.close()
            browser.close()
    finally:
        stop_server(proc)


if __name__ == "__main__":
    main()
