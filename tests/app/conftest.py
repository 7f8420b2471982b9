"""AppTest fixtures: the app on a temporary study database, with Streamlit's caches cleared."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import streamlit as st
from streamlit.runtime.scriptrunner.script_cache import ScriptCache
from streamlit.testing.v1 import AppTest

from cacas.store import StudyStore

ROOT = Path(__file__).resolve().parents[2]
APP = str(ROOT / "app.py")
TIMEOUT = 60


@pytest.fixture(scope="session", autouse=True)
def components_scanned_once():
    """Each AppTest scans every installed distribution's metadata for Streamlit components (v2
    manifests) on its first run, as a server does once at its start: 0.3-0.8 s per test, most of a
    page test's time. The installed packages do not change during the tests: scanned once here."""
    from streamlit.components.v2 import manifest_scanner

    real = manifest_scanner.scan_component_manifests
    found = real()
    manifest_scanner.scan_component_manifests = lambda *a, **k: list(found)
    yield
    manifest_scanner.scan_component_manifests = real


class CompiledOnce(ScriptCache):
    """A script's bytecode compiled once for all the tests, as a server compiles each page once for all its
    sessions. AppTest gives each run a new, empty ScriptCache, so every run parsed app.py and its page again and
    rewrote their syntax trees for Streamlit's "magic": about half of a page test's time (py-spy over tests/app:
    107 of 211 s of script runs in ScriptCache.get_bytecode). Keyed by the file's path, size and modification
    time and the magic option (``runner.magicEnabled``): a script written again is compiled again (as a server whose
    file watcher is on has it recompiled; the app's runs with none: .streamlit/config.toml)."""

    compiled: dict[tuple, object] = {}

    def get_bytecode(self, script_path: str):
        from streamlit import config

        path = os.path.abspath(script_path)
        stat = os.stat(path)
        key = (path, stat.st_size, stat.st_mtime_ns, config.get_option("runner.magicEnabled"))
        code = self.compiled.get(key)
        if code is None:
            code = self.compiled[key] = super().get_bytecode(path)
        return code


@pytest.fixture(scope="session", autouse=True)
def scripts_compiled_once():
    """Every AppTest run takes the scripts' bytecode from :class:`CompiledOnce` (its page's, through its pages
    manager, and app.py's, through its script runner)."""
    from streamlit.testing.v1 import app_test, local_script_runner

    real = app_test.ScriptCache, local_script_runner.ScriptCache
    app_test.ScriptCache = local_script_runner.ScriptCache = CompiledOnce
    yield
    app_test.ScriptCache, local_script_runner.ScriptCache = real


@pytest.fixture(scope="session", autouse=True)
def script_runs_waited_for_without_polling():
    """AppTest waits for a script run by polling its runner every millisecond (``require_widgets_deltas``), each
    poll reading every event of the run so far (one per element drawn) and taking the interpreter lock from the
    script's thread. The thread ends once the run is over (it emits SHUTDOWN, then returns): joined here, with
    the same timeout and the same error when it runs out."""
    from streamlit.testing.v1 import local_script_runner

    real = local_script_runner.require_widgets_deltas

    def require_widgets_deltas(runner, timeout: float = 3) -> None:
        thread = runner._script_thread
        if thread is not None:
            thread.join(timeout)
        if not runner.script_stopped():  # still going: stopped, and the run fails as AppTest's own wait fails
            runner.request_stop()
            runner.join()
            raise RuntimeError(f"AppTest script run timed out after {timeout}(s)")

    local_script_runner.require_widgets_deltas = require_widgets_deltas
    yield
    local_script_runner.require_widgets_deltas = real


@pytest.fixture
def db(tmp_path, monkeypatch):
    """A fresh study database file; the app finds it through $CACAS_DB."""
    path = tmp_path / "study.sqlite"
    monkeypatch.setenv("CACAS_DB", str(path))
    st.cache_data.clear()
    st.cache_resource.clear()
    yield path
    st.cache_data.clear()
    st.cache_resource.clear()


@pytest.fixture
def store(db):
    s = StudyStore(db)
    yield s
    s.close()


@pytest.fixture(autouse=True)
def navigation_mode(monkeypatch):
    """AppTest resets Streamlit's old ``pages/``-folder mode before every run, so each run would
    start as a server's very first request (where ``ui.require_app`` reruns through app.py and a
    click of that run is lost). Start each run as a server does after its first request: in
    ``st.navigation`` mode. The first-request path itself is covered by the browser tests."""
    from streamlit.runtime.pages_manager import PagesManager
    from streamlit.testing.v1 import app_test

    class NavigationPagesManager(PagesManager):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            PagesManager.uses_pages_directory = False

    monkeypatch.setattr(app_test, "PagesManager", NavigationPagesManager)


@pytest.fixture
def app(db, monkeypatch):
    """A function that opens the app (optionally on a page and with query parameters) and runs it."""
    monkeypatch.chdir(ROOT)

    def open_app(page: str | None = None, **query) -> AppTest:
        at = AppTest.from_file(APP, default_timeout=TIMEOUT)
        for k, v in query.items():
            at.query_params[k] = v
        at.run()
        if page is not None:
            at.switch_page(page)
            at.run()
        return at
    return open_app


@pytest.fixture
def quick_policy(monkeypatch):
    """An untrained (randomly initialised) SAC policy as the initial policy, so that page tests do
    not train one; the page does not care how the policy in force was trained."""
    import cacas.adaptation
    import cacas.study_day
    from cacas.policy import ReshapedPolicy
    from cacas.sac import DiscreteSAC, SACConfig

    policy = ReshapedPolicy(DiscreteSAC(SACConfig(), seed=0), None, beta=1.0, method="initial")
    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    monkeypatch.setattr(cacas.study_day, "initial_policy_ready", lambda: True)
    return policy


@pytest.fixture(autouse=True)
def no_recognisers(monkeypatch):
    """Page tests do not depend on the shipped sound and scene models (their accuracy is tested
    with the recognition modules): by default no model is installed; a test that wants one
    patches ``cacas.lab.model_stamp`` itself."""
    import cacas.lab

    monkeypatch.setattr(cacas.lab, "model_stamp", lambda kind: None)


class _Offered(dict):
    """The ``downloads`` fixture: name or key -> bytes, and ``at_click``: file name -> the button's data."""

    def __init__(self):
        super().__init__()
        self.at_click: dict = {}


@pytest.fixture
def downloads(monkeypatch):
    """What the page's download buttons offer (bytes), by the button's key and by file name (the
    last button drawn with that name): a button's label alone said nothing of what it downloads.
    Data made on the click (a callable, Streamlit's deferred download) is made here, as a click would;
    ``.at_click[file_name]`` is what the button holds, to make it again later (a click after a change
    made elsewhere since the page was drawn)."""
    offered = _Offered()
    real = st.download_button

    def download_button(label, data, file_name=None, *args, **kwargs):
        offered.at_click[file_name] = data
        made = data() if callable(data) else data
        data_bytes = made.encode("utf-8") if isinstance(made, str) else made
        offered[file_name] = data_bytes
        if kwargs.get("key"):
            offered[kwargs["key"]] = data_bytes
        return real(label, data, file_name, *args, **kwargs)
    monkeypatch.setattr(st, "download_button", download_button)
    return offered
