"""The browser tests' Chromium (conftest.Chromium): pages of one profile whose cache serves Streamlit's frontend from
one page to the next, each test's traces undone after it, and this test process's apps on one port while it is free
(the cache is keyed by address, port included)."""

from __future__ import annotations

import socket

import pytest
from conftest import app_port, close_page, open_page

pytestmark = pytest.mark.browser

#: the Streamlit scripts a page loaded, with the bytes each took over the network (0: from the browser's cache)
SCRIPTS_JS = """() => performance.getEntriesByType('resource')
  .filter(e => /[/]static[/]js[/].*[.]js$/.test(e.name))
  .map(e => [e.name, e.transferSize, e.decodedBodySize])"""


def test_a_second_page_of_the_profile_takes_streamlits_scripts_from_the_cache(server, browser):
    from test_browser_mini_study import goto

    first = open_page(browser, viewport={"width": 1280, "height": 800})
    goto(first, server)
    close_page(first)
    second = open_page(browser, viewport={"width": 1280, "height": 800})
    goto(second, server)
    scripts = second.evaluate(SCRIPTS_JS)
    close_page(second)
    assert scripts, "the page loaded no Streamlit script"
    assert all(sent == 0 and size > 0 for _, sent, size in scripts), scripts  # none over the network again


def test_a_page_needing_a_context_of_its_own_gets_one_and_closes_with_it(browser):
    phone = open_page(browser, viewport={"width": 390, "height": 844}, is_mobile=True, has_touch=True)
    laptop = open_page(browser, viewport={"width": 1000, "height": 700})
    assert phone.context is not browser.profile and laptop.context is browser.profile
    # (a mobile page without a viewport tag is laid out 980 px wide: the screen is the phone's)
    assert phone.evaluate("() => [screen.width, matchMedia('(pointer: coarse)').matches]") == [390, True]
    assert laptop.evaluate("() => [innerWidth, matchMedia('(pointer: coarse)').matches]") == [1000, False]
    refusing = open_page(browser, accept_downloads=False)  # the profile accepts downloads
    assert refusing.context is not browser.profile
    close_page(refusing)
    beside = open_page(laptop)  # in its context, closed with it
    assert beside.context is browser.profile
    context = phone.context
    close_page(phone)
    close_page(laptop)
    assert laptop.is_closed() and beside.is_closed() and not context.pages


def test_what_a_test_leaves_in_the_profile_is_undone(server, browser):
    """forget (run after each test that used the browser) closes the pages the test opened, not one open before it,
    and clears the cookies and the served apps' local storage (Streamlit keeps the sidebar's width and the theme
    there), so that no test starts from what another left."""
    from test_browser_mini_study import goto

    before = open_page(browser)  # as a module's page, open before the test
    page = open_page(browser)
    goto(page, server)
    page.evaluate("() => { localStorage.setItem('sidebarWidth', '400'); document.cookie = 'left=1; path=/'; }")
    own = open_page(browser, has_touch=True)
    browser.forget(kept={before})
    assert page.is_closed() and own.is_closed() and not before.is_closed()
    assert browser.profile.cookies() == []
    page = open_page(browser)
    goto(page, server)
    assert page.evaluate("() => [localStorage.getItem('sidebarWidth'), document.cookie.includes('left=1')]") == [
        None, False]
    close_page(page)
    close_page(before)


def test_the_apps_take_one_port_while_it_is_free_and_another_while_it_is_taken(monkeypatch):
    import conftest
    from headless import free_port

    port = free_port()
    monkeypatch.setattr(conftest, "_APP_PORT", [port])  # this module's app holds the test process's own now
    assert app_port() == port
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", port))
        taken.listen()
        other = app_port()
        assert other != port
    assert app_port() == port
