"""scripts/bench_pages_browser.py runs and prints its two tables, on a 2-participant x 5-day study, one page
and one repeat (~20 s). It times a page's run by the browser tests' count of script runs, imported from
tests/browser/headless.py: a broken import or a wait that never ends fails here, not in a benchmark."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.browser


def test_the_browser_page_benchmark_prints_its_tables(tmp_path):
    db = tmp_path / "study.sqlite"
    subprocess.run([sys.executable, "scripts/bench_pages_db.py", str(db), "--participants", "2", "--days", "5"],
                   cwd=ROOT, check=True, capture_output=True, timeout=600)
    done = subprocess.run([sys.executable, "scripts/bench_pages_browser.py", str(db), "--repeats", "1",
                           "--pages", "overview", "--log", str(tmp_path / "streamlit.log")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = [line for line in done.stdout.splitlines() if not line.startswith("load average ")]
    assert lines[:2] == ["| page | cold: idle / charts drawn (s) | load: idle (s) | load: charts drawn (s) |",
                         "|---|---:|---:|---:|"]
    assert lines[2].startswith("| overview | ") and lines[3] == ""
    assert lines[4:6] == ["| interaction | median [min-max] (s) |", "|---|---:|"]
    assert [line.split(" | ")[0] for line in lines[6:]] == [
        "| Results: another participant in the sidebar",
        "| Results: Data source to 'A simulated run' and back to the human study (each)",
        "| Adaptation: another 'Before' policy"]
