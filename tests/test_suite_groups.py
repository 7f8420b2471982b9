"""tests/conftest.py: each browser test file is one group of pytest-xdist's (scripts/test.sh runs the whole suite at
once with ``--dist loadgroup``), so that its tests share their module's Streamlit server in one test process; the
other tests are in no group (each goes to whichever process is free)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: a plugin printing each collected test's xdist groups once every other plugin has marked them
PROBE = '''
import json
import pytest


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(items):
    print("GROUPS " + json.dumps({i.nodeid: [m.args[0] for m in i.iter_markers("xdist_group")] for i in items}))
'''


def test_a_browser_test_files_tests_are_one_group_and_the_others_in_none(tmp_path):
    (tmp_path / "groups_probe.py").write_text(PROBE)
    files = ["tests/browser/test_browser_first_request.py", "tests/test_script_bench_long_run.py",
             "tests/test_d4a.py"]
    done = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider",
                           "-p", "no:xdist", "-p", "groups_probe", *files], cwd=ROOT, capture_output=True, text=True,
                          timeout=300, env={**__import__("os").environ, "PYTHONPATH": str(tmp_path)})
    line = next((x for x in done.stdout.splitlines() if x.startswith("GROUPS ")), None)
    assert line, done.stdout[-2000:] + done.stderr[-2000:]
    groups = json.loads(line[len("GROUPS "):])
    by_file: dict[str, set] = {}
    for nodeid, names in groups.items():
        by_file.setdefault(nodeid.split("::")[0], set()).add(tuple(names))
    assert by_file[files[0]] == {(files[0],)}  # every test of the browser file in its file's group
    assert by_file[files[1]] == {(files[1],)}  # a browser test outside tests/browser (a benchmark script's)
    assert by_file[files[2]] == {()} and len(groups) > 3  # the others in none
