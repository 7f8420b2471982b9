"""Every Python file of the project compiles without a warning: an invalid escape sequence ("\\A" in a CSS string,
app.CONNECTION_STYLE once) is a DeprecationWarning in Python 3.11, a SyntaxWarning from 3.12 and meant to become an
error (PEP 701's notes; the Python 3.12 changelog), and it was printed 1,040 times among the page tests' warnings."""

import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted(p for folder in ("cacas", "pages", "scripts", "tests") for p in (ROOT / folder).rglob("*.py")) + [
    ROOT / "app.py"]


def test_the_sources_are_found():
    names = {p.relative_to(ROOT).as_posix() for p in SOURCES}
    assert {"app.py", "cacas/jobs.py", "pages/session.py", "tests/test_source_files.py"} <= names


def test_every_source_compiles_without_a_warning():
    said = {}
    for path in SOURCES:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            try:
                compile(path.read_text(encoding="utf-8"), str(path), "exec")
            except (SyntaxWarning, DeprecationWarning) as warning:
                said[path.relative_to(ROOT).as_posix()] = str(warning)
    assert said == {}
