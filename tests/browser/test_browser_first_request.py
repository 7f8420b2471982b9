"""A fresh server whose first request goes straight to a page still runs it through app.py
(Streamlit's old pages/ mode would run the page alone: no sidebar, no participant)."""

WAIT = "[data-testid='stApp'][data-test-script-state='notRunning']"


def test_first_request_to_a_page_gets_the_app_shell(server, browser):
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    page.goto(f"{server}/results")
    page.wait_for_selector(WAIT, timeout=90_000)
    page.wait_for_timeout(500)
    nav = page.locator("[data-testid='stSidebarNav']").inner_text()
    assert "Overview" in nav and "Simulation lab" in nav  # the app's navigation, titled pages
    assert "ui" not in nav.split("\n") and "app" not in nav.split("\n")  # not the pages/ folder's files
    assert page.get_by_role("heading", name="Results").first.is_visible()
    assert page.locator("[data-testid='stSidebar']").get_by_text("CACAS Studio").first.is_visible()
    page.close()
