"""cacas.preference_form: the Participants page's preference form, its choices to the persona format and
back (S3 slots, S4 bins), its checks, and the table of a participant's preferences."""

import pytest

from cacas import preference_form
from cacas.preferences import Preference


def test_slots_and_hours():
    assert preference_form.slots_to_hours([3, 4, 8, 9]) == [[6, 10], [16, 20]]
    assert preference_form.slots_to_hours([]) is None and preference_form.slots_to_hours(range(12)) is None
    assert preference_form.hours_to_slots([[6, 10], [16, 20]]) == [3, 4, 8, 9]
    assert preference_form.interval_to_bins([0, 25]) == (0, 20)
    assert preference_form.interval_to_bins(None) == (0, 200)


def test_preference_form_and_checks():
    stove = preference_form.preference_from_form(" Turn it off ", ["use stove"], ["kitchen"], [3], (0, 30),
                                             "remind to turn off")
    assert stove == {"description": "Turn it off", "activity": ["use stove"], "scene": ["kitchen"],
                     "hours": [[6, 8]], "interval": [0, 30], "action": "remind to turn off"}
    assert preference_form.preference_from_form("", [], [], [], (0, 200), None) is None
    # an imported preference's task (S5; the form has no field for it) is kept when the form saves it
    assert preference_form.preference_from_form("", ["cough"], [], [], (0, 200), "pain check", ["chitchat"]) == {
        "activity": ["cough"], "task": ["chitchat"], "action": "pain check"}
    chat = preference_form.preference_from_form("", ["use stove"], [], [], (0, 200), "chitchat")
    person, errors, overall = preference_form.check_preferences("P01", [stove, chat], numbers=[1, 4])
    assert person is None and not errors and overall.startswith('preferences 1 ("Turn it off") and 4 both cover')
    bad = preference_form.preference_from_form("", ["use stove"], [], [], (0, 200), None)
    person, errors, overall = preference_form.check_preferences("P01", [stove, bad], numbers=[1, 2])
    assert person is None and list(errors) == [2] and errors[2].startswith("choose an action: ") and overall is None
    # an overlap among the valid ones is said in the same check as another preference's error, named
    # by their numbers on the form (walkthrough: it was said only on the save after the error was mended)
    person, errors, overall = preference_form.check_preferences("P01", [stove, bad, chat], numbers=[1, 2, 3])
    assert person is None and list(errors) == [2] and overall.startswith('preferences 1 ("Turn it off") and 3 both cover')
    person, errors, overall = preference_form.check_preferences("P01", [stove])
    # 1 activity (use stove) x 1 room (kitchen) x 1 time slot (06:00-08:00) x 8 interval bins in
    # 0-30 min (0, 1, 2, 5, 10, 15, 20, 30) = 8 S1-S4 states
    assert person.covered_count() == 8 and not errors and overall is None
    assert preference_form.check_preferences("P01", [])[2].startswith("describe at least one")
    # what is missing, in the form's words; a wrong value gets the library's message naming the field
    nothing = preference_form.preference_from_form("just words", [], [], [], (0, 200), None)
    assert preference_form.check_preferences("P01", [nothing])[1] == {
        1: "choose at least one activity and an action: a preference says which activities lead to which action"}
    typo = {"activity": ["coughing"], "action": "pain check"}
    assert preference_form.check_preferences("P01", [typo])[1][1].startswith("field 'activity': unknown activity 'coughing'")
    # a missing field and contact details in the words: both at once (walkthrough: the words' problem
    # was said only once the activity had been chosen)
    mailed = preference_form.preference_from_form("mail me at a@b.org", [], [], [], (0, 200), "pain check")
    assert preference_form.check_preferences("P01", [mailed])[1] == {
        1: "choose at least one activity: a preference says which activities lead to which action; and field "
           "'description': holds what looks like contact details ('a@b.org'); valid: the participant's words "
           "without e-mail addresses or phone numbers (study data are pseudonymous)"}


def test_a_preferences_hours_read_as_the_tablet_writes_a_time_of_day():
    """The Participants table said "06-12 h", its form "06-08 h", the tablet "06:00-08:00"."""
    from cacas import spaces

    assert preference_form.hours_label([(6, 12), (20, 24)]) == "06:00-12:00, 20:00-24:00"
    assert preference_form.hours_label([(6, 8)]) == spaces.time_slot_label(3)
    assert preference_form.hours_label(None) == "any time"


@pytest.mark.parametrize("hours", [[[6, 10], [16, 20]], [[7, 11]], [[0, 24]], [[22, 24], [0, 2]], [[9, 10]]])
def test_hours_to_slots_counts_slots_as_a_preference_does(hours):
    expected = Preference(activity=("cough",), action="pain check", hours=tuple(map(tuple, hours))).slot_indices()
    assert preference_form.hours_to_slots(hours) == expected
    assert preference_form.hours_to_slots([[7, 11]]) == [4]  # only the slots wholly inside: 08-10
    assert preference_form.hours_to_slots(None) == [] and preference_form.hours_to_slots([]) == []  # any time


def test_a_preferences_interval_reads_as_the_minutes_its_bins_cover():
    """Walkthrough: the preferences table said "5-30" for the interval [5, 30], read as "up to 30 minutes", while
    the preference takes in the S4 bin the tablet offers as "30-60 min" (the file holds bins' lower ends, Table I).
    The table says the minutes covered, in the tablet's words for the bins."""
    from cacas.preferences import Participant

    label = preference_form.preference_interval_label
    assert label((5, 30)) == "5-60 min" and label((0, 30)) == "0-60 min"
    assert label((60, 200)) == "60+ min" and label((0, 0)) == "0-1 min" and label((200, 200)) == "200+ min"
    assert label((7, 45)) == "10-60 min"  # bins 10, 15, 20 and 30 lie in [7, 45]
    assert label(None) == "any" and label((0, 200)) == "any"
    table = preference_form.preferences_table(Participant("P01", (
        Preference(activity=("cough",), action="pain check", interval=(5, 30)),
        Preference(activity=("use stove",), action="remind to turn off"))))
    assert list(table["since last activity"]) == ["5-60 min", "any"]


def test_a_preferences_own_words_holding_field_do_not_cut_its_message():
    """The form's message starts at the field, or at "preferences 1 ... and 2": words of the participant's own that
    held "field '" cut it inside them ('field 'hours' please"), field 'hours': ...'; walk3b)."""
    bad = {"activity": ["cough"], "action": "pain check", "hours": [[7, 9]], "description": "my field 'hours' please"}
    assert preference_form.check_preferences("P01", [bad])[1][1].startswith("field 'hours': [7, 9] is invalid")
    a = {"activity": ["cough"], "action": "pain check", "description": "field 'a' one"}
    b = {"activity": ["cough"], "action": "chitchat", "description": "field 'b' two"}
    assert preference_form.check_preferences("P01", [a, b])[2].startswith(
        "preferences 1 (\"field 'a' one\") and 2 (\"field 'b' two\") both cover ")
