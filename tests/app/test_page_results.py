import json

from apphelpers import no_exception, open_tab, save_runs, texts
from pages import ui

PAGE = "pages/results.py"
FIG4, TABLES = "Fig. 4 · methods", "Tables"


def _study_with_a_day(store):
    store.add_participant("P01")
    store.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
    day = store.open_day("P01")
    for robot, resp in [("pain check", "accept"), ("chitchat", "reject"), ("pain check", "accept")]:
        store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                                 robot_action=robot, response=resp)
    store.close_day("P01", day)
    store.record_adaptation("P01", 0, "cacas", {}, 0.0, {"preference_accuracy": 0.25})


def test_results_empty_study(app):
    at = app(PAGE)
    no_exception(at)
    assert "No study day with interactions yet" in texts(at)


def test_results_show_day_one_and_downloads(app, store, downloads):
    _study_with_a_day(store)
    store.add_participant("P02")  # not started yet: counted among the study's participants
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert "2 participants (1 with a study day), 3 interactions logged" in texts(at)
    assert "Day 1 mean success rate" in [m.label for m in at.metric]
    assert at.metric[0].value == "67%"
    open_tab(at, "results-tab", TABLES)  # where "Download everything" is
    labels = [b.label for b in at.get("download_button")]
    for name in ("interactions.csv", "daily.csv", "participants.csv", "questionnaire.csv", "adaptations.csv"):
        assert f"Download {name}" in labels
    assert any("zip" in label for label in labels)
    # each button downloads its own table, as cacas export writes it (a label said nothing of what it held)
    from cacas import records
    from cacas.export import export_tables
    written = export_tables(store, "default")
    # named as the zip is, after the study (walkthrough: two studies' "interactions.csv" met in a Downloads
    # folder as "interactions (1).csv"); the labels keep the table's name, as cacas export writes it
    for name in ("interactions", "daily", "participants", "questionnaire", "adaptations"):
        assert downloads[f"{name}-default.csv"] == records.csv_bytes(written[name]), name
    assert not [f for f in downloads.at_click if f.endswith(".csv") and not f.endswith("-default.csv")]
    # a download reruns nothing: a rerun replaced the prepared files of the other buttons, and a
    # download right after another one found its file gone (MediaFileStorageError)
    assert [b.label for b in at.get("download_button") if not b.proto.ignore_rerun] == []
    store.add_participant("P03")
    store.open_day("P03")  # a day begun, nothing recorded on it: a study day all the same (as Overview's "Started")
    at.run()
    assert "3 participants (2 with a study day), 3 interactions logged" in texts(at)


def test_a_day_in_progress_is_shown_as_so_far(app, store):
    _study_with_a_day(store)
    day = store.open_day("P01")
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="chitchat", response="reject")
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert at.metric[0].label == "Day 2 mean success rate so far" and at.metric[0].value == "0%"
    assert "Day 2 is still open for P01: its figures are so far" in texts(at)
    store.close_day("P01", day)
    at = app(PAGE, participant="P01")
    assert at.metric[0].label == "Day 2 mean success rate" and "still open" not in texts(at)


def test_questionnaire_entry_and_summary(app, store):
    _study_with_a_day(store)
    at = app(PAGE, participant="P01")
    at.text_area(key="quest-comments-0").input("The robot learnt my evenings.")
    next(b for b in at.button if b.label == "Save answer").click().run()  # no score chosen: refused
    no_exception(at)
    assert "choose the participant's score, from 1 (very dissatisfied) to 10" in texts(at)
    assert len(store.questionnaire_frame()) == 0
    assert at.text_area(key="quest-comments-0").value == "The robot learnt my evenings."  # kept to fix the score
    at.button_group(key="quest-score-0").set_value(9)
    next(b for b in at.button if b.label == "Save answer").click().run()
    no_exception(at)
    answers = store.questionnaire_frame()
    assert list(answers["satisfaction"]) == [9] and list(answers["comments"]) == ["The robot learnt my evenings."]
    # on the page, under the form (a toast of ~25 words left before it was read: accessibility walkthrough)
    assert "Saved P01's answer (9). It was given after day 1 of 7." in [m.value for m in at.success]
    # saved: the form is empty for the next participant's answer
    assert at.button_group(key="quest-score-1").value is None and at.text_area(key="quest-comments-1").value == ""
    values = {m.label: m.value for m in at.metric}
    assert values["Answers"] == "1" and values["Mean"] == "9.00" and values["Rated 8 or higher"] == "100%"
    assert any("Counted here though given before their day 7: P01 (questionnaire.csv's day says when)." in c.value
               for c in at.caption)  # answered after day 1: named
    shown = next(d.value for d in at.dataframe if "satisfaction" in d.value.columns)
    assert list(shown.columns) == ["participant", "day", "satisfaction", "comments", "saved"]
    assert shown["saved"].iloc[0].endswith(" UTC")
    assert not any("Simulated participants answer no questionnaire" in i.value for i in at.info)
    # a second answer says it replaces the first in the summary (it did so silently)
    at.button_group(key="quest-score-1").set_value(7)
    next(b for b in at.button if b.label == "Save answer").click().run()
    assert ("Saved P01's answer (7). It was given after day 1 of 7. It replaces P01's earlier answer (9) in the "
            "summary; questionnaire.csv keeps both.") in [m.value for m in at.success]
    assert {m.label: m.value for m in at.metric}["Mean"] == "7.00" and len(store.questionnaire_frame()) == 2
    at.run()  # said once: the next run of the page no longer says it
    assert not any(m.value.startswith("Saved P01's answer") for m in at.success)


def test_an_answer_saved_by_mistake_is_removed_once_the_code_is_typed(app, store):
    """Walkthrough: an answer saved for the wrong participant (the form starts at the sidebar's participant)
    could not be removed. The participant's latest answer is, once their code is typed; the summary then counts
    the answer before it."""
    _study_with_a_day(store)
    store.record_questionnaire("P01", 9)
    store.add_participant("P00")
    store.open_day("P00")
    store.record_questionnaire("P00", 8)
    store.record_questionnaire("P01", 2, "meant for P02")
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert at.selectbox(key="quest-remove-who").options == ["P00: 8, saved " + _short(store, 1),
                                                            "P01: 2, saved " + _short(store, -1)]
    assert at.selectbox(key="quest-remove-who").value == "P01"  # the sidebar's participant
    remove = next(b for b in at.button if b.label == "Remove this answer")
    assert remove.disabled  # nothing typed yet
    at.text_input(key="quest-remove-confirm").input("P01").run()
    next(b for b in at.button if b.label == "Remove this answer").click().run()
    no_exception(at)
    assert store.questionnaire_frame()["satisfaction"].tolist() == [9, 8]  # P01's 9 and P00's 8
    assert "Removed P01's latest answer (2)." in [t.value for t in at.toast]
    assert {m.label: m.value for m in at.metric}["Mean"] == "8.50"
    assert at.text_input(key="quest-remove-confirm").value == ""  # typed afresh for another removal


def _short(store, row: int) -> str:
    from cacas.app_support import short_time

    return short_time(store.questionnaire_frame()["created_at"].iloc[row])


def test_questionnaire_of_a_participant_without_a_day_is_refused(app, store):
    _study_with_a_day(store)
    store.add_participant("P02")
    at = app(PAGE, participant="P02")
    at.button_group(key="quest-score-0").set_value(9)
    next(b for b in at.button if b.label == "Save answer").click().run()
    no_exception(at)
    assert "participant P02 has had no study day yet" in texts(at)
    assert len(store.questionnaire_frame()) == 0
    assert at.button_group(key="quest-score-0").value == 9  # the score stays for another pick of participant


def test_the_change_since_day_1_rounds_halves_as_the_percentages_do(app, db):
    """Review: 25 % on day 1 and 38 % (37.5) on day 2 said "+12 points" (Python's round to even)."""
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame({"participant": ["P01", "P01", "P03", "P03"], "method": ["cacas"] * 4, "day": [1, 2, 1, 2],
                          "success_rate": [0.5, 0.0, 0.0, 0.75], "preference_accuracy": [0.2, 0.5, 0.2, 0.5],
                          "cumulative_feedback": [8, 15, 8, 15], "interactions": [15, 15, 15, 15]})
    saved_runs.save_run(saved_runs.runs_dir(db), "run-h", daily, pd.DataFrame({"participant": ["P01"]}), {})
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    no_exception(at)
    assert (at.metric[0].value, at.metric[0].delta) == ("38%", "+13 points since day 1")


def test_a_run_with_no_success_rate_is_not_sent_to_the_study_session(app, db):
    """Review: a daily.csv without a success rate said 'Run a day on the Study session page'."""
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame({"participant": ["P01"], "method": ["nn"], "day": [1], "success_rate": [float("nan")],
                          "preference_accuracy": [0.4], "cumulative_feedback": [8], "interactions": [15]})
    saved_runs.save_run(saved_runs.runs_dir(db), "run-n", daily, pd.DataFrame({"participant": ["P01"]}), {})
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    no_exception(at)
    assert "No success rate in this daily.csv: no method acted with the participants" in texts(at)
    assert "Study session" not in texts(at)


def test_results_of_a_simulated_run(app, db, downloads):
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame({"participant": ["P01", "P01"], "method": ["cacas", "cacas"], "day": [1, 2],
                          "success_rate": [0.3, 0.6], "preference_accuracy": [0.2, 0.5],
                          "cumulative_feedback": [8, 15], "interactions": [15, 15]})
    by_pref = pd.DataFrame({"participant": ["P01"] * 2, "method": ["cacas"] * 2, "day": [1, 2], "preference": [1, 1],
                            "label": ["Cough: pain check"] * 2, "activity": ["cough"] * 2,
                            "action": ["pain check"] * 2, "states": [40, 40], "correct": [8, 20],
                            "accuracy": [0.2, 0.5]})
    saved_runs.save_run(saved_runs.runs_dir(db), "run-a", daily, pd.DataFrame({"participant": ["P01"]}), {},
                         by_pref)
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    no_exception(at)
    assert at.selectbox(key="results-run").value == "run-a"
    assert at.metric[0].label == "Day 2 mean success rate" and at.metric[0].value == "60%"
    assert at.metric[0].delta == "+30 points since day 1"
    assert at.metric[1].value == "15 data points" and at.metric[2].value == "1"
    assert not any("Which preferences" in t for t in texts(at).splitlines())  # only the open tab runs
    open_tab(at, "results-tab", FIG4)
    no_exception(at)
    fig4 = at.dataframe[0].value  # the per-method, per-day means under Fig. 4
    assert list(fig4.index) == ["CACAS"] and list(fig4.columns) == ["day 1", "day 2"]
    assert fig4.loc["CACAS"].tolist() == [20, 50]
    assert at.select_slider(key="results-prefs:Simulated run: run-a-day").value == 2  # the last day first
    assert "Which preferences each method learnt" in texts(at)
    assert "Download by_preference.csv" in [b.label for b in at.get("download_button")]
    # a run's tables named after the run as its folder is named ("run_a" before), as the study's after the study
    assert {"daily-run-a.csv", "by_preference-run-a.csv"} <= set(downloads.at_click)
    assert "daily.csv" not in downloads.at_click
    # and the whole run, as the Simulation lab offers it (its upload here takes it as it is)
    assert downloads["results-dl-run-zip"] == downloads["cacas-run-run-a.zip"] == \
        saved_runs.run_zip(saved_runs.runs_dir(db) / "run-a")
    assert any("Simulated participants answer no questionnaire" in i.value for i in at.info)
    # and no human-study form or summary beside that note
    assert "Save answer" not in [b.label for b in at.button]
    assert "Answers" not in [m.label for m in at.metric]


def test_each_run_opens_its_heatmap_on_its_own_last_day(app, db):
    """A day picked for one run's heatmap was kept for the next run shown (or the human study)."""
    save_runs(db, {"run-a": 2, "run-c": 3})
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    at.selectbox(key="results-run").set_value("run-c").run()
    open_tab(at, "results-tab", FIG4)
    slider = "results-prefs:Simulated run: {}-day"
    assert at.select_slider(key=slider.format("run-c")).value == 3
    at.select_slider(key=slider.format("run-c")).set_value(1).run()
    at.selectbox(key="results-run").set_value("run-a").run()
    no_exception(at)
    assert at.select_slider(key=slider.format("run-a")).value == 2  # run-a's last day, not run-c's pick


def _each_loop_run(app, db, nn_feedback: int, nn_day_2: int):
    """Results opened on a saved run of P01 over 2 days, CACAS and NN each in its own closed loop (NN's day 2:
    ``nn_feedback`` data points after ``nn_day_2`` recorded interactions)."""
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame({"participant": ["P01"] * 4, "method": ["cacas", "cacas", "nn", "nn"], "day": [1, 2, 1, 2],
                          "success_rate": [0.3, 0.6, 0.3, 0.4], "preference_accuracy": [0.2, 0.5, 0.2, 0.3],
                          "cumulative_feedback": [8, 15, 8, nn_feedback], "interactions": [15, 15, 15, nn_day_2]})
    saved_runs.save_run(saved_runs.runs_dir(db), "run-each", daily, pd.DataFrame({"participant": ["P01"]}),
                        {"loop": "each"})
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    no_exception(at)
    return at


def test_results_of_a_run_with_every_method_in_its_own_closed_loop(app, db):
    at = _each_loop_run(app, db, nn_feedback=14, nn_day_2=14)
    titles = [c.proto.spec for c in at.get("plotly_chart")]
    assert any("Success rate by method, each in its own closed loop" in t for t in titles)
    assert "methods CACAS, NN, each in its own closed loop." in texts(at)
    assert at.selectbox(key="results-fig3-method").value == "cacas"
    assert at.metric[0].value == "60%"
    at.selectbox(key="results-fig3-method").set_value("nn").run()
    no_exception(at)
    assert at.metric[0].value == "40%" and at.metric[1].value == "14 data points"


def test_fig3_by_methods_hollow_points_are_said_under_it(app, db):
    """walk2: Fig. 3 by method marks a day resting on few answers hollow now, as Fig. 3 does; a caption under it
    says what a hollow point is (its hover gives the fewest), and Fig. 3's own caption under the method's figure."""
    at = _each_loop_run(app, db, nn_feedback=10, nn_day_2=2)
    assert HOLLOW.replace("its label", "its hover") in texts(at)
    assert HOLLOW not in texts(at)  # CACAS, shown below, has none
    at.selectbox(key="results-fig3-method").set_value("nn").run()
    assert HOLLOW in texts(at) and "Mean over participants; the band spans" in texts(at)


def test_a_human_study_adapted_with_two_methods_shows_each_method_in_force(app, store):
    store.add_participant("P01")
    store.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
    for day_no, answers in ((1, ["accept", "reject"]), (2, ["accept", "accept"])):
        if day_no == 2:  # the researcher adapted day 1 with NN: its policy is in force on day 2
            store.save_policy("P01", 1, "nn", b"policy bytes")
        day = store.open_day("P01")
        for resp in answers:
            store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                                     robot_action="pain check", response=resp)
        store.close_day("P01", day)
    at = app(PAGE, participant="P01")
    no_exception(at)
    titles = [c.proto.spec for c in at.get("plotly_chart")]
    assert any("Success rate by the method whose policy was in force" in t for t in titles)
    assert not any("each in its own closed loop" in t for t in titles)  # that is a simulated run's wording
    assert at.selectbox(key="results-fig3-method").value == "cacas"
    assert at.metric[0].label == "Day 1 mean success rate" and at.metric[0].value == "50%"
    at.selectbox(key="results-fig3-method").set_value("nn").run()
    no_exception(at)
    assert at.metric[0].label == "Day 2 mean success rate" and at.metric[0].value == "100%"


def test_human_study_accuracy_by_described_preference(app, store):
    _study_with_a_day(store)
    store.record_adaptation("P01", 0, "nn", {}, 0.0, {"preference_accuracy": 0.5, "by_preference": [
        {"preference": 1, "label": "cough -> pain check", "activity": "cough", "action": "pain check",
         "states": 400, "correct": 200}]})
    at = open_tab(app(PAGE, participant="P01"), "results-tab", FIG4)
    no_exception(at)
    assert "Which preferences each method learnt" in texts(at)
    heat = [c for c in at.get("plotly_chart") if "Accuracy by described preference" in c.proto.spec]
    # read as JSON: plotly writes "·" and "→" as \u escapes unless orjson (not a dependency) is installed
    assert len(heat) == 1 and "P01 · 1. cough → pain check" in json.dumps(json.loads(heat[0].proto.spec),
                                                                          ensure_ascii=False)
    assert "Download by_preference.csv" in [b.label for b in at.get("download_button")]


def test_the_policy_files_are_checked_for_the_zip_only_on_the_tables_tab(app, store, monkeypatch):
    """Scale walk (60 participants x 21 days): whether the zip can be made (every policy file there and matching
    its sha256) was asked on every run of the page, wherever it opened: 790 MB read, 2.5 s of its first run after
    a server's start. Only the Tables tab, where "Download everything" is, asks now."""
    from cacas.store import StudyStore

    _study_with_a_day(store)
    store.save_policy("P01", 1, "cacas", b"a policy")
    asked = []
    real = StudyStore.damaged_policy_files
    monkeypatch.setattr(StudyStore, "damaged_policy_files", lambda self, *a: asked.append(a) or real(self, *a))
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert asked == [] and not any("zip" in b.label for b in at.get("download_button"))
    open_tab(at, "results-tab", TABLES)
    no_exception(at)
    assert asked and any("zip" in b.label for b in at.get("download_button"))


def test_no_zip_offered_while_a_policy_file_is_missing(app, store):
    _study_with_a_day(store)
    store.save_policy("P01", 1, "cacas", b"a policy")
    store.active_policy("P01").path.unlink()
    at = open_tab(app(PAGE, participant="P01"), "results-tab", TABLES)
    no_exception(at)
    assert "No zip: 1 policy file is missing" in texts(at)
    labels = [b.label for b in at.get("download_button")]
    assert "Download interactions.csv" in labels and not any("zip" in label for label in labels)


def test_no_zip_offered_while_a_policy_file_is_damaged(app, store):
    """Safety audit: a policy file changed on disk (its sha256 no longer the recorded one) left the
    zip offered, and the click failed with the browser's bare "Failed to generate file for
    download" (Streamlit logs the error; the researcher saw nothing of which file or what to do)."""
    _study_with_a_day(store)
    store.save_policy("P01", 1, "cacas", b"a policy")
    store.active_policy("P01").path.write_bytes(b"another policy")
    at = open_tab(app(PAGE, participant="P01"), "results-tab", TABLES)
    no_exception(at)
    assert ("No zip: 1 policy file does not match its recorded sha256 (changed or damaged) "
            "(P01/day1-cacas-") in texts(at)
    assert "Restore it from a backup" in texts(at)  # one file: "it", not "them"
    labels = [b.label for b in at.get("download_button")]
    assert "Download interactions.csv" in labels and not any("zip" in label for label in labels)


def test_the_zip_is_made_in_memory_as_cacas_export_writes_it(app, store, downloads, monkeypatch, tmp_path):
    """Safety audit: "Download everything" wrote the study's tables and zip into a temporary folder to
    read the zip back: a server killed during the download left that plain copy of the study (notes,
    comments, a withdrawn participant's answers) in /tmp for good, and a full /tmp failed the download."""
    from cacas import export
    from cacas.store import files

    _study_with_a_day(store)
    store.save_policy("P01", 1, "cacas", b"a policy")
    expected = export.export_study(store, tmp_path / "cli").bundle.read_bytes()

    def no_copy_on_disk(*args, **kwargs):
        raise AssertionError("the study was written to disk for the download")
    monkeypatch.setattr(files, "write_all", no_copy_on_disk)
    at = open_tab(app(PAGE, participant="P01"), "results-tab", TABLES)
    no_exception(at)
    assert downloads["cacas-study-default.zip"] == expected


def test_a_participant_removed_after_the_page_was_drawn_is_not_in_its_downloads(app, store, downloads):
    """Safety audit: a Results tab drawn before a participant's removal (a withdrawal, in another tab)
    still downloaded their rows: each table's CSV was made on the click from the frame read when the
    page was drawn. The study's tables are read from the database at the click."""
    import io

    import pandas as pd

    _study_with_a_day(store)
    store.add_participant("P02")
    day = store.open_day("P02")
    store.record_interaction("P02", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
    store.record_questionnaire("P02", 6, "fine")
    made = downloads.at_click  # file name -> what the button makes on the click
    at = app(PAGE, participant="P01")
    no_exception(at)
    store.remove_participant("P02", "P02")  # another tab, after this page was drawn
    for name in ("interactions-default.csv", "daily-default.csv", "participants-default.csv",
                 "questionnaire-default.csv"):
        table = pd.read_csv(io.BytesIO(made[name]()))
        assert "P02" not in set(table["participant"]), name


def test_a_broken_simulated_run_is_named_not_a_crash(app, db):
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "success_rate": [0.3],
                          "preference_accuracy": [0.2], "cumulative_feedback": [8], "interactions": [15]})
    folder = saved_runs.save_run(saved_runs.runs_dir(db), "run-b", daily, pd.DataFrame({"participant": ["P01"]}), {})
    (folder / "interactions.csv").unlink()
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    no_exception(at)
    assert "run-b: no interactions.csv; not a complete run" in texts(at)


def test_only_the_open_figure_tab_runs_and_its_choices_are_kept_meanwhile(app, db):
    """Profile (24 x 7 study): Fig. 4's tab, with its heatmap, was over half of every rerun of the page, shown
    or not. Only the open figure tab runs; a day picked on Fig. 4's heatmap is still picked after a visit to
    Fig. 3."""
    save_runs(db, {"run-c": 3})
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    no_exception(at)
    assert at.metric[0].label == "Day 3 mean success rate"  # Fig. 3, the open tab
    assert "Which preferences each method learnt" not in texts(at) and len(at.get("plotly_chart")) == 1
    slider = "results-prefs:Simulated run: run-c-day"
    open_tab(at, "results-tab", FIG4)
    no_exception(at)
    assert "Which preferences each method learnt" in texts(at) and not at.metric  # Fig. 3 not run
    at.select_slider(key=slider).set_value(1).run()
    open_tab(at, "results-tab", "Fig. 3 · success rate")
    assert at.metric[0].label == "Day 3 mean success rate" and "Which preferences" not in texts(at)
    open_tab(at, "results-tab", FIG4)
    no_exception(at)
    assert at.select_slider(key=slider).value == 1  # kept while its tab was not drawn


def test_comparing_methods_can_be_stopped_and_keeps_the_runs_recorded(app, db, store, monkeypatch):
    """Compare methods records each run as it goes (and skips recorded ones when started again),
    so a stopped comparison keeps its runs: the page says so, not "nothing was saved"."""
    import threading

    import cacas.method_comparison
    from cacas.jobs import RUNNER
    from cacas.parallel import default_jobs

    _study_with_a_day(store)
    reported = threading.Event()

    asked = {}

    def compare(db, study=None, progress=None, jobs=1):
        asked["jobs"] = jobs
        for run in range(100_000):
            progress(run / 100_000, f"run {run}")
            reported.set()
            threading.Event().wait(0.01)

    monkeypatch.setattr(cacas.method_comparison, "compare_methods", compare)
    at = open_tab(app(PAGE, participant="P01"), "results-tab", FIG4)
    next(b for b in at.button if b.label == "Compare methods on this study's data").click().run()
    job = RUNNER.get(f"compare:{db}:default")
    assert job is not None and reported.wait(30)
    assert asked["jobs"] == default_jobs()  # participants side by side, one worker process per core
    at.run()
    next(b for b in at.button if b.label == "Stop").click().run()
    assert job.wait(30) and job.status == "stopped"
    at.run()
    no_exception(at)
    assert any("Comparing methods was stopped" in i.value and "the runs recorded so far are kept" in i.value
               for i in at.info)
    assert any(b.label == "Compare methods on this study's data" for b in at.button)  # it can go on
    RUNNER.forget(f"compare:{db}:default")


def test_a_finished_comparison_says_what_it_recorded(app, db, store, monkeypatch):
    """The comparison ended without a word (walkthrough): the page says how many runs it recorded,
    or that every day had them already."""
    import cacas.method_comparison
    from cacas import app_support
    from cacas.jobs import RUNNER

    _study_with_a_day(store)
    from cacas.method_comparison import Compared

    # what the runs are: "15 runs recorded" said neither (walkthrough)
    for runs, said in ((Compared(9, 6), "9 adaptations after study days and 6 scores of the initial policy (day 0) "
                                        "recorded, in Fig. 4 and the tables below"),
                       (Compared(1, 0), "1 adaptation after study days recorded"),
                       (Compared(), "no new run; each method has one for every closed day")):
        monkeypatch.setattr(cacas.method_comparison, "compare_methods", lambda *a, runs=runs, **k: runs)
        at = open_tab(app(PAGE, participant="P01"), "results-tab", FIG4)
        next(b for b in at.button if b.label == "Compare methods on this study's data").click().run()
        assert RUNNER.get(f"compare:{db}:default").wait(30)
        at.run()
        no_exception(at)
        ended = app_support.short_time(RUNNER.get(f"compare:{db}:default").finished)
        # when it ended: the server keeps the last comparison, and a session opened later read it as news
        assert any(said in s.value and s.value.startswith("Methods compared (") and f", ended {ended}): " in s.value
                   for s in at.success)
        RUNNER.forget(f"compare:{db}:default")


def test_right_after_an_adaptation_the_policies_for_the_next_day_are_listed_apart(app, store):
    _study_with_a_day(store)
    store.record_adaptation("P01", 1, "cacas", {}, 1.0, {"preference_accuracy": 0.75})  # after day 1
    at = app(PAGE)
    no_exception(at)
    assert at.metric[0].label == "Day 1 mean success rate"  # Fig. 3 stays with the days that happened
    open_tab(at, "results-tab", FIG4)
    no_exception(at)
    fig4 = at.dataframe[0].value
    # Fig. 4 is daily.csv's (the walkthrough's export drew another figure than the page), the day ahead
    # a table of its own
    assert list(fig4.columns) == ["day 1"] and fig4.loc["CACAS"].tolist() == [25]
    ahead = at.dataframe[1].value
    assert ahead.to_dict("records") == [{"participant": "P01", "day": 2, "CACAS": "75%"}]
    assert any("Fig. 4 and daily.csv take these in once the day has begun." in c.value for c in at.caption)


def test_human_study_compares_on_the_same_participants(app, store):
    """W02 has only CACAS scores (its comparison not run) and has not reached day 2: Fig. 4's
    methods are averaged over P01 alone, and Fig. 3's change since day 1 is P01's own."""
    _study_with_a_day(store)  # P01: day 1 (2 of 3 accepted), CACAS initial scored 0.25
    store.record_adaptation("P01", 0, "nn", {}, 0.0, {"preference_accuracy": 0.25})
    day = store.open_day("P01")
    for robot, resp in [("pain check", "accept")] * 3:
        store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                                 robot_action=robot, response=resp)
    store.record_adaptation("P01", 1, "cacas", {}, 0.0, {"preference_accuracy": 0.75})
    store.record_adaptation("P01", 1, "nn", {}, 0.0, {"preference_accuracy": 0.5})
    store.add_participant("W02")
    store.save_preferences("W02", [{"activity": ["cough"], "action": "pain check"}])
    day = store.open_day("W02")
    store.record_interaction("W02", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="chitchat", response="reject")
    store.record_adaptation("W02", 0, "cacas", {}, 0.0, {"preference_accuracy": 0.95})
    at = app(PAGE, participant="P01")
    no_exception(at)
    values = {m.label: m for m in at.metric}
    rate = values["Day 2 mean success rate so far"]
    assert rate.value == "100%" and rate.delta == "+33 points since day 1 (1 with both days)"  # P01: 67% -> 100%, not the means
    assert values["Participants on day 2"].value == "1 of 2"
    open_tab(at, "results-tab", FIG4)
    no_exception(at)
    table = next(d.value for d in at.dataframe if "day 1" in list(d.value.columns))
    assert table.loc["CACAS", "day 1"] == 25 and table.loc["NN", "day 1"] == 25  # not (25% + 95%) / 2
    assert table.loc["NN", "day 2"] == 50
    assert "so these are left out: W02 day 1 (no NN); compare methods again to add them." in texts(at)


def test_days_recorded_since_the_comparison_are_said_to_need_it(app, store):
    """Compared after day 1, then day 2 recorded: Fig. 4's NN line ended at day 1 and nothing said why."""
    _study_with_a_day(store)
    store.record_adaptation("P01", 0, "nn", {}, 0.0, {"preference_accuracy": 0.25})
    store.record_adaptation("P01", 1, "cacas", {}, 0.0, {"preference_accuracy": 0.75})
    _a_cough(store, store.open_day("P01"))
    at = open_tab(app(PAGE, participant="P01"), "results-tab", FIG4)
    no_exception(at)
    assert "Not compared yet, so CACAS alone: P01 day 2; compare methods again to add them." in texts(at)


def test_tables_show_empty_cells_empty(app, db):
    """daily.csv's baseline rows have no success rate: the Tables tab shows the cell empty, as the
    CSV holds it (Streamlit's table wrote "None"), and the column stays a number column (it was shown
    as CSV text: left-aligned, six decimals, sorted as text)."""
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame({"participant": ["P01", "P01"], "method": ["cacas", "nn"], "day": [1, 1],
                          "success_rate": [0.3, float("nan")], "preference_accuracy": [0.2, 0.1],
                          "cumulative_feedback": [8, 8], "interactions": [15, 15]})
    saved_runs.save_run(saved_runs.runs_dir(db), "run-a", daily, pd.DataFrame({"participant": ["P01"]}), {})
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    no_exception(at)
    table = next(d for d in at.dataframe if "success_rate" in d.value.columns and len(d.value) == 2)
    assert table.proto.placeholder == ""  # the empty cell drawn empty
    shown = table.value
    assert shown["success_rate"].iloc[0] == 0.3 and pd.isna(shown["success_rate"].iloc[1])
    assert shown["success_rate"].dtype.kind == "f" and list(shown["day"]) == [1, 1]  # numbers sort as numbers
    # Fig. 4's table: a method without a score that day shows a dash
    two = pd.concat([daily, daily.assign(day=2, preference_accuracy=[0.4, float("nan")])])
    saved_runs.save_run(saved_runs.runs_dir(db), "run-b", two, pd.DataFrame({"participant": ["P01"]}), {})
    at.run()
    at.selectbox(key="results-run").set_value("run-b").run()
    open_tab(at, "results-tab", FIG4)
    element = next(d for d in at.dataframe if "day 2" in d.value.columns)
    fig4 = element.value
    assert element.proto.placeholder == "–"
    assert fig4.loc["NN", "day 1"] == 10 and pd.isna(fig4.loc["NN", "day 2"])
    assert fig4.loc["CACAS"].tolist() == [20, 40]


def _a_cough(store, day: int, response: str = "accept") -> None:
    """One interaction of P01's ``day``: a cough, the robot's pain check, ``response``."""
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response=response)


def test_one_interaction_is_said_in_the_singular(app, store):
    store.add_participant("P01")
    _a_cough(store, store.open_day("P01"))
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert "1 participant (1 with a study day), 1 interaction logged, 1 of them recorded" in texts(at)


def test_a_day_begun_with_only_unanswered_proposals_is_on_fig3(app, store):
    """Review: such a day was left out of Fig. 3 and its metrics, as if the participant had not
    begun it."""
    _study_with_a_day(store)
    _a_cough(store, store.open_day("P01"), response="others")  # left unanswered: not recorded
    at = app(PAGE, participant="P01")
    no_exception(at)
    values = {m.label: m.value for m in at.metric}
    assert values["Day 2 mean success rate so far"] == "–"
    assert at.metric[0].proto.delta == "nothing recorded yet"  # "–" alone read as a missing figure
    assert values["Participants on day 2"] == "1"
    assert values["Mean cumulative feedback, day 2"] == "3 data points"  # day 1's, carried over


def test_on_a_phone_the_preference_heatmap_is_drawn_narrow_and_says_how_its_rows_are_named(app, db, monkeypatch):
    """Phone's left-alone item: Fig. 4 by preference at 390 px had 16-px cells, its row labels and title cut.
    A phone's browser (ui.on_a_phone: its User-Agent) gets the narrow heatmap and a line saying what a row's
    name is and where the preference's words are; a laptop's page is as before."""
    import json

    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "success_rate": [0.5],
                          "preference_accuracy": [0.5], "cumulative_feedback": [8], "interactions": [15]})
    by_pref = pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "preference": [1],
                            "label": ["Cough: pain check"], "activity": ["cough"], "action": ["pain check"],
                            "states": [40], "correct": [20], "accuracy": [0.5]})
    saved_runs.save_run(saved_runs.runs_dir(db), "run-phone", daily, pd.DataFrame({"participant": ["P01"]}), {},
                        by_pref)
    said = "Rows: participant · preference number; tap a cell for the preference's activities and action."
    for phone, rows in ((False, ["P01 · 1. cough → pain check"]), (True, ["P01 · 1"])):
        monkeypatch.setattr(ui, "on_a_phone", lambda: phone)
        at = app(PAGE)
        at.button_group[0].set_value("A simulated run").run()
        open_tab(at, "results-tab", FIG4)
        no_exception(at)
        spec = json.loads(at.get("plotly_chart")[-1].proto.spec)
        assert spec["data"][0]["y"] == rows
        assert (said in [c.value for c in at.caption]) is phone


def test_the_preference_heatmap_of_many_participants_shows_a_few_at_first(app, db, downloads):
    """Large-study walkthrough: 24 participants gave 120 heatmap rows, 3,300 px, the header gone after
    one screen. More than 8: the first 8 are shown and a list chooses others; the download stays whole."""
    import io
    import json

    import pandas as pd

    from cacas import saved_runs

    people = [f"P{i:02d}" for i in range(1, 11)]
    daily = pd.DataFrame({"participant": people, "method": ["cacas"] * 10, "day": [1] * 10,
                          "success_rate": [0.5] * 10, "preference_accuracy": [0.5] * 10,
                          "cumulative_feedback": [8] * 10, "interactions": [15] * 10})
    by_pref = pd.DataFrame({"participant": people, "method": ["cacas"] * 10, "day": [1] * 10, "preference": [1] * 10,
                            "label": ["Cough: pain check"] * 10, "activity": ["cough"] * 10,
                            "action": ["pain check"] * 10, "states": [40] * 10, "correct": [20] * 10,
                            "accuracy": [0.5] * 10})
    saved_runs.save_run(saved_runs.runs_dir(db), "run-many", daily, pd.DataFrame({"participant": people}), {},
                         by_pref)
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    open_tab(at, "results-tab", FIG4)
    no_exception(at)
    who = at.multiselect(key="results-prefs:Simulated run: run-many-who")
    assert who.value == people[:8]

    def heatmap_rows():
        spec = json.loads(at.get("plotly_chart")[-1].proto.spec)
        return [y for trace in spec["data"] for y in trace.get("y", [])]
    assert any("P08" in str(y) for y in heatmap_rows()) and not any("P09" in str(y) for y in heatmap_rows())
    who.set_value(people).run()
    assert any("P10" in str(y) for y in heatmap_rows())
    who.set_value(people[:2]).run()
    offered = downloads["results-prefs:Simulated run: run-many-dl"]  # the heatmap's own button
    assert set(pd.read_csv(io.BytesIO(offered))["participant"]) == set(people)  # whole, whoever is shown
    who.set_value([]).run()
    no_exception(at)
    assert "Choose at least one participant." in [i.value for i in at.info]
    assert "Download by_preference.csv" in [b.label for b in at.get("download_button")]
    assert len(pd.read_csv(io.BytesIO(downloads["results-prefs:Simulated run: run-many-dl"]))) == 10


def test_a_study_in_progress_can_show_only_the_days_everyone_reached(app, store):
    """Walkthrough: with P01 on day 2 and P02 on day 1, Fig. 3's line rose from day 1 (both) to day 2
    (P01 alone) only because P02 was not averaged. The researcher can keep the figures to the days
    every participant has reached; the day labels say how many each day averages."""
    _study_with_a_day(store)  # P01: day 1 closed, 2 of 3 accepted
    store.add_participant("P02")
    day = store.open_day("P02")
    for _ in range(3):
        store.record_interaction("P02", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                                 robot_action="chitchat", response="reject")
    store.close_day("P02", day)
    _a_cough(store, store.open_day("P01"))  # P01's day 2: 1 of 1 accepted
    at = app(PAGE, participant="P01")
    no_exception(at)
    days = at.radio(key="results-days")
    assert days.value == "every" and "P02 on day 1" in days.options[0] and "Only day 1" in days.options[1]
    fig3 = json.loads(at.get("plotly_chart")[0].proto.spec)
    assert fig3["layout"]["xaxis"]["ticktext"] == ["1<br>n = 2", "2<br>n = 1"]
    assert at.metric[0].label == "Day 2 mean success rate so far" and at.metric[0].value == "100%"
    days.set_value("common").run()
    no_exception(at)
    assert at.metric[0].label == "Day 1 mean success rate" and at.metric[0].value == "33%"  # (67 % + 0 %) / 2
    fig3 = json.loads(at.get("plotly_chart")[0].proto.spec)
    assert "ticktext" not in fig3["layout"]["xaxis"] and fig3["layout"]["xaxis"]["range"] == [0.5, 1.5]
    assert len(at.get("dataframe")) >= 1  # the tables stay whole
    store.close_day("P01", 2)
    day = store.open_day("P02")
    cough = dict(activity="cough", scene="bedroom", hour=8, interval_minutes=5, robot_action="pain check")
    store.record_interaction("P02", day, response="accept", **cough)
    at = app(PAGE, participant="P01")
    assert not [r for r in at.radio if r.key == "results-days"]  # everyone on day 2: nothing to choose
    for code in ("P03", "P04", "P05", "P06", "P07"):  # many behind: four named, the others counted
        store.add_participant(code)
        store.record_interaction(code, store.open_day(code), response="accept", **cough)
    at = app(PAGE, participant="P01")
    assert at.radio(key="results-days").options[0].endswith("P03 on day 1, P04 on day 1, P05 on day 1, P06 on day 1 "
                                                             "and 1 more)")


def test_a_closed_table_sends_no_rows_but_keeps_its_download(app, store, downloads):
    """Helper's profile of a 24 x 7 study: the Tables tab sent every table's rows (3.4 MB) on each load of
    the page, in expanders that were closed; a closed table is drawn once opened, its download stays."""
    _study_with_a_day(store)
    at = app(PAGE, participant="P01")
    no_exception(at)
    tables = [e for e in at.expander if ".csv · " in e.label]
    assert {"daily.csv", "interactions.csv", "adaptations.csv", "participants.csv"} <= {e.label.split(" · ")[0] for e in tables}
    drawn = {e.label.split(" · ")[0]: [type(c).__name__ for c in e.children.values()].count("Dataframe")
             for e in tables}
    assert drawn["daily.csv"] == 1  # open at first
    assert drawn["interactions.csv"] == 0 and drawn["adaptations.csv"] == 0 and drawn["participants.csv"] == 0
    assert {"dl-table-interactions", "dl-table-adaptations", "dl-table-participants"} <= set(downloads)
    assert downloads["dl-table-interactions"].decode().count("\n") == 1 + 3  # the header and the day's 3 rows


def test_the_study_tables_are_read_again_only_when_the_database_changes(app, store, monkeypatch):
    """The page read every table of the study on each run (a third of a run for a 24 x 7 study); it keeps
    them until the study database changes: through the page (a questionnaire answer), or another program."""
    import cacas.export

    _study_with_a_day(store)
    reads = []
    real = cacas.export.export_tables
    monkeypatch.setattr(cacas.export, "export_tables", lambda *a, **k: reads.append(1) or real(*a, **k))
    at = app(PAGE, participant="P01")
    at.run()
    no_exception(at)
    assert len(reads) == 1  # two runs, nothing written: read once

    def label(table: str) -> str:
        return next(e.label for e in at.expander if e.label.startswith(f"{table}.csv · "))

    assert label("questionnaire") == "questionnaire.csv · 0 rows"
    at.button_group(key="quest-score-0").set_value(9)  # written by the page's own connection
    next(b for b in at.button if b.label == "Save answer").click().run()
    no_exception(at)
    assert label("questionnaire") == "questionnaire.csv · 1 row" and len(reads) == 2
    store.add_participant("P02")  # written by another connection
    at.run()
    assert "2 participants (1 with a study day)" in texts(at) and label("participants") == "participants.csv · 2 rows"
    assert len(reads) == 3


HOLLOW = ("A hollow point is a day where a participant's success rate rests on fewer than 5 recorded interactions "
          "(its label gives the fewest)")


def test_fig3s_hollow_points_are_said_under_it(app, store):
    """Walkthrough: a hollow point labelled "fewest 2 interactions" was explained only in its hover; the
    caption says what it is while the figure has one."""
    store.add_participant("P01")
    day = store.open_day("P01")
    for _ in range(4):
        _a_cough(store, day)
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert HOLLOW in texts(at)
    _a_cough(store, day)  # the fifth: no hollow point left
    at.run()
    no_exception(at)
    assert "A hollow point" not in texts(at) and "Mean over participants; the band spans" in texts(at)


def test_comparing_a_study_with_no_closed_day_says_there_was_nothing_to_compare(app, db, store):
    """Walkthrough: "Compare methods" on a study of imported participants, none with a closed day, said
    "no new run; each method has one for every closed day ... already", as if all were compared."""
    from cacas.jobs import RUNNER

    store.add_participant("P01")
    store.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
    at = open_tab(app(PAGE, participant="P01"), "results-tab", FIG4)
    next(b for b in at.button if b.label == "Compare methods on this study's data").click().run()
    assert RUNNER.get(f"compare:{db}:default").wait(60)
    at.run()
    no_exception(at)
    said = [i.value for i in at.info if i.value.startswith("Nothing compared (")]
    assert said and "no participant with described preferences has a closed study day yet" in said[0]
    assert not [s.value for s in at.success]  # not a success: nothing was done
    RUNNER.forget(f"compare:{db}:default")


def test_a_run_each_in_its_own_loop_offers_its_methods_in_the_papers_order(app, db):
    """A --loop each run of nn, orl and cacas: Fig. 3's "Method" listed NN, ORL, CACAS (daily.csv's order, the order
    chosen) under a figure and beside a Fig. 4 that list CACAS, ORL, NN (walkthrough)."""
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame([{"participant": "P01", "method": m, "day": d, "success_rate": 0.5, "preference_accuracy": 0.5,
                           "cumulative_feedback": 5 * d, "interactions": 5} for m in ("nn", "orl", "cacas")
                          for d in (1, 2)])
    saved_runs.save_run(saved_runs.runs_dir(db), "run-each", daily, pd.DataFrame({"participant": ["P01"]}),
                        {"loop": "each"})
    at = app(PAGE)
    at.button_group[0].set_value("A simulated run").run()
    no_exception(at)
    assert at.selectbox(key="results-fig3-method").options == ["CACAS", "ORL", "NN"]
    assert at.selectbox(key="results-fig3-method").value == "cacas"
