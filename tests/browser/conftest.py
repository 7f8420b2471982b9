"""Browser tests: ``streamlit run app.py`` on a temporary study database, driven in Debian's
headless Chromium with Playwright (design.md: ``playwright install`` cannot download browsers here)."""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import pytest
from headless import CHROMIUM, FLAGS, free_port, wait_until_up

ROOT = Path(__file__).resolve().parents[2]
#: where a failed browser test leaves a screenshot of each page it had open (set CACAS_BROWSER_FAILURES to keep them)
FAILURES = Path(os.environ.get("CACAS_BROWSER_FAILURES") or Path(tempfile.gettempdir()) / "cacas-browser-failures")
#: the log files of the apps running now (``_run_app``), for a failed test's report
RUNNING_LOGS: list[Path] = []
#: the origins of the apps this test process has served, whose storage the tests' profile forgets after each test
SERVED_ORIGINS: set[str] = set()
#: the port this test process's apps take when it is free (:func:`app_port`)
_APP_PORT: list[int] = []


@pytest.fixture(scope="session")
def initial_policy():
    """The initial policy (CACAA step 1) is cached on disk after its first training; train it
    here once, so that the app's first proposal does not wait for it."""
    from cacas.adaptation import load_initial_policy

    return load_initial_policy()


class ForkedServer:
    """A Streamlit server forked by the tests' zygote (server_zygote.py), driven as a ``subprocess.Popen``: polled,
    terminated, waited for and killed by its pid (the zygote's child: the system reaps it once it ends)."""

    def __init__(self, pid: int):
        self.pid = pid

    def poll(self) -> int | None:
        try:
            os.kill(self.pid, 0)
        except ProcessLookupError:
            return 0
        return None

    def terminate(self) -> None:
        self._signal(signal.SIGTERM)

    def kill(self) -> None:
        self._signal(signal.SIGKILL)

    def _signal(self, sig: int) -> None:
        try:
            os.kill(self.pid, sig)
        except ProcessLookupError:
            pass

    def wait(self, timeout: float) -> int:
        deadline = time.monotonic() + timeout
        while self.poll() is None:
            if time.monotonic() > deadline:
                raise subprocess.TimeoutExpired(f"server {self.pid}", timeout)
            time.sleep(0.05)
        return 0


#: this test process's zygote (server_zygote.py), started by the first server a test needs, ended with the session
_ZYGOTE: list[subprocess.Popen] = []


def _zygote() -> subprocess.Popen:
    if _ZYGOTE and _ZYGOTE[0].poll() is None:
        return _ZYGOTE[0]
    _ZYGOTE.clear()
    errors = tempfile.TemporaryFile("w+")  # the zygote's own (a server writes to its log)
    zygote = subprocess.Popen([sys.executable, "-u", str(Path(__file__).with_name("server_zygote.py"))], cwd=ROOT,
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=errors, text=True)
    if json.loads(zygote.stdout.readline() or "{}").get("ready") is not True:
        errors.seek(0)
        raise RuntimeError(f"the browser tests' server zygote (server_zygote.py) did not start (exit {zygote.wait()}):"
                           f"\n{errors.read()[-3000:]}")
    errors.close()  # read only if it does not start (the zygote keeps its own descriptor)
    _ZYGOTE.append(zygote)
    return zygote


def pytest_sessionfinish(session):
    for zygote in _ZYGOTE:
        zygote.stdin.close()  # it ends at the end of its input
        try:
            zygote.wait(30)  # its interpreter's exit with torch loaded takes 1-3 s
        except subprocess.TimeoutExpired:  # not a reason to fail a run whose tests are over
            zygote.kill()


class ServedURL(str):
    """A server's base URL, with its process id (``pid``; the forked server's command line is the zygote's)."""

    pid: int


def app_port() -> int:
    """The port of this test process's apps: the same one whenever it is free (one app at a time), so that the
    profile's cache (:class:`Chromium`), keyed by address, port included, serves each app Streamlit's frontend
    compiled; a free one while it is taken (a second app at once)."""
    if not _APP_PORT:
        _APP_PORT.append(free_port())
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server's (its closed connections linger)
        try:
            s.bind(("127.0.0.1", _APP_PORT[0]))
        except OSError:
            return free_port()
    return _APP_PORT[0]


def _run_app(tmp: Path, port: int | None = None, **env):
    """``streamlit run app.py`` on ``port`` (default :func:`app_port`) with ``env`` added, forked by the zygote
    (server_zygote.py: the heavy imports done once); yields its base URL (a :class:`ServedURL`), then stops it."""
    port = port or app_port()
    env = dict(os.environ, PYTHONUNBUFFERED="1", **env)
    argv = ["run", "app.py", "--server.port", str(port), "--server.headless", "true", "--server.address", "127.0.0.1",
            "--browser.gatherUsageStats", "false", "--server.fileWatcherType", "none"]
    zygote = _zygote()
    zygote.stdin.write(json.dumps({"argv": argv, "env": env, "log": str(tmp / "streamlit.log")}) + "\n")
    zygote.stdin.flush()
    proc = ForkedServer(json.loads(zygote.stdout.readline())["pid"])
    base = ServedURL(f"http://127.0.0.1:{port}")
    base.pid = proc.pid
    SERVED_ORIGINS.add(base)
    wait_until_up(proc, base, tmp / "streamlit.log", 60)
    RUNNING_LOGS.append(tmp / "streamlit.log")
    yield base
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
    RUNNING_LOGS.remove(tmp / "streamlit.log")


class AppURL(str):
    """The app's base URL, with the path of its study database (``db``) for a test that sets up
    what it needs without depending on an earlier test of its module."""

    db: Path


@pytest.fixture(scope="module")
def server(tmp_path_factory, initial_policy):
    """The app on a free port with a fresh study database; yields its base URL (an :class:`AppURL`)."""
    tmp = tmp_path_factory.mktemp("browser")
    for url in _run_app(tmp, CACAS_DB=str(tmp / "study.sqlite")):
        app = AppURL(url)
        app.db = tmp / "study.sqlite"
        yield app


@pytest.fixture(scope="module")
def library_server(tmp_path_factory):
    """The app (``.url``) over a study data folder of its own (``.data``: a copy of the shipped scene library, no sound
    clip, no model), for tests that add to the libraries: the checkout's study_data stays as it is."""
    tmp = tmp_path_factory.mktemp("libraries")
    data = tmp / "study_data"
    shutil.copytree(ROOT / "study_data" / "scenes", data / "scenes")
    (data / "sounds").mkdir()
    for url in _run_app(tmp, CACAS_STUDY_DATA=str(data), CACAS_DB=str(tmp / "study.sqlite")):
        yield SimpleNamespace(url=url, data=data)


#: the options a page of the tests' profile (:class:`Chromium`) can have (the viewport set on the page; downloads the
#: profile accepts): any other (a phone's touch screen, ``is_mobile``), or downloads refused, needs a context of its own
PROFILE_OPTIONS = frozenset({"viewport", "accept_downloads"})


class Chromium:
    """The ``browser`` fixture: Debian's Chromium with a profile on disk (``profile``, one per test process), whose
    HTTP cache and V8 code cache keep Streamlit's frontend compiled from one page to the next, and a plain browser
    (``plain()``, started when first needed) for pages that need a context of their own (:func:`open_page`).

    A page load of the Overview cost ~6.9 s of CPU (the machine's; Chromium ~6.0, its server 0.55) in a context of
    its own (an incognito one: each compiled Streamlit's JavaScript again and fetched it from the server) and ~4.5 s
    as a new page of one profile (measured with five loads each on the 2-core EPYC); the browser part, two at a time,
    took 564 s of wall and 1,080 s of CPU with a context for each page, 521 s and 962 s with the profile. What a test
    leaves in the profile is undone after it (:meth:`forget`): its pages closed, cookies and the served origins'
    storage cleared."""

    def __init__(self, playwright, profile: Path):
        self._playwright = playwright
        # accept_downloads as open_page's contexts (Playwright's default) and the page fixture's
        self.profile = playwright.chromium.launch_persistent_context(
            str(profile), executable_path=CHROMIUM, args=FLAGS, headless=True, accept_downloads=True)
        for blank in self.profile.pages:  # the one a persistent context opens with: tests count their pages
            blank.close()
        self._plain = None

    def plain(self):
        """A browser without a profile, for contexts with options a profile's page cannot have."""
        if self._plain is None:
            self._plain = self._playwright.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
        return self._plain

    @property
    def contexts(self) -> list:
        """Every context with pages of the tests' (the profile's, then the plain browser's)."""
        return [self.profile] + (self._plain.contexts if self._plain is not None else [])

    def forget(self, kept: set) -> None:
        """Undo what a test left: its pages (any not in ``kept``, e.g. a module's page) and contexts closed, the
        profile's cookies and the served origins' local storage cleared (the cache is kept: it is what the profile
        is for)."""
        for pg in self.profile.pages:
            if pg not in kept:
                pg.close()
        if self._plain is not None:
            for context in self._plain.contexts:
                if not any(pg in kept for pg in context.pages):
                    context.close()
        self.profile.clear_cookies()
        if SERVED_ORIGINS:
            cdp = self.profile.new_cdp_session(self.profile.pages[0]) if self.profile.pages else None
            blank = None
            if cdp is None:  # a page's session: the browser's own (new_browser_cdp_session) answers "Internal error"
                blank = open_page(self)
                cdp = self.profile.new_cdp_session(blank)
            for origin in SERVED_ORIGINS:
                cdp.send("Storage.clearDataForOrigin", {"origin": origin, "storageTypes": "local_storage,indexeddb"})
            cdp.detach()
            if blank is not None:
                blank.close()

    def close(self) -> None:
        self.profile.close()
        if self._plain is not None:
            self._plain.close()


#: this test process's Chromium (the ``browser`` fixture's), for :func:`_undo_the_tests_pages`
_CHROMIUM: list[Chromium] = []


@pytest.fixture(scope="session")
def browser(tmp_path_factory):
    """Debian's Chromium with the tests' profile (:class:`Chromium`), one for the whole session."""
    from playwright.sync_api import sync_playwright

    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} is missing: install Debian's chromium (scripts/test.sh does)")
    with sync_playwright() as p:
        chromium = Chromium(p, tmp_path_factory.mktemp("chromium-profile"))
        _CHROMIUM.append(chromium)
        yield chromium
        _CHROMIUM.remove(chromium)
        chromium.close()


@pytest.fixture(autouse=True)
def _undo_the_tests_pages(request):
    """After a test that used the browser, what it left there is undone (:meth:`Chromium.forget`); pages open
    before it (a module's) stay."""
    kept = {pg for context in _CHROMIUM[0].contexts for pg in context.pages} if _CHROMIUM else set()
    yield
    if _CHROMIUM and "browser" in request.fixturenames:
        _CHROMIUM[0].forget(kept)


#: the environment variable that slows the tests' Chromium N times (Chrome DevTools' CPU throttling), as on a
#: loaded CI machine: to reproduce a flake that only the CI saw (:func:`open_page`)
SLOWDOWN = "CACAS_BROWSER_SLOWDOWN"


def cpu_slowdown() -> float | None:
    """How many times :data:`SLOWDOWN` slows Chromium's CPU; None when it is unset or empty. Anything but a
    number >= 1 is refused by name (pytest.UsageError): Chromium took 0.5, 0 or -1 without a word and ran at
    full speed, and a word failed every browser test with float()'s message."""
    value = os.environ.get(SLOWDOWN, "").strip()
    if not value:
        return None
    try:
        rate = float(value)
    except ValueError:
        rate = math.nan
    if not (math.isfinite(rate) and rate >= 1):
        raise pytest.UsageError(f"{SLOWDOWN}={value!r} is not a number >= 1: it is how many times the browser tests "
                                f"slow Chromium's CPU (e.g. 4; 1 does not slow it). Leave it unset for full speed.")
    return rate


def pytest_collection_modifyitems(config, items):
    """A bad :data:`SLOWDOWN` stops the run before its first test, with one line saying what is valid (only
    when the browser tests are collected: this conftest is read then)."""
    cpu_slowdown()


def open_page(opener, **options):
    """A new page: ``opener`` the ``browser`` fixture (a :class:`Chromium`), a page of the tests' profile, with
    ``options`` (:data:`PROFILE_OPTIONS`: ``viewport``, default 1280 x 720, set on the page), or, with any other
    option (``is_mobile``, ``has_touch``), in a new context of its own, made with them; ``opener`` a page, a new page
    beside it, in its context. Close a page with :func:`close_page`. Its CPU is slowed :data:`SLOWDOWN` times when
    that is set. Every page the browser tests open comes from here (test_browser_slowdown checks), so that the knob
    slows them all."""
    if not isinstance(opener, Chromium):
        page = opener.context.new_page()
        opener._cacas_beside = [*getattr(opener, "_cacas_beside", []), page]
    elif set(options) <= PROFILE_OPTIONS and options.get("accept_downloads", True):
        page = opener.profile.new_page()
        if "viewport" in options:
            page.set_viewport_size(options["viewport"])
    else:
        page = opener.plain().new_context(**options).new_page()
    rate = cpu_slowdown()
    if rate is not None:
        page.context.new_cdp_session(page).send("Emulation.setCPUThrottlingRate", {"rate": rate})
    return page


def close_page(page) -> None:
    """Close a page :func:`open_page` opened, with the pages opened beside it: its context, if it had one of its own."""
    for beside in getattr(page, "_cacas_beside", []):
        beside.close()
    if any(page.context is chromium.profile for chromium in _CHROMIUM):
        page.close()
    else:  # a context of its own
        page.context.close()


@pytest.fixture
def page(browser, tmp_path):
    """A new page of the tests' profile at 1360 x 900 (downloads accepted; :func:`open_page`)."""
    pg = open_page(browser, viewport={"width": 1360, "height": 900}, accept_downloads=True)
    pg.set_default_timeout(30_000)
    yield pg
    close_page(pg)


#: what a failed test's report says of a page: its address, Streamlit's script and connection states, and its text
PAGE_STATE = """() => {
  const app = document.querySelector("[data-testid='stApp']");
  return {url: location.href, script: app && app.getAttribute('data-test-script-state'),
          connection: app && app.getAttribute('data-test-connection-state'),
          text: document.body ? document.body.innerText : ''};
}"""


def describe_page(page, screenshot: Path, text_chars: int = 3000) -> str:
    """A page as a failed test left it, for the test's report: where it is, what state Streamlit's
    script and connection are in, its runs (``headless.ScriptRuns``, if counted), the end of its text
    (``text_chars``), and a full-page screenshot saved to ``screenshot``. A page that cannot be read
    says why, in one line."""
    try:
        state = page.evaluate(PAGE_STATE)
    except Exception as e:  # a closed or crashed page: the report says so and goes on
        return f"{page.url}: the page could not be read ({type(e).__name__}: {str(e).splitlines()[0]})"
    try:
        screenshot.parent.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(screenshot), full_page=True, timeout=10_000)
        saved = f"screenshot: {screenshot}"
    except Exception as e:
        saved = f"no screenshot ({type(e).__name__})"
    text = state["text"]
    if len(text) > text_chars:
        text = "..." + text[-text_chars:]
    runs = getattr(page, "_cacas_runs", None) or "runs not counted"
    return (f"{state['url']}\nscript {state['script']}, connection {state['connection']}, {runs}; {saved}\n"
            f"--- page text ---\n{text}")


def log_tail(path: Path, lines: int = 40) -> str:
    """The last ``lines`` lines of an app's log."""
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError as e:
        return f"{path}: not readable ({e.strerror})"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """A browser test that fails reports every page it has open (``describe_page``) and the end of each
    running app's log: what a failure in CI looked like, which its traceback alone does not say."""
    outcome = yield
    report = outcome.get_result()
    if report.when != "call" or not report.failed:
        return
    browser = item.funcargs.get("browser")
    pages = [pg for context in (browser.contexts if browser is not None else []) for pg in context.pages]
    for i, pg in enumerate(pages, 1):
        name = f"{item.name}-{i}.png".replace("/", "_")
        report.sections.append((f"browser page {i} of {len(pages)}", describe_page(pg, FAILURES / name)))
    for log in RUNNING_LOGS:
        report.sections.append((f"app log {log}", log_tail(log)))
