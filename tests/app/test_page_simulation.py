import json

import pytest

from apphelpers import no_exception, save_runs, texts

from cacas.jobs import RUNNER

PAGE = "pages/simulation.py"


def test_simulation_lab_opens_with_the_example_personas(app):
    at = app(PAGE)
    no_exception(at)
    assert at.multiselect[0].value[:2] == ["P01", "P02"]


def run_small_study(at, db, methods, choose=lambda at: None):
    """P01, 2 days of 4 interactions with ``methods`` (and whatever ``choose`` sets), run on the
    page's button; waits for the background job and reruns the page. Returns the job."""
    at.multiselect[0].set_value(["P01"])
    at.number_input[0].set_value(2)   # days
    at.number_input[1].set_value(4)   # interactions a day
    at.multiselect[1].set_value(methods)
    choose(at)
    next(b for b in at.button if b.label == "Run simulation").click().run()
    job = RUNNER.get(f"simulate:{db}")
    assert job is not None and job.wait(300), "simulation did not finish"
    assert job.status == "done", job.error
    at.run()
    no_exception(at)
    return job


def test_the_methods_are_listed_by_the_names_the_figures_give_them(app):
    """The Methods picker listed the codes --methods takes ('cacas-no-pr') beside figures and captions saying
    'CACAS w/o PR' (figs); its help names the codes for the command line. The value stays the code."""
    at = app(PAGE)
    no_exception(at)
    methods = next(m for m in at.multiselect if m.label == "Methods")
    assert methods.options == ["CACAS", "CACAS w/o PR", "ORL", "NN", "Bandit (TS)", "SAC on user data"]
    assert methods.value == ["cacas", "cacas-no-pr", "orl", "nn"]
    assert "`cacas simulate --methods` takes them as cacas, cacas-no-pr, orl, nn, bandit, sac-user-data." in methods.help


def test_simulation_runs_in_the_background_and_shows_the_run(app, db):
    at = app(PAGE)
    job = run_small_study(at, db, ["nn"], lambda at: at.number_input[4].set_value(0.5))  # ask after half
    assert (job.result / "daily.csv").exists()
    # the progress bar names the running settings
    assert job.label == "Simulating P01 · 2 days · NN · seed 0"
    assert ("1 participant · 2 days · 4 interactions a day · methods NN · seed 0 · asks after 50% of rejections"
            " · personas: study_data/personas/example.json") in texts(at)
    assert json.loads((job.result / "settings.json").read_text())["personas"] == "study_data/personas/example.json"
    assert len(at.get("plotly_chart")) == 3  # Fig. 3, Fig. 4 and Fig. 4 by described preference
    assert (job.result / "by_preference.csv").exists()
    assert "Which preferences each method learnt" in texts(at)
    at.button_group(key=f"sim-prefs:{job.result.name}-view").set_value("One method, day by day").run()
    no_exception(at)
    assert at.selectbox(key=f"sim-prefs:{job.result.name}-method").value == "nn"
    assert "Download by_preference.csv" in [b.label for b in at.get("download_button")]


def test_a_second_run_is_shown_when_it_ends_not_the_one_looked_at_before(app, db):
    at = app(PAGE)
    first = run_small_study(at, db, ["nn"])
    assert at.selectbox(key="sim-run").value == first.result.name
    second = run_small_study(at, db, ["nn"], lambda at: at.number_input[2].set_value(1))  # seed 1
    assert second.result.name != first.result.name
    assert at.selectbox(key="sim-run").value == second.result.name
    assert "methods NN · seed 1" in texts(at)
    at.selectbox(key="sim-run").set_value(first.result.name).run()  # going back to the first one stays there
    assert at.selectbox(key="sim-run").value == first.result.name
    assert "methods NN · seed 0" in texts(at)


def test_a_run_started_says_where_its_progress_is(app, db):
    """Walkthrough at 1280 x 800: the progress bar and the Stop button are under the form, below the fold, and
    the click on "Run simulation" seemed to do nothing but grey out the button. A toast says it started, and
    where to follow it; once."""
    at = app(PAGE)
    at.multiselect[0].set_value(["P01"])
    at.number_input[0].set_value(2)   # days
    at.number_input[1].set_value(4)   # interactions a day
    at.multiselect[1].set_value(["nn"])
    next(b for b in at.button if b.label == "Run simulation").click().run()
    no_exception(at)
    assert [t.value for t in at.toast] == ["Simulation started: its progress, and a Stop button, are under the form."]
    job = RUNNER.get(f"simulate:{db}")
    assert job is not None and job.wait(300), "simulation did not finish"
    at.run()
    assert not at.toast  # said once


def test_each_run_opens_its_heatmap_on_its_own_last_day(app, db):
    """Walkthrough: a 3-day run ended after a 2-day one, and its heatmap by described preference opened on
    day 2, the day the slider had for the run shown before (one key for every run); the Results page keys
    it by run already."""
    save_runs(db, {"run-a": 2, "run-c": 3})
    at = app(PAGE)
    at.selectbox(key="sim-run").set_value("run-a").run()
    no_exception(at)

    def day_shown():
        return next(s.value for s in at.select_slider if s.label == "Day")

    assert day_shown() == 2
    at.selectbox(key="sim-run").set_value("run-c").run()
    no_exception(at)
    assert day_shown() == 3  # run-c's last day, not the day run-a's heatmap had
    next(s for s in at.select_slider if s.label == "Day").set_value(1).run()
    at.selectbox(key="sim-run").set_value("run-a").run()
    assert day_shown() == 2  # and run-a's own last day, not run-c's pick


def test_each_method_in_its_own_closed_loop(app, db):
    import pandas as pd

    at = app(PAGE)
    loop = next(r for r in at.radio if r.label == "Who acts with the participants")
    assert loop.value == "first"  # the paper's protocol by default
    job = run_small_study(at, db, ["nn", "bandit"], lambda at: loop.set_value("each"))
    assert "methods NN, Bandit (TS) · seed 0 · each method in its own closed loop" in texts(at)
    daily = pd.read_csv(job.result / "daily.csv")
    assert daily["success_rate"].notna().all()  # both acted
    titles = [c.proto.spec for c in at.get("plotly_chart")]
    assert any("Success rate by method, each in its own closed loop" in t for t in titles)


def test_simulation_refuses_an_empty_choice_with_the_library_message(app, db):
    at = app(PAGE)
    at.multiselect[1].set_value([])
    next(b for b in at.button if b.label == "Run simulation").click().run()
    no_exception(at)
    assert "no method given; valid: cacas, cacas-no-pr" in texts(at)  # saved_runs.check_simulation's words
    at.multiselect[0].set_value([])
    at.multiselect[1].set_value(["nn"])
    next(b for b in at.button if b.label == "Run simulation").click().run()
    no_exception(at)
    assert "choose at least one simulated participant" in texts(at)
    assert RUNNER.get(f"simulate:{db}") is None  # nothing started


def test_a_size_out_of_range_is_named_under_the_button(app, db):
    """The inputs have no bounds of their own (a bound showed a red mark and the button did nothing):
    the check names the field by its label and what is valid."""
    at = app(PAGE)
    fields = {n.label: n for n in at.number_input}
    for label, value, message in [
            ("Days", 0, "Days 0 is invalid; valid: a whole number of days from 1 to 365"),
            ("Interactions a day", 5000,
             "Interactions a day 5000 is invalid; valid: a whole number from 1 to 1440 (one a minute)"),
            ("No-response rate", 1.0, "No-response rate 1.0 is invalid; valid: 0 <= rate < 1")]:
        at = app(PAGE)
        next(n for n in at.number_input if n.label == label).set_value(value)
        next(b for b in at.button if b.label == "Run simulation").click().run()
        no_exception(at)
        assert [e.value for e in at.error] == [message]
    assert set(fields) >= {"Days", "Interactions a day", "Seed", "No-response rate", "Ask after a rejection"}
    assert RUNNER.get(f"simulate:{db}") is None  # nothing started


def test_every_problem_of_the_form_is_listed_under_the_button(app, db):
    at = app(PAGE)
    next(n for n in at.number_input if n.label == "Days").set_value(0)
    next(n for n in at.number_input if n.label == "No-response rate").set_value(1.0)
    at.multiselect[1].set_value([])
    next(b for b in at.button if b.label == "Run simulation").click().run()
    no_exception(at)
    assert [e.value for e in at.error] == [
        "- no method given; valid: cacas, cacas-no-pr, orl, nn, bandit, sac-user-data\n"
        "- Days 0 is invalid; valid: a whole number of days from 1 to 365\n"
        "- No-response rate 1.0 is invalid; valid: 0 <= rate < 1"]
    assert RUNNER.get(f"simulate:{db}") is None  # nothing started


def test_a_run_folder_without_its_interactions_is_named_not_a_crash(app, db):
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [1], "success_rate": [0.3],
                          "preference_accuracy": [0.2], "cumulative_feedback": [8], "interactions": [15]})
    folder = saved_runs.save_run(saved_runs.runs_dir(db), "run-a", daily, pd.DataFrame({"participant": ["P01"]}),
                                  {"participants": ["P01"], "days": 1, "interactions": 15, "methods": ["cacas"],
                                   "seed": 3})
    at = app(PAGE)
    no_exception(at)
    assert "1 participant · 1 day · 15 interactions a day · methods CACAS · seed 3" in texts(at)
    (folder / "interactions.csv").unlink()
    at.run()
    no_exception(at)
    assert "no interactions.csv; not a complete run" in texts(at)


def test_simulation_lab_offers_the_leave_me_alone_examples(app):
    at = app(PAGE)
    at.radio[0].set_value("The same, each with a 'leave me alone' preference (Q01-Q08)").run()
    no_exception(at)
    assert at.multiselect[0].value == [f"Q{i:02d}" for i in range(1, 9)]


def _forms(node):
    """The form blocks under an AppTest node (AppTest has no accessor for forms)."""
    found = [node] if getattr(node, "type", None) == "form" else []
    for child in (node.children.values() if isinstance(getattr(node, "children", None), dict) else []):
        found += _forms(child)
    return found


def test_enter_in_a_field_does_not_start_a_run(app):
    """A long run starts only on its button, not when Enter is pressed in "Days"."""
    at = app(PAGE)
    no_exception(at)
    form = next(f for f in _forms(at._tree) if f.proto.form.form_id == "simulation")
    assert form.proto.form.enter_to_submit is False


def test_a_method_without_a_success_rate_shows_a_dash_not_none(app, db):
    at = app(PAGE)
    run_small_study(at, db, ["nn", "bandit"])  # Fig. 4 protocol: only nn acts
    """... and the shares stay numbers (percent), so that the columns sort as numbers."""
    element = next(d for d in at.dataframe if "success_rate" in d.value.columns)
    assert element.proto.placeholder == "–"
    table = element.value
    rows = table.set_index(["method", "day"])
    assert rows.loc["Bandit (TS)", "success_rate"].isna().all()
    nn = rows.loc["NN", "success_rate"]
    assert nn.notna().all() and nn.between(0, 100).all() and (nn > 1).any()  # percent, not shares
    assert table["preference_accuracy"].between(0, 100).all()
    config = json.loads(element.proto.columns)
    assert all(config[c]["type_config"]["format"] == "%.0f%%" for c in ("success_rate", "preference_accuracy"))
    # the bandit's cumulative feedback is NN's (it adapted from NN's interactions): the column says so
    assert (rows.loc["Bandit (TS)", "cumulative_feedback"] == rows.loc["NN", "cumulative_feedback"]).all()
    assert "it adapted from the interactions of the first method, so it shows that method's count" in (
        config["cumulative_feedback"]["help"])


def test_a_run_of_this_studys_participants_keeps_none_of_their_words(app, db, store):
    """Walkthrough: a run over the study's participants wrote each preference's own words into
    its by_preference.csv, which stays after the participant is removed ("Simulation lab runs are
    not participant data")."""
    import pandas as pd

    store.add_participant("P01")
    store.save_preferences("P01", [{"description": "When I cough at night, ask whether I am in pain",
                                    "activity": ["cough"], "action": "pain check"}])
    at = app(PAGE)
    at.radio(key="sim-source").set_value("This study's participants").run()
    job = run_small_study(at, db, ["nn"])
    labels = pd.read_csv(job.result / "by_preference.csv")["label"]
    assert set(labels) == {"cough -> pain check"}
    assert not [f.name for f in job.result.iterdir() if f.suffix in (".csv", ".json", ".html")
                and "ask whether I am in pain" in f.read_text()]


@pytest.fixture
def held_run(monkeypatch):
    """The page's simulation, held running until the test lets it go (``release``); the page's
    settings of it are recorded in ``calls``."""
    import threading

    from cacas import saved_runs

    gate, calls = threading.Event(), []

    def run(participants, out_root, progress=None, **settings):
        calls.append(dict(settings, participants=[p.id for p in participants]))
        progress(0.1, "simulating")
        gate.wait(60)
        raise RuntimeError("released by the test")

    monkeypatch.setattr(saved_runs, "run_simulation", run)
    yield gate.set, calls
    gate.set()


def test_a_participant_added_to_the_study_since_is_chosen_with_the_others(app, db, store, held_run):
    """The form keeps the participants chosen among the study's; one added to the study later was
    left out (review): it is chosen, as every participant is at first, and one left out stays so."""
    release, calls = held_run
    for code in ("P01", "P02", "P03"):
        store.add_participant(code)
        store.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
    at = app(PAGE)
    at.radio(key="sim-source").set_value("This study's participants").run()
    at.multiselect[0].set_value(["P01", "P02"])  # P03 left out on purpose
    next(b for b in at.button if b.label == "Run simulation").click().run()
    assert calls[0]["participants"] == ["P01", "P02"]
    release()
    assert RUNNER.get(f"simulate:{db}").wait(60)
    store.add_participant("P04")
    store.save_preferences("P04", [{"activity": ["cough"], "action": "pain check"}])
    at.switch_page("pages/overview.py")
    at.run()
    at.switch_page(PAGE)
    at.run()
    no_exception(at)
    assert at.multiselect[0].value == ["P01", "P02", "P04"]


def test_the_studys_participants_are_offered_by_code_whatever_its_letter_case(app, db, store, held_run):
    """Offered as the sidebar lists them ("p01, R01, r02"; sorted as stored: "R01, p01, r02"); a run keeps each
    participant's place (random stream) in the exact code's order, as before."""
    release, calls = held_run
    for code in ("r02", "R01", "p01"):
        store.add_participant(code)
        store.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
    at = app(PAGE)
    at.radio(key="sim-source").set_value("This study's participants").run()
    assert at.multiselect[0].options == ["p01", "R01", "r02"] and at.multiselect[0].value == ["p01", "R01", "r02"]
    at.multiselect[0].set_value(["r02", "p01"])
    next(b for b in at.button if b.label == "Run simulation").click().run()
    no_exception(at)
    assert (calls[0]["participants"], calls[0]["places"]) == (["r02", "p01"], [2, 1])  # R01 p01 r02, as before
    release()
    assert RUNNER.get(f"simulate:{db}").wait(60)


def _form(at):
    """What the form shows: the persona source, the participants, the sizes, methods and who acts."""
    sizes = {n.label: n.value for n in at.number_input}
    loop = next(r for r in at.radio if r.label == "Who acts with the participants")
    return (at.radio(key="sim-source").value, at.multiselect[0].value, sizes, at.multiselect[1].value, loop.value)


def test_the_form_keeps_the_researchers_choices_while_other_pages_are_open(app, db, held_run):
    """Walkthrough: a 2-participant, 3-day, 2-method run was started; after a visit to the Overview
    the form showed its defaults again (8 participants x 7 days x 4 methods), so a second click on
    Run would have started the long default study."""
    release, calls = held_run
    at = app(PAGE)
    at.radio(key="sim-source").set_value("The same, each with a 'leave me alone' preference (Q01-Q08)").run()
    at.multiselect[0].set_value(["Q01", "Q02"])
    fields = {n.label: n for n in at.number_input}
    for label, value in (("Days", 3), ("Interactions a day", 5), ("Seed", 4), ("No-response rate", 0.2),
                         ("Ask after a rejection", 0.3)):
        fields[label].set_value(value)
    at.multiselect[1].set_value(["nn", "bandit"])
    next(r for r in at.radio if r.label == "Who acts with the participants").set_value("each")
    next(b for b in at.button if b.label == "Run simulation").click().run()
    no_exception(at)
    assert calls == [dict(days=3, interactions=5, methods=("nn", "bandit"), seed=4, no_response_rate=0.2,
                          ask_after_reject=0.3, loop="each", personas="study_data/personas/example_leave_me_alone.json",
                          participants=["Q01", "Q02"], places=[0, 1])]
    chosen = ("The same, each with a 'leave me alone' preference (Q01-Q08)", ["Q01", "Q02"],
              {"Days": 3, "Interactions a day": 5, "Seed": 4, "No-response rate": 0.2, "Ask after a rejection": 0.3},
              ["nn", "bandit"], "each")
    assert _form(at) == chosen
    at.switch_page("pages/overview.py")
    at.run()
    no_exception(at)
    at.switch_page(PAGE)
    at.run()
    no_exception(at)
    assert _form(at) == chosen  # it showed the defaults: P01-P08, 7 days, 4 methods
    assert next(b for b in at.button if b.label == "Run simulation").disabled  # the run is going
    release()
    assert RUNNER.get(f"simulate:{db}").wait(60)
    at.switch_page("pages/overview.py")
    at.run()
    at.switch_page(PAGE)
    at.run()
    no_exception(at)
    assert _form(at) == chosen  # after the run too: a second click runs the same study again


def test_while_a_run_is_going_the_form_shows_its_choices(app, db, held_run):
    """A second browser tab (another session) opened during a run showed the defaults in the form
    while the progress bar named the running settings."""
    release, calls = held_run
    first = app(PAGE)
    first.multiselect[0].set_value(["P03"])
    next(n for n in first.number_input if n.label == "Days").set_value(2)
    first.multiselect[1].set_value(["orl"])
    next(b for b in first.button if b.label == "Run simulation").click().run()
    assert len(calls) == 1
    second = app(PAGE)
    no_exception(second)
    source, who, sizes, methods, loop = _form(second)
    assert (source, who, sizes["Days"], sizes["Interactions a day"], methods, loop) == (
        "Example personas (P01-P08)", ["P03"], 2, 15, ["orl"], "first")
    # once shown, the choices are the researcher's again: another persona source is not put back by the rerun
    other = "The same, each with a 'leave me alone' preference (Q01-Q08)"
    second.radio(key="sim-source").set_value(other).run()
    no_exception(second)
    assert (second.radio(key="sim-source").value, second.multiselect[0].value[0]) == (other, "Q01")
    release()
    assert RUNNER.get(f"simulate:{db}").wait(60)


def test_an_uploaded_persona_file_is_kept_while_other_pages_are_open(app, db):
    """The uploader, not drawn on another page, forgot the file: back on the page the form had no
    participants. The file stays in use, said under the uploader, until another one is uploaded."""
    from cacas.paths import study_data_dir

    data = (study_data_dir() / "personas" / "example.json").read_bytes()
    at = app(PAGE)
    at.radio(key="sim-source").set_value("Upload a persona file").run()
    at.file_uploader(key="sim-upload").upload("mine.json", data, "application/json").run()
    no_exception(at)
    at.multiselect[0].set_value(["P02", "P05"])
    next(n for n in at.number_input if n.label == "Days").set_value(0)  # refused: the form is submitted, no run
    next(b for b in at.button if b.label == "Run simulation").click().run()
    at.switch_page("pages/overview.py")
    at.run()
    at.switch_page(PAGE)
    at.run()
    no_exception(at)
    assert (at.radio(key="sim-source").value, at.multiselect[0].value) == ("Upload a persona file", ["P02", "P05"])
    assert next(n for n in at.number_input if n.label == "Days").value == 0
    assert "mine.json, uploaded before in this browser tab. Upload another file to replace it." in texts(at)
    at.run()  # a rerun on the page keeps it
    assert at.multiselect[0].value == ["P02", "P05"]
    at.file_uploader(key="sim-upload").upload("mine.json", data, "application/json").run()  # again, then removed
    assert "uploaded before" not in texts(at)
    at.file_uploader(key="sim-upload").set_value(None).run()  # by the researcher: gone
    no_exception(at)
    assert at.multiselect[0].value == [] and "uploaded before" not in texts(at)


def test_a_run_of_some_participants_seeds_each_by_its_place_in_the_file(app, db, held_run):
    """The lab gives simulate_study each chosen participant's place in the persona file, not in the
    choice, so P03 gets the rows `cacas simulate` gives P03 from the whole file (or --participants)."""
    release, calls = held_run
    at = app(PAGE)
    at.multiselect[0].set_value(["P03", "P01"])
    next(b for b in at.button if b.label == "Run simulation").click().run()
    assert calls[0]["participants"] == ["P03", "P01"] and calls[0]["places"] == [2, 0]
    release()
    assert RUNNER.get(f"simulate:{db}").wait(60)


def test_a_runs_downloads_are_named_after_the_run(app, db, downloads):
    """Walkthrough: the tables downloaded as plain "daily.csv", "interactions.csv" ..., and two runs' files
    met in a Downloads folder as "daily (1).csv"; named after the run now, as Results names them, and as its
    folder is named (the ui helper: "daily-20260301_101500_seed0_1p_2d.csv" of the folder
    20260301-101500-seed0-1p-2d, its "-" made "_")."""
    run = "20260301-101500-seed0-1p-2d"  # as saved_runs.new_run_name names a run
    save_runs(db, {run: 2})
    at = app(PAGE)
    no_exception(at)
    assert {f"daily-{run}.csv", f"interactions-{run}.csv", f"summary-{run}.csv",
            f"by_preference-{run}.csv"} <= set(downloads.at_click)
    assert not [f for f in downloads.at_click if f in ("daily.csv", "interactions.csv", "summary.csv")]
    assert {"Download daily.csv", "Download by_preference.csv"} <= {b.label for b in at.get("download_button")}


def test_a_whole_run_downloads_as_a_zip_of_its_folder_with_its_checksums(app, db, downloads):
    """Walkthrough: the run's files came one by one, without the checksums.sha256 Results' upload asks
    for; the whole folder is one zip now, named after it."""
    import io
    import zipfile

    from cacas import saved_runs

    run = "20260301-101500-seed0-1p-2d"
    save_runs(db, {run: 2})
    at = app(PAGE)
    no_exception(at)
    assert "Download the whole run (zip of its folder)" in [b.label for b in at.get("download_button")]
    with zipfile.ZipFile(io.BytesIO(downloads[f"cacas-run-{run}.zip"])) as zf:
        names = zf.namelist()
        folder = saved_runs.runs_dir(db) / run
        assert f"{run}/checksums.sha256" in names and f"{run}/daily.csv" in names
        assert all(zf.read(n) == (folder / n.split("/", 1)[1]).read_bytes() for n in names)


def test_fig3s_hollow_points_are_said_under_it(app, db):
    """Walkthrough: "fewest 2 interactions" beside a hollow point on Fig. 3, said nowhere on the page but
    in its hover: a caption under the figure says what it is while the run has one."""
    import pandas as pd

    from cacas import saved_runs

    save_runs(db, {"run-a": 2})  # 15 interactions a day: nothing hollow
    at = app(PAGE)
    no_exception(at)
    assert "A hollow point" not in texts(at)
    daily = pd.DataFrame({"participant": ["P01", "P01"], "method": ["cacas", "cacas"], "day": [1, 2],
                          "success_rate": [0.5, 1.0], "preference_accuracy": [0.2, 0.4],
                          "cumulative_feedback": [15, 17], "interactions": [15, 2]})
    saved_runs.save_run(saved_runs.runs_dir(db), "run-b", daily, pd.DataFrame({"participant": ["P01"]}), {})
    at.run().selectbox(key="sim-run").set_value("run-b").run()
    no_exception(at)
    assert ("A hollow point is a day where a participant's success rate rests on fewer than 5 recorded "
            "interactions (its label gives the fewest)") in texts(at)


def test_fig3_by_methods_hollow_points_are_said_under_it(app, db):
    """walk2: Fig. 3 by method (--loop each) now marks a day resting on few answers hollow, as Fig. 3 does;
    the caption under it says what a hollow point is (its hover gives the fewest)."""
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame([{"participant": "P01", "method": m, "day": d, "success_rate": 0.5, "preference_accuracy": 0.5,
                           "cumulative_feedback": 5 * d, "interactions": 2 if (m, d) == ("nn", 2) else 15}
                          for m in ("cacas", "nn") for d in (1, 2)])
    saved_runs.save_run(saved_runs.runs_dir(db), "run-each", daily, pd.DataFrame({"participant": ["P01"]}),
                        {"loop": "each", "methods": ["cacas", "nn"]})
    at = app(PAGE)
    no_exception(at)
    assert ("A hollow point is a day where a participant's success rate rests on fewer than 5 recorded "
            "interactions (its hover gives the fewest)") in texts(at)


def test_a_runs_table_and_figures_list_the_methods_in_the_papers_order(app, db):
    """A run of nn, orl and cacas, each in its own closed loop (daily.csv in the order chosen): the lab's table and
    Fig. 3 listed NN, ORL, CACAS beside Fig. 4's CACAS, ORL, NN (walkthrough); every one now in the paper's order."""
    import pandas as pd

    from cacas import saved_runs

    daily = pd.DataFrame([{"participant": "P01", "method": m, "day": d, "success_rate": 0.5, "preference_accuracy": 0.5,
                           "cumulative_feedback": 5 * d, "interactions": 5} for m in ("nn", "orl", "cacas")
                          for d in (1, 2)])
    saved_runs.save_run(saved_runs.runs_dir(db), "run-each", daily, pd.DataFrame({"participant": ["P01"]}),
                        {"loop": "each", "methods": ["nn", "orl", "cacas"]})
    at = app(PAGE)
    no_exception(at)
    table = next(d for d in at.dataframe if "success_rate" in d.value.columns).value
    assert list(dict.fromkeys(table["method"])) == ["CACAS", "ORL", "NN"]
    specs = [json.loads(c.proto.spec) for c in at.get("plotly_chart")[:2]]
    assert [[t["name"] for t in spec["data"]] for spec in specs] == [["CACAS", "ORL", "NN"]] * 2


def test_an_uploaded_persona_file_lists_every_problem_one_a_line(app):
    """The file's problems all at once (walk3: three mistakes, three tries), one a line under the uploader."""
    data = json.dumps({"participants": [
        {"id": "P01", "preferences": [{"activity": ["coughing"], "action": "pain check"}]},
        {"id": "P02", "preferences": [{"activity": ["cough"], "action": "dance"}]}]}).encode()
    at = app(PAGE)
    at.radio(key="sim-source").set_value("Upload a persona file").run()
    at.file_uploader(key="sim-upload").upload("mine.json", data, "application/json").run()
    no_exception(at)
    [error] = [e.value for e in at.error]
    assert error.splitlines()[0] == "mine.json: 2 problems, each to mend:"
    assert error.splitlines()[2].startswith("1. participant P01, preference 1, field 'activity': unknown activity "
                                            "'coughing'; did you mean 'cough'?")
    assert error.splitlines()[3].startswith("2. participant P02, preference 1, field 'action': unknown action 'dance'")


def test_the_form_opens_with_the_commands_defaults(app):
    """The README: the Simulation lab runs the same study as `cacas simulate`. Its form's days, interactions a day,
    seed, no-response rate, ask-after-reject rate and methods are the command's defaults (twins kept apart: the page's
    literals beside the parser's; a docs walkthrough compared them by hand)."""
    from cacas.cli import build_parser

    simulate = build_parser().parse_args(["simulate", "--personas", "p.json", "--out", "o"])
    at = app(PAGE)
    no_exception(at)
    shown = {n.label: n.value for n in at.number_input}
    assert shown == {"Days": simulate.days, "Interactions a day": simulate.interactions, "Seed": simulate.seed,
                     "No-response rate": simulate.no_response_rate, "Ask after a rejection": simulate.ask_after_reject}
    methods = next(m for m in at.multiselect if m.label == "Methods")
    assert ",".join(methods.value) == simulate.methods
