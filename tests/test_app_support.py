import math

import pandas as pd
import pytest

from cacas import app_support, records
from cacas.recent_activity import recent_events
from cacas.store import StudyStore
from studies import cough_day
from cacas.study_day import STUDY_DAYS


def test_questionnaire_summary_matches_the_papers_definition():
    # 8 ratings with mean 8.125, sample SD 0.64 and 7 of 8 at 8 or above (Section V-B.2)
    answers = pd.DataFrame({"participant": [f"P0{i}" for i in range(1, 9)],
                            "satisfaction": [7, 8, 8, 8, 8, 8, 9, 9]})
    s = app_support.questionnaire_summary(answers)
    assert s["n"] == 8 and s["mean"] == pytest.approx(8.125)
    assert s["sd"] == pytest.approx(0.641, abs=1e-3) and s["share_8_or_more"] == pytest.approx(0.875)
    # the latest answer of a participant counts
    again = pd.concat([answers, pd.DataFrame({"participant": ["P01"], "satisfaction": [10]})])
    assert app_support.questionnaire_summary(again)["mean"] == pytest.approx(8.5)
    empty = app_support.questionnaire_summary(answers.iloc[:0])
    assert empty["n"] == 0 and math.isnan(empty["mean"])
    assert s["mid_study"] == []  # a table without days (an upload): none named


def test_answers_given_before_the_last_day_are_named():
    """Review: an answer given on day 1 counted in the mean, SD and share at 8 or more without a
    word (the paper asks after the 7 days); the latest answer decides."""
    answers = pd.DataFrame({"participant": ["P01", "P02", "P03", "P03"], "day": [7, 1, 2, 7],
                            "satisfaction": [9, 10, 6, 8]})
    s = app_support.questionnaire_summary(answers)
    assert s["n"] == 3 and s["mid_study"] == ["P02"]


def test_overview_says_who_still_owes_the_questionnaire(tmp_path):
    """After day 7 the next step is the post-test questionnaire until an answer given after the study
    is recorded (one given mid-study is not the post-test)."""
    store = StudyStore(tmp_path / "s.sqlite")
    for code in ("P01", "P02"):
        store.add_participant(code)
        store.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
        for _ in range(STUDY_DAYS):
            day = store.open_day(code)
            if day == 3:
                store.record_questionnaire(code, 5)  # mid-study: not the post-test
            store.close_day(code, day)
    steps = lambda: dict(zip(*app_support.overview_frame(store)[["participant", "next step"]].T.values))
    assert steps() == {"P01": "Study done: record the questionnaire (Results)",
                       "P02": "Study done: record the questionnaire (Results)"}
    store.record_questionnaire("P02", 9)
    assert steps() == {"P01": "Study done: record the questionnaire (Results)",
                       "P02": "Study done; questionnaire recorded"}
    store.close()


def test_overview_reads_the_studys_interactions_once(tmp_path, monkeypatch):
    """Scale walk (60 participants x 21 days): the Overview filtered the study's interactions once per
    participant and read each one's latest day again (day_status), a third of its run; now one read, with
    each row as day_status alone says it: an open day's recorded interactions (not the unanswered one), a
    closed day's 0, someone with none."""
    from cacas.study_day import day_status

    store = StudyStore(tmp_path / "s.sqlite")
    cough_day(store, "P01", answers=[("pain check", "accept"), ("chitchat", "reject"), ("pain check", "others")])
    cough_day(store, "P02", answers=[("chitchat", "accept")])
    store.close_day("P02", 1)
    store.add_participant("P03")
    reads = []
    real = store.interactions_frame
    monkeypatch.setattr(store, "interactions_frame", lambda *a, **k: reads.append((a, k)) or real(*a, **k))
    table = app_support.overview_frame(store).set_index("participant")
    assert len(reads) == 1
    assert table["interactions today"].to_dict() == {"P01": 2, "P02": 0, "P03": 0}
    assert day_status(store, "P01").recorded_today == 2
    assert table.loc["P01", "success rate so far"] == pytest.approx(0.5)
    assert table.loc["P02", "success rate so far"] == pytest.approx(1.0)
    assert math.isnan(table.loc["P03", "success rate so far"]) and table.loc["P03", "last recorded"] == ""
    assert table["next step"].to_dict() == {"P01": "Day 1: 13 more interactions on the tablet",
                                            "P02": "Adapt after day 1 (Adaptation)",
                                            "P03": "Describe 5 preferences (Participants)"}
    store.close()


def test_overview_and_events(tmp_path):
    store = StudyStore(tmp_path / "s.sqlite")
    day = cough_day(store, answers=[("pain check", "accept"), ("chitchat", "reject")])
    table = app_support.overview_frame(store)
    row = table.iloc[0]
    assert row["day"] == "1 of 7 (open)" and row["interactions today"] == 2
    assert row["success rate so far"] == pytest.approx(0.5)
    assert row["next step"] == "Day 1: 13 more interactions on the tablet"
    assert row["policy"] == "initial"
    words = list(recent_events(store)["what"])
    assert words[0] == "day 1, interaction 2: robot proposed 'chitchat', rejected"
    assert "preferences saved (version 1, 1 preference)" in words
    for robot in ("do nothing", "chitchat"):  # a request on the robot's silence, or instead of its proposal
        store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                                 robot_action=robot, response="accept", type="type_2", user_action="pain check")
    words = list(recent_events(store)["what"])
    assert words[:2] == ["day 1, interaction 4: robot proposed 'chitchat', participant asked for 'pain check' instead",
                         "day 1, interaction 3: asked for 'pain check'"]
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="do nothing", response="others")
    assert recent_events(store)["what"].iloc[0] == "day 1, interaction 5: robot stayed quiet, nothing asked"
    # one study's events: another study's participant is not in them
    store.create_study("pilot")
    store.add_participant("Q01", study="pilot")
    assert set(recent_events(store, study="default", limit=50)["participant"]) == {"P01"}
    pilot = recent_events(store, study="pilot", limit=50)
    assert pilot["participant"].tolist() == ["Q01", ""] and pilot["what"].iloc[-1] == "study pilot created"
    # Fig. 3's rate is of the recorded interactions: an unanswered proposal is not one (Section V-B)
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="others")
    assert app_support.overview_frame(store, "default").iloc[0]["success rate so far"] == pytest.approx(1 / 4)
    # "last recorded" is the last interaction's time: a questionnaire answered later does not move it
    last = app_support.short_time(store.interactions_frame(method=None)["time"].max())
    assert app_support.overview_frame(store, "default").iloc[0]["last recorded"] == last
    from cacas.store import validate
    with pytest.MonkeyPatch.context() as mp:  # answered on a later day
        mp.setattr(validate, "now", lambda: "2099-01-01T10:00:00.000Z")
        store.record_questionnaire("P01", 8)
    assert app_support.overview_frame(store, "default").iloc[0]["last recorded"] == last
    assert app_support.overview_frame(store, "pilot").iloc[0]["last recorded"] == ""  # Q01: none yet
    store.close()


def test_interactions_view_shows_what_the_robot_heard_and_a_request(tmp_path):
    store = StudyStore(tmp_path / "s.sqlite")
    store.add_participant("P01")
    day = store.open_day("P01")
    store.record_interaction("P01", day, activity="use stove", scene="kitchen", hour=8, interval_minutes=5,
                             robot_action="remind to put back", response="reject", recognised_activity="use scissor")
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=9, interval_minutes=5,
                             robot_action="set a timer", response="accept", type="type_2", user_action="pain check")
    view = app_support.interactions_view(store.interactions_frame("P01", method=None, extra=True))
    assert list(view["robot heard"]) == ["use scissor", "(as set)"]  # misheard; no recogniser: as set
    assert list(view["since last activity"]) == ["5-10 min", "5-10 min"]  # S4
    assert list(view["robot saw"]) == ["(as set)", "(as set)"]  # the CSV's recognised_scene is empty too
    assert list(view["robot proposed"]) == ["remind to put back", "set a timer"]
    assert list(view["answer"]) == ["rejected", "asked for pain check"]
    assert list(app_support.interactions_view(view.iloc[0:0]).columns) == list(view.columns)
    store.close()


def test_a_models_synthetic_share_is_said_all_some_or_none():
    assert app_support.synthetic_words({"synthetic": True, "synthetic_items": 792}) == " (synthetic)"
    assert app_support.synthetic_words({"synthetic": False, "synthetic_items": 131}) == " (131 synthetic)"
    assert app_support.synthetic_words({"synthetic": False, "synthetic_items": 0}) == ""
    assert app_support.synthetic_words({"synthetic": False}) == ""  # trained before the count was kept
    assert app_support.synthetic_words({}) == ""


def test_short_time_of_a_stamp_or_epoch_seconds():
    assert app_support.short_time("2026-11-21T09:47:34.123Z") == "2026-11-21 09:47 UTC"
    assert app_support.short_time(0.0) == "1970-01-01 00:00 UTC"
    assert app_support.short_time(1_795_000_000) == "2026-11-18 11:06 UTC"


def test_short_time_of_a_stamp_with_an_offset_or_without_a_zone():
    """A study imported with times as an older version stored them (kept as they were, with a note: an offset, or no
    zone) had its text cut and called UTC: "2026-10-26T01:30:00+02:00" read "2026-10-26 01:30 UTC" on the Overview, for
    2026-10-25 23:30 UTC; a time without a zone was called UTC too. A model's "trained" time has an offset of +00:00."""
    assert app_support.short_time("2026-10-26T01:30:00+02:00") == "2026-10-25 23:30 UTC"
    assert app_support.short_time("2026-03-29T03:00:00.5+02:00") == "2026-03-29 01:00 UTC"  # Berlin's DST day
    assert app_support.short_time("2026-11-21T18:40:00+00:00") == "2026-11-21 18:40 UTC"
    assert app_support.short_time("2026-03-29T00:59:59") == "2026-03-29 00:59 (no time zone)"
    assert app_support.short_time("2026-03-29") == "2026-03-29"  # a date alone, and what is no time, as it is
    assert app_support.short_time("not a time, but long") == "not a time, but long"


def test_last_recorded_is_the_latest_moment_whatever_the_times_offset(tmp_path):
    """A study imported from an older version keeps an interaction time with an offset as it was (with a note):
    "2026-10-26T00:30:00+02:00" (2026-10-25 22:30 UTC, Berlin's night the clocks go back) sorted as text after
    "2026-10-25T23:00:01.000Z", and the Overview's "last recorded" named the earlier interaction, with its date."""
    import sqlite3

    store = StudyStore(tmp_path / "s.sqlite")
    day = cough_day(store, answers=[("pain check", "accept")] * 2)
    store.close()
    with sqlite3.connect(tmp_path / "s.sqlite") as db:  # as an import of an older version's bundle leaves them
        db.execute("UPDATE interactions SET time = '2026-10-26T00:30:00+02:00' WHERE idx = 1")
        db.execute("UPDATE interactions SET time = '2026-10-25T23:00:01.000Z' WHERE idx = 2")
    store = StudyStore(tmp_path / "s.sqlite")
    assert day == 1 and app_support.overview_frame(store).iloc[0]["last recorded"] == "2026-10-25 23:00 UTC"
    store.close()


def test_participants_are_said_by_code_whatever_its_letter_case():
    """Notes and tables name participants as a person reads the codes ("p01, R01, r02"; sorted as stored,
    capitals first: "R01, p01, r02")."""
    import pandas as pd

    left = pd.DataFrame([{"participant": who, "day": 1, "missing": ["nn"]} for who in ("r02", "R01")]
                        + [{"participant": "p01", "day": 2, "missing": ["nn"]}])
    assert app_support.left_out_note(left).endswith("left out: p01 day 2 (no NN); R01, r02 day 1 (no NN).")
    left = left.assign(day=1)
    assert app_support.left_out_note(left).endswith("left out: p01, R01, r02 day 1 (no NN).")
    ahead = pd.DataFrame([{"participant": who, "day": day, "method": "cacas", "preference_accuracy": 0.5,
                           "in_force": True} for who in ("r02", "R01", "p01") for day in (3, 2)])
    view = app_support.next_day_view(ahead)
    assert list(zip(view["participant"], view["day"])) == [("p01", 2), ("p01", 3), ("R01", 2), ("R01", 3),
                                                           ("r02", 2), ("r02", 3)]


def test_day_ranges_and_the_fig4_left_out_note():
    import pandas as pd

    from cacas.app_support import day_ranges, left_out_note
    assert day_ranges([5, 1, 2, 3, 2.0]) == "1-3, 5" and day_ranges([4]) == "4"
    left = pd.DataFrame([{"participant": "W02", "day": 1, "missing": ["cacas-no-pr", "orl", "nn"]},
                         {"participant": "W02", "day": 2, "missing": ["cacas-no-pr", "orl", "nn"]},
                         {"participant": "W03", "day": 4, "missing": ["nn"]}])
    assert left_out_note(left, again=True) == (
        " Methods are compared on the same participants, so these are left out: W02 days 1-2 (no CACAS w/o PR, "
        "ORL, NN); W03 day 4 (no NN); compare methods again to add them.")
    assert left_out_note(left.iloc[2:]).endswith("W03 day 4 (no NN).")
    assert left_out_note(left.iloc[:0]) == ""
    # large-study walkthrough: days lacking different methods were lumped under one list (P06 had w/o PR
    # on days 1-2), and 19 participants lacking the same were named one by one
    every = ["cacas-no-pr", "orl", "nn"]
    left = pd.DataFrame([{"participant": "P06", "day": d, "missing": ["orl", "nn"] if d <= 2 else every}
                         for d in range(1, 8)]
                        + [{"participant": who, "day": d, "missing": every} for who in ("P07", "P08", "R01")
                           for d in range(1, 8)])
    assert left_out_note(left) == (
        " Methods are compared on the same participants, so these are left out: P06 days 1-2 (no ORL, NN), "
        "days 3-7 (no CACAS w/o PR, ORL, NN); P07, P08, R01 days 1-7 (no CACAS w/o PR, ORL, NN).")


def test_days_recorded_since_the_last_comparison_are_named():
    """Walkthrough: after comparing on day 2 and recording days 3-4, Fig. 4's baselines stopped at
    day 3 with nothing saying why."""
    import pandas as pd

    rows = [("P01", "cacas", d, 0.5) for d in (1, 2, 3, 4)] + [("P01", m, d, 0.3) for m in ("orl", "nn")
                                                               for d in (1, 2)]
    rows += [("P02", "cacas", 1, 0.4), ("P02", "cacas", 2, None), ("P02", "orl", 1, 0.2), ("P02", "nn", 1, 0.2)]
    daily = pd.DataFrame(rows, columns=["participant", "method", "day", "preference_accuracy"])
    assert app_support.uncompared_note(daily) == (
        " Not compared yet, so CACAS alone: P01 days 3-4; compare methods again to add them.")
    assert app_support.uncompared_note(daily[daily["day"] <= 2]) == ""  # every scored day compared
    assert app_support.uncompared_note(daily[daily["method"] == "cacas"]) == ""  # never compared: the button says it


def test_overview_names_the_newest_policy_after_a_roll_back(tmp_path):
    """Walkthrough: after a roll-back the Overview read "version 1", as if no later version existed."""
    store = StudyStore(tmp_path / "s.sqlite")
    store.add_participant("P01")
    day = store.open_day("P01")
    store.close_day("P01", day)
    for run in (1, 2):  # adapted twice after day 1
        store.save_policy("P01", day, "cacas", f"policy {run}".encode())
    assert app_support.overview_frame(store).iloc[0]["policy"] == "version 2"
    store.set_active_policy("P01", 1)
    assert app_support.overview_frame(store).iloc[0]["policy"] == "version 1 (newest: 2)"
    store.set_active_policy("P01", None)
    assert app_support.overview_frame(store).iloc[0]["policy"] == "initial (newest: 2)"


def test_the_next_step_once_a_day_has_its_interactions_is_to_close_and_adapt():
    """The paper's ~15 recorded interactions a day (answered or asked for; unanswered moments do
    not count): then the overview says to close the day and adapt."""
    from cacas.study_day import DayStatus

    def status(saved, recorded):
        return DayStatus(day=2, open=True, interactions_today=saved, total_interactions=20 + saved,
                         policy_version=1, waiting_for_adaptation=False, finished=False, recorded_today=recorded)

    assert app_support.next_step(True, status(16, 14)) == "Day 2: 1 more interaction on the tablet"  # one, not "1 more interactions"
    assert app_support.next_step(True, status(17, 15)) == "Close day 2 and adapt (Adaptation)"
    assert app_support.next_step(True, status(20, 20)) == "Close day 2 and adapt (Adaptation)"


def test_the_days_count_says_the_plan_apart_once_past_it():
    assert app_support.day_count(0) == "0 of about 15 interactions today"
    assert app_support.day_count(15) == "15 of about 15 interactions today"
    assert app_support.day_count(54) == "54 interactions today (about 15 planned)"


def test_the_sidebar_starts_at_the_participant_last_worked_with(tmp_path):
    with StudyStore(tmp_path / "s.sqlite") as store:
        assert app_support.last_participant(store) is None
        store.add_participant("P02")
        store.add_participant("P01")
        store.create_study("pilot")
        store.add_participant("Q01", study="pilot")
        assert app_support.last_participant(store, "default") == "P01"  # added last
        store.record_interaction("P02", store.open_day("P02"), activity="cough", scene="bedroom", hour=8,
                                 interval_minutes=5, robot_action="pain check", response="accept")
        assert app_support.last_participant(store, "default") == "P02"  # answered last
        assert app_support.last_participant(store, "pilot") == "Q01"  # each study its own
        store.remove_participant("P02", confirm="P02")
        assert app_support.last_participant(store, "default") == "P01"  # a removed code is not offered
        store.create_study("empty")
        assert app_support.last_participant(store, "empty") is None
        # a removal, the latest of the study's events (about no participant), does not move it to the first code
        store.add_participant("P03")
        store.add_participant("P04")
        store.remove_participant("P04", confirm="P04")
        assert store.events(study="default", limit=1)["what"].tolist() == ["remove_participant"]
        assert app_support.last_participant(store, "default") == "P03"


def test_the_participant_last_worked_with_is_found_behind_any_number_of_other_events(tmp_path):
    """last_participant read the study's last 20 events, latest_study the last 200: a run of events
    about no participant (removals of codes added by mistake, studies created) hid the participant
    last worked with, and the sidebar opened at the first code, or at no study. The store looks up
    the latest event naming each participant instead."""
    with StudyStore(tmp_path / "s.sqlite") as store:
        for code in ("P01", "P02"):
            store.add_participant(code)
        store.open_day("P02")  # worked with last
        for i in range(21):
            store.add_participant(f"X{i:02d}")
            store.remove_participant(f"X{i:02d}", confirm=f"X{i:02d}")
        assert app_support.last_participant(store, "default") == "P02"
        for i in range(201):
            store.create_study(f"pilot {i}")
        store.add_participant("Q01", study="pilot 7")
        assert app_support.latest_study(store) == "pilot 7"
        store.open_day("P01")
        assert app_support.latest_study(store) == "default" and app_support.last_participant(store, "default") == "P01"
        for i in range(201):
            store.create_study(f"walk {i}")
        assert app_support.latest_study(store) == "default"
        assert store.latest_participant() == store.latest_participant("default") == "P01"
        assert store.latest_participant("pilot 7") == "Q01" and store.latest_participant("walk 3") is None


def test_open_days_names_each_participant_whose_latest_day_is_open(tmp_path):
    """From the days table (it asked each participant's status): the open day of each participant
    whose latest day is open, of the study asked for."""
    store = StudyStore(tmp_path / "s.sqlite")
    store.create_study("pilot")
    for code in ("P01", "P02", "P03"):
        store.add_participant(code)
    store.add_participant("Q01", study="pilot")
    store.close_day("P01", store.open_day("P01"))
    store.save_policy("P01", 1, "nn", b"adapted")
    assert store.open_day("P01") == 2  # P01: day 1 closed, day 2 open
    store.close_day("P02", store.open_day("P02"))  # P02: day 1 closed; P03: not started
    store.open_day("Q01")
    assert app_support.open_days(store, "default") == {"P01": 2}
    assert app_support.open_days(store) == {"P01": 2, "Q01": 1}
    assert app_support.open_days(store, "nobody") == {}
    store.close()


def test_a_large_studys_zip_points_to_cacas_export():
    """Large-study walkthrough: 'Download everything' built a 200 MB zip in the server's memory."""
    small = pd.DataFrame({"size": [660_153] * 10})
    assert app_support.bundle_note(small, "study_data/cacas.sqlite") == ""
    assert app_support.bundle_note(small.iloc[:0], "study_data/cacas.sqlite") == ""
    large = pd.DataFrame({"size": [660_153] * 168})
    assert app_support.bundle_note(large, "study_data/cacas.sqlite", "pilot") == (
        "The zip holds 111 MB of policy files (168 versions), built in the app's memory on the click; "
        "`cacas export --db study_data/cacas.sqlite --study pilot --out export/` writes the same zip (and the "
        "tables) straight to disk.")
    assert "`cacas export --db '/data/my study.sqlite' --study 'pilot 2' --out export/`" in app_support.bundle_note(
        large, "/data/my study.sqlite", "pilot 2")  # a path as a shell takes it


def test_a_long_jobs_time_left_is_estimated_once_there_is_enough_to_tell():
    """Large-study walkthrough: a comparison of 10 minutes and more showed no time remaining."""
    assert app_support.time_left(8, 0.5) == ""  # too soon
    assert app_support.time_left(60, 0.12) == ""  # too little done: the workers' start weighs too much
    assert app_support.time_left(60, 1.0) == ""  # done
    assert app_support.time_left(20, 0.5) == ", about 20 s left"
    assert app_support.time_left(60, 0.25) == ", about 3 min left"
    # the pace measured from the job's first report of work done: its start-up is no measure of it
    # (a 46-s simulation with 10 s of start-up said 'about 39 s left' at 25 s, 39 % done)
    assert app_support.time_left(25, 0.388) == ", about 39 s left"
    assert app_support.time_left(25, 0.388, (10.15, 0.002)) == ", about 24 s left"
    assert app_support.time_left(20, 0.25, (10, 0.2)) == ", about 60 s left"  # a tenth more not yet done: from the start


def test_a_studys_download_names_have_no_spaces():
    assert app_support.study_file_name("cacas-study", "pilot walkB", ".zip") == "cacas-study-pilot_walkb.zip"
    assert app_support.study_file_name("personas", "default", ".json") == "personas-default.json"
    assert app_support.study_file_name("personas", "?? ", ".json") == "personas-study.json"


def test_a_runs_download_names_are_its_folders_name():
    """A simulated run's tables are named after its folder as it is named on disk: "-" was made "_" (the ui
    helper), so that "daily-20260301_101500_seed0_8p_7d.csv" matched no folder. A name a shell trips on
    (a folder renamed by hand) is made safe as a study's is."""
    assert app_support.run_file_name("daily", "20260301-101500-seed0-8p-7d-2", ".csv") == \
        "daily-20260301-101500-seed0-8p-7d-2.csv"
    assert app_support.run_file_name("daily", "Pilot_B.v2", ".csv") == "daily-Pilot_B.v2.csv"
    assert app_support.run_file_name("daily", "my run", ".csv") == "daily-my_run.csv"
    assert app_support.run_file_name("daily", "-x", ".csv") == "daily-x.csv"  # no name that reads as an option


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
    # the methods as the figures name them (the codes read 'cacas', 'nn')
    assert list(runs["what"]) == ["CACAS", "CACAS", "NN (comparison)", "initial policy, scored for Fig. 4 (CACAS)"]
    assert list(table["method"]) == ["CACAS", "CACAS"]
    assert list(runs["preference accuracy"]) == [75.0, 100.0, 10.0, 25.0]
    assert list(runs["policy version"]) == ["1", "2", "", ""]  # a comparison run saves no policy (read "None")
    assert all(c.endswith(" UTC") and len(c) == 20 for c in runs["saved"])  # "YYYY-MM-DD HH:MM UTC"
    store.close()


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
        tables = (store.participants_frame(), store.policies_frame())
        assert app_support.rolled_back_note(store.events(), *tables) == app_support.rolled_back_note(store.events())


def test_the_roll_back_note_reads_as_past_once_a_later_version_is_in_force(tmp_path):
    """Walkthrough (Results): after a roll-forward the note still read "After a roll-back (P02), a day uses the
    version put in force instead": right about the days that used it, but as if it still held. Once the newest
    version is in force again (a roll-forward, or a day adapted since), it is said as past."""
    from cacas.store import StudyStore

    with StudyStore(tmp_path / "s.sqlite") as store:
        for code in ("P01", "P02"):
            store.add_participant(code)
            store.close_day(code, store.open_day(code))
            store.save_policy(code, 1, "cacas", b"policy after day 1")
            store.set_active_policy(code, None)  # back to the initial policy

        def note():
            return app_support.rolled_back_note(store.events(), store.participants_frame(), store.policies_frame())

        store.set_active_policy("P02", 1)  # forward again
        how = ("(a day rolled back in its middle, the version most of its interactions had): Fig. 4 scores that "
               "version for CACAS, while the baselines keep their runs adapted from days 1..d-1.")
        assert note() == (" After a roll-back (P01), a day uses the version put in force instead; while a roll-back "
                          "held (P02; a later version is in force again), a day used the version it put in force "
                          + how)
        store.close_day("P01", store.open_day("P01"))
        store.save_policy("P01", 2, "cacas", b"policy after day 2")  # a day adapted since: the newest is in force
        assert note() == (" While a roll-back held (P01, P02; a later version is in force again), a day used the "
                          "version it put in force " + how)


def test_a_roll_back_no_interaction_was_recorded_under_is_not_named(tmp_path):
    """Walkthrough (Results): P01's policy was rolled back to the initial one after day 1 and put forward to
    version 1 again before day 2 started, and every interaction used the policy of its day; Results still said
    "While a roll-back held (P01; ...), a day used the version it put in force", as if P01's figures had a
    rolled-back day. Given the interactions, a past roll-back is named only where an interaction was recorded
    with an older policy than the newest saved by then; one in force now is named as before (the next days use it)."""
    from cacas.store import StudyStore

    kw = dict(activity="cough", scene="bedroom", hour=8, interval_minutes=5, robot_action="pain check",
              response="accept")
    with StudyStore(tmp_path / "s.sqlite") as store:
        for code in ("P01", "P02"):
            store.add_participant(code)
            day = store.open_day(code)
            store.record_interaction(code, day, **kw)
            store.close_day(code, day)
            store.save_policy(code, 1, "cacas", b"policy after day 1")
            store.set_active_policy(code, None)  # rolled back to the initial policy...
        store.set_active_policy("P01", 1)  # ... and, for P01, forward again before day 2
        for code, version in (("P01", 1), ("P02", None)):  # P02's day 2 under the initial policy
            store.record_interaction(code, store.open_day(code), policy_version=version, **kw)
        store.set_active_policy("P02", 1)

        def note(interactions=True):
            tables = (store.participants_frame(), store.policies_frame())
            return app_support.rolled_back_note(store.events(), *tables,
                                                store.interactions_frame(extra=True) if interactions else None)

        how = ("(a day rolled back in its middle, the version most of its interactions had): Fig. 4 scores that "
               "version for CACAS, while the baselines keep their runs adapted from days 1..d-1.")
        assert note() == (" While a roll-back held (P02; a later version is in force again), a day used the version "
                          "it put in force " + how)
        assert note(interactions=False).startswith(" While a roll-back held (P01, P02;")  # without them, as before
        store.set_active_policy("P02", None)  # in force now: named, though no interaction used it yet
        store.set_active_policy("P01", None)
        assert note().startswith(" After a roll-back (P01, P02), a day uses the version put in force instead")
        store.set_active_policy("P01", 1)
        store.set_active_policy("P02", 1)
        store.record_interaction("P02", 2, policy_version=1, **kw)
        assert note().startswith(" While a roll-back held (P02;")
        # P01 only ever rolled back between its days: nothing to say about anyone's figures
        store.remove_participant("P02", confirm="P02")
        assert note() == ""


def test_an_import_of_personas_is_said_group_by_group():
    """It said "Imported 3 participants: P01, P02, P03" of one unchanged and one whose preferences were replaced."""
    from cacas.store import PersonasImport

    done = PersonasImport(codes=("P01", "P02", "P03", "P04"), added=("P03", "P04"), replaced=("P02",),
                          unchanged=("P01",))
    assert app_support.personas_imported(done, "example.json") == (
        "Imported example.json: added P03, P04 · preferences replaced for P02 · unchanged P01.")
    assert app_support.personas_imported(PersonasImport(codes=("P05",), first=("P05",)), "mine.json") == (
        "Imported mine.json: first preferences for P05.")


def test_the_initial_policys_fig4_scores_name_their_method(tmp_path):
    """Walkthrough (Adaptation, "Adaptation runs"): a method comparison scores the initial policy as day 0 once
    for each method (Fig. 4's day 1 of each), and the table showed four rows alike, "initial policy, scored for
    Fig. 4", that read as duplicates. Each names its method."""
    from cacas.store import StudyStore

    store = StudyStore(tmp_path / "s.sqlite")
    store.add_participant("P01")
    methods = ("cacas", "cacas-no-pr", "orl", "nn")
    for method in methods:
        store.record_adaptation("P01", 0, method, {"initial": True}, 0.0, {"preference_accuracy": 0.25})
    runs = app_support.runs_table(store.adaptations_frame("P01"))
    assert list(runs["what"]) == [f"initial policy, scored for Fig. 4 ({m})" for m in ("CACAS", "CACAS w/o PR", "ORL",
                                                                                        "NN")]
    assert runs["what"].is_unique
    store.close()


def test_counted_agrees_in_number():
    """The pages said "1 participant(s)" (walkthrough)."""
    assert [app_support.counted(n, "participant") for n in (0, 1, 2, 1500)] == [
        "0 participants", "1 participant", "2 participants", "1,500 participants"]
    assert app_support.counted(1, "photo", "photos") == "1 photo"
    assert app_support.counted(3, "policy file") == "3 policy files"


def test_a_clock_behind_the_studys_latest_record_is_said(tmp_path):
    """Clock walk: a server restarted with its clock set back records what follows as earlier than what came
    before; nothing said so. Ahead by more than CLOCK_SLACK_S: one line with both times; otherwise nothing."""
    from datetime import timedelta

    from cacas.store import StudyStore
    from cacas.store.validate import iso_time

    with StudyStore(tmp_path / "study.sqlite") as store:
        store.add_participant("P01")
        newest = iso_time(store.newest_time())
        assert app_support.clock_behind(store, newest + timedelta(seconds=5)) is None
        assert app_support.clock_behind(store, newest - timedelta(seconds=app_support.CLOCK_SLACK_S - 1)) is None
        said = app_support.clock_behind(store, newest - timedelta(hours=26))
        assert said == (f"this computer's clock says {app_support.short_time((newest - timedelta(hours=26)).timestamp())}"
                        f", before the study's latest record ({app_support.short_time(store.newest_time())}): set the "
                        "clock right before recording more, or what is recorded now will be dated before what was "
                        "recorded then")


def test_the_overview_names_a_day_past_the_studys_seven(tmp_path):
    from cacas.study_day import STUDY_DAYS

    store = StudyStore(tmp_path / "s.sqlite")
    cough_day(store, "P01")
    for day in range(1, STUDY_DAYS + 1):
        store.close_day("P01", day)
        store.open_day("P01")
    table = app_support.overview_frame(store).set_index("participant")
    assert table.loc["P01", "day"] == f"{STUDY_DAYS + 1}, past the study's {STUDY_DAYS} (open)"


@pytest.mark.parametrize("user_agent, phone", [
    ("Mozilla/5.0 (iPhone; CPU iPhone OS 17_0 like Mac OS X) AppleWebKit/605.1.15 (KHTML, like Gecko) Version/17.0 "
     "Mobile/15E148 Safari/604.1", True),
    ("Mozilla/5.0 (Linux; Android 14; Pixel 8) AppleWebKit/537.36 (KHTML, like Gecko) Chrome/126.0 Mobile "
     "Safari/537.36", True),
    ("Mozilla/5.0 (Linux; Android 14; SM-X710) AppleWebKit/537.36 (KHTML, like Gecko) Chrome/126.0 Safari/537.36",
     False),  # an Android tablet
    ("Mozilla/5.0 (Macintosh; Intel Mac OS X 10_15_7) AppleWebKit/605.1.15 (KHTML, like Gecko) Version/17.0 "
     "Safari/605.1.15", False),  # a Mac, and an iPad since iPadOS 13
    ("Mozilla/5.0 (Windows NT 10.0; Win64; x64) AppleWebKit/537.36 (KHTML, like Gecko) Chrome/126.0 Safari/537.36",
     False),
    ("", False), (None, False),
])
def test_a_phone_is_known_by_mobi_in_its_user_agent(user_agent, phone):
    """Phone's left-alone item: the server does not know the page's width; MDN's advice is "Mobi" in the
    User-Agent for a phone (Fig. 4's heatmap by preference is drawn narrow for it)."""
    from cacas.app_support import is_phone

    assert is_phone(user_agent) is phone
