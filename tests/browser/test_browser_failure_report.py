"""A browser test that fails says what its pages showed (conftest's report hook): the page's address, its
script state and run counters, its text and a screenshot, and the end of the running app's log."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.browser

CONFTEST = Path(__file__).with_name("conftest.py")

#: a test module that fails on a page showing a Streamlit-like app in the middle of a run
FAILING = r'''
import conftest
import headless


def test_fails_on_a_running_page(page, tmp_path):
    log = tmp_path / "streamlit.log"  # as _run_app registers a running app's log
    log.write_text("Starting up\nError executing deferred callable\n")
    conftest.RUNNING_LOGS.append(log)
    page.set_content("<div data-testid='stApp' data-test-script-state='running'>Waiting for the robot</div>")
    runs = headless.watch_runs(page)
    runs.started, runs.finished, runs.seen = 3, 2, 2
    assert False, "the test's own message"


def test_passes(page):
    page.set_content("<p>Nothing to report</p>")
'''


def test_a_failed_browser_test_reports_its_pages(tmp_path):
    for name in ("conftest.py", "headless.py"):
        (tmp_path / name).write_text(CONFTEST.with_name(name).read_text())
    (tmp_path / "test_failing.py").write_text(FAILING)
    shots = tmp_path / "shots"
    out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env={**__import__("os").environ, "CACAS_BROWSER_FAILURES": str(shots)}).stdout
    assert "1 failed, 1 passed" in out, out
    assert "the test's own message" in out  # the failure as before, the page's state after it
    assert "browser page 1 of 1" in out
    assert "script running, connection None, runs started 3, finished 2, waited for 2" in out
    assert "Waiting for the robot" in out
    assert "Nothing to report" not in out  # a passing test reports nothing
    assert "app log " in out and "Starting up\nError executing deferred callable" in out
    shot = shots / "test_fails_on_a_running_page-1.png"
    assert f"screenshot: {shot}" in out
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_page_that_cannot_be_read_is_said_in_one_line(browser, tmp_path):
    from conftest import close_page, describe_page, open_page

    page = open_page(browser)
    page.close()
    said = describe_page(page, tmp_path / "closed.png")
    assert "the page could not be read" in said and "\n" not in said
    assert not (tmp_path / "closed.png").exists()
    close_page(page)


def test_an_apps_log_is_reported_by_its_last_lines(tmp_path):
    from conftest import log_tail

    log = tmp_path / "streamlit.log"
    log.write_text("".join(f"line {i}\n" for i in range(100)))
    assert log_tail(log, lines=3) == "line 97\nline 98\nline 99"
    assert log_tail(tmp_path / "missing.log").endswith("not readable (No such file or directory)")
