"""A whole study through one app server, compressed: does anything in the server grow day after day?

    python3 scripts/bench_long_run.py [--participants 8] [--days 7] [--tablet 2] [--tabs 20]
                                      [--tracemalloc] [--settle 0] [--json FILE] [--keep DIR]

A lab starts ``streamlit run app.py`` on Monday and leaves it running for the study. This starts it on a
temporary study database (``scripts/long_run_server.py``: the app's server with a probe inside) whose
participants are the example personas (more than 8: their preferences again under new codes), and drives
the study through it in headless Chromium, a day at a time:

* each participant's tablet opens in a new tab, starts the day, and answers ``--tablet`` proposals (Accept,
  Reject, "Nothing needed" in turn), going offline for a second and back after the first (a tablet asleep,
  its connection back), then its tab is closed; the rest of the day's 15 interactions are recorded by this
  script through the study database (a quicker stand-in for the same tablet: the server reads them);
* the researcher's page, open all along in one tab, follows a tablet on the Study session page, then closes
  each participant's day and adapts it on the Adaptation page (the server's background job writes the
  policy file), then loads Results, opens its Tables tab and downloads the whole study (the zip), and the
  Overview;
* ``--tabs`` more tabs open a researcher's page (a random one, a random participant) and are closed.

After each day it asks the probe for a sample of the server process (``long_run_server.sample``) and prints
a row: its resident memory, threads, open file descriptors (those of the study database, its -wal and -shm),
the WAL file's size, Streamlit's sessions (connected, and kept for a reconnection), their session-state
keys, the entries of the app's ``st.cache_*`` functions, media files, deferred downloads and st.dataframe's
row sources held, SQLite
connections open, torch tensors alive, the tablets' board and the background jobs kept; then a table of
each cached function's entries day by day. ``--holders`` counts what holds the server's DataFrames alive.
``--tracemalloc`` traces the server's allocations (slower)
and prints the lines whose allocations grew most from day 1's end to the last day's. ``--settle S``
waits S seconds after the last day with no tab open and samples again (Streamlit keeps a closed tab's
session 2 minutes for a reconnection). Prints Markdown tables; not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # this checkout's cacas
sys.path.insert(1, str(ROOT / "tests" / "browser"))  # the browser tests' Chromium and run counting
from headless import CHROMIUM, FLAGS, IDLE, free_port, wait_until, wait_until_up, watch_runs  # noqa: E402

#: Contexts the tablets set in turn (activity, room, time of day).
CONTEXTS = [("cough", "bedroom", "08:00-10:00"), ("use stove", "kitchen", "12:00-14:00"),
            ("fall down", "living room", "18:00-20:00"), ("cut food", "kitchen", "10:00-12:00"),
            ("use hair dryer", "bathroom", "06:00-08:00"), ("watch TV", "living room", "20:00-22:00")]
#: The researcher's pages (their paths), for the tabs opened and closed.
PAGES = ["", "participants", "session", "adaptation", "results", "simulation", "sounds"]
PER_DAY = 15


def start_server(db: Path, probe: Path, log: Path, tracemalloc: bool):
    port = free_port()
    env = dict(os.environ, PYTHONUNBUFFERED="1", CACAS_DB=str(db),
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    cmd = [sys.executable, str(ROOT / "scripts" / "long_run_server.py"), str(probe)]
    cmd += ["--tracemalloc"] if tracemalloc else []
    cmd += ["--", "--server.port", str(port), "--server.headless", "true", "--server.address", "127.0.0.1",
            "--browser.gatherUsageStats", "false", "--server.fileWatcherType", "none"]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=open(log, "w"), stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    wait_until_up(proc, base, log, 120)
    return proc, base


class Probe:
    """Asks the server's probe for a sample (``ask-N`` -> ``sample-N.json``)."""

    def __init__(self, folder: Path, holders: bool = False, timeout: float = 300):
        self.folder, self.n, self.holders, self.timeout = folder, 0, holders, timeout

    def sample(self, reference: bool = False) -> dict:
        timeout = self.timeout
        (self.folder / f"ask-{self.n}").write_text(" ".join(["reference"] * reference + ["holders"] * self.holders))
        out = self.folder / f"sample-{self.n}.json"
        deadline = time.time() + timeout
        while not out.exists():
            if time.time() > deadline:
                raise RuntimeError("the server's probe did not answer")
            time.sleep(0.1)
        self.n += 1
        return json.loads(out.read_text())


# --- the browser ------------------------------------------------------------------------------------

def idle(page, timeout: int = 600_000) -> None:
    """Wait for the run the last action started (if one starts within 2 s) to end."""
    runs = watch_runs(page)
    wait_until(page, lambda: runs.started > runs.seen or runs.busy, 2_000, fail=False)
    wait_until(page, lambda: not runs.busy, timeout)
    page.wait_for_selector(IDLE, timeout=timeout)
    runs.seen = runs.started
    page.wait_for_timeout(100)


def goto(page, url: str) -> None:
    watch_runs(page)
    page.goto(url)
    page.wait_for_selector("[data-testid='stApp']")
    idle(page)


def button(page, text: str):
    return page.locator("button").filter(has_text=re.compile(re.escape(text) + "$")).first


def click(page, text: str) -> None:
    runs = watch_runs(page)
    before = runs.started
    button(page, text).click()
    wait_until(page, lambda: runs.started > before and not runs.busy, 600_000)
    page.wait_for_selector(IDLE, timeout=600_000)
    runs.seen = runs.started
    page.wait_for_timeout(100)


def tap(page, label: str, option: str) -> None:
    group = page.locator("[data-testid='stButtonGroup']").filter(has=page.locator("label", has_text=label)).first
    group.get_by_role("radio", name=option, exact=True).click()


def choose(page, label: str, option: str) -> None:
    box = page.locator("[data-testid='stSelectbox']").filter(has=page.locator("label", has_text=label)).first
    box.locator("input").click()
    page.keyboard.type(option)
    page.get_by_role("option", name=option, exact=True).first.click()


def new_tab(browser, width: int = 1360, height: int = 900):
    ctx = browser.new_context(viewport={"width": width, "height": height}, accept_downloads=True)
    page = ctx.new_page()
    page.set_default_timeout(600_000)
    return page


def tablet_day(browser, base: str, code: str, day: int, answers: int, turn: int) -> int:
    """The participant's tablet in a new tab: start the day, answer ``answers`` proposals (offline for a
    second after the first), close the tab. Returns the interactions it recorded."""
    page = new_tab(browser, 1024, 768)
    try:
        goto(page, f"{base}/?participant={code}&view=tablet")
        page.locator("button").filter(has_text=re.compile(rf"(Start day {day}|Do it)$")).first.wait_for()
        if button(page, f"Start day {day}").count():
            click(page, f"Start day {day}")
        button(page, "Do it").wait_for()
        for i in range(answers):
            activity, room, slot = CONTEXTS[(turn + i) % len(CONTEXTS)]
            tap(page, "Time of day", slot)
            tap(page, "Time since", "20-30 min")
            choose(page, "Activity", activity)
            tap(page, "Room", room)
            click(page, "Do it")
            page.locator("button").filter(has_text=re.compile(r"(Accept|Nothing needed)$")).first.wait_for()
            idle(page)
            if button(page, "Accept").count():
                click(page, ("Accept", "Reject", "No response")[(turn + i) % 3])
            else:
                click(page, "Nothing needed")
            button(page, "Do it").wait_for()
            if i == 0:  # the tablet asleep a moment: its websocket drops, then it reconnects
                page.context.set_offline(True)
                page.wait_for_timeout(1500)
                page.context.set_offline(False)
                page.wait_for_selector("[data-testid='stApp'][data-test-connection-state='CONNECTED']",
                                       timeout=60_000)
        return answers
    except Exception:
        page.screenshot(path=str(Path(tempfile.gettempdir()) / f"long-run-tablet-{code}-{day}.png"))
        raise
    finally:
        page.context.close()


def fill_day(db: Path, code: str, day: int) -> int:
    """The rest of the day's interactions, through the study database (as another tablet would), until
    :data:`PER_DAY` are recorded (answered); returns how many it wrote."""
    from cacas.store import StudyStore
    from cacas.study_day import day_status

    with StudyStore(db) as store:
        missing = PER_DAY - day_status(store, code).recorded_today
        for i in range(missing):
            activity, room, slot = CONTEXTS[i % len(CONTEXTS)]
            store.record_interaction(code, day, activity=activity, scene=room, hour=8 + (i % 12),
                                     interval_minutes=25, robot_action="pain check",
                                     response=("accept", "reject")[i % 2])
    return max(0, missing)


def adapt(page, base: str, code: str, day: int) -> None:
    goto(page, f"{base}/adaptation?participant={code}")
    short = page.locator("[data-testid='stCheckbox']").filter(has_text=f"Close day {day} with")
    if short.count():  # fewer than 15 answered (not expected: fill_day records them)
        short.first.locator("label").click()
        idle(page)
    click(page, f"Close day {day} and adapt")
    page.wait_for_function(
        "() => /is in force from day|closed and adapted|adapted already/.test("
        "document.querySelector(\"[data-testid='stMain']\").innerText)", timeout=600_000, polling=250)
    idle(page)


def results_and_export(page, base: str, code: str) -> int:
    """Results, its Tables tab, "Download everything"; the zip's size."""
    goto(page, f"{base}/results?participant={code}")
    before = watch_runs(page).started
    page.get_by_role("tab", name="Tables").click()
    wait_until(page, lambda: watch_runs(page).started > before and not watch_runs(page).busy, 600_000)
    idle(page)
    with page.expect_download(timeout=300_000) as dl:
        button(page, "Download everything (zip of every table and policy file)").click()
    path = dl.value.path()
    return os.path.getsize(path) if path else 0


# --- the report -------------------------------------------------------------------------------------

def row_of(label: str, s: dict, db: Path, minutes: float, tabs: int, interactions: int) -> dict:
    st, obj, fds = s.get("streamlit", {}), s.get("objects", {}), s.get("fds", {})
    wal = Path(f"{db}-wal")
    return {"when": label, "min": round(minutes, 1), "tabs": tabs, "interactions": interactions,
            "rss_mb": s.get("rss_mb"), "threads": s.get("threads"), "fds": fds.get("total"),
            "db_fds": f"{fds.get('db', 0)}/{fds.get('wal', 0)}/{fds.get('shm', 0)}",
            "wal_kb": round(wal.stat().st_size / 1024) if wal.exists() else 0,
            "sessions": f"{st.get('sessions_active')}/{st.get('sessions_kept')}",
            "state_keys": st.get("session_state_keys_total"),
            "cache_entries": sum(v for v in s.get("caches", {}).values() if isinstance(v, int)),
            "media": f"{st.get('media_files')}/{st.get('deferred_downloads')}/{st.get('dataframe_sources')}",
            "sqlite_open": obj.get("sqlite3.Connection open"), "tensor_mb": obj.get("torch tensor MB"),
            "dataframes": obj.get("DataFrame", 0), "board": obj.get("tablet board entries"),
            "jobs": obj.get("jobs kept"), "probe_s": s.get("probe_s")}


COLUMNS = [("when", "when"), ("min", "min"), ("tabs", "tabs opened"), ("interactions", "interactions"),
           ("rss_mb", "RSS MB"), ("threads", "threads"), ("fds", "fds"), ("db_fds", "db/wal/shm fds"),
           ("wal_kb", "WAL KB"), ("sessions", "sessions live/kept"), ("state_keys", "state keys"),
           ("cache_entries", "cache entries"), ("media", "media/deferred/table sources"), ("sqlite_open", "sqlite conns"),
           ("tensor_mb", "tensor MB"), ("dataframes", "DataFrames"), ("board", "board"), ("jobs", "jobs")]


def print_row(row: dict, header: bool = False) -> None:
    if header:
        print("| " + " | ".join(h for _, h in COLUMNS) + " |")
        print("|---" + "|---:" * (len(COLUMNS) - 1) + "|")
    print("| " + " | ".join(str(row[k]) for k, _ in COLUMNS) + " |", flush=True)


def print_caches(samples: list[tuple[str, dict]]) -> None:
    names = sorted({n for _, s in samples for n in s.get("caches", {})})
    print("\n| cached function | " + " | ".join(label for label, _ in samples) + " |")
    print("|---" + "|---:" * len(samples) + "|")
    for n in names:
        print(f"| {n} | " + " | ".join(str(s.get("caches", {}).get(n, 0)) for _, s in samples) + " |")


def participants(n: int) -> dict:
    """The example personas' participants, then their preferences again under new codes, ``n`` in all."""
    base = json.loads((ROOT / "study_data" / "personas" / "example.json").read_text())["participants"]
    out = []
    for i in range(n):
        p = dict(base[i % len(base)])
        p["id"] = f"P{i + 1:02d}"
        out.append(p)
    return {"participants": out}


def main() -> None:
    from playwright.sync_api import sync_playwright

    from cacas.store import StudyStore

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--participants", type=int, default=8)
    ap.add_argument("--days", type=int, default=7)
    ap.add_argument("--tablet", type=int, default=2, help="proposals answered on each tablet a day (of 15)")
    ap.add_argument("--tabs", type=int, default=20, help="researcher's tabs opened and closed a day")
    ap.add_argument("--tracemalloc", action="store_true")
    ap.add_argument("--holders", action="store_true",
                    help="count what holds the server's DataFrames alive (changes its memory a little)")
    ap.add_argument("--settle", type=float, default=0.0, metavar="SECONDS")
    ap.add_argument("--json", help="write every sample here")
    ap.add_argument("--keep", help="study folder to use and keep (default: a temporary one)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rng = random.Random(args.seed)

    folder = Path(args.keep or tempfile.mkdtemp(prefix="cacas-long-run-"))
    folder.mkdir(parents=True, exist_ok=True)
    db, probe_dir = folder / "study.sqlite", folder / "probe"
    probe_dir.mkdir(exist_ok=True)
    with StudyStore(db) as store:
        store.import_personas(participants(args.participants))
    codes = [f"P{i + 1:02d}" for i in range(args.participants)]
    proc, base = start_server(db, probe_dir, folder / "streamlit.log", args.tracemalloc)
    print(f"server pid {proc.pid}, {base}, study folder {folder}; load average {os.getloadavg()[0]:.1f}",
          file=sys.stderr, flush=True)
    # a tracemalloc snapshot of the server (1.4 GB, torch's allocations traced) took over 5 minutes at load 13
    probe = Probe(probe_dir, args.holders, timeout=3600 if args.tracemalloc else 300)
    t0 = time.time()
    tabs = interactions = 0
    samples: list[tuple[str, dict]] = []
    rows = []
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
            researcher = new_tab(browser)
            goto(researcher, f"{base}/?participant={codes[0]}")
            tabs += 1
            s = probe.sample()
            samples.append(("start", s))
            rows.append(row_of("start", s, db, 0, tabs, interactions))
            print(f"load average {os.getloadavg()[0]:.1f}")
            print_row(rows[-1], header=True)
            for day in range(1, args.days + 1):
                watched = codes[(day - 1) % len(codes)]
                goto(researcher, f"{base}/session?participant={watched}")  # follows that tablet meanwhile
                for i, code in enumerate(codes):
                    interactions += tablet_day(browser, base, code, day, args.tablet, turn=day + i)
                    tabs += 1
                    interactions += fill_day(db, code, day)
                for code in codes:
                    adapt(researcher, base, code, day)
                zip_size = results_and_export(researcher, base, codes[day % len(codes)])
                goto(researcher, f"{base}/?participant={codes[0]}")
                for _ in range(args.tabs):
                    extra = new_tab(browser)
                    goto(extra, f"{base}/{rng.choice(PAGES)}?participant={rng.choice(codes)}")
                    extra.context.close()
                    tabs += 1
                s = probe.sample(reference=day == 1)  # --tracemalloc: growth from day 1's end on
                s["zip_bytes"] = zip_size
                samples.append((f"day {day}", s))
                rows.append(row_of(f"day {day}", s, db, (time.time() - t0) / 60, tabs, interactions))
                print_row(rows[-1])
            researcher.context.close()
            browser.close()
        if args.settle:
            time.sleep(args.settle)
            s = probe.sample()
            samples.append(("settled", s))
            rows.append(row_of(f"+{args.settle:g} s, no tab", s, db, (time.time() - t0) / 60, tabs, interactions))
            print_row(rows[-1])
    finally:
        proc.terminate()
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
    print(f"load average {os.getloadavg()[0]:.1f}")
    print_caches(samples)
    last = samples[-1][1]
    print("\nthreads by name (last sample):", json.dumps(last.get("thread_names")))
    print("open fds by kind (last sample):", json.dumps(last.get("fds")))
    print("objects (last sample):", json.dumps(last.get("objects")))
    for label, s in samples:
        if "tracemalloc_top" in s and label == samples[-1][0]:
            print(f"\ntracemalloc, {label} against day 1's end ({s['tracemalloc_mb']} MB traced):")
            for line in s["tracemalloc_top"]:
                print("   ", line)
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "samples": samples}, indent=1))
    if not args.keep:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main()
