"""scripts/bench_long_run.py runs a study through one app server and prints its samples of the server process:
here 1 participant x 1 day, one tablet answer, one more tab (~1-2 min). A broken probe (scripts/long_run_server.py,
inside the server) or a wait that never ends fails here, not in the week-long benchmark."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.browser


def test_the_long_run_benchmark_prints_a_row_a_day_from_the_servers_probe(tmp_path):
    samples = tmp_path / "samples.json"
    done = subprocess.run([sys.executable, "scripts/bench_long_run.py", "--participants", "1", "--days", "1",
                           "--tablet", "1", "--tabs", "1", "--json", str(samples), "--keep", str(tmp_path / "study")],
                          cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = [line for line in done.stdout.splitlines() if line.startswith("| ")]
    assert lines[0].startswith("| when | min | tabs opened | interactions | RSS MB | threads | fds |")
    assert [line.split(" | ")[0] for line in lines[1:3]] == ["| start", "| day 1"]
    assert "| cached function | start | day 1 |" in lines
    rows = json.loads(samples.read_text())["rows"]
    day = rows[-1]
    assert day["interactions"] == 15 and day["tabs"] == 3  # the researcher's tab, the tablet's, one more
    # the probe answered from inside the server: its memory, its open study database, the tablet's policy cached
    assert day["rss_mb"] > 100 and day["fds"] > 0 and day["db_fds"].split("/")[0] != "0"
    caches = json.loads(samples.read_text())["samples"][-1][1]["caches"]
    assert caches["resource:pages.ui.policy_version"] >= 1
