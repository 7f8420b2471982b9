"""An element whose code did not load. Streamlit loads most elements' code when a page first draws one, and a fetch
that failed (the lab's Wi-Fi dropped, the server restarted, while the page loaded) left the element as a red box,
"TypeError: Failed to fetch dynamically imported module: .../Multiselect....js", for the page's life: the browser
keeps a module that failed, and no rerun drew it. The researcher's page says so and what to do (app.CONNECTION_STYLE);
the participant's tablet reloads itself (app.TABLET_RELOAD_SCRIPT). Here the fetches fail by Playwright's routing:
the first one of a chunk, or every one."""

from __future__ import annotations

import json
import re

import pytest

from conftest import close_page, open_page
from test_browser_mini_study import goto
from test_browser_tablet_waits import waiting_server  # noqa: F401 (a fixture: this module's own server)

pytestmark = pytest.mark.browser

#: Streamlit's box for an element it could not draw (its stack: an st.error has none)
BROKEN = "[data-testid='stErrorElementStack']"
#: what the page says over itself of it (the app's band, or nothing: "none")
SAID = "() => getComputedStyle(document.querySelector(\"[data-testid='stApp']\"), '::before').content"


@pytest.fixture(scope="module")
def day_server(waiting_server):
    """The app (a server of this module's) over P02, on day 1: an open day, whose tablet asks for the context."""
    return waiting_server[1]


def fail_fetches(page, chunks: str, times: int | None = None) -> list[str]:
    """The page's fetches of Streamlit's code ``chunks`` (a regular expression of their names, e.g. "Multiselect")
    fail: the first ``times`` (None: all); returns the list of those failed so far."""
    failed = []

    def route(r):
        if times is None or len(failed) < times:
            failed.append(r.request.url)
            r.abort()
        else:
            r.continue_()

    page.route(re.compile(rf"/static/js/(?:{chunks})\.[^/.]+\.js$"), route)
    return failed


def test_a_researchers_page_says_that_part_of_it_did_not_load_and_to_reload_it(browser, day_server):
    page = open_page(browser, viewport={"width": 1280, "height": 800})
    page.set_default_timeout(60_000)
    try:
        failed = fail_fetches(page, "Multiselect")
        goto(page, f"{day_server}/participants?participant=P02")
        page.wait_for_selector(BROKEN, state="attached")
        assert failed and page.locator("[data-testid=stMultiSelect]").count() == 0
        page.wait_for_timeout(1500)  # a rerun (a tab's) draws them no better, and the page is not reloaded
        page.evaluate("() => { window.cacasStillHere = true; }")
        page.get_by_role("tab", name="Details of P02").click()
        page.get_by_role("tab", name="Preferences of P02").click()
        page.wait_for_timeout(2500)
        assert page.evaluate("() => window.cacasStillHere === true")  # a form's changes are not lost unasked
        said = page.evaluate(SAID)
        assert "Part of this page could not be drawn" in said and "Reload the page" in said, said
        band = page.evaluate("""() => { const s = getComputedStyle(document.querySelector("[data-testid='stApp']"),
                                                                     '::before');
                                        return [s.position, s.top, parseFloat(s.height), s.opacity]; }""")
        assert band[:2] == ["fixed", "0px"] and band[2] < 160 and band[3] == "1", band
    finally:
        close_page(page)


def test_a_page_drawn_whole_says_nothing(browser, day_server):
    page = open_page(browser, viewport={"width": 1280, "height": 800})
    page.set_default_timeout(60_000)
    try:
        goto(page, f"{day_server}/participants?participant=P02")
        assert page.locator("[data-testid=stMultiSelect]").count() > 0
        assert page.evaluate(SAID) == "none"
    finally:
        close_page(page)


def test_the_tablet_reloads_itself_when_part_of_it_did_not_load(browser, day_server):
    """The tablet's context form (chips, buttons) lost its code once: the tablet reloads once connected, and the
    participant sees the form, whole."""
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    page.set_default_timeout(60_000)
    try:
        failed = fail_fetches(page, "Button|ButtonGroup", times=1)
        page.goto(f"{day_server}/?participant=P02&view=tablet")
        page.wait_for_function("() => JSON.parse(sessionStorage.getItem('cacasReloads') || '[]').length === 1")
        goto(page, page.url)  # the page after its reload (goto waits for its run and its styles)
        page.get_by_role("button", name="Do it").wait_for()
        assert len(failed) == 1 and page.locator(BROKEN).count() == 0
        assert page.evaluate(SAID) == "none"
    finally:
        close_page(page)


def test_a_tablet_whose_code_never_loads_is_not_reloaded_for_ever_and_says_to_tell_the_researcher(browser,
                                                                                                     day_server):
    page = open_page(browser, viewport={"width": 1024, "height": 768})
    page.set_default_timeout(60_000)
    try:
        fail_fetches(page, "Button|ButtonGroup")
        page.goto(f"{day_server}/?participant=P02&view=tablet")
        page.wait_for_function("() => JSON.parse(sessionStorage.getItem('cacasReloads') || '[]').length === 3")
        page.wait_for_selector(BROKEN, state="attached")
        page.evaluate("() => { window.cacasStillHere = true; }")
        page.wait_for_timeout(6000)  # no fourth reload; the words have faded in (after 5 s)
        assert page.evaluate("() => window.cacasStillHere === true")
        assert len(json.loads(page.evaluate("() => sessionStorage.getItem('cacasReloads')"))) == 3
        said = page.evaluate(SAID)
        assert "Part of this screen did not load" in said and "tell the researcher" in said, said
        assert page.evaluate("""() => getComputedStyle(document.querySelector("[data-testid='stApp']"),
                                                       '::before').opacity""") == "1"
    finally:
        close_page(page)
