"""cacas.recent_activity: the Overview's recent activity in words, a method comparison's runs one line."""

import pandas as pd
import pytest

from cacas.recent_activity import recent_events
from cacas.store import StudyStore
from studies import cough_day, policy_bytes


def test_recent_events_name_the_days_an_adaptation_used(tmp_path):
    store = StudyStore(tmp_path / "s.sqlite")
    store.add_participant("P01")
    for day in (1, 2, 3):
        store.close_day("P01", store.open_day("P01"))
        if day != 2:
            version = store.save_policy("P01", day, "nn", policy_bytes("policy bytes"))
            store.record_adaptation("P01", day, "nn", {}, 1.0, {}, version)
    store.record_adaptation("P01", 2, "orl", {"comparison": True}, 1.0, {})  # a Fig. 4 comparison run
    words = [w for w in recent_events(store, limit=20)["what"]
             if w.startswith(("adaptation", "comparison"))]
    assert words == ["comparison run (ORL) on days 1-2, no policy saved",
                     "adaptation (NN) from days 1-3: version 2", "adaptation (NN) from day 1: version 1"]
    store.close()


def test_a_method_comparisons_runs_are_one_line_of_recent_activity(tmp_path):
    """Walkthrough: one participant-day's comparison gave 8 lines ("comparison run (NN) on day 1, no
    policy saved", ...), and they pushed everything else out of the Overview's recent activity."""
    store = StudyStore(tmp_path / "s.sqlite")
    store.add_participant("P01")
    store.close_day("P01", store.open_day("P01"))
    for method in ("cacas-no-pr", "orl", "nn"):
        store.record_adaptation("P01", 0, method, {"comparison": True}, 1.0, {})
    for method in ("cacas-no-pr", "orl", "nn"):
        store.record_adaptation("P01", 1, method, {"comparison": True}, 1.0, {})
    store.add_participant("P02")
    store.record_adaptation("P02", 0, "nn", {}, 1.0, {})  # another participant's: a line of its own
    words = list(recent_events(store, limit=4)["what"])
    assert words == ["initial policy scored (NN)", "participant added",
                     "comparison runs (CACAS w/o PR, ORL, NN) on day 1, no policy saved",
                     "initial policy scored (CACAS w/o PR, ORL, NN)"]
    store.close()


def _comparison_runs(codes, days, methods=("cacas-no-pr", "orl", "nn")):
    """A Fig. 4 comparison's runs in the order compare_methods records them with one worker per
    participant: each participant's methods one after another (the initial policy scored, then
    after each closed day), the participants' runs taking turns."""
    per = [[(code, day, method) for method in methods for day in [0] + list(days)] for code in codes]
    return [run for turn in zip(*per) for run in turn]


def _record_run(store, code, day, method):
    store.record_adaptation(code, day, method, {"initial": True} if day == 0 else {"comparison": True}, 1.0, {})


def _two_participants_two_days(tmp_path):
    store = StudyStore(tmp_path / "s.sqlite")
    for code in ("P01", "P02"):
        store.add_participant(code)
        for _ in (1, 2):
            store.close_day(code, store.open_day(code))
    return store


def test_an_interleaved_comparison_is_one_line_and_leaves_the_other_events_in_the_list(tmp_path):
    """Walkthrough: after "Compare methods" for 2 participants x 2 days all 10 rows of the Overview's
    recent activity read "comparison run (NN) on days 1-2, no policy saved" (the participants run
    side by side and each method day by day, so no two runs in a row were of one participant-day);
    a day closed and a questionnaire answered meanwhile were pushed out."""
    store = _two_participants_two_days(tmp_path)
    day3 = store.open_day("P01")
    runs = _comparison_runs(("P01", "P02"), (1, 2))
    for i, run in enumerate(runs):
        _record_run(store, *run)
        if i == 5:
            store.close_day("P01", day3)  # the tablet's day ends while the researcher compares
        if i == 11:
            store.record_questionnaire("P02", 8)
    events = recent_events(store, limit=10)
    assert list(events["what"])[:4] == [
        "comparison runs (CACAS w/o PR, ORL, NN) for P01, P02 on days 1-2, no policy saved",
        "initial policy scored (CACAS w/o PR, ORL, NN) for P01, P02",
        "questionnaire: satisfaction 8", "day 3 closed"]
    assert list(events["participant"])[:4] == ["2 participants", "2 participants", "P02", "P01"]
    assert "day 2 closed" in list(events["what"])  # the days before the comparison too
    # one participant's comparison alone: each method's days one after another, still one line
    assert list(recent_events(store, participant="P02", limit=3)["what"]) == [
        "comparison runs (CACAS w/o PR, ORL, NN) on days 1-2, no policy saved",
        "initial policy scored (CACAS w/o PR, ORL, NN)", "questionnaire: satisfaction 8"]
    store.close()


def _comparison_with_p03_meanwhile(tmp_path, meanwhile):
    """P01 and P02's comparison of days 1-2 (``_comparison_runs``), with ``meanwhile(store, day)``
    done for P03 (added, day 1 open) after its 9th run; returns the store."""
    store = _two_participants_two_days(tmp_path)
    store.add_participant("P03")
    day = store.open_day("P03")
    for i, run in enumerate(_comparison_runs(("P01", "P02"), (1, 2))):
        _record_run(store, *run)
        if i == 8:
            meanwhile(store, day)
    return store


def test_a_comparison_never_swallows_a_real_adaptation_made_meanwhile(tmp_path):
    """A participant adapted (policy saved) while a comparison of others runs: its runs, the
    initial policy's score of its day 1 included, stay lines of their own."""
    def adapt_p03(store, day):  # as study_day.adapt_day does it
        store.note_adaptation_started("P03", day, "cacas")
        store.close_day("P03", day)
        store.save_adapted_policy("P03", day, "cacas", policy_bytes("policy bytes"), {}, 1.0, {"preference_accuracy": 0.5},
                                  initial_metrics={"preference_accuracy": 0.25})

    store = _comparison_with_p03_meanwhile(tmp_path, adapt_p03)
    events = recent_events(store, limit=10)
    rows = list(zip(events["participant"], events["what"]))
    assert rows[:6] == [
        ("2 participants", "comparison runs (CACAS w/o PR, ORL, NN) for P01, P02 on days 1-2, no policy saved"),
        ("2 participants", "initial policy scored (CACAS w/o PR, ORL, NN) for P01, P02"),
        ("P03", "adaptation (CACAS) from day 1: version 1"),
        ("P03", "policy version 1 saved and put in force"),
        ("P03", "initial policy scored (CACAS)"),
        ("P03", "day 1 closed")]
    # a second comparison later (days closed since) is a line of its own, not merged into the first
    for code in ("P01", "P02"):
        store.close_day(code, store.open_day(code))
    for run in _comparison_runs(("P01", "P02"), (3,)):
        if run[1]:
            _record_run(store, *run)
    words = list(recent_events(store, limit=10)["what"])
    assert words[:4] == ["comparison runs (CACAS w/o PR, ORL, NN) for P01, P02 on days 1-3, no policy saved",
                         "day 3 closed", "day 3 started", "day 3 closed"]
    assert words.count("comparison runs (CACAS w/o PR, ORL, NN) for P01, P02 on days 1-2, no policy saved") == 1
    store.close()


def test_a_comparison_an_hour_after_another_is_a_line_of_its_own(tmp_path):
    """Runs of one comparison come seconds apart; runs for the same days an hour later (another
    method added, nothing closed since) are another comparison."""
    from cacas.store import validate

    store = _two_participants_two_days(tmp_path)
    for run in _comparison_runs(("P01", "P02"), (1, 2), methods=("orl",)):
        _record_run(store, *run)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(validate, "now", lambda: "2099-01-01T10:00:00.000Z")
        for run in _comparison_runs(("P01", "P02"), (1, 2), methods=("nn",)):
            _record_run(store, *run)
    assert list(recent_events(store, limit=4)["what"]) == [
        "comparison runs (NN) for P01, P02 on days 1-2, no policy saved",
        "initial policy scored (NN) for P01, P02",
        "comparison runs (ORL) for P01, P02 on days 1-2, no policy saved",
        "initial policy scored (ORL) for P01, P02"]
    store.close()


def test_a_comparison_longer_than_the_events_read_at_first_is_said_whole(tmp_path):
    """recent_events reads the newest events 8 a line at first: a comparison with a tablet's
    interactions recorded meanwhile begins before them, and its lines still name every run."""
    def tablet_p03(store, day):
        for _ in range(12):
            store.record_interaction("P03", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                                     robot_action="pain check", response="accept")

    store = _comparison_with_p03_meanwhile(tmp_path, tablet_p03)
    assert list(recent_events(store, limit=3)["what"]) == [
        "comparison runs (CACAS w/o PR, ORL, NN) for P01, P02 on days 1-2, no policy saved",
        "initial policy scored (CACAS w/o PR, ORL, NN) for P01, P02",
        "day 1, interaction 12: robot proposed 'pain check', accepted"]
    store.close()


class _Events:
    """A store whose events are given (the columns of StudyStore.events), for details no store writes."""

    def __init__(self, rows):
        self.frame = pd.DataFrame(rows, columns=["id", "at", "what", "participant", "details"])

    def events(self, participant=None, limit=None, study=None):
        return self.frame.tail(limit).reset_index(drop=True)


def test_recent_events_with_details_that_are_not_a_json_object():
    """Details are parsed once an event; broken or non-object details give the event's kind, said
    unreadable (they read "initial policy scored (None)" and "day None closed"), and merge with nothing."""
    store = _Events([(1, "2026-11-21T09:00:00.000Z", "close_day", "P01", "not json"),
                     (2, "2026-11-21T09:00:01.000Z", "record_adaptation", "P01", "[1, 2]"),
                     (3, "2026-11-21T09:00:02.000Z", "open_day", "P01", '{"day": 2}')])
    assert list(recent_events(store)["what"]) == [
        "day 2 started", "record adaptation (its details are not readable)",
        "close day (its details are not readable)"]


def test_an_adaptations_start_and_an_import_are_said_in_words(tmp_path):
    """Walkthrough (Overview): each day's adaptation took a line "adapt start" (the event's kind, its
    underscore dropped) beside "adaptation (CACAS) from days 1-7: version 7", and an import read
    "import bundle". An adaptation that was recorded needs no line of its start; one that saved nothing
    (the app stopped during it, or it still runs) keeps it, in words."""
    from cacas.export import export_study, import_bundle

    store = StudyStore(tmp_path / "s.sqlite")
    day = cough_day(store)
    store.close_day("P01", day)
    store.note_adaptation_started("P01", day, "cacas")  # a start that saved nothing: the app stopped
    store.note_adaptation_started("P01", day, "bandit")  # the researcher adapts again: recorded
    store.record_adaptation("P01", day, "bandit", {}, 1.0, {}, store.save_policy("P01", day, "bandit", policy_bytes("policy")))
    words = list(recent_events(store, limit=20)["what"])
    assert words[:2] == ["adaptation (Bandit (TS)) from day 1: version 1", "policy version 1 saved and put in force"]
    assert "adaptation (CACAS) from day 1 started" in words
    assert not [w for w in words if "bandit" in w and "started" in w]
    assert all("_" not in w and w != "adapt start" for w in words), words
    export_study(store, tmp_path / "out")
    store.close()
    import_bundle(tmp_path / "out" / "cacas-study.zip", tmp_path / "copy.sqlite")
    with StudyStore(tmp_path / "copy.sqlite") as copy:
        assert recent_events(copy, limit=1)["what"].iloc[0] == "study imported (1 participant, 1 interaction)"
