"""Helpers for the page tests (imported as ``apphelpers``)."""

from __future__ import annotations

from streamlit.testing.v1 import AppTest


def no_exception(at: AppTest) -> None:
    assert not at.exception, [e.value for e in at.exception]


def texts(at: AppTest) -> str:
    """All the markdown, captions, titles and messages of the page as one text."""
    parts = []
    for kind in ("title", "header", "subheader", "markdown", "caption", "info", "warning", "error",
                 "success", "toast"):
        try:
            parts += [str(e.value) for e in getattr(at, kind)]
        except (AttributeError, KeyError):
            pass
    return "\n".join(parts)
