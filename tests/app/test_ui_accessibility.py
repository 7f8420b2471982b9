"""What a screen reader reads of the pages' own pieces (accessibility walkthrough)."""

from __future__ import annotations

import ast
from pathlib import Path

from pages import ui

ROOT = Path(__file__).resolve().parents[2]


def test_an_icon_in_text_is_read_in_words_or_skipped():
    assert ui.icon("smart_toy") == '<span aria-hidden="true">:material/smart_toy:</span>'
    assert ui.icon("check", "as chosen") == ('<span role="img" aria-label="as chosen"><span aria-hidden="true">'
                                             ':material/check:</span></span>')
    assert 'aria-label="a &quot;b&quot; &lt;c&gt;"' in ui.icon("help", 'a "b" <c>')


def test_every_chart_of_the_pages_is_drawn_with_a_description():
    """ui.chart gives st.plotly_chart its alt (cacas.plots.describe); a chart drawn with st.plotly_chart itself
    has none, and a screen reader read its tick labels run together."""
    bare = []
    for path in [ROOT / "app.py", *sorted((ROOT / "pages").glob("*.py"))]:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "plotly_chart":
                if not any(isinstance(k, ast.keyword) and k.arg == "alt" for k in node.keywords):
                    bare.append(f"{path.name}:{node.lineno}")
    assert bare == []


def test_a_notes_icon_is_skipped_and_its_words_stay_words(monkeypatch):
    """ui.noted: ":material/info: ..." in a caption was read "info icon ..." before each such note; the icon is now
    hidden from a screen reader. The HTML this allows is the icon's only: a file name or typed words holding "<"
    stay words."""
    import streamlit as st

    drawn = []
    monkeypatch.setattr(st, "caption", lambda text, **kw: drawn.append((text, kw)))
    ui.noted("attach_file", "<script>x</script> & mine.json, uploaded before")
    assert drawn == [('<span aria-hidden="true">:material/attach_file:</span> &lt;script&gt;x&lt;/script&gt; &amp; '
                      "mine.json, uploaded before", {"unsafe_allow_html": True})]


def test_no_page_writes_an_icon_into_its_text_for_a_screen_reader_to_read_out():
    """A ":material/...:" at the start of a caption's or a markdown's text (not an icon= argument, which Streamlit
    hides) is read as its ligature: such notes go through ui.noted."""
    import re

    spoken = re.compile(r"""\b(?:caption|markdown)\(f?["']:material/""")
    found = [f"{path.name}:{n}" for path in [ROOT / "app.py", *sorted((ROOT / "pages").glob("*.py"))]
             for n, line in enumerate(path.read_text().splitlines(), 1) if spoken.search(line)]
    assert found == []
