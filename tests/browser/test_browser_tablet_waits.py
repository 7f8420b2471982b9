"""A tablet left waiting for the researcher moves on by itself.

On "Day 1 is finished. The robot is learning from it ..." the tablet had no button and was never
drawn again: only a reload of the browser, which a participant does not think of (and a kiosk
tablet may not allow), showed "Start day 2" once the researcher had adapted the robot (walkthrough
at 1024 x 768)."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from cacas.store import StudyStore
from conftest import _run_app, open_page
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
    page.context.close()


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
    page.context.close()
