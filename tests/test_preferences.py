import json

import pytest

from cacas import errors, spaces
from cacas import preferences as prefs
from cacas.errors import CacasError

STOVE = {"description": "When I use the stove in the kitchen, remind me to turn it off.",
         "activity": ["use stove", "fry food"], "scene": ["kitchen"], "hours": [[6, 10], [16, 20]],
         "interval": [0, 30], "action": "remind to turn off"}


def doc(*preferences, pid="P01"):
    return {"participants": [{"id": pid, "preferences": list(preferences)}]}


def test_design_example_parses_and_counts():
    (p,) = prefs.parse_personas(doc(STOVE))
    pref = p.preferences[0]
    assert pref.scene == ("kitchen",) and pref.hours == ((6, 10), (16, 20))
    # 2 activities x 1 scene x 4 slots x 8 interval bins (0..30)
    assert pref.covered_count() == 2 * 1 * 4 * 8
    assert p.covered_count() == 64


def test_missing_optional_fields_mean_any():
    (p,) = prefs.parse_personas(doc({"activity": ["cough"], "action": "pain check"}))
    assert p.covered_count() == 6 * 12 * 12


def test_union_counts_overlap_once():
    a = {"activity": ["cough"], "action": "pain check"}
    b = {"activity": ["cough"], "scene": ["bedroom"], "action": "pain check"}
    (p,) = prefs.parse_personas(doc(a, b))
    assert p.covered_count() == 6 * 12 * 12


def test_preferred_action_table():
    (p,) = prefs.parse_personas(doc(STOVE))
    table = p.preferred_action_table()
    from cacas import spaces
    assert table[spaces.activity_index("use stove"), spaces.scene_index("kitchen"), 3, 0, 0] == \
        spaces.action_index("remind to turn off")
    assert table[spaces.activity_index("use stove"), spaces.scene_index("bedroom"), 3, 0, 0] == -1


@pytest.mark.parametrize("change,field,needle", [
    ({"activity": ["stove"]}, "activity", "'stove'"),
    ({"activity": []}, "activity", "non-empty"),
    ({"action": "make tea"}, "action", "'make tea'"),
    ({"scene": ["garage"]}, "scene", "'garage'"),
    ({"hours": [[7, 10]]}, "hours", "even"),
    ({"hours": [[22, 2]]}, "hours", "over midnight"),
    ({"interval": [40, 50]}, "interval", "covering at least one"),
    ({"interval": [30, 0]}, "interval", "min <= max"),
    ({"task": ["bake"]}, "task", "'bake'"),
    ({"colour": "red"}, "colour", "unknown field; valid fields: description, activity"),
    # a near miss is named (walkthrough: 'use scissors' was followed by the 33 names to search)
    ({"activity": ["use scissors"]}, "activity", "unknown activity 'use scissors'; did you mean 'use scissor'? valid: "),
    ({"scene": ["Livingroom"]}, "scene", "unknown scene 'Livingroom'; did you mean 'living room'? valid: bedroom"),
    ({"action": "remind to turn of"}, "action", "; did you mean 'remind to turn off'? valid: do nothing"),
    ({"secne": ["kitchen"]}, "secne", "unknown field; did you mean 'scene'? valid fields: description"),
    ({"hours": [[6.0, 10]]}, "hours", "hours are whole numbers, written without a decimal point: 6, not 6.0"),
    # a range over or up to midnight is said as the ranges that hold it (it said "e.g. [[22, 24], [0, 2]]" for each:
    # [22, 0], "until midnight", then read as 22:00-02:00; [6, 6] was "over midnight")
    ({"hours": [[20, 4]]}, "hours", "[20, 4] is invalid (a range over midnight is two ranges: [[20, 24], [0, 4]], "
                                    "20:00-24:00 and 00:00-04:00)"),
    ({"hours": [[21, 3]]}, "hours", "[21, 3] is invalid (a range over midnight is two ranges, in even hours as the day "
                                    "is in 2-hour slots from midnight: [[20, 24], [0, 4]], 20:00-24:00 and 00:00-04:00, "
                                    "holds 21:00-03:00)"),
    ({"hours": [[22, 0]]}, "hours", "[22, 0] is invalid (midnight as a range's end is 24: [22, 24], 22:00-24:00)"),
    ({"hours": [[24, 2]]}, "hours", "[24, 2] is invalid (midnight as a range's start is 0: [0, 2], 00:00-02:00)"),
    ({"hours": [[6, 6]]}, "hours", "[6, 6] is invalid (its start and end are the same hour, so it holds no time; "
                                   "the whole day is [[0, 24]], or leave 'hours' out)"),
    ({"hours": [[24, 0]]}, "hours", "[24, 0] is invalid (its start and end are the same hour"),
    # a newcomer's persona file (walkthrough): a plural field, one range written bare, odd hours, "7am"
    ({"activities": ["cough"]}, "activities", "unknown field; did you mean 'activity'? valid fields: description"),
    ({"hours": [6, 10]}, "hours", "[6, 10] is invalid (one range is a list of one pair: [[6, 10]], not [6, 10])"),
    ({"hours": [[7, 9]]}, "hours", "[7, 9] is invalid (the day is in 2-hour slots from midnight, so a range "
                                   "starts and ends at an even hour: [6, 10], 06:00-10:00, holds 07:00-09:00)"),
    ({"hours": [["7am", "9am"]]}, "hours", "(hours are numbers of the 24-hour clock, not text: 6 for 06:00, "
                                           "18 for 6 pm); valid: a list of [start, end) pairs"),
    ({"hours": []}, "hours", "must be a list of [start, end) pairs in whole even hours 0-24 with start < end"),
    ({"description": 7}, "description", "must be text (the participant's own words)"),
    ({"action": ["remind to turn off"]}, "action", "must be one action name; valid: do nothing, "),
])
def test_bad_preference_names_participant_preference_field(change, field, needle):
    bad = dict(STOVE, **change)
    with pytest.raises(CacasError) as err:
        prefs.parse_personas(doc({"activity": ["cough"], "action": "pain check"}, bad), "f.json")
    msg = str(err.value)
    assert "f.json" in msg and "participant P01" in msg and "preference 2" in msg
    assert f"field '{field}'" in msg and needle in msg


def test_missing_action_and_activity():
    with pytest.raises(CacasError, match="field 'action': is missing"):
        prefs.parse_personas(doc({"activity": ["cough"]}))
    with pytest.raises(CacasError, match="field 'activity': is missing"):
        prefs.parse_personas(doc({"action": "pain check"}))
    # written as null, it is there: review, "is missing" misled
    with pytest.raises(CacasError, match="field 'activity': is null; it must be a non-empty list of activity names"):
        prefs.parse_personas(doc({"activity": None, "action": "pain check"}))


def test_optional_fields_written_null_mean_any_as_docs_personas_says():
    one = prefs.parse_personas(doc({"activity": ["cough"], "action": "pain check", "scene": None, "hours": None,
                                    "interval": None, "task": None, "description": None}))[0]
    bare = prefs.parse_personas(doc({"activity": ["cough"], "action": "pain check"}))[0]
    assert one.preferences == bare.preferences
    assert prefs.parse_personas(doc({"activity": ["watch TV", "Watch tv"], "action": "chitchat"}))[0] \
        .preferences[0].activity == ("watch TV",)  # listed twice in any case: counts once


def test_overlap_with_different_actions_names_both():
    a = {"activity": ["cough"], "action": "pain check"}
    b = {"activity": ["cough", "sneeze"], "scene": ["bedroom"], "action": "show compassion"}
    with pytest.raises(CacasError) as err:
        prefs.parse_personas(doc(a, b), "f.json")
    msg = str(err.value)
    assert "preferences 1 and 2" in msg and "pain check" in msg and "show compassion" in msg


def test_overlap_names_both_preferences_by_the_start_of_their_words():
    """walk3: the overlap refusal named the two preferences by number only, where the file's other
    refusals quote the start of a preference's words (errors.shortened); one without words: its number."""
    a = {"activity": ["cough"], "action": "pain check",
         "description": "When I cough in the evening, ask whether something hurts"}
    b = {"activity": ["cough", "sneeze"], "scene": ["bedroom"], "action": "show compassion",
         "description": "Be kind when I am ill"}
    with pytest.raises(CacasError) as err:
        prefs.parse_personas(doc(a, b), "f.json")
    assert str(err.value).startswith('f.json, participant P01: preferences 1 ("When I cough in the evening, ask '
                                     'whether...") and 2 ("Be kind when I am ill") both cover ')
    del b["description"]
    with pytest.raises(CacasError, match=r'preferences 1 \("When I cough in the evening, ask whether\.\.\."\) and 2 '
                                         r'both cover'):
        prefs.parse_personas(doc(a, b), "f.json")


def test_overlap_with_disjoint_tasks_is_fine():
    a = {"activity": ["cough"], "task": ["do nothing"], "action": "pain check"}
    b = {"activity": ["cough"], "task": ["chitchat"], "action": "show compassion"}
    (p,) = prefs.parse_personas(doc(a, b))
    assert p.covered_count() == 6 * 12 * 12


def test_a_preference_wholly_inside_another_with_the_same_action_is_redundant():
    (p,) = prefs.parse_personas(doc(
        {"activity": ["cough", "sneeze"], "action": "pain check"},
        {"activity": ["cough"], "scene": ["bedroom"], "hours": [[22, 24]], "action": "pain check"},  # inside 1
        {"activity": ["use stove"], "action": "remind to turn off"},
        {"activity": ["sneeze", "snore"], "action": "pain check"},  # overlaps 1, not inside it
        {"activity": ["cough", "sneeze"], "action": "pain check"},  # identical to 1: the later is the extra
    ))
    assert prefs.redundant_preferences(p.preferences) == [(1, 0), (4, 0)]
    # inside by its states but for other tasks (S5) than the outer one's: not redundant
    narrow_tasks = prefs.parse_preference({"activity": ["cough"], "action": "pain check", "task": ["chitchat"]})
    all_tasks_inner = prefs.parse_preference({"activity": ["cough"], "action": "pain check"})
    assert prefs.redundant_preferences([narrow_tasks, all_tasks_inner]) == [(0, 1)]
    # the same states with another action is a conflict, not a redundancy
    assert prefs.redundant_preferences([all_tasks_inner, prefs.parse_preference(
        {"activity": ["cough"], "action": "chitchat", "task": ["set a timer"]})]) == []


def test_duplicate_ids_and_bad_documents():
    d = {"participants": [doc(STOVE)["participants"][0], doc(STOVE)["participants"][0]]}
    with pytest.raises(CacasError, match="appears twice"):
        prefs.parse_personas(d)
    # codes differing only in letter case are refused as the study database refuses them
    upper, lower = doc(STOVE)["participants"][0], dict(doc(STOVE)["participants"][0])
    lower["id"] = upper["id"].lower()
    with pytest.raises(CacasError) as err:
        prefs.parse_personas({"participants": [upper, lower]}, "people.json")
    assert str(err.value) == (f"people.json, participant {lower['id']}, field 'id': differs from participant "
                              f"{upper['id']} only in letter case; codes must be unique")
    with pytest.raises(CacasError, match="list 'participants'"):
        prefs.parse_personas([1, 2])
    with pytest.raises(CacasError, match="field 'id'"):
        prefs.parse_personas({"participants": [{"preferences": [STOVE]}]})


COUGH = {"activity": ["cough"], "action": "pain check"}


@pytest.mark.parametrize("data, message", [
    ({"participants": []}, "people.json: 'participants' is empty; add at least one participant"),
    ({"participants": ["P01"]}, "people.json: participant 1 must be an object with 'id' and 'preferences'"),
    ({"participants": [{"id": "P01", "name": "Anna", "preferences": [COUGH]}]},
     "people.json, participant P01, field 'name': unknown field; valid fields: id, preferences"),
    ({"participants": [{"id": "P01", "preferences": [COUGH], "preferenses": []}]},
     "people.json, participant P01, field 'preferenses': unknown field; did you mean 'preferences'? valid fields: "
     "id, preferences"),
    ({"participants": [{"id": "P01", "preferences": []}]},
     "people.json, participant P01, field 'preferences': must be a non-empty list of preferences"),
    ({"participants": [{"id": "P01", "preferences": [COUGH, "cough -> pain check"]}]},
     "people.json, participant P01, preference 2: must be an object with fields description, activity, "),
])
def test_a_bad_participant_entry_is_named(data, message):
    with pytest.raises(CacasError) as err:
        prefs.parse_personas(data, "people.json")
    assert str(err.value).startswith(message)


def test_load_file_errors(tmp_path):
    with pytest.raises(CacasError, match="no such persona file"):
        prefs.load_personas(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(CacasError, match="not valid JSON"):
        prefs.load_personas(bad)
    with pytest.raises(CacasError, match=r"^.*: cannot be read \(Is a directory\)$"):
        prefs.load_personas(tmp_path)


def test_save_load_round_trip(tmp_path):
    chat = {"activity": ["watch TV"], "task": ["chitchat", "do nothing"], "action": "show compassion"}
    people = prefs.parse_personas(doc(STOVE, {"activity": ["cough"], "action": "pain check"}, chat))
    path = tmp_path / "p.json"
    prefs.save_personas(people, path)
    assert prefs.load_personas(path) == people
    assert json.loads(path.read_text())["participants"][0]["preferences"][0] == STOVE
    assert json.loads(path.read_text())["participants"][0]["preferences"][2] == chat  # the task (S5) kept


def test_a_save_on_a_full_disk_says_so_and_keeps_the_file(tmp_path, monkeypatch, fail_on_call):
    """Safety round: a fixed '.tmp' name, no fsync, and a bare OSError on a full disk."""
    import os

    people = prefs.parse_personas(doc(STOVE))
    path = tmp_path / "p.json"
    path.write_text("earlier\n")
    monkeypatch.setattr(os, "fsync", fail_on_call(os.fsync, 1))
    with pytest.raises(CacasError, match=rf"^{path}: cannot be written \(No space left on device\); nothing was saved"):
        prefs.save_personas(people, path)
    assert path.read_text() == "earlier\n" and os.listdir(tmp_path) == ["p.json"]


@pytest.mark.parametrize("data, message", [
    (b"\x89PNG\r\n\x1a\n\x00\x00", r"upload.json: cannot be read as UTF-8 text \(it is not text\); valid: a JSON persona "
                                 r"file saved as UTF-8"),
    # a lab in Germany: Windows-1252 (it said only "cannot be read as UTF-8 text; valid: a JSON persona file", which
    # it was), and older Notepad's "Unicode", UTF-16
    ('{"participants": [\n{"id": "DE01", "preferences": [{"description": "Küche"}]}]}'.encode("cp1252"),
     r"^upload.json: cannot be read as UTF-8 text \(byte 0xfc on line 2 is not UTF-8: it was saved in another "
     r"encoding, such as Windows-1252\); valid: a JSON persona file saved as UTF-8$"),
    ('{"participants": []}'.encode("utf-16"), r"^upload.json: cannot be read as UTF-8 text \(it is UTF-16 text, as a "
                                              r"spreadsheet saves 'Unicode text' and older Notepad 'Unicode'\)"),
    ("[" * 100_000 + "]" * 100_000, r"upload.json: nested too deeply to be a persona file"),
    ("{", r"upload.json: not valid JSON \(line 1, column 2"),
    # json kept the last of two without a word: this preference ran as chitchat
    ('{"participants": [{"id": "P01", "preferences": [{"activity": ["cough"], "action": "pain check", '
     '"action": "chitchat"}]}]}', r"upload.json: field 'action' appears twice in one object; write each field once"),
])
def test_persona_json_that_is_not_a_persona_document(data, message):
    with pytest.raises(CacasError, match=message):
        prefs.persona_json(data, "upload.json")


@pytest.mark.parametrize("text, message", [
    # json reads a lone \\ud83d escape as half of a character, which no UTF-8 file can hold: a whole simulation
    # ran, then failed writing its tables (CLI audit); named where it is, in a key too
    ('{"participants": [{"id": "P01", "preferences": [{"activity": ["cough", "sn\\udc00eeze"]}]}]}',
     r"^upload.json, participant P01, preference 1, field 'activity': holds half of a character \('\\udc00' "),
    ('{"participants": [{"id": "P\\ud800", "preferences": []}]}',
     r"^upload.json, participant 1, field 'id': holds half of a character \('\\ud800' "),
    ('{"participants": [{"id": "P01", "preferences": [{}, {"act\\ud83dion": 1}]}]}',
     r"^upload.json, participant P01, preference 2, field 'act\\ud83dion': holds half"),
    ('{"notes": "\\ud83d"}', r"^upload.json, field 'notes': holds half of a character"),
    ('{"participants": [{"id": "P01", "preferences": [{"hours": [[0, 1' + "0" * 4400 + ']]}]}]}',
     r"^upload.json: the number on line 1 has 4401 digits, more than can be read \(4300\); valid: the format"),
])
def test_persona_json_that_no_study_can_read_or_save_is_refused_where_it_is(text, message):
    with pytest.raises(CacasError, match=message):
        prefs.persona_json(text, "upload.json")


def test_persona_json_keeps_a_whole_character_written_as_its_two_escapes():
    doc = prefs.persona_json('{"participants": [{"id": "P01", "description": "tea \\ud83d\\ude00"}]}', "f.json")
    assert doc["participants"][0]["description"] == "tea \U0001f600"


def test_an_unknown_top_level_field_is_refused():
    """A misspelt top-level key passed without a word (participants' and preferences' are refused)."""
    with pytest.raises(CacasError, match="people.json, field 'studdy': unknown field; valid fields: participants"):
        prefs.parse_personas({"participants": [{"id": "P01", "preferences": [STOVE]}], "studdy": "typo"},
                             "people.json")


def test_an_infinite_interval_is_refused():
    doc = json.loads('{"participants": [{"id": "P01", "preferences": [{"activity": ["cough"], '
                     '"action": "pain check", "interval": [0, 1e999]}]}]}')
    with pytest.raises(CacasError, match=r"participant P01.*field 'interval'.*Infinity.*is invalid"):
        prefs.parse_personas(doc, "f.json")


def test_a_description_with_contact_details_is_refused_naming_the_field():
    from cacas.errors import CacasError
    from cacas.preferences import check_private_words, parse_personas

    doc = {"participants": [{"id": "P01", "preferences": [
        {"activity": ["cough"], "action": "pain check"},
        {"description": "When I fall, call my daughter on +44 20 7946 0958", "activity": ["fall down"],
         "action": "call someone for help"}]}]}
    person = parse_personas(doc, "f.json")[0]  # cacas simulate reads the researcher's own file as it is
    with pytest.raises(CacasError, match=r"f\.json, participant P01, preference 2 \(\"When I fall.*\"\), field "
                                         r"'description': holds what looks like contact details \('\+44 20 7946 0958'\)"):
        check_private_words(person, "f.json")
    doc["participants"][0]["preferences"][1]["description"] = "When I fall at 07:30 on 2026-11-21, call my daughter"
    check_private_words(parse_personas(doc, "f.json")[0], "f.json")  # dates and times pass


def test_a_persona_file_saved_with_a_utf8_bom_is_read(tmp_path):
    """Editors such as Notepad save UTF-8 with a byte-order mark; the file is still UTF-8 JSON."""
    text = json.dumps(doc(STOVE))
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    (p,) = prefs.load_personas(path)
    assert p.preferences[0].action == "remind to turn off"
    assert prefs.persona_json(b"\xef\xbb\xbf" + text.encode("utf-8"), "upload.json") == json.loads(text)
    assert prefs.persona_json("\ufeff" + text, "upload.json") == json.loads(text)  # bytes decoded as utf-8


def test_overlap_that_only_a_task_separates_names_the_task():
    """Preference 1 applies during one task (S5), preference 2 to every task: the example state
    includes the task and the advice lists task as a way to separate them."""
    a = {"activity": ["use stove"], "task": ["set a timer"], "action": "remind to turn off"}
    b = {"activity": ["use stove"], "action": "chitchat"}
    with pytest.raises(CacasError) as err:
        prefs.parse_personas(doc(a, b), "f.json")
    msg = str(err.value)
    assert "preferences 1 and 2" in msg
    assert "while the robot's task is 'set a timer'" in msg
    assert "activity, scene, hours, interval or task" in msg


def test_overlap_without_tasks_gives_no_task_in_the_example():
    a = {"activity": ["cough"], "action": "pain check"}
    b = {"activity": ["cough"], "scene": ["bedroom"], "action": "show compassion"}
    with pytest.raises(CacasError) as err:
        prefs.parse_personas(doc(a, b), "f.json")
    assert "task is" not in str(err.value)


def test_the_persona_format_page_shows_a_valid_file_and_every_field():
    """docs/personas.md is the format a researcher reads (the contract lived only outside the
    repository): its example parses, and its table names every field the validator knows."""
    import re
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs" / "personas.md").read_text()
    example = re.search(r"```json\n(.*?)```", page, re.S).group(1)
    assert prefs.parse_personas(prefs.persona_json(example, "docs/personas.md"))[0].covered_count() > 0
    table = set(re.findall(r"^\| `(\w+)` \|", page, re.M))
    assert table == set(prefs.FIELDS) | {"participants", "id", "preferences"}


def test_a_persona_file_says_every_problem_in_one_line():
    """walk3: a file with three mistakes took three runs, one refusal each. Every participant's
    problems and each invalid preference's first are said at once, numbered, in one line (the CLI's
    contract); a page lists them one a line. The valid names of a second unknown activity refer to
    the first's list instead of writing 33 names again."""
    data = {"participants": [
        {"id": "P01", "preferences": [{"activity": ["coughing"], "action": "pain check"},
                                      COUGH,
                                      {"activity": ["snorring"], "action": "dance"}]},
        {"id": "P02", "preferences": [dict(COUGH, hours=[6, 10])]},
        {"id": "P03", "preferences": [COUGH]},
        {"id": "P01", "preferences": [dict(COUGH, activity=["cutting food"])]},
    ]}
    with pytest.raises(CacasError) as err:
        prefs.parse_personas(data, "people.json")
    said = str(err.value)
    assert "\n" not in said
    assert said.startswith("people.json: 5 problems, each to mend: [1] participant P01, preference 1, field "
                           "'activity': unknown activity 'coughing'; did you mean 'cough'? valid: cough, cry, ")
    assert ("[2] participant P01, preference 3, field 'action': unknown action 'dance'; valid: do nothing, " in said)
    assert ("[3] participant P02, preference 1, field 'hours': [6, 10] is invalid (one range is a list of one "
            "pair: [[6, 10]], not [6, 10]); valid: " in said)
    assert ("[4] participant P01, preference 1, field 'activity': unknown activity 'cutting food'; did you mean "
            "'cut food'? valid: as in problem 1 [5] participant P01, field 'id': appears twice; codes must be "
            "unique") in said
    assert said.count("flush toilet") == 1 and "P03" not in said and "people.json" not in said[5:]
    assert errors.one_a_line(err.value).splitlines()[:4] == [
        "people.json: 5 problems, each to mend:", "",
        "1. participant P01, preference 1, field 'activity': unknown activity 'coughing'; did you mean 'cough'? "
        "valid: cough, cry, clear throat, sneeze, sniff, fall down, burp, yawn, snore, drink water, drink milk, "
        "drink soup, eat apple, eat noodle, eat chips, wash hands, wash clothes, wash dishes, use scissor, use "
        "blender, use stove, use hair dryer, use microwave, use fan, watch TV, type keyboard, cut food, fry food, "
        "pour water into glass, shave, brush teeth, flush toilet, do nothing",
        "2. participant P01, preference 3, field 'action': unknown action 'dance'; valid: do nothing, show "
        "compassion, chitchat, remind to take medicine, ask to offer help, call someone for help, set a timer, "
        "pain check, confirm sound, record sound, remind to turn off, remind to be careful, remind to put back, "
        "remind to unplug"]


def test_one_problem_is_said_as_before_and_overlaps_wait_for_valid_preferences():
    """One problem keeps its own message (no count, no number); two preferences that overlap with
    different actions are judged only when every preference of the participant reads."""
    overlap = [COUGH, dict(COUGH, action="show compassion")]
    with pytest.raises(CacasError) as err:
        prefs.parse_personas({"participants": [{"id": "P01", "preferences": [*overlap, {"activity": ["x"]}]}]}, "a.json")
    assert str(err.value) == ("a.json, participant P01, preference 3, field 'action': is missing; valid: one of "
                              + ", ".join(spaces.ACTIONS))
    assert errors.one_a_line(err.value) == str(err.value)
    with pytest.raises(CacasError, match=r"^a\.json, participant P01: preferences 1 and 2 both cover"):
        prefs.parse_personas({"participants": [{"id": "P01", "preferences": overlap}]}, "a.json")


def test_a_file_of_many_problems_writes_the_first_eight_and_counts_the_rest():
    data = {"participants": [{"id": f"P{i:02d}", "preferences": [dict(COUGH, action="dance")]} for i in range(1, 12)]}
    with pytest.raises(errors.Problems) as err:
        prefs.parse_personas(data, "many.json")
    said = str(err.value)
    assert said.startswith("many.json: 11 problems, each to mend: [1] participant P01, preference 1, field 'action'")
    assert "[8] participant P08" in said and "P09" not in said and said.endswith("; valid: as in problem 1 [and 3 more]")
    listed = errors.one_a_line(err.value).splitlines()
    assert len(listed) == 2 + 11 and listed[-1].startswith("11. participant P11, preference 1, field 'action'")
