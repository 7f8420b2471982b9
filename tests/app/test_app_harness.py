"""The page tests' own harness (conftest.py): what it shares between AppTests keeps each run's results as a
fresh AppTest gives them."""
import os
import time

from conftest import TIMEOUT
from streamlit.runtime.scriptrunner import script_cache
from streamlit.testing.v1 import AppTest


def counted_compiles(monkeypatch) -> list[str]:
    """The scripts Streamlit compiles from now on (each compile rewrites the script for "magic" first)."""
    compiled = []
    real = script_cache.magic.add_magic

    def add_magic(code, script_path):
        compiled.append(os.path.basename(script_path))
        return real(code, script_path)

    monkeypatch.setattr(script_cache.magic, "add_magic", add_magic)
    return compiled


def test_a_page_opened_again_runs_the_bytecode_compiled_the_first_time(app, monkeypatch):
    app("pages/participants.py")  # app.py and the page compiled here, unless an earlier test compiled them
    compiled = counted_compiles(monkeypatch)
    at = app("pages/participants.py")  # a new AppTest, as every page test opens
    at.run()  # and a rerun of it
    assert compiled == [] and not at.exception


def test_a_script_written_again_is_compiled_again(tmp_path, db, monkeypatch):
    script = tmp_path / "page.py"
    script.write_text("import streamlit as st\nst.write('first version')\n")
    at = AppTest.from_file(str(script), default_timeout=TIMEOUT).run()
    assert [m.value for m in at.markdown] == ["first version"]
    script.write_text("import streamlit as st\nst.write('second')\n")  # another size
    at = AppTest.from_file(str(script), default_timeout=TIMEOUT).run()
    assert [m.value for m in at.markdown] == ["second"]
    script.write_text("import streamlit as st\nst.write('third!')\n")  # the same size, written later
    stat = script.stat()
    os.utime(script, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))
    at = AppTest.from_file(str(script), default_timeout=TIMEOUT).run()
    assert [m.value for m in at.markdown] == ["third!"]


def test_a_bare_expression_is_still_written_to_the_page_from_the_shared_bytecode(tmp_path, db):
    """Streamlit's "magic" (a bare expression of a script is written to the page) is compiled into the shared
    bytecode as into a server's."""
    script = tmp_path / "page.py"
    script.write_text("words = 'a bare string'\nwords\n")  # (a first line alone would be the docstring)
    for _ in range(2):
        at = AppTest.from_file(str(script), default_timeout=TIMEOUT).run()
        assert [m.value for m in at.markdown] == ["a bare string"]


def test_a_script_run_is_waited_for_without_polling_its_runner(tmp_path, db, monkeypatch):
    """AppTest's own wait read every event of the run every millisecond (one per element drawn so far)."""
    from streamlit.testing.v1 import local_script_runner

    looks = []
    real = local_script_runner.LocalScriptRunner.script_stopped
    monkeypatch.setattr(local_script_runner.LocalScriptRunner, "script_stopped",
                        lambda runner: looks.append(1) or real(runner))
    script = tmp_path / "page.py"
    script.write_text("import time\nimport streamlit as st\nfor i in range(20):\n    time.sleep(0.01)\n"
                      "    st.write(i)\n")
    at = AppTest.from_file(str(script), default_timeout=TIMEOUT).run()
    assert len(at.markdown) == 20
    assert len(looks) <= 2, len(looks)


def test_a_script_run_longer_than_its_timeout_is_stopped_and_fails_naming_the_timeout(tmp_path, db):
    script = tmp_path / "page.py"
    steps = tmp_path / "steps.txt"
    script.write_text(f"import time\nimport streamlit as st\nfor i in range(200):\n    time.sleep(0.05)\n"
                      f"    st.empty()\n    open({str(steps)!r}, 'a').write('.')\n")
    at = AppTest.from_file(str(script), default_timeout=0.5)
    try:
        at.run()
    except RuntimeError as error:
        assert str(error) == "AppTest script run timed out after 0.5(s)"
    else:
        raise AssertionError("a 10-s script run passed for finished within 0.5 s")
    done = steps.read_text()
    time.sleep(0.3)
    assert steps.read_text() == done and len(done) < 200  # stopped, not left running
