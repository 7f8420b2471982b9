"""CACAS_BROWSER_SLOWDOWN (conftest.SLOWDOWN) slows every page the browser tests open: the pages come from
conftest.open_page, which slows Chromium's CPU; tests that opened their own pages (restart, narrow, navigation,
tablet waits, figures) ran at full speed. A value that is not a number >= 1 stops the run with one line."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import SLOWDOWN, close_page, cpu_slowdown, open_page

pytestmark = pytest.mark.browser

HERE = Path(__file__).parent

#: milliseconds of a fixed busy loop, by the page's own clock (which throttling does not slow)
BUSY_MS = """() => { const t = performance.now(); let x = 0;
  for (let i = 0; i < 1e7; i++) x += Math.sqrt(i);
  return x > 0 ? performance.now() - t : -1; }"""


#: a page in a context of its own (an option the tests' profile cannot give its pages: conftest.PROFILE_OPTIONS)
OWN_CONTEXT = {"has_touch": False}


@pytest.mark.parametrize("slowed_options, plain_options", [({}, OWN_CONTEXT), (OWN_CONTEXT, {})],
                         ids=["profile page slowed", "own context slowed"])
def test_a_page_opened_with_the_knob_runs_its_javascript_slower(browser, monkeypatch, slowed_options, plain_options):
    """The same loop (~20 ms at full speed) in a page opened with the knob at 16 against one opened without, in
    turns: in one of up to three rounds of seven loops each, the slowed page's fastest loop at least 3 times the plain
    page's fastest (6-9 times measured; 1.0 with the knob not applied). The fastest and up to three rounds because the
    other test process's load only adds to a loop's time and can starve the throttle's own thread for a round.
    Either kind of page open_page opens (one of the tests' profile, one in a context of its own) slowed, beside one
    of the other kind: two pages of the profile can share a renderer process, and so its throttle."""
    monkeypatch.delenv(SLOWDOWN, raising=False)
    plain = open_page(browser, **plain_options)
    monkeypatch.setenv(SLOWDOWN, "16")
    slowed = open_page(browser, **slowed_options)
    try:
        for pg in (plain, slowed):
            pg.set_content("<p>busy</p>")
            pg.evaluate(BUSY_MS)  # compiled once before it is measured
        rounds = []
        for _ in range(3):  # a round where the throttle shows is enough; three without it fail
            times = {pg: [] for pg in (plain, slowed)}
            for _ in range(7):
                for pg in (plain, slowed):
                    times[pg].append(round(pg.evaluate(BUSY_MS)))
            rounds.append((min(times[slowed]) / min(times[plain]), times[plain], times[slowed]))
            if rounds[-1][0] > 3:
                break
        assert rounds[-1][0] > 3, "\n".join(f"ratio {r:.2f}: plain {p}, slowed {s}" for r, p, s in rounds)
    finally:
        close_page(plain)
        close_page(slowed)


@pytest.mark.parametrize("value, rate", [(None, None), ("", None), ("4", 4.0), (" 2.5 ", 2.5), ("1", 1.0)])
def test_the_knob_is_a_rate_or_unset(monkeypatch, value, rate):
    if value is None:
        monkeypatch.delenv(SLOWDOWN, raising=False)
    else:
        monkeypatch.setenv(SLOWDOWN, value)
    assert cpu_slowdown() == rate


@pytest.mark.parametrize("value", ["abc", "0.5", "0", "-1", "inf", "nan", "4x"])
def test_a_bad_knob_is_refused_by_name(monkeypatch, value):
    monkeypatch.setenv(SLOWDOWN, value)
    with pytest.raises(pytest.UsageError) as refused:
        cpu_slowdown()
    assert str(refused.value) == (f"CACAS_BROWSER_SLOWDOWN={value!r} is not a number >= 1: it is how many times the "
                                  f"browser tests slow Chromium's CPU (e.g. 4; 1 does not slow it). Leave it unset for "
                                  f"full speed.")


def test_a_bad_knob_stops_the_run_before_its_first_test_in_one_line(tmp_path):
    """Before, every browser test erred on its own with float()'s "could not convert string to float: 'abc'"
    (and 0.5, 0 or -1 passed for a slowdown while Chromium ran at full speed)."""
    for name in ("conftest.py", "headless.py"):
        (tmp_path / name).write_text((HERE / name).read_text())
    (tmp_path / "test_page.py").write_text("def test_opens(page):\n    page.set_content('<p>x</p>')\n")
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          env={**{k: v for k, v in os.environ.items() if not k.startswith("PYTEST_XDIST")},
                               SLOWDOWN: "abc"})  # a pytest of its own, not one of this run's xdist workers
    assert done.returncode == pytest.ExitCode.USAGE_ERROR, done.stdout[-2000:]
    assert done.stderr.strip().splitlines() == [
        "ERROR: CACAS_BROWSER_SLOWDOWN='abc' is not a number >= 1: it is how many times the browser tests slow "
        "Chromium's CPU (e.g. 4; 1 does not slow it). Leave it unset for full speed."]
    assert "no tests ran" in done.stdout


class _PageOpenings(ast.NodeVisitor):
    """``found``: (function, line) of every ``.new_page(...)`` and ``.new_context(...)`` call of a module."""

    def __init__(self):
        self.where, self.found = ["<module>"], []

    def visit_FunctionDef(self, node):
        self.where.append(node.name)
        self.generic_visit(node)
        self.where.pop()

    visit_AsyncFunctionDef = visit_FunctionDef

    def visit_Call(self, node):
        if isinstance(node.func, ast.Attribute) and node.func.attr in ("new_page", "new_context"):
            self.found.append((self.where[-1], node.lineno))
        self.generic_visit(node)


def test_every_page_the_browser_tests_open_comes_from_open_page():
    """A page opened any other way runs at full speed under the knob (the restart, narrow, navigation, tablet
    waits and figures tests did): conftest.open_page is the one place that opens pages."""
    openings = []
    for path in sorted(HERE.glob("*.py")):
        visitor = _PageOpenings()
        visitor.visit(ast.parse(path.read_text()))
        openings += [(path.name, func, line) for func, line in visitor.found]
    assert {(name, func) for name, func, _ in openings} == {("conftest.py", "open_page")}, openings
