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
