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


def test_the_differing_preferences_are_counted_against_the_d4a_given(script, tmp_path, capsys):
    """walk3: 'differing from D4A' was always against the shipped D4A; --d4a FILE (as cacas simulate's)
    counts against a lab's own table, and a bad one is one line, exit 2."""
    from cacas import spaces
    from cacas.d4a import D4A, load_d4a, save_d4a

    path = tmp_path / "p.json"
    path.write_text(json.dumps({"participants": [{"id": "P01", "preferences": [
        {"activity": ["cough"], "action": "pain check"}]}]}))
    shipped = load_d4a()
    cough, pain = spaces.ACTIVITIES.index("cough"), spaces.ACTIONS.index("pain check")
    table = shipped.table.copy()
    assert shipped.response(cough, pain) == spaces.ACCEPT
    table[cough, pain] = spaces.REJECT  # a lab whose generic user declines a pain check after a cough
    save_d4a(D4A(table), tmp_path / "ours.csv")
    assert script.main([str(path)]) == 0
    row = capsys.readouterr().out.splitlines()[2]
    assert script.main([str(path), "--d4a", str(tmp_path / "ours.csv")]) == 0
    ours = capsys.readouterr().out.splitlines()[2]
    assert (row, ours) == ("| P01 | 1 | 864 | 0 |", "| P01 | 1 | 864 | 1 |")
    assert script.main([str(path), "--d4a", str(tmp_path / "none.csv")]) == 2
    assert capsys.readouterr().err.strip() == f"persona_table: {tmp_path / 'none.csv'}: no such D4A file"
