"""The researcher's browser history: one page visit, one entry, so Back goes back a page a press.

Streamlit's own navigation clears the address on a page change; the app wrote the participant,
day and study back one at a time, and each write pushed an entry into the browser's history:
Back took three or four presses to leave a page (walkthrough). The sidebar's page links now carry
the address, and the address is written in one change, only when it changes."""

from __future__ import annotations

import pytest

from cacas.store import StudyStore
from conftest import _run_app, close_page, open_page
from test_browser_mini_study import goto, idle

pytestmark = pytest.mark.browser

PAGES = ["Participants", "Study session", "Adaptation", "Results"]


@pytest.fixture(scope="module")
def two_study_server(tmp_path_factory):
    """The app over P01 (study 'default') and P02 (study 'pilot'): the address carries the study too."""
    tmp = tmp_path_factory.mktemp("navigation")
    db = tmp / "study.sqlite"
    with StudyStore(db) as s:
        s.add_participant("P01")
        s.create_study("pilot", "")
        s.add_participant("P02", study="pilot")
    yield from _run_app(tmp, CACAS_DB=str(db))


def _heading(page) -> str:
    return page.locator("h1").first.inner_text()


def test_back_leaves_a_page_in_one_press_and_keeps_the_participant(browser, two_study_server):
    page = open_page(browser, viewport={"width": 1280, "height": 900})
    goto(page, f"{two_study_server}/?participant=P01")
    start = page.evaluate("history.length")
    links = page.locator(".st-key-page-links")
    for name in PAGES:
        links.get_by_role("link", name=name).click()
        idle(page)
        page.wait_for_function("n => history.length >= n", arg=start + PAGES.index(name) + 1)
    idle(page)
    assert page.evaluate("history.length") == start + len(PAGES)  # one entry a page
    assert "participant=P01" in page.url and "study=default" in page.url and "day=1" in page.url
    for name in reversed(PAGES[:-1]):
        page.go_back()
        idle(page)
        page.wait_for_function("t => document.querySelector('h1') && document.querySelector('h1').innerText"
                               ".startsWith(t)", arg=name)
        assert _heading(page).startswith(name) and "participant=P01" in page.url
    close_page(page)


def test_a_study_database_that_cannot_be_opened_lists_no_page_files(browser, tmp_path):
    """Walkthrough (the study data folder on read-only media): the app said "The study database cannot be
    opened" and stopped before its navigation, so Streamlit listed the pages/ folder's files in the sidebar,
    "app", "adaptation", ..., "ui" (a helper module, not a page). The message stands alone."""
    (tmp_path / "a-file").write_text("not a folder")
    for url in _run_app(tmp_path, CACAS_DB=str(tmp_path / "a-file" / "study.sqlite")):
        page = open_page(browser, viewport={"width": 1280, "height": 800})
        try:
            goto(page, url, app_styled=False)  # it stops before drawing them
            page.get_by_text("The study database cannot be opened").wait_for()
            idle(page)
            page.screenshot(path=str(tmp_path / "cannot-be-opened.png"))
            assert page.locator("[data-testid='stSidebarNav']").count() == 0
            assert page.get_by_role("link", name="ui", exact=True).count() == 0
        finally:
            close_page(page)
