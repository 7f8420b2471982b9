"""pages.ui.require_app: a page runs through app.py (its sidebar, the participant from the address),
known per run from app.py's routing, not from Streamlit's server-wide old-style pages flag."""

import pytest
from streamlit.runtime.pages_manager import PagesManager

from pages import ui


class Rerun(Exception):
    pass


@pytest.fixture
def reruns(monkeypatch):
    """st.rerun as an exception to catch; the old-style pages flag as Streamlit leaves it once any
    session has routed (off), and put back after the test."""
    def rerun():
        raise Rerun
    monkeypatch.setattr(ui.st, "rerun", rerun)
    monkeypatch.setattr(PagesManager, "uses_pages_directory", False)


def test_a_page_run_alone_reruns_through_the_app_even_once_another_session_switched_the_old_mode_off(reruns):
    """Two pages reconnecting to a restarted server at once both started alone; the first switched the
    flag off, and the second, reading it off, went on alone: "Select a participant in the sidebar"."""
    ui._ROUTED.run = False
    with pytest.raises(Rerun):
        ui.require_app()


def test_a_page_the_app_routed_runs_and_the_next_run_alone_does_not_pass_for_routed(reruns):
    ui.routed()
    ui.require_app()  # no rerun: the app's run
    with pytest.raises(Rerun):  # read once: a later run of the page alone is not taken for the app's
        ui.require_app()


def test_the_first_request_to_a_page_switches_the_old_mode_off(reruns, monkeypatch):
    monkeypatch.setattr(PagesManager, "uses_pages_directory", True)
    ui._ROUTED.run = False
    with pytest.raises(Rerun):
        ui.require_app()
    assert PagesManager.uses_pages_directory is False
