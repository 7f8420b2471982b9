"""scripts/bench_pages.py: its output is the Markdown table alone, to paste as it is (Streamlit's warnings of a
page run outside a server came between its rows; README audit)."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_page_benchmark_prints_its_table_and_nothing_between_the_rows(tmp_path):
    db = tmp_path / "study.sqlite"
    subprocess.run([sys.executable, "scripts/bench_pages_db.py", str(db), "--participants", "1", "--days", "1"],
                   cwd=ROOT, check=True, capture_output=True, timeout=600)
    done = subprocess.run([sys.executable, "scripts/bench_pages.py", str(db), "--repeats", "1",
                           "--pages", "overview,participants", "--participant", "P000"],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.splitlines()
    assert lines[:2] == ["| page | first run (s) median [min-max] | repeat run (s) median [min-max] |",
                         "|---|---:|---:|"]
    assert [line.split(" | ")[0] for line in lines[2:]] == ["| overview", "| participants"]
    after_warm_up = done.stderr.split("warm-up (imports, first ever run)")[1]
    assert "ScriptRunContext" not in after_warm_up and "No runtime found" not in after_warm_up


def test_the_calendar_study_runs_day_by_day(tmp_path):
    """scripts/bench_pages_db.py --calendar (scale walk): the study written as it runs, for what reads it by time
    (the Overview's recent activity, "last recorded"): day d of everyone on the d-th calendar day, records in the
    order of their times, the method comparison of every participant-day after the last day, one line."""
    from cacas.recent_activity import recent_events
    from cacas.store import StudyStore

    db = tmp_path / "study.sqlite"
    subprocess.run([sys.executable, "scripts/bench_pages_db.py", str(db), "--participants", "2", "--days", "3",
                    "--interactions", "2", "--calendar"], cwd=ROOT, check=True, capture_output=True, timeout=600)
    store = StudyStore(db, readonly=True)
    events = store.events()
    assert events["at"].is_monotonic_increasing
    inter = store.interactions_frame(method=None)
    dates = inter.assign(date=inter["time"].str[:10]).groupby("day")["date"].unique()
    assert all(len(d) == 1 for d in dates) and dates.map(lambda d: d[0]).is_monotonic_increasing
    assert dates.map(lambda d: d[0]).nunique() == 3
    runs = events[events["what"] == "record_adaptation"]
    last_close = events.loc[events["what"] == "close_day", "at"].max()
    compared = runs[runs["details"].str.contains('"policy_version": null') & ~runs["details"].str.contains('"day": 0')]
    assert len(compared) == 2 * 3 * 3 and (compared["at"] > last_close).all()
    assert recent_events(store, limit=1)["what"].iloc[0] == \
        "comparison runs (CACAS w/o PR, ORL, NN) for P000, P001 on days 1-3, no policy saved"
    store.close()
