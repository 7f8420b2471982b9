"""A tablet left waiting for the researcher moves on by itself.

On "Day 1 is finished. The robot is learning from it ..." the tablet had no button and was never
drawn again: only a reload of the browser, which a participant does not think of (and a kiosk
tablet may not allow), showed "Start day 2" once the researcher had adapted the robot (walkthrough
at 1024 x 768)."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from cacas.store import StudyStore
from conftest import _run_app, close_page, open_page
from test_browser_mini_study import goto

pytestmark = pytest.mark.browser


def on_day_1(s: StudyStore, code: str, closed: bool) -> None:
    """``code`` added with a preference, on day 1: open, or closed (one interaction) and not adapted yet."""
    s.add_participant(code)
    s.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
    day = s.open_day(code)
    if closed:
        s.record_interaction(code, day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
        s.close_day(code, day)


@pytest.fixture(scope="module")
def waiting_server(tmp_path_factory):
    """The app over P01, whose day 1 is closed and not adapted yet, and P02, on day 1."""
    tmp = tmp_path_factory.mktemp("tablet-waits")
    db = tmp / "study.sqlite"
    with StudyStore(db) as s:
        on_day_1(s, "P01", closed=True)
        on_day_1(s, "P02", closed=False)
    for url in _run_app(tmp, CACAS_DB=str(db)):  # the server stops once the module's tests are done
        yield db, url


def test_the_tablet_shows_start_day_2_once_the_day_is_adapted_without_a_reload(browser, waiting_server):
    db, url = waiting_server
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    goto(page, f"{url}/?participant=P01&view=tablet")
    expect(page.get_by_text("Day 1 is finished. The robot is learning from it")).to_be_visible(timeout=30_000)
    page.evaluate("window.notReloaded = true")
    with StudyStore(db) as s:  # the researcher adapts the robot, on their own screen
        s.save_policy("P01", 1, "cacas", b"the adapted policy")
    expect(page.get_by_role("button", name="Start day 2")).to_be_visible(timeout=30_000)
    assert page.evaluate("window.notReloaded === true")  # drawn again in place, not reloaded
    assert page.get_by_text("Day 1 is finished").count() == 0
    close_page(page)


def test_the_tablet_on_an_open_days_form_follows_the_researcher_closing_the_day(browser, waiting_server):
    """Walkthrough: a tablet left on the context form kept asking "What are you doing?" after the
    researcher had closed (and adapted) the day on their own screen; what was set there was not used."""
    db, url = waiting_server
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    goto(page, f"{url}/?participant=P02&view=tablet")
    expect(page.get_by_text("What are you doing?")).to_be_visible(timeout=30_000)
    page.evaluate("window.notReloaded = true")
    with StudyStore(db) as s:  # the researcher closes the day, on their own screen
        s.close_day("P02", 1)
    expect(page.get_by_text("Day 1 is finished. The robot is learning from it")).to_be_visible(timeout=30_000)
    assert page.evaluate("window.notReloaded === true")  # drawn again in place, not reloaded
    assert page.get_by_text("What are you doing?").count() == 0
    close_page(page)


def test_the_adaptation_page_follows_a_proposal_the_tablet_shows_after_it_was_drawn(browser, waiting_server):
    """A study day with several tablets (lan): the researcher opened the Adaptation page, then the participant set
    a context on the tablet. The page's warning that the tablet shows a proposal (an answer after closing is not
    saved) is drawn only with the page: it never came, and "Close day 1 and adapt" lost the answer the
    participant was about to give. The page follows the tablet while the day is open, as the Study session's
    researcher view does."""
    db, url = waiting_server
    with StudyStore(db) as s:
        on_day_1(s, "P03", closed=False)
    desk = open_page(browser, viewport={"width": 1360, "height": 900})
    goto(desk, f"{url}/adaptation?participant=P03")
    expect(desk.get_by_role("button", name="Close day 1 and adapt")).to_be_visible(timeout=30_000)
    desk.evaluate("window.notReloaded = true")
    assert desk.get_by_text("tablet shows a proposal").count() == 0
    tablet = open_page(browser, viewport={"width": 1024, "height": 768})  # a proposal on the tablet, after the page
    goto(tablet, f"{url}/?participant=P03&view=tablet&ctx=3.6.20.2&at=1.1")
    expect(tablet.locator("[data-testid='stChatMessage']").first).to_be_visible(timeout=60_000)
    expect(desk.get_by_text("P03's tablet shows a proposal (use stove")).to_be_visible(timeout=30_000)
    assert desk.evaluate("window.notReloaded === true")  # drawn again in place, not reloaded
    close_page(tablet)
    close_page(desk)
