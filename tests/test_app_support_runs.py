"""app_support: simulated runs saved all or nothing and read back in one call, and the small
helpers the pages share (slots of a preference's hours, short timestamps, answers in words)."""


import pandas as pd
import pytest

from cacas import app_support, records
from cacas.errors import CacasError
from cacas.preferences import Preference
from cacas.store import files


def _daily(rate=0.3):
    return pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "success_rate": [rate],
                         "preference_accuracy": [0.2], "cumulative_feedback": [10], "interactions": [15]})


def _by_pref():
    return pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "preference": [1],
                         "accuracy": [0.25]})


@pytest.mark.parametrize("hours", [[[6, 10], [16, 20]], [[7, 11]], [[0, 24]], [[22, 24], [0, 2]], [[9, 10]]])
def test_hours_to_slots_counts_slots_as_a_preference_does(hours):
    expected = Preference(activity=("cough",), action="pain check", hours=tuple(map(tuple, hours))).slot_indices()
    assert app_support.hours_to_slots(hours) == expected
    assert app_support.hours_to_slots([[7, 11]]) == [4]  # only the slots wholly inside: 08-10
    assert app_support.hours_to_slots(None) == [] and app_support.hours_to_slots([]) == []  # any time


def test_a_studys_download_names_have_no_spaces():
    assert app_support.study_file_name("cacas-study", "pilot walkB", ".zip") == "cacas-study-pilot_walkb.zip"
    assert app_support.study_file_name("personas", "default", ".json") == "personas-default.json"
    assert app_support.study_file_name("personas", "?? ", ".json") == "personas-study.json"


def test_short_time_and_answers_in_words():
    assert app_support.short_time("2026-11-21T09:47:34.123Z") == "2026-11-21 09:47 UTC"
    assert app_support.short_time("?") == "?"
    assert records.RESPONSE_WORDS == {"accept": "accepted", "reject": "rejected", "others": "no response"}
    inter = pd.DataFrame({"day": [1, 1], "index": [0, 1], "time_slot": [3, 3], "interval": [5, 200],
                          "activity": ["cough"] * 2,
                          "scene": ["bedroom"] * 2, "type": [records.ROBOT_INITIATED] * 2,
                          "robot_action": ["pain check", "chitchat"], "response": ["others", "reject"],
                          "user_action": ["", ""]})
    assert list(app_support.interactions_view(inter)["answer"]) == ["no response", "rejected"]
    assert list(app_support.interactions_view(inter)["since last activity"]) == ["5-10 min", "200+ min"]


def test_load_run_reads_what_save_run_wrote(tmp_path):
    root = tmp_path / "runs"
    inter = pd.DataFrame({"participant": ["P01"], "day": [1]})
    folder = app_support.save_run(root, "run1", _daily(), inter, {"seed": 4, "methods": ["cacas"]}, _by_pref())
    run = app_support.load_run(folder)
    assert run.name == "run1" and run.settings == {"seed": 4, "methods": ["cacas"]}
    assert run.daily.equals(_daily()) and run.interactions.equals(inter) and run.by_preference.equals(_by_pref())
    assert list(run.tables) == ["daily", "interactions", "by_preference"]
    assert sorted(p.name for p in folder.iterdir()) == ["by_preference.csv", "daily.csv", "interactions.csv",
                                                        "settings.json"]  # no temporary file left
    # the same name saved again without by_preference: the earlier one is not left behind as this run's
    app_support.save_run(root, "run1", _daily(0.6), inter, {})
    run = app_support.load_run(folder)
    assert run.by_preference is None and "by_preference" not in run.tables and run.settings == {}
    assert run.daily["success_rate"].tolist() == [0.6]


def test_load_run_names_what_is_missing_or_unreadable(tmp_path):
    with pytest.raises(CacasError, match="no such run folder"):
        app_support.load_run(tmp_path / "absent")
    folder = app_support.save_run(tmp_path, "r", _daily(), pd.DataFrame({"participant": ["P01"]}), {})
    (folder / "settings.json").write_text("{not json")
    with pytest.raises(CacasError, match=r"settings\.json: not readable JSON"):
        app_support.load_run(folder)
    (folder / "settings.json").write_text("[1, 2]")
    with pytest.raises(CacasError, match="not a JSON object"):
        app_support.load_run(folder)
    (folder / "interactions.csv").unlink()
    with pytest.raises(CacasError, match="no interactions.csv; not a complete run"):
        app_support.load_run(folder)


def test_a_failure_part_way_leaves_the_earlier_run_whole(tmp_path, monkeypatch, fail_on_call):
    root = tmp_path / "runs"
    inter = pd.DataFrame({"participant": ["P01"], "day": [1]})
    folder = app_support.save_run(root, "run1", _daily(0.3), inter, {"seed": 1}, _by_pref())
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    opened = fail_on_call(open, 2)
    monkeypatch.setattr(files, "open", opened, raising=False)
    with pytest.raises(CacasError, match="No space left on device"):
        app_support.save_run(root, "run1", _daily(0.9), inter.assign(day=2), {"seed": 2}, _by_pref())
    monkeypatch.undo()
    assert len(opened.calls) == 2  # the failure came part-way through the files
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before  # old run whole, no temporary file
    assert app_support.load_run(folder).settings == {"seed": 1}
    assert app_support.list_runs(root) == ["run1"]


def test_a_simulation_choice_is_checked_before_a_run(tmp_path):
    with pytest.raises(CacasError, match="choose at least one simulated participant"):
        app_support.run_simulation([], tmp_path, methods=("cacas",))
    with pytest.raises(CacasError, match="no method given"):
        app_support.check_simulation(["P01"], [])
    with pytest.raises(CacasError, match="unknown method 'dqn'"):
        app_support.check_simulation(["P01"], ["cacas", "dqn"])
    assert app_support.check_simulation(["P01"], ["NN", "cacas"]) == ("nn", "cacas")
    with pytest.raises(CacasError, match="method 'nn' is listed twice"):  # likely a typo for another method
        app_support.check_simulation(["P01"], ["NN", "cacas", "nn"])
    assert not tmp_path.joinpath("runs").exists() and list(tmp_path.iterdir()) == []


def test_every_problem_of_the_simulation_form_is_named_at_once():
    """The form is filled in at once: one refusal names each problem, one a line, in the form's
    order, by the lab's labels (the command line still stops at the first: one line)."""
    with pytest.raises(CacasError) as refused:
        app_support.check_simulation([], ["cacas", "dqn"], days=0, interactions=15, seed=-1,
                                     no_response_rate=1.0)
    assert str(refused.value).splitlines() == [
        "choose at least one simulated participant",
        "unknown method 'dqn'; valid: cacas, cacas-no-pr, orl, nn, bandit, sac-user-data",
        "Days 0 is invalid; valid: a whole number of days from 1 to 365",
        "Seed -1 is invalid; valid: a whole number from 0 to 4294967295",
        "No-response rate 1.0 is invalid; valid: 0 <= rate < 1"]
    from cacas.experiment import check_study_arguments
    with pytest.raises(CacasError) as first:
        check_study_arguments(0, 15, 1.0, seed=-1)
    assert str(first.value) == "--days 0 is invalid; valid: a whole number of days from 1 to 365"


def test_a_run_is_named_by_what_it_compared_not_only_its_time(tmp_path):
    daily = pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "success_rate": [0.3],
                          "preference_accuracy": [0.2], "cumulative_feedback": [8], "interactions": [15]})
    inter = pd.DataFrame({"participant": ["P01"]})
    app_support.save_run(tmp_path, "20261126-081502-seed0-8p-7d", daily, inter,
                         {"participants": [f"P0{i}" for i in range(1, 9)], "days": 7, "interactions": 15,
                          "methods": ["cacas", "nn"], "seed": 0, "loop": "first",
                          "personas": "study_data/personas/example.json"})
    app_support.save_run(tmp_path, "20261126-081733-seed3-1p-1d", daily, inter,
                         {"participants": ["P01"], "days": 1, "methods": ["bandit"], "seed": 3, "loop": "each",
                          "ask_after_reject": 0.5, "personas": "uploaded file mine.json (sha256 0123456789ab)"})
    app_support.save_run(tmp_path, "20261126-081734-seed3-1p-1d", daily, inter,
                         {"participants": ["P01"], "days": 1, "methods": ["bandit"], "seed": 3,
                          "personas": "the described preferences of the participants of study 'pilot'"})
    app_support.save_run(tmp_path, "from-the-command-line", daily, inter, {})
    (tmp_path / "from-the-command-line" / "settings.json").unlink()
    app_support.save_run(tmp_path, "broken", daily, inter, {})
    (tmp_path / "broken" / "settings.json").write_text("{not json")
    assert app_support.run_label(tmp_path, "20261126-081502-seed0-8p-7d") == \
        "26 Nov 2026 08:15:02 · 8 participants (example.json) · 7 days · 15 a day · CACAS, NN · seed 0"
    assert app_support.run_label(tmp_path, "20261126-081733-seed3-1p-1d") == (
        "26 Nov 2026 08:17:33 · 1 participant (mine.json) · 1 day · Bandit (TS) · seed 3 · asks after 50% of "
        "rejections · each in its own loop")
    assert app_support.run_label(tmp_path, "20261126-081734-seed3-1p-1d") == \
        "26 Nov 2026 08:17:34 · 1 participant (study pilot) · 1 day · Bandit (TS) · seed 3"
    assert app_support.run_label(tmp_path, "from-the-command-line") == "from-the-command-line"
    assert app_support.run_label(tmp_path, "broken") == "broken"  # the picker still lists it; opening it names the file
    with pytest.raises(CacasError, match="settings.json: not readable JSON"):
        app_support.load_run(tmp_path / "broken")
    assert [app_support.run_days(d) for d in (1, 7, None)] == ["1 day", "7 days", "? days"]


def test_a_runs_caption_leaves_out_what_the_run_did_not_keep():
    full = {"participants": ["P01", "P02"], "days": 7, "interactions": 15, "methods": ["cacas", "nn"], "seed": 0,
            "ask_after_reject": 0.25, "loop": "each", "personas": "study_data/personas/example.json"}
    assert app_support.run_caption(full) == (
        "2 participants · 7 days · 15 interactions a day · methods cacas, nn · seed 0 · asks after 25% of "
        "rejections · each method in its own closed loop · personas: study_data/personas/example.json")
    assert app_support.run_caption({"participants": ["P01"], "days": 1, "seed": 3}) == \
        "1 participant · 1 day · seed 3"  # no "None interactions a day"
    assert app_support.run_label("/nowhere", "x") == "x"


def test_versions_table_gives_each_version_its_run_accuracy(tmp_path):
    from cacas.store import StudyStore

    store = StudyStore(tmp_path / "s.sqlite")
    store.add_participant("P01")
    for day in (1, 2):
        store.close_day("P01", store.open_day("P01"))
        version = store.save_policy("P01", day, "cacas", f"policy {day}".encode())
        store.record_adaptation("P01", day, "cacas", {}, 1.0, {"preference_accuracy": 0.5 + 0.25 * day,
                                                               "preferences_version": day}, version)
    store.record_adaptation("P01", 2, "nn", {"comparison": True}, 1.0, {"preference_accuracy": 0.1})  # no version
    table = app_support.versions_table(store.policy_versions("P01"), store.adaptations_frame("P01"))
    assert list(table["version"]) == [1, 2] and list(table["adapted from"]) == ["day 1", "days 1-2"]
    assert list(table["preference accuracy"]) == [75.0, 100.0]  # the comparison run is no version's
    assert list(table["in force"]) == ["", "yes"] and all(len(h) == 12 for h in table["sha256"])
    assert list(table["scored on"]) == ["version 1", "version 2"]  # the described preferences' versions
    assert list(app_support.versions_table([], store.adaptations_frame("P01")).columns)[0] == "version"
    store.record_adaptation("P01", 0, "cacas", {"initial": True}, 0.0, {"preference_accuracy": 0.25})
    runs = app_support.runs_table(store.adaptations_frame("P01"))
    assert list(runs.columns) == ["day", "what", "duration (s)", "preference accuracy", "scored on",
                                  "policy version", "saved"]
    assert list(runs["scored on"]) == ["version 1", "version 2", "", ""]  # older runs name none
    assert list(runs["what"]) == ["cacas", "cacas", "nn (comparison)", "initial policy, scored for Fig. 4"]
    assert list(runs["preference accuracy"]) == [75.0, 100.0, 10.0, 25.0]
    assert list(runs["policy version"]) == ["1", "2", "", ""]  # a comparison run saves no policy (read "None")
    assert all(c.endswith(" UTC") and len(c) == 20 for c in runs["saved"])  # "YYYY-MM-DD HH:MM UTC"
    store.close()


def test_the_lab_runs_participants_side_by_side_with_the_same_tables(tmp_path, monkeypatch):
    """run_simulation (the Simulation lab) uses a worker process per core by default, as `cacas
    simulate`; the saved tables are those of one process."""
    import cacas.experiment
    from cacas.preferences import load_personas
    from cacas.paths import study_data_dir

    people = load_personas(study_data_dir() / "personas" / "example.json")[:2]
    used = []
    real = cacas.experiment.simulate_study
    monkeypatch.setattr(cacas.experiment, "simulate_study", lambda *a, **k: used.append(k["jobs"]) or real(*a, **k))
    monkeypatch.setattr(cacas.experiment, "default_jobs", lambda: 2)
    side_by_side = app_support.run_simulation(people, tmp_path / "a", days=2, interactions=4, methods=("nn",))
    one = app_support.run_simulation(people, tmp_path / "b", days=2, interactions=4, methods=("nn",), jobs=1)
    assert used == [2, 1]
    for name in ("daily.csv", "interactions.csv", "by_preference.csv"):
        assert (side_by_side / name).read_bytes() == (one / name).read_bytes()


def test_a_loaded_daily_csv_keeps_its_counts_whole(tmp_path):
    # the Fig. 4 protocol: a baseline's row has no successes of its own (an empty cell)
    path = tmp_path / "daily.csv"
    path.write_text("participant,method,day,success_rate,preference_accuracy,cumulative_feedback,interactions,"
                    "successes\nP01,cacas,1,0.25,0.5,4,4,1\nP01,nn,1,,0.4,4,4,\n")
    daily = app_support.load_daily(path)
    assert str(daily["successes"].dtype) == "Int64" and daily["successes"].tolist()[0] == 1
    assert records.csv_bytes(daily).splitlines()[1].endswith(b",4,4,1")


def test_an_uploaded_persona_file_is_checked_as_an_import_is_and_its_source_kept():
    import json

    good = {"participants": [{"id": "P01", "preferences": [{"activity": ["cough"], "action": "pain check"}]}]}
    data = json.dumps(good).encode()
    assert [p.id for p in app_support.uploaded_personas("mine.json", data)] == ["P01"]
    named = json.loads(data)
    named["participants"][0]["id"] = "John Smith"
    with pytest.raises(CacasError, match=r"mine\.json: participant code 'John Smith' is invalid; valid: a "
                                         r"pseudonymous code"):
        app_support.uploaded_personas("mine.json", json.dumps(named).encode())
    mailed = json.loads(data)
    mailed["participants"][0]["preferences"][0]["description"] = "if I cough, mail john.smith@example.org"
    with pytest.raises(CacasError, match=r"mine\.json, participant P01, preference 1 .*field 'description': holds what looks "
                                         r"like contact details \('john\.smith@example\.org'\)"):
        app_support.uploaded_personas("mine.json", json.dumps(mailed).encode())
    source = app_support.persona_source("Upload a persona file", "mine.json", data)
    assert source.startswith("uploaded file mine.json (sha256 ") and len(source.split("sha256 ")[1]) == 13
    assert source != app_support.persona_source("Upload a persona file", "mine.json", json.dumps(named).encode())
    assert app_support.persona_source("x", "example.json") == "study_data/personas/example.json"
    assert app_support.persona_source("x", study="pilot") == "the described preferences of the participants of study 'pilot'"


def test_the_results_page_says_what_a_roll_back_changes(tmp_path):
    from cacas.store import StudyStore

    with StudyStore(tmp_path / "s.sqlite") as store:
        for code in ("P01", "P02"):
            store.add_participant(code)
            store.close_day(code, store.open_day(code))
            store.save_policy(code, 1, "cacas", b"policy after day 1")
        assert app_support.rolled_back_note(store.events()) == ""
        store.set_active_policy("P02", None)  # back to the initial policy
        assert app_support.rolled_back_note(store.events()) == (
            " After a roll-back (P02), a day uses the version put in force instead (a day rolled back in its middle, "
            "the version most of its interactions had): Fig. 4 scores that version for CACAS, while the baselines "
            "keep their runs adapted from days 1..d-1.")
