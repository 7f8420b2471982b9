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
    runs.frame(_frame(script_finished=ForwardMsg.FINISHED_EARLY_FOR_RERUN))  # a click during the run
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
