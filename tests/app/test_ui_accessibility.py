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
