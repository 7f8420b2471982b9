"""The browser tests' servers come from the zygote (server_zygote.py): each starts with the heavy imports done, runs
with its own environment and working folder, waits for its own subprocesses, and is gone once its test is over."""

from __future__ import annotations

import os
import signal
import urllib.request
from pathlib import Path

import pytest
from conftest import ROOT, _run_app, close_page, open_page

pytestmark = pytest.mark.browser


def test_a_server_starts_with_torch_imported_in_the_checkout_and_is_reaped_once_stopped(tmp_path):
    db = tmp_path / "study.sqlite"
    run = _run_app(tmp_path, CACAS_DB=str(db))
    url = next(run)
    pid = url.pid
    try:
        with urllib.request.urlopen(f"{url}/_stcore/health", timeout=10) as r:
            assert r.status == 200
        # before any page was opened (a page starts app._preload): torch's library is already loaded
        assert "libtorch_cpu" in Path(f"/proc/{pid}/maps").read_text()
        assert Path(f"/proc/{pid}/cwd").resolve() == ROOT
        # SIGCHLD is not ignored (the zygote ignores it): the server waits for its own subprocesses
        ignored = int(next(line for line in Path(f"/proc/{pid}/status").read_text().splitlines()
                           if line.startswith("SigIgn:")).split()[1], 16)
        assert not ignored & (1 << (signal.SIGCHLD - 1))
        assert "You can now view your Streamlit app" in (tmp_path / "streamlit.log").read_text()
    finally:
        next(run, None)
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # stopped, and reaped: no zombie left


def test_two_servers_at_once_each_open_their_own_database(tmp_path, browser):
    """Each forked server runs in the environment its test gave it (CACAS_DB), not the zygote's: the
    Overview's sidebar names the database each opened."""
    from test_browser_mini_study import goto

    runs = []
    try:
        for name in ("a", "b"):
            (tmp_path / name).mkdir()
            runs.append(_run_app(tmp_path / name, CACAS_DB=str(tmp_path / name / "study.sqlite")))
        urls = [next(run) for run in runs]
        assert urls[0].pid != urls[1].pid
        for name, url in zip(("a", "b"), urls):
            page = open_page(browser, viewport={"width": 1280, "height": 800})
            goto(page, url)
            sidebar = page.locator("[data-testid='stSidebar']").inner_text()
            assert f"Database: {tmp_path / name / 'study.sqlite'}" in sidebar, sidebar
            close_page(page)
    finally:
        for run in runs:
            next(run, None)
