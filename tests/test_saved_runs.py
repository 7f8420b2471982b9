"""saved_runs: simulated runs saved all or nothing and read back in one call, named in words, made
for a background job (the Results page's uploads: test_uploaded_run)."""


import pandas as pd
import pytest

from cacas import records, saved_runs, uploaded_run
from cacas.errors import CacasError
from cacas.store import files


def _daily(rate=0.3):
    return pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "success_rate": [rate],
                         "preference_accuracy": [0.2], "cumulative_feedback": [10], "interactions": [15]})


def _by_pref():
    return pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "preference": [1],
                         "accuracy": [0.25]})


def test_load_run_reads_what_save_run_wrote(tmp_path):
    root = tmp_path / "runs"
    inter = pd.DataFrame({"participant": ["P01"], "day": [1]})
    folder = saved_runs.save_run(root, "run1", _daily(), inter, {"seed": 4, "methods": ["cacas"]}, _by_pref())
    run = saved_runs.load_run(folder)
    assert run.name == "run1" and run.settings == {"seed": 4, "methods": ["cacas"]}
    assert run.daily.equals(_daily()) and run.interactions.equals(inter) and run.by_preference.equals(_by_pref())
    assert list(run.tables) == ["daily", "interactions", "by_preference"]
    assert sorted(p.name for p in folder.iterdir()) == ["by_preference.csv", "checksums.sha256", "daily.csv",
                                                        "interactions.csv", "settings.json"]  # no temporary file left
    # the checksums list the run's files, as cacas simulate --out's do (the Results upload checks them)
    assert sorted(files.parse_checksums((folder / files.CHECKSUMS).read_bytes())) == [
        "by_preference.csv", "daily.csv", "interactions.csv", "settings.json"]
    # the same name saved again without by_preference: the earlier one is not left behind as this run's
    saved_runs.save_run(root, "run1", _daily(0.6), inter, {})
    run = saved_runs.load_run(folder)
    assert run.by_preference is None and "by_preference" not in run.tables and run.settings == {}
    assert run.daily["success_rate"].tolist() == [0.6]
    assert not (folder / "by_preference.csv").exists()
    assert "by_preference.csv" not in files.parse_checksums((folder / files.CHECKSUMS).read_bytes())


def test_a_runs_zip_holds_its_folders_files_under_its_name_the_same_each_time(tmp_path):
    import io
    import time
    import zipfile

    inter = pd.DataFrame({"participant": ["P01"], "day": [1]})
    folder = saved_runs.save_run(tmp_path, "run1", _daily(), inter, {"seed": 1}, _by_pref())
    (folder / "notes.txt").write_text("mine")  # a researcher's file beside the run's is not the run's
    data = saved_runs.run_zip(folder)
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        assert zf.namelist() == [f"run1/{n}" for n in ("daily.csv", "interactions.csv", "by_preference.csv",
                                                       "settings.json", "checksums.sha256")]
        assert zf.read("run1/daily.csv") == (folder / "daily.csv").read_bytes()
    time.sleep(1.1)
    assert saved_runs.run_zip(folder) == data  # no time stamps of the moment in it
    (folder / "daily.csv").write_bytes(records.csv_bytes(_daily(0.9)))
    with pytest.raises(CacasError, match=r"daily\.csv does not match checksums\.sha256"):
        saved_runs.run_zip(folder)


def test_a_run_whose_files_do_not_match_its_checksums_is_refused_by_name(tmp_path):
    """Walkthrough: the Simulation lab's run folders had no checksums.sha256 (cacas simulate --out's
    have one), so a run killed between two renames, files of two runs side by side, read as one run."""
    root = tmp_path / "runs"
    inter = pd.DataFrame({"participant": ["P01"], "day": [1]})
    folder = saved_runs.save_run(root, "run1", _daily(0.3), inter, {"seed": 1}, _by_pref())
    earlier = (folder / "daily.csv").read_bytes()
    saved_runs.save_run(root, "run1", _daily(0.6), inter, {"seed": 2}, _by_pref())
    (folder / "daily.csv").write_bytes(earlier)  # as a kill before daily.csv's rename leaves it
    with pytest.raises(CacasError, match=r"run1: daily\.csv does not match checksums\.sha256: the run that wrote "
                                         r"that folder was stopped part-way .* run it again"):
        saved_runs.load_run(folder)
    (folder / "by_preference.csv").unlink()
    with pytest.raises(CacasError, match=r"by_preference\.csv, daily\.csv do not match"):
        saved_runs.load_run(folder)
    # a folder written without checksums (an older version's run) is read as before
    (folder / files.CHECKSUMS).unlink()
    assert saved_runs.load_run(folder).daily["success_rate"].tolist() == [0.3]


def test_load_run_names_what_is_missing_or_unreadable(tmp_path):
    with pytest.raises(CacasError, match="no such run folder"):
        saved_runs.load_run(tmp_path / "absent")
    folder = saved_runs.save_run(tmp_path, "r", _daily(), pd.DataFrame({"participant": ["P01"]}), {})
    (folder / files.CHECKSUMS).unlink()  # settings written by hand (with them, a changed file is said first)
    (folder / "settings.json").write_text("{not json")
    with pytest.raises(CacasError, match=r"settings\.json: not readable JSON"):
        saved_runs.load_run(folder)
    (folder / "settings.json").write_text("[1, 2]")
    with pytest.raises(CacasError, match="not a JSON object"):
        saved_runs.load_run(folder)
    (folder / "interactions.csv").unlink()
    with pytest.raises(CacasError, match="no interactions.csv; not a complete run"):
        saved_runs.load_run(folder)


def test_a_failure_part_way_leaves_the_earlier_run_whole(tmp_path, monkeypatch, fail_on_call):
    root = tmp_path / "runs"
    inter = pd.DataFrame({"participant": ["P01"], "day": [1]})
    folder = saved_runs.save_run(root, "run1", _daily(0.3), inter, {"seed": 1}, _by_pref())
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    opened = fail_on_call(open, 2)
    monkeypatch.setattr(files, "open", opened, raising=False)
    with pytest.raises(CacasError, match="No space left on device"):
        saved_runs.save_run(root, "run1", _daily(0.9), inter.assign(day=2), {"seed": 2}, _by_pref())
    monkeypatch.undo()
    assert len(opened.calls) == 2  # the failure came part-way through the files
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before  # old run whole, no temporary file
    assert saved_runs.load_run(folder).settings == {"seed": 1}
    assert saved_runs.list_runs(root) == ["run1"]


def test_a_simulation_choice_is_checked_before_a_run(tmp_path):
    with pytest.raises(CacasError, match="choose at least one simulated participant"):
        saved_runs.run_simulation([], tmp_path, methods=("cacas",))
    with pytest.raises(CacasError, match="no method given"):
        saved_runs.check_simulation(["P01"], [])
    with pytest.raises(CacasError, match="unknown method 'dqn'"):
        saved_runs.check_simulation(["P01"], ["cacas", "dqn"])
    assert saved_runs.check_simulation(["P01"], ["NN", "cacas"]) == ("nn", "cacas")
    with pytest.raises(CacasError, match="method 'nn' is listed twice"):  # likely a typo for another method
        saved_runs.check_simulation(["P01"], ["NN", "cacas", "nn"])
    assert not tmp_path.joinpath("runs").exists() and list(tmp_path.iterdir()) == []


def test_every_problem_of_the_simulation_form_is_named_at_once():
    """The form is filled in at once: one refusal names each problem, one a line, in the form's
    order, by the lab's labels (the command line still stops at the first: one line)."""
    with pytest.raises(CacasError) as refused:
        saved_runs.check_simulation([], ["cacas", "dqn"], days=0, interactions=15, seed=-1,
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
    saved_runs.save_run(tmp_path, "20261126-081502-seed0-8p-7d", daily, inter,
                         {"participants": [f"P0{i}" for i in range(1, 9)], "days": 7, "interactions": 15,
                          "methods": ["cacas", "nn"], "seed": 0, "loop": "first",
                          "personas": "study_data/personas/example.json"})
    saved_runs.save_run(tmp_path, "20261126-081733-seed3-1p-1d", daily, inter,
                         {"participants": ["P01"], "days": 1, "methods": ["bandit"], "seed": 3, "loop": "each",
                          "ask_after_reject": 0.5, "personas": "uploaded file mine.json (sha256 0123456789ab)"})
    saved_runs.save_run(tmp_path, "20261126-081734-seed3-1p-1d", daily, inter,
                         {"participants": ["P01"], "days": 1, "methods": ["bandit"], "seed": 3,
                          "personas": "the described preferences of the participants of study 'pilot'"})
    saved_runs.save_run(tmp_path, "from-the-command-line", daily, inter, {})
    for made_by_hand in ("settings.json", files.CHECKSUMS):  # as an older version's command wrote it
        (tmp_path / "from-the-command-line" / made_by_hand).unlink()
    saved_runs.save_run(tmp_path, "broken", daily, inter, {})
    (tmp_path / "broken" / files.CHECKSUMS).unlink()
    (tmp_path / "broken" / "settings.json").write_text("{not json")
    assert saved_runs.run_label(tmp_path, "20261126-081502-seed0-8p-7d") == \
        "26 Nov 2026 08:15:02 UTC · 8 participants (example.json) · 7 days · 15 a day · CACAS, NN · seed 0"
    assert saved_runs.run_label(tmp_path, "20261126-081733-seed3-1p-1d") == (
        "26 Nov 2026 08:17:33 UTC · 1 participant (mine.json) · 1 day · Bandit (TS) · seed 3 · asks after 50% of "
        "rejections · each in its own loop")
    assert saved_runs.run_label(tmp_path, "20261126-081734-seed3-1p-1d") == \
        "26 Nov 2026 08:17:34 UTC · 1 participant (study pilot) · 1 day · Bandit (TS) · seed 3"
    assert saved_runs.run_label(tmp_path, "from-the-command-line") == "from-the-command-line"
    assert saved_runs.run_label(tmp_path, "broken") == "broken"  # the picker still lists it; opening it names the file
    with pytest.raises(CacasError, match="settings.json: not readable JSON"):
        saved_runs.load_run(tmp_path / "broken")
    assert [saved_runs.run_days(d) for d in (1, 7, None)] == ["1 day", "7 days", "? days"]


def test_a_runs_caption_leaves_out_what_the_run_did_not_keep():
    """... and names the methods as the figures do (walk2: "methods cacas, cacas-no-pr" beside "CACAS w/o PR")."""
    full = {"participants": ["P01", "P02"], "days": 7, "interactions": 15, "methods": ["cacas", "cacas-no-pr", "nn"],
            "seed": 0, "ask_after_reject": 0.25, "loop": "each", "personas": "study_data/personas/example.json"}
    assert saved_runs.run_caption(full) == (
        "2 participants · 7 days · 15 interactions a day · methods CACAS, CACAS w/o PR, NN · seed 0 · asks after 25% of "
        "rejections · each method in its own closed loop · personas: study_data/personas/example.json")
    assert saved_runs.run_caption({"participants": ["P01"], "days": 1, "seed": 3}) == \
        "1 participant · 1 day · seed 3"  # no "None interactions a day"
    assert saved_runs.run_label("/nowhere", "x") == "x"


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
    side_by_side = saved_runs.run_simulation(people, tmp_path / "a", days=2, interactions=4, methods=("nn",))
    one = saved_runs.run_simulation(people, tmp_path / "b", days=2, interactions=4, methods=("nn",), jobs=1)
    assert used == [2, 1]
    for name in ("daily.csv", "interactions.csv", "by_preference.csv"):
        assert (side_by_side / name).read_bytes() == (one / name).read_bytes()


def test_a_loaded_daily_csv_keeps_its_counts_whole(tmp_path):
    # the Fig. 4 protocol: a baseline's row has no successes of its own (an empty cell)
    path = tmp_path / "daily.csv"
    path.write_text("participant,method,day,success_rate,preference_accuracy,cumulative_feedback,interactions,"
                    "successes\nP01,cacas,1,0.25,0.5,4,4,1\nP01,nn,1,,0.4,4,4,\n")
    daily = saved_runs.load_daily(path)
    assert str(daily["successes"].dtype) == "Int64" and daily["successes"].tolist()[0] == 1
    assert records.csv_bytes(daily).splitlines()[1].endswith(b",4,4,1")


def test_participant_codes_of_digits_keep_their_leading_zeros(tmp_path):
    """Codes such as 007 and 012 were read as the numbers 7 and 12 from a run's or an uploaded
    daily.csv, by_preference.csv and interactions.csv."""
    daily = pd.DataFrame({c: [1, 1] for c in records.DAILY_COLUMNS}).assign(participant=["007", "012"], method="cacas")
    by_pref = pd.DataFrame({c: [1] for c in records.BY_PREFERENCE_COLUMNS}).assign(participant="007", method="cacas")
    tables = uploaded_run.load_uploaded_tables([("d.csv", records.csv_bytes(daily)),
                                                ("b.csv", records.csv_bytes(by_pref))])
    assert tables["daily"]["participant"].tolist() == ["007", "012"]
    assert tables["by_preference"]["participant"].tolist() == ["007"]
    (tmp_path / "daily.csv").write_bytes(records.csv_bytes(daily))
    assert saved_runs.load_daily(tmp_path / "daily.csv")["participant"].tolist() == ["007", "012"]
    # a caller's own column types keep it too
    assert records.read_csv(tmp_path / "daily.csv", dtype={"day": int})["participant"].tolist() == ["007", "012"]


def test_an_uploaded_persona_file_is_checked_as_an_import_is_and_its_source_kept():
    import json

    good = {"participants": [{"id": "P01", "preferences": [{"activity": ["cough"], "action": "pain check"}]}]}
    data = json.dumps(good).encode()
    assert [p.id for p in saved_runs.uploaded_personas("mine.json", data)] == ["P01"]
    named = json.loads(data)
    named["participants"][0]["id"] = "John Smith"
    with pytest.raises(CacasError, match=r"mine\.json: participant code 'John Smith' is invalid; valid: a "
                                         r"pseudonymous code"):
        saved_runs.uploaded_personas("mine.json", json.dumps(named).encode())
    mailed = json.loads(data)
    mailed["participants"][0]["preferences"][0]["description"] = "if I cough, mail john.smith@example.org"
    with pytest.raises(CacasError, match=r"mine\.json, participant P01, preference 1 .*field 'description': holds what looks "
                                         r"like contact details \('john\.smith@example\.org'\)"):
        saved_runs.uploaded_personas("mine.json", json.dumps(mailed).encode())
    source = saved_runs.persona_source("Upload a persona file", "mine.json", data)
    assert source.startswith("uploaded file mine.json (sha256 ") and len(source.split("sha256 ")[1]) == 13
    assert source != saved_runs.persona_source("Upload a persona file", "mine.json", json.dumps(named).encode())
    assert saved_runs.persona_source("x", "example.json") == "study_data/personas/example.json"
    assert saved_runs.persona_source("x", study="pilot") == "the described preferences of the participants of study 'pilot'"


def test_runs_round_trip_and_bad_daily(tmp_path):
    daily = pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "success_rate": [0.3],
                          "preference_accuracy": [0.2], "cumulative_feedback": [10], "interactions": [15]})
    root = saved_runs.runs_dir(tmp_path / "s.sqlite")
    saved_runs.save_run(root, "run1", daily, pd.DataFrame({"participant": ["P01"]}), {"seed": 0})
    assert saved_runs.list_runs(root) == ["run1"]
    assert saved_runs.load_daily(root / "run1" / "daily.csv").equals(daily)
    assert saved_runs.load_by_preference(root / "run1") is None  # a run saved without it
    by_pref = pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "preference": [1],
                            "accuracy": [0.25]})
    saved_runs.save_run(root, "run2", daily, pd.DataFrame({"participant": ["P01"]}), {"seed": 0}, by_pref)
    assert saved_runs.load_by_preference(root / "run2").equals(by_pref)
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n")
    with pytest.raises(CacasError, match="not a daily.csv; missing columns: participant"):
        saved_runs.load_daily(tmp_path / "bad.csv")


def test_two_runs_finished_in_the_same_second_keep_both(tmp_path, monkeypatch):
    """Adversarial audit: the Simulation lab names a run by its time to the second, seed and size:
    two runs (two tabs, two researchers on one study) of one seed and size that finished in the same
    second got one folder, and the second's tables replaced the first's."""
    import cacas.experiment
    from cacas.experiment import StudyResult
    from cacas.preferences import parse_participant

    people = [parse_participant({"id": "P01", "preferences": [{"activity": ["cough"], "action": "pain check"}]})]
    made = iter(["first", "second"])

    def simulate_study(*args, **kwargs):
        which = next(made)
        daily = _daily().assign(method=which)  # each run's own rows, told apart by their method column
        return StudyResult(daily, pd.DataFrame({"participant": ["P01"], "method": [which]}), _by_pref())

    monkeypatch.setattr(cacas.experiment, "simulate_study", simulate_study)
    import datetime

    class Frozen(datetime.datetime):  # both runs finish at 08:00:00
        @classmethod
        def now(cls, tz=None):
            return datetime.datetime(2026, 11, 27, 8, 0, 0, 400_000, tzinfo=tz)

    monkeypatch.setattr(datetime, "datetime", Frozen)
    one = saved_runs.run_simulation(people, tmp_path, methods=("nn",), jobs=1)
    two = saved_runs.run_simulation(people, tmp_path, methods=("nn",), jobs=1)
    assert (one.name, two.name) == ("20261127-080000-seed0-1p-7d", "20261127-080000-seed0-1p-7d-2")
    assert saved_runs.load_run(one).daily["method"].tolist() == ["first"]
    assert saved_runs.load_run(two).daily["method"].tolist() == ["second"]
    assert saved_runs.run_label(tmp_path, two.name).startswith("27 Nov 2026 08:00:00 UTC · 1 participant")
