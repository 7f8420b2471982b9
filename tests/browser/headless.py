"""The app's pages in Debian's headless Chromium: the browser's path and flags, and a page's Streamlit script
runs counted from the messages its server sends over the websocket. Shared by the browser tests
(conftest.py, test_browser_mini_study.py) and ``scripts/bench_pages_browser.py``, which puts this folder
on its ``sys.path``: the benchmark times a page's run by the same count as the tests wait for it.
It imports nothing of the tests (their fixtures and knobs stay in conftest.py)."""

from __future__ import annotations

import socket
import time
import urllib.request

CHROMIUM = "/usr/bin/chromium"
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", "--no-first-run"]
#: Streamlit's app element once no script run is going (as the page has drawn it)
IDLE = "[data-testid='stApp'][data-test-script-state='notRunning']"
#: every element of the page is drawn: none is Streamlit's placeholder (stSkeleton), which stands in for an element
#: while the browser loads its code (a multi-choice field's, a button's, st.html's: each loaded lazily, once a page)
DRAWN_JS = "() => !document.querySelector('[data-testid=stSkeleton]')"


class ScriptRuns:
    """The script runs of a page's session, counted from the messages its Streamlit server sends over the
    websocket, as the browser receives them (:func:`watch_runs`): ``started`` (a NewSession message opens
    each run, a fragment's too), ``finished`` (ScriptFinished), and ``seen``, the runs a test helper has
    waited for. The page's ``data-test-script-state`` alone missed runs: a run of ~100 ms whose first and
    last messages the loaded browser handled in one go never turned it "running" (CI: the Results page's
    upload choice was drawn, and the helper waited 60 s for its run).

    A session runs one script at a time, so a NewSession also ends the run before it: a widget's rerun
    during a run (Streamlit's ``runner.fastReruns``, on by default) replaces the run's runner, and the
    stopped run sends no ScriptFinished. ``finished`` then stays below ``started``; ``busy`` follows the
    last of these messages, not the difference."""

    def __init__(self):
        self.started = self.finished = self.seen = 0
        self.running = False  # a NewSession came last: its run is going
        self.rerun_follows = False  # the last run stopped early for a rerun, whose NewSession is still to come

    def frame(self, payload) -> None:
        if isinstance(payload, str):
            return
        from streamlit.proto.ForwardMsg_pb2 import ForwardMsg

        msg = ForwardMsg.FromString(payload)
        kind = msg.WhichOneof("type")
        if kind == "new_session":
            self.started += 1
            self.running, self.rerun_follows = True, False
        elif kind == "script_finished":
            self.finished += 1
            self.running = False
            self.rerun_follows = msg.script_finished == ForwardMsg.FINISHED_EARLY_FOR_RERUN

    @property
    def busy(self) -> bool:
        """A run is going, or one stopped for a rerun that has not begun yet."""
        return self.running or self.rerun_follows

    def __str__(self) -> str:
        return f"runs started {self.started}, finished {self.finished}, waited for {self.seen}"


def watch_runs(page) -> ScriptRuns:
    """The page's :class:`ScriptRuns`, counting from now on (every websocket the page opens, a
    reconnection's too); the same one on a second call."""
    if getattr(page, "_cacas_runs", None) is None:
        page._cacas_runs = ScriptRuns()
        page.on("websocket", lambda ws: ws.on("framereceived", page._cacas_runs.frame))
    return page._cacas_runs


def wait_until(page, done, timeout: int, fail: bool = True) -> bool:
    """Poll ``done()`` every 20 ms for up to ``timeout`` ms (the page's websocket messages are counted
    meanwhile); False when it never held and not ``fail``, else AssertionError naming the runs."""
    deadline = time.monotonic() + timeout / 1000
    while not done():
        if time.monotonic() > deadline:
            if fail:
                raise AssertionError(f"the page's script runs did not end within {timeout / 1000:g} s "
                                     f"({watch_runs(page)})")
            return False
        page.wait_for_timeout(20)
    return True


def run_over(page, since: int, timeout: int = 60_000) -> None:
    """Wait until a run has started since the page's ``since``-th (``watch_runs(page).started`` before the
    action) and none is going, then until the page shows it idle (:data:`IDLE`)."""
    runs = watch_runs(page)
    wait_until(page, lambda: runs.started > since and not runs.busy, timeout)
    page.wait_for_selector(IDLE, timeout=timeout)


def drawn(page, timeout: int = 60_000) -> None:
    """Wait until every element of the page is drawn (:data:`DRAWN_JS`): a run can be over while some of its
    elements still wait for their code. A test that read the Participants page's multi-choice fields once its run
    was over found fewer than it drew (CI at load 7-10, two browser tests at a time: the fields out of order)."""
    page.wait_for_function(DRAWN_JS, timeout=timeout)


def free_port() -> int:
    """A TCP port free on the loopback now, for a Streamlit server of the benchmarks."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until_up(proc, base: str, log, seconds: float) -> None:
    """Wait until the Streamlit server ``proc`` at ``base`` answers its health check; killed, and a RuntimeError
    with its log's (``log``, a Path) last lines, if it stops or ``seconds`` pass first. Shared by the benchmark
    scripts that start a server (scripts/bench_pages_browser.py, scripts/bench_long_run.py) and the browser tests'
    conftest."""
    deadline = time.time() + seconds
    while True:
        try:
            with urllib.request.urlopen(f"{base}/_stcore/health", timeout=2) as r:
                if r.status == 200:
                    return
        except OSError:
            pass
        if proc.poll() is not None or time.time() > deadline:
            proc.kill()
            raise RuntimeError(f"streamlit did not start: {log.read_text()[-3000:]}")
        time.sleep(0.3)
