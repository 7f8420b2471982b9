"""The browser tests' and the page benchmark's count of a page's script runs (headless.ScriptRuns), from
the messages Streamlit's server sends: a run is begun by its NewSession and over at its ScriptFinished, unless that says a rerun
follows; text frames and other messages count nothing."""

from __future__ import annotations

from headless import ScriptRuns
from streamlit.proto.ForwardMsg_pb2 import ForwardMsg


def _frame(**fields) -> bytes:
    msg = ForwardMsg()
    for name, value in fields.items():
        if name == "new_session":
            msg.new_session.page_script_hash = value
        else:
            setattr(msg, name, value)
    return msg.SerializeToString()


def test_a_run_is_counted_from_its_first_message_to_its_last():
    runs = ScriptRuns()
    assert not runs.busy and str(runs) == "runs started 0, finished 0, waited for 0"
    runs.frame(_frame(new_session="home"))
    assert runs.started == 1 and runs.busy
    runs.frame(_frame(script_finished=ForwardMsg.FINISHED_EARLY_FOR_RERUN))  # st.rerun() in the run
    assert runs.finished == 1 and runs.busy  # its rerun is still to come
    runs.frame(_frame(new_session="home"))
    runs.frame("a text frame")
    other = ForwardMsg()
    other.page_info_changed.query_string = "participant=P01"
    runs.frame(other.SerializeToString())
    assert runs.started == 2 and runs.busy
    runs.frame(_frame(script_finished=ForwardMsg.FINISHED_SUCCESSFULLY))
    assert (runs.started, runs.finished) == (2, 2) and not runs.busy
    runs.frame(_frame(new_session="home"))  # a fragment's run is a run too
    runs.frame(_frame(script_finished=ForwardMsg.FINISHED_FRAGMENT_RUN_SUCCESSFULLY))
    assert (runs.started, runs.finished) == (3, 3) and not runs.busy


def test_a_run_stopped_by_a_widgets_rerun_is_over_at_the_next_runs_first_message():
    """With Streamlit's runner.fastReruns (on by default), a click during a run stops its runner and starts
    another: the stopped run sends no ScriptFinished (its runner's last messages are dropped). Recorded on
    the tablet: the page's first run (its recognisers' warm-up) going when "Do it" was pressed gave
    NewSession, NewSession, ScriptFinished; the count said a run was going for good after it, and
    scripts/bench_pages_browser.py --tablet waited 300 s for it."""
    runs = ScriptRuns()
    runs.frame(_frame(new_session="session"))  # the page's first run, still going ...
    runs.frame(_frame(new_session="session"))  # ... when a click's rerun replaced it
    assert runs.started == 2 and runs.busy
    runs.frame(_frame(script_finished=ForwardMsg.FINISHED_SUCCESSFULLY))
    assert (runs.started, runs.finished) == (2, 1) and not runs.busy
    assert str(runs) == "runs started 2, finished 1, waited for 0"
