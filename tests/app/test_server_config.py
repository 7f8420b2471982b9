"""The app's server settings (.streamlit/config.toml), read by Streamlit's own config loader."""
from pathlib import Path

from streamlit import config

PROJECT_ROOT = Path(__file__).resolve().parents[2]


def options(monkeypatch, names=("server.address", "server.fileWatcherType", "server.runOnSave",
                                 "browser.gatherUsageStats")):
    monkeypatch.chdir(PROJECT_ROOT)  # Streamlit reads ./.streamlit/config.toml
    config.get_config_options(force_reparse=True)
    return {name: config.get_option(name) for name in names}


def test_study_data_stays_on_this_machine_and_code_on_disk_is_not_reloaded_into_a_running_study(monkeypatch):
    try:
        got = options(monkeypatch)
    finally:
        monkeypatch.undo()
        config.get_config_options(force_reparse=True)
    # localhost only; no usage statistics; a git pull during a study is not half-loaded into the
    # running server (modules reloaded while cached stores and policies keep the old classes)
    assert got == {"server.address": "localhost", "server.fileWatcherType": "none",
                   "server.runOnSave": False, "browser.gatherUsageStats": False}


def test_a_script_run_does_not_end_with_a_full_garbage_collection(monkeypatch):
    """Streamlit's default ends every script run with gc.collect(2): 150-250 ms holding the interpreter
    lock in this server (torch, pandas, plotly: some 300,000 objects). A running job's progress reruns
    every 0.5 s (ui.job_progress), so the adaptation, in the same process, waited for the lock: "Close day
    N and adapt" took 6.3 s with the page open, 2.9 s with it closed (walkthrough; measured in Chromium).
    AppTest's runner skips that collection whatever the setting, so the setting itself is tested here."""
    try:
        got = options(monkeypatch, ("runner.postScriptGC",))
    finally:
        monkeypatch.undo()
        config.get_config_options(force_reparse=True)
    assert got == {"runner.postScriptGC": False}


def test_the_app_script_runs_bare_as_a_worker_process_runs_it(tmp_path):
    """A Simulation lab worker (multiprocessing's spawn) re-runs app.py, the server's __main__,
    without a Streamlit session before it starts its work: the script must get through it (a
    page's title read on the bare stub page crashed every worker), and do nothing there (each
    worker opened the study database)."""
    import os
    import subprocess
    import sys

    run = subprocess.run([sys.executable, str(PROJECT_ROOT / "app.py")], cwd=tmp_path, capture_output=True, text=True,
                         env=dict(os.environ, CACAS_DB=str(tmp_path / "s.sqlite")), timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stderr == ""  # nothing in the server's log either (each worker wrote two ScriptRunContext warnings)
    assert not (tmp_path / "s.sqlite").exists()  # no database opened (nor created) by a worker


PRELOAD_CHECK = """
import gc, importlib, sys, threading
from app import PRELOADED
started = []
real_start = threading.Thread.start
def start(self):
    started.append(self.name)
    return real_start(self)
threading.Thread.start = start
collecting = []  # whether the garbage collector ran automatically while each preloaded module was imported
real_import = importlib.import_module
def import_module(name, *args, **kwargs):
    if threading.current_thread().name == "cacas-preload" and name in PRELOADED:
        collecting.append(gc.isenabled())
    return real_import(name, *args, **kwargs)
importlib.import_module = import_module
from cacas import lab
loaded = []  # the threads that loaded a sound or scene model
real_load = lab.load_recognizer
def load_recognizer(kind):
    loaded.append((kind, threading.current_thread().name))
    return real_load(kind)
lab.load_recognizer = load_recognizer
from streamlit.testing.v1 import AppTest
for _ in range(2):  # two runs of the first page: one import thread for the server process
    at = AppTest.from_file("app.py", default_timeout=120)
    at.run()
    assert not at.exception, at.exception
print(started.count("cacas-preload"))
for t in threading.enumerate():
    if t.name == "cacas-preload":
        t.join(120)
print(" ".join(sorted(m for m in PRELOADED if m in sys.modules)))
print(collecting, gc.isenabled())
print(sorted(loaded))
"""


def test_the_first_page_starts_the_heavy_imports_in_the_background_once(tmp_path):
    """The first visit of Adaptation after the server's start took 3.8 s and of Sounds and scenes 6.4 s
    (torch, torchvision; a 24 x 7 study, 5 s after the first page) against 2.2 s and 3.0 s with the
    imports done in the background once the first page is drawn (README, Performance)."""
    import os
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", PRELOAD_CHECK], cwd=PROJECT_ROOT, capture_output=True, text=True,
                         env=dict(os.environ, CACAS_DB=str(tmp_path / "s.sqlite")), timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split("\n")[:4] == ["1", "cacas.adaptation librosa.feature.spectral torchvision.models",
                                          # no automatic collection while importing (app._preload: Python 3.11's
                                          # AST race with a page compiled meanwhile), on again afterwards
                                          "[False, False, False] True",
                                          # the saved models too, once, in that thread (the first Sounds and scenes
                                          # page and the tablet's first form loaded them)
                                          "[('scene', 'cacas-preload'), ('sound', 'cacas-preload')]"]


FIRST_RECOGNITION_CHECK = """
import importlib, sys
from app import PRELOADED
for name in PRELOADED:
    importlib.import_module(name)
from cacas import lab, spaces
from cacas.audio.library import clip_paths
from cacas.vision.library import image_paths
sound, scene = lab.load_recognizer("sound"), lab.load_recognizer("scene")
before = set(sys.modules)
sound.recognize(clip_paths(spaces.ACTIVITIES[0])[0])
print(len(set(sys.modules) - before), sorted({m.split(".")[0] for m in set(sys.modules) - before}))
before = set(sys.modules)
scene.recognize(image_paths(spaces.SCENES[0])[0])
print(sorted({m.split(".")[0] for m in set(sys.modules) - before}))
"""


def test_the_background_imports_leave_nothing_to_import_for_the_tablets_first_recognition(tmp_path):
    """The tablet's first proposal recognises a clip and a photo. ``librosa.feature`` is a lazy stub:
    preloaded by that name, the first recognition still imported scipy.signal, soundfile and numba (some
    1,000 modules, 3.6 s), on the tablet's page; the module that computes the MFCC is preloaded now."""
    import os
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", FIRST_RECOGNITION_CHECK], cwd=PROJECT_ROOT, capture_output=True,
                         text=True, env=dict(os.environ, CACAS_DB=str(tmp_path / "s.sqlite")), timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    sound, scene = run.stdout.splitlines()
    assert sound == "0 []"  # the number of modules the clip's recognition imported, and their packages
    assert scene in ("[]", "['PIL']")  # at most Pillow's reader of the photo's format (3 small modules)
