"""scripts/persona_table.py: the README's table of a persona file, and one line for a bad file."""

import json

import pytest

from script_module import load_script


@pytest.fixture(scope="module")
def script():
    return load_script("persona_table")


def test_the_table_of_a_persona_file(script, tmp_path, capsys):
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"participants": [{"id": "P01", "preferences": [
        {"activity": ["cough"], "action": "pain check"}]}]}))
    assert script.main([str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("| participant | preferences | covered S1-S4 states |")
    assert lines[2].startswith("| P01 | 1 | ") and lines[-1].startswith("| mean | 1 | ")


def test_a_bad_persona_file_is_one_line_and_exit_2(script, tmp_path, capsys):
    """README review: a bad file printed a traceback and exit 1 where cacas simulate says one line, exit 2."""
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"participants": [{"id": "P01", "preferences": [
        {"activity": ["cough"], "action": "pain check", "hours": [[7, 9]]}]}]}))
    assert script.main([str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("persona_table: ") and "p.json" in err[0] and "P01" in err[0]


def test_the_means_have_two_decimals_at_most(script, tmp_path, capsys):
    """walk3: three participants with 3, 2 and 2 preferences read '| mean | 2.33333 | ...'."""
    cough = {"activity": ["cough"], "action": "pain check"}
    people = [{"id": f"A0{i}", "preferences": [cough, {"activity": ["snore"], "action": "do nothing"}]
               + ([{"activity": ["use stove"], "action": "remind to turn off"}] if i == 1 else [])} for i in (1, 2, 3)]
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"participants": people}))
    assert script.main([str(path)]) == 0
    assert capsys.readouterr().out.splitlines()[-1].startswith("| mean | 2.33 | ")
