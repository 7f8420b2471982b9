"""A server restarted under the participant's open tablet: their first tap afterwards is saved.

The page comes back from its address (the proposal's context and interaction mark) and its next
click reaches a new session; Streamlit runs a button's callback only in a session that drew the
button, so the first tap after a restart was lost without a word (pages.ui.button)."""

from __future__ import annotations

from contextlib import contextmanager

import pytest

from cacas.store import StudyStore
from conftest import _run_app, close_page, open_page
from headless import free_port
from test_browser_mini_study import CANDIDATES, button, goto, idle, shows, speaking_context, text_of
from test_browser_tablet_waits import on_day_1

CONNECTS = "() => window.__cacasConnects"  # the page's connections to the server so far (goto counts them)
RECONNECTED = "n => window.__cacasConnects > n"

pytestmark = pytest.mark.browser


@contextmanager
def app_to_restart(tmp_path, db):
    """The app on a port of its own; yields its URL and ``restart()``, which stops the server and
    starts it again on the same port and database (an open page reconnects by itself)."""
    port = free_port()
    runs = [_run_app(tmp_path, port=port, CACAS_DB=str(db))]
    url = next(runs[0])

    def restart():
        next(runs[-1], None)
        runs.append(_run_app(tmp_path, port=port, CACAS_DB=str(db)))
        next(runs[-1])
    try:
        yield url, restart
    finally:
        next(runs[-1], None)


def test_the_first_tap_after_a_server_restart_is_saved(tmp_path, browser, initial_policy):
    db = tmp_path / "study.sqlite"
    with StudyStore(db) as s:
        s.add_participant("P01")
        s.save_preferences("P01", [{"activity": ["use stove"], "scene": ["kitchen"], "action": "remind to turn off"}])
        s.open_day("P01")
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    page.set_default_timeout(30_000)
    with app_to_restart(tmp_path, db) as (url, restart):
        goto(page, f"{url}/?participant=P01&view=tablet")
        speaking_context(page, CANDIDATES)
        connects = page.evaluate(CONNECTS)
        restart()
        # the page reconnects by itself: waited for, not a fixed 3 s
        page.wait_for_function(RECONNECTED, arg=connects, timeout=60_000)
        button(page, "Accept").click()  # once
        shows(page, "Saved (accepted)", timeout=90_000)  # a new server loads the policy first
        with StudyStore(db, readonly=True) as s:
            rows = s.interactions_frame("P01", method=None)
        assert list(rows["response"]) == ["accept"] and list(rows["index"]) == [1]
    close_page(page)


def test_the_researchers_first_click_after_a_server_restart_is_saved(tmp_path, browser):
    """The same for the researcher's pages: a participant typed into the form before a restart is
    added by one click on "Add participant" after it (the click was lost: nothing added)."""
    db = tmp_path / "study.sqlite"
    with StudyStore(db) as s:
        s.add_participant("P01")
    page = open_page(browser, viewport={"width": 1360, "height": 900})
    page.set_default_timeout(30_000)
    with app_to_restart(tmp_path, db) as (url, restart):
        goto(page, f"{url}/participants")
        page.get_by_role("tab", name="Add a participant").click()
        idle(page)
        page.get_by_role("textbox", name="Pseudonymous code", exact=True).fill("P02")  # in a form: no rerun
        connects = page.evaluate(CONNECTS)
        restart()
        page.wait_for_function(RECONNECTED, arg=connects, timeout=60_000)  # the page reconnects by itself
        button(page, "Add participant").click()  # once
        shows(page, "Preferences of P02")
        with StudyStore(db, readonly=True) as s:
            assert [p.code for p in s.list_participants()] == ["P01", "P02"]
    close_page(page)


def test_pages_reconnecting_to_a_restarted_server_at_once_keep_their_participant(tmp_path, browser):
    """Pages that rerun by themselves (the researcher's Study session follows the tablet, a tablet
    waits for the researcher) ask the restarted server for a run as they reconnect. Two at once: the
    first switched Streamlit's old-style pages mode off, and the second page, reading it off, ran
    alone, without the app's sidebar: "Select a participant in the sidebar" under an address naming
    P01 (pages.ui.require_app)."""
    db = tmp_path / "study.sqlite"
    with StudyStore(db) as s:
        on_day_1(s, "P01", closed=False)
        on_day_1(s, "P02", closed=True)  # its tablet waits for the researcher
    researcher = open_page(browser, viewport={"width": 1280, "height": 800})
    tablet = open_page(browser, viewport={"width": 1024, "height": 768})
    with app_to_restart(tmp_path, db) as (url, restart):
        goto(researcher, f"{url}/session?participant=P01")
        goto(tablet, f"{url}/?participant=P02&view=tablet")
        shows(researcher, "Study session\u00a0· P01")
        shows(tablet, "Day 1 is finished")
        connects = researcher.evaluate(CONNECTS), tablet.evaluate(CONNECTS)
        restart()
        for page, n in zip((researcher, tablet), connects):
            page.wait_for_function(RECONNECTED, arg=n, timeout=60_000)
        shows(researcher, "Study session\u00a0· P01", "Day 1 of 7")
        shows(tablet, "Day 1 is finished")
        idle(researcher)
        assert "Select a participant" not in text_of(researcher)
    close_page(researcher)
    close_page(tablet)


STATE = "() => document.querySelector(\"[data-testid='stApp']\").getAttribute('data-test-connection-state')"
SAID = "() => getComputedStyle(document.querySelector(\"[data-testid='stApp']\"), '::after').content"
DIALOGS = "() => [...document.querySelectorAll(\"[data-testid='stDialog']\")].filter(d => d.offsetParent !== null).length"


@contextmanager
def server_away(tmp_path, db, page, address: str):
    """The app on ``db``, ``page`` opened at ``address`` (after the server's URL) and saying nothing of its
    connection; then the server stops, and this yields once the page pings it and Streamlit has opened its dialog
    (what the page says then is the test's); then the server starts again on its port, and the page, reconnected,
    says nothing any more."""
    port = free_port()
    server = _run_app(tmp_path, port=port, CACAS_DB=str(db))
    url = next(server)
    try:
        goto(page, url + address)
        assert page.evaluate(SAID) == "none"
        next(server, None)  # the server stops: the page pings it, and Streamlit opens its dialog
        page.wait_for_function(f"() => ({STATE})() === 'PINGING_SERVER'", timeout=30_000)
        page.wait_for_selector("[data-testid='stDialog']", state="attached", timeout=30_000)
        yield
        server = _run_app(tmp_path, port=port, CACAS_DB=str(db))
        next(server)
        page.wait_for_function(f"() => ({STATE})() === 'CONNECTED'", timeout=60_000)
        assert page.evaluate(SAID) == "none"
    finally:
        next(server, None)
        close_page(page)


def test_the_tablet_says_in_its_own_words_that_its_connection_comes_back(tmp_path, browser):
    """A study day with several tablets (lan): when the lab's network dropped, or the server restarted, the
    participant read Streamlit's dialog "Connection error: Streamlit server is not responding. Are you connected to
    the internet?". The tablet says in its own words that it comes back by itself, and nothing once it has."""
    db = tmp_path / "study.sqlite"
    with StudyStore(db) as s:
        s.add_participant("P01")
        s.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
        s.open_day("P01")
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    with server_away(tmp_path, db, page, "/?participant=P01&view=tablet"):
        assert "lost its connection to the robot" in page.evaluate(SAID)
        assert "comes back by itself" in page.evaluate(SAID)
        assert page.evaluate(DIALOGS) == 0  # Streamlit's, with its words, is not shown


def test_a_researchers_page_says_in_the_apps_words_that_its_server_is_not_answering(tmp_path, browser):
    """The researcher's pages showed Streamlit's dialog "Connection error: Streamlit server is not responding. Are you
    connected to the internet?" over the page, dimmed, when the server restarted or stopped: a band at the top says
    what it is and what to do, the page readable under it, and nothing once the page has reconnected."""
    db = tmp_path / "study.sqlite"
    with StudyStore(db) as s:
        s.add_participant("P01")
    page = open_page(browser, viewport={"width": 1280, "height": 800})
    with server_away(tmp_path, db, page, "/participants?participant=P01"):
        said = page.evaluate(SAID)
        assert "server is not answering" in said and "reconnects by itself" in said and "streamlit run app.py" in said
        assert "internet" not in said
        assert page.evaluate(DIALOGS) == 0
        band = page.evaluate("""() => { const s = getComputedStyle(document.querySelector("[data-testid='stApp']"),
                                                                     '::after');
                                        return [s.position, s.top, parseFloat(s.height)]; }""")
        assert band[:2] == ["fixed", "0px"] and band[2] < 160, band  # a band at the top, not over the whole page
