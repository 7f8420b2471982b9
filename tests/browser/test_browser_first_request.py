"""A fresh server whose first request goes straight to a page still runs it through app.py
(Streamlit's old pages/ mode would run the page alone: no sidebar, no participant)."""

import pytest
from conftest import close_page, open_page
from playwright.sync_api import expect

pytestmark = pytest.mark.browser

WAIT = "[data-testid='stApp'][data-test-script-state='notRunning']"


def test_first_request_to_a_page_gets_the_app_shell(server, browser):
    page = open_page(browser, viewport={"width": 1280, "height": 900})
    page.goto(f"{server}/results")
    page.wait_for_selector(WAIT, timeout=90_000)
    # waited for, not read at once: a loaded run found the page idle and its heading not drawn yet (is_visible
    # False: an idle page between two runs, or one not drawn at once)
    nav = page.locator(".st-key-page-links")
    expect(nav).to_contain_text("Overview", timeout=30_000)  # the app's navigation, titled pages
    expect(nav).to_contain_text("Simulation lab", timeout=30_000)
    items = nav.inner_text().split("\n")  # drawn at once, from one message: the whole list once these are in
    assert "ui" not in items and "app" not in items  # not the pages/ folder's files
    expect(page.get_by_role("heading", name="Results").first).to_be_visible(timeout=30_000)
    expect(page.locator("[data-testid='stSidebar']").get_by_text("CACAS Studio").first).to_be_visible(timeout=30_000)
    close_page(page)
