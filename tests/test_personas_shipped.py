"""The shipped example personas and the hold-out personas: realistic, varied, and not the generic user."""

from pathlib import Path

import pytest

from cacas import spaces
from cacas.d4a import differs_from_generic, load_d4a, persona_summary
from cacas.paths import PROJECT_ROOT, study_data_dir
from cacas.preferences import load_personas, parse_personas
from script_module import load_script

EXAMPLE = study_data_dir() / "personas" / "example.json"
HOLDOUT = Path(__file__).parent / "data" / "holdout_personas.json"
LEAVE_ME_ALONE = study_data_dir() / "personas" / "example_leave_me_alone.json"
#: Written by someone who had seen design.md and the paper but not our personas or results (README,
#: "Personas written independently"): like a reviewer's, with several "leave me alone" preferences.
INDEPENDENT = Path(__file__).parent / "data" / "independent_personas.json"
#: A second set written the same way in session 8, by a helper who saw design.md and the paper only.
INDEPENDENT_S = Path(__file__).parent / "data" / "independent_personas_s.json"
#: Two more in session 12, by a helper told the format, Table I and the issue's wording only (it
#: could glance at one example file for the format): T01-T08 and U01-U08.
INDEPENDENT_T = Path(__file__).parent / "data" / "independent_personas_t.json"
INDEPENDENT_U = Path(__file__).parent / "data" / "independent_personas_u.json"
#: One more (V01-V08, commit 9a2206d), by a helper told the format, the paper and the issue, to check
#: the issue's targets on personas nobody had tuned for; four "do nothing" preferences.
INDEPENDENT_V = Path(__file__).parent / "data" / "independent_personas_v.json"
FILES = {"example": (EXAMPLE, 8, "P"), "holdout": (HOLDOUT, 6, "H")}


@pytest.fixture(scope="module")
def d4a():
    return load_d4a()


@pytest.mark.parametrize("kind", FILES)
def test_files_load_with_five_preferences_each(kind):
    path, n, prefix = FILES[kind]
    people = load_personas(path)
    assert [p.id for p in people] == [f"{prefix}{i:02d}" for i in range(1, n + 1)]
    for p in people:
        assert len(p.preferences) == 5
        assert all(pref.description for pref in p.preferences)


@pytest.mark.parametrize("kind", FILES)
def test_covered_counts_like_the_papers(kind, d4a, capsys):
    path, _, _ = FILES[kind]
    summary = persona_summary(load_personas(path), d4a)
    with capsys.disabled():
        print(f"\n{kind} personas: covered S1-S4 states per participant (paper: 1564 on average)")
        print(summary.to_string(index=False))
    assert summary.covered_states.between(500, 3000).all()
    assert 900 <= summary.covered_states.mean() <= 2500
    # a mix of broad (a whole activity: 6 scenes x 12 slots x 12 bins) and narrow preferences
    counts = [pref.covered_count() for p in load_personas(path) for pref in p.preferences]
    assert max(counts) >= 6 * 12 * 12 and min(counts) <= 50


@pytest.mark.parametrize("kind", FILES)
def test_most_preferences_are_personal_twists_on_d4a(kind, d4a):
    path, _, _ = FILES[kind]
    prefs = [pref for p in load_personas(path) for pref in p.preferences]
    differing = sum(differs_from_generic(pref, d4a) for pref in prefs)
    assert differing / len(prefs) >= 0.5  # designed: 30/40 example, 21/30 hold-out
    assert differing < len(prefs)  # some agree with the generic user, as on the paper's day 1


@pytest.mark.parametrize("kind", FILES)
def test_variety_and_no_do_nothing(kind):
    path, _, _ = FILES[kind]
    people = load_personas(path)
    prefs = [pref for p in people for pref in p.preferences]
    assert sum(pref.action == "do nothing" for pref in prefs) <= 1
    assert not any("do nothing" in pref.activity for pref in prefs)
    assert len({pref.action for pref in prefs}) >= 10
    assert len({a for pref in prefs for a in pref.activity}) >= 20
    assert any(pref.scene is not None for pref in prefs) and any(pref.scene is None for pref in prefs)
    assert any(pref.hours is not None for pref in prefs) and any(pref.interval is not None for pref in prefs)
    for p in people:  # each participant's preferences span several activities
        assert len({a for pref in p.preferences for a in pref.activity}) >= 4


@pytest.mark.parametrize("path,letter,quiet_ones", [(INDEPENDENT, "R", ["R02", "R03", "R05", "R08"]),
                                                     (INDEPENDENT_S, "S", ["S02", "S04", "S06", "S07", "S08"]),
                                                     (INDEPENDENT_T, "T", ["T02", "T04", "T05"]),
                                                     (INDEPENDENT_U, "U", ["U02", "U04", "U06"]),
                                                     (INDEPENDENT_V, "V", ["V03", "V04", "V06", "V08"])])
def test_independent_personas_load_and_include_leave_me_alone_preferences(path, letter, quiet_ones):
    people = load_personas(path)
    assert [p.id for p in people] == [f"{letter}{i:02d}" for i in range(1, 9)]
    assert all(len(p.preferences) == 5 and all(pref.description for pref in p.preferences) for p in people)
    quiet = [p.id for p in people if any(pref.action == "do nothing" for pref in p.preferences)]
    assert quiet == quiet_ones


def test_example_uses_every_action_but_do_nothing():
    prefs = [pref for p in load_personas(EXAMPLE) for pref in p.preferences]
    assert {pref.action for pref in prefs} == set(spaces.ACTIONS) - {"do nothing"}


def test_holdout_differs_from_example():
    example = {(a, pref.action) for p in load_personas(EXAMPLE) for pref in p.preferences for a in pref.activity}
    holdout = {(a, pref.action) for p in load_personas(HOLDOUT) for pref in p.preferences for a in pref.activity}
    assert len(holdout - example) >= len(holdout) * 0.6


def test_differs_from_generic_examples(d4a):
    stove, twist = parse_personas({"participants": [{"id": "X", "preferences": [
        {"activity": ["use stove"], "action": "remind to turn off"},
        {"activity": ["use blender"], "action": "remind to unplug"}]}]})[0].preferences
    assert not differs_from_generic(stove, d4a)
    assert differs_from_generic(twist, d4a)


def test_readme_table_is_the_computed_one():
    module = load_script("persona_table")
    readme = (PROJECT_ROOT / "README.md").read_text(encoding="utf-8")
    assert module.markdown(EXAMPLE) in readme


def test_leave_me_alone_examples_are_the_examples_plus_one_do_nothing_preference():
    for p, q in zip(load_personas(EXAMPLE), load_personas(LEAVE_ME_ALONE), strict=True):
        assert q.id == "Q" + p.id[1:]
        assert q.preferences[:5] == p.preferences
        quiet = q.preferences[5]
        assert quiet.action == "do nothing" and quiet.description
        # a context of its own: none of the other five preferences covers it
        assert not (quiet.coverage_mask() & p.coverage_mask()).any()
