import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cacas import records, spaces
from cacas.errors import AlreadyAdapted, CacasError
from cacas.policy import ReshapedPolicy
from cacas.sac import DiscreteSAC, SACConfig
from cacas.store import StudyStore
from cacas.study_day import (STUDY_DAYS, Context, DayStatus, answer, clip_for, day_of, day_status, propose,
                             proposal_draws, questionnaire_timing, start_day)


@pytest.fixture
def store(tmp_path):
    s = StudyStore(tmp_path / "s.sqlite")
    s.add_participant("P01")
    s.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
    yield s
    s.close()


def test_day_1_waits_for_the_described_preferences(tmp_path):
    """A participant with no described preferences could start the study, whose scores need them."""
    with StudyStore(tmp_path / "s.sqlite") as s:
        s.add_participant("P02")
        with pytest.raises(CacasError, match=r"^participant P02 has no described preferences; describe them "
                                              r"before day 1 \(Participants page\)$"):
            start_day(s, "P02")
        assert day_status(s, "P02").day == 0  # nothing opened
        s.save_preferences("P02", [{"activity": ["cough"], "action": "pain check"}])
        assert start_day(s, "P02") == 1


def test_a_day_is_not_started_without_the_d4a_pairs(store, tmp_path, monkeypatch):
    """An empty $CACAS_STUDY_DATA failed only at the first proposal, in front of the participant,
    with day 1 already open (walkthrough): now the day is refused, naming the folder and the fix."""
    monkeypatch.setenv("CACAS_STUDY_DATA", str(tmp_path / "empty"))
    with pytest.raises(CacasError, match=r"^day 1 of participant P01 not started: the study data folder .*empty "
                                          r"lacks the shipped d4a.csv, .*valid: copy them from the shipped folder"):
        start_day(store, "P01")
    assert day_status(store, "P01").day == 0  # nothing opened
    monkeypatch.delenv("CACAS_STUDY_DATA")
    assert start_day(store, "P01") == 1


def test_a_day_is_not_started_with_a_d4a_file_that_does_not_parse(store, tmp_path, monkeypatch):
    """The folder has every shipped file but a D4A table edited wrongly: its own error is said
    (it was replaced by a vague 'cannot be read')."""
    import shutil

    from cacas.paths import PROJECT_ROOT

    data = tmp_path / "data"
    for name in ("personas", "sounds", "scenes", "models"):
        (data / name).mkdir(parents=True)
    shutil.copy(PROJECT_ROOT / "study_data" / "d4a.csv", data / "d4a.csv")
    with open(data / "d4a.csv", "a") as f:
        f.write("not an activity,accept\n")
    monkeypatch.setenv("CACAS_STUDY_DATA", str(data))
    from cacas.d4a import load_d4a

    with pytest.raises(CacasError) as parse:
        load_d4a()
    with pytest.raises(CacasError) as refused:
        start_day(store, "P01")
    assert str(refused.value) == f"day 1 of participant P01 not started: {parse.value}"
    assert day_status(store, "P01").day == 0  # nothing opened


@pytest.fixture
def policy():
    return ReshapedPolicy(DiscreteSAC(SACConfig(), seed=0), None, beta=1.0, method="initial")


def test_a_bandit_in_force_on_the_tablet_draws_anew_after_a_server_restart_and_keeps_a_proposal_through_a_rerun():
    """The Adaptation page can put a bandit in force; the tablet loads it from its file after each
    server restart, and its Thompson draws restarted from the same seed: day after day the same
    sequence of proposals. The tablet's draws are keyed by who, day, interaction and policy."""
    from cacas.d4a import load_d4a
    from cacas.policy import BanditPolicy, policy_from_bytes

    data = BanditPolicy(load_d4a().table).to_bytes()  # the prior only: its draws vary widely
    ctx = Context.from_choices(4, 6, "cough", "bedroom")

    def proposals(day, indices):  # a server start: the policy loaded from its file, then a day of proposals
        policy = policy_from_bytes(data)
        return [propose(policy, ctx, draws=proposal_draws("P01", day, i, "sha")).action for i in indices]

    day1, day2 = proposals(1, range(1, 31)), proposals(2, range(1, 31))
    assert day1 != day2  # 30 draws each: equal only by a chance of less than 1e-20
    assert len(set(day1)) > 1  # the draws differ from one interaction to the next
    # a rerun of the page, or a restart before the answer, draws the interaction at hand again: the same proposal
    assert proposals(1, [5, 5, 5]) == [day1[4]] * 3
    # another participant or another policy version draws otherwise
    assert proposal_draws("P01", 1, 5, "sha").random(4).tolist() != proposal_draws("P02", 1, 5, "sha").random(4).tolist()
    assert proposal_draws("P01", 1, 5, "sha").random(4).tolist() != proposal_draws("P01", 1, 5, "ahs").random(4).tolist()


def test_context_token_round_trip_and_bad_input():
    ctx = Context.from_choices(3, 7, "Use Stove", "KITCHEN")
    assert (ctx.activity, ctx.scene, ctx.hour, ctx.interval_minutes) == ("use stove", "kitchen", 6, 30)
    assert Context.from_token(ctx.to_token()) == ctx
    with pytest.raises(CacasError, match="time of day 12 is invalid"):
        Context.from_choices(12, 0, "cough", "bedroom")
    with pytest.raises(CacasError, match=r"^time since the last activity 12 is invalid; valid: bin 0..11$"):
        Context.from_choices(1, 12, "cough", "bedroom")
    with pytest.raises(CacasError, match="unknown activity"):
        Context.from_choices(1, 0, "dance", "bedroom")
    with pytest.raises(CacasError, match="in the address is invalid"):
        Context.from_token("1.2.99.0")
    for token in ("1.2.-1.0", "1.2.0.-1", "1.2.-33.0"):  # taken from the end of the lists: another context
        with pytest.raises(CacasError, match="in the address is invalid"):
            Context.from_token(token)


def test_answers_are_recorded_with_the_state(store, policy):
    day = start_day(store, "P01")
    ctx = Context.from_choices(4, 6, "cough", "bedroom")
    p1 = propose(policy, ctx, None, policy_version=None)
    assert p1.state == spaces.State.from_names("cough", "bedroom", 8, 20)
    assert np.isclose(p1.probabilities.sum(), 1.0)
    assert p1.robot_speaks  # the seed-0 policy proposes something here
    answer(store, "P01", day, p1, response="reject")
    p2 = propose(policy, ctx, store.interactions_frame("P01").iloc[-1].to_dict(), heard="sneeze",
                 heard_confidence=0.6)
    assert p2.heard == "sneeze" and p2.state.activity == spaces.activity_index("sneeze")
    answer(store, "P01", day, p2, user_action="pain check")
    df = store.interactions_frame("P01", extra=True)
    assert list(df["type"]) == [records.ROBOT_INITIATED, records.USER_INITIATED]
    assert df["activity"].iloc[1] == "cough" and df["recognised_activity"].iloc[1] == "sneeze"
    assert df["user_action"].iloc[1] == "pain check" and df["response"].iloc[1] == "accept"
    assert df["previous_action"].iloc[1] == p1.action
    with pytest.raises(CacasError, match="not a request"):
        answer(store, "P01", day, p2, user_action="do nothing")
    with pytest.raises(CacasError, match="answer 'maybe' is invalid"):
        answer(store, "P01", day, p2, response="maybe")
    with pytest.raises(CacasError, match="not both"):
        answer(store, "P01", day, p2, response="accept", user_action="chitchat")
    assert len(store.interactions_frame("P01")) == 2  # the refused answers wrote nothing


def test_when_the_robot_did_nothing_only_no_response_is_an_answer(store, policy):
    day = start_day(store, "P01")
    spoken = propose(policy, Context.from_choices(4, 6, "cough", "bedroom"))
    silent = dataclasses.replace(spoken, action="do nothing")  # the policy chose to do nothing
    assert not silent.robot_speaks
    for refused in ("accept", "reject"):
        with pytest.raises(CacasError, match="the robot did not propose anything; answer 'no response'"):
            answer(store, "P01", day, silent, response=refused)
    assert store.interactions_frame("P01").empty  # the refused answers wrote nothing
    answer(store, "P01", day, silent, response="no response")
    row = store.interactions_frame("P01").iloc[0]
    assert (row["type"], row["robot_action"], row["response"]) == (records.ROBOT_INITIATED, "do nothing",
                                                                   "others")


def test_next_day_waits_for_the_adaptation(store):
    assert day_status(store, "P01").day_on_screen == 1  # before the study: day 1, ready to start
    day = start_day(store, "P01")
    assert start_day(store, "P01") == day  # a reload opens nothing new
    assert day_status(store, "P01").day_on_screen == day
    store.close_day("P01", day)
    assert day_status(store, "P01").waiting_for_adaptation
    assert day_status(store, "P01").day_on_screen == day  # "day 1 is finished", until adapted
    with pytest.raises(CacasError, match="has not been adapted yet"):
        start_day(store, "P01")
    store.record_adaptation("P01", day, "nn", {"comparison": True}, 1.0, {})  # a comparison run: no policy
    assert day_status(store, "P01").waiting_for_adaptation
    version = store.save_policy("P01", day, "nn", b"a policy adapted with a baseline")
    store.set_active_policy("P01", None)  # adapted, then rolled back to the initial policy: still adapted
    assert not day_status(store, "P01").waiting_for_adaptation and version == 1
    assert day_status(store, "P01").day_on_screen == day + 1  # the next day, ready to start
    assert start_day(store, "P01") == day + 1
    finished = dataclasses.replace(day_status(store, "P01"), day=STUDY_DAYS, open=False, finished=True)
    assert finished.day_on_screen == STUDY_DAYS


def test_there_is_no_day_after_the_studys_last(store):
    """Review: the library opened day 8 after the 7 days (the tablet said "All 7 days are done",
    the Overview "day 8 of 7")."""
    for day in range(1, STUDY_DAYS + 1):
        assert start_day(store, "P01") == day
        store.close_day("P01", day)
        store.save_policy("P01", day, "nn", f"policy after day {day}".encode())
    assert day_status(store, "P01").finished
    with pytest.raises(CacasError, match=f"participant P01 has done all {STUDY_DAYS} study days; the study has "
                                         f"{STUDY_DAYS} \\(Section V-B.1\\): there is no day {STUDY_DAYS + 1}"):
        start_day(store, "P01")
    assert [d.day for d in store.days("P01")] == list(range(1, STUDY_DAYS + 1))


def test_clip_choice_is_stable():
    ctx = Context.from_choices(3, 7, "cough", "kitchen")
    clips = [f"c{i}.ogg" for i in range(10)]
    chosen = clip_for(ctx, "P01", 1, 2, clips)
    assert chosen == clip_for(ctx, "P01", 1, 2, clips)  # a reload plays the same clip
    assert chosen in {Path(c) for c in clips}
    # the choice depends on the interaction: other indices of the day play other clips
    assert {clip_for(ctx, "P01", 1, i, clips) for i in range(20)} - {chosen}
    assert clip_for(ctx, "P01", 1, 2, []) is None


def test_store_interactions_give_the_recorded_state(store):
    """The adaptation reads the store's interactions: the state it rebuilds must be the one recorded
    (S4 30 minutes is bin 7)."""
    day = start_day(store, "P01")
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=30,
                             robot_action="pain check", response="accept")
    states = records.policy_states(store.interactions_frame("P01"))
    assert tuple(states[0][:4]) == (spaces.activity_index("cough"), 0, 4, spaces.interval_bin(30))


def test_the_robot_acts_on_the_room_it_saw(store, policy):
    day = start_day(store, "P01")
    ctx = Context.from_choices(4, 6, "cough", "bedroom")
    p = propose(policy, ctx, None, heard="cough", heard_confidence=0.9, seen="Living Room")
    assert p.seen == "living room" and p.state.scene == spaces.scene_index("living room")
    answer(store, "P01", day, p, user_action="pain check")
    row = store.interactions_frame("P01", extra=True).iloc[0]
    assert (row["scene"], row["recognised_scene"]) == ("bedroom", "living room")


def test_each_answer_keeps_the_models_that_heard_and_saw(store, policy):
    """After a retraining mid-study, the interactions say which model recognised what."""
    day = start_day(store, "P01")
    ctx = Context.from_choices(4, 6, "cough", "bedroom")
    answer(store, "P01", day, propose(policy, ctx, None, heard="cough", heard_confidence=0.9, seen="bedroom",
                                      sound_model="aaaaaaaaaaaa", scene_model="bbbbbbbbbbbb"), response="reject")
    answer(store, "P01", day, propose(policy, ctx, None, heard="cough", heard_confidence=0.8,
                                      sound_model="cccccccccccc", scene_model="bbbbbbbbbbbb"), response="reject")
    answer(store, "P01", day, propose(policy, ctx, None, sound_model="cccccccccccc"), response="reject")
    rows = store.interactions_frame("P01", extra=True)
    # no room seen, nothing heard (no recogniser): no model named for it
    assert list(rows["sound_model"]) == ["aaaaaaaaaaaa", "cccccccccccc", ""]
    assert list(rows["scene_model"]) == ["bbbbbbbbbbbb", "", ""]


def test_asking_for_what_the_robot_offered_is_accepting_it(store, policy):
    day = start_day(store, "P01")
    p = propose(policy, Context.from_choices(3, 6, "use stove", "kitchen"))
    if not p.robot_speaks:  # make the robot speak: the proposal is what the policy chose
        p = propose(policy, Context.from_choices(8, 6, "cough", "bedroom"))
    assert p.robot_speaks
    other = next(a for a in spaces.ACTIONS[1:] if a != p.action)
    answer(store, "P01", day, p, user_action=p.action.upper())  # names match case-insensitively
    answer(store, "P01", day, p, user_action=other)
    df = store.interactions_frame("P01")
    assert list(df["type"]) == [records.ROBOT_INITIATED, records.USER_INITIATED]
    assert list(df["response"]) == ["accept", "accept"] and list(df["user_action"]) == ["", other]
    assert records.is_success(df).tolist() == [True, False]


def test_an_answer_is_written_once_for_its_interaction_number(store, policy):
    """A second click, or a second tab answering the same proposal: the store checks the day's
    interaction number in the same transaction as the write, so nothing is written twice."""
    from cacas.errors import AlreadyRecorded

    day = start_day(store, "P01")
    p = propose(policy, Context.from_choices(4, 6, "cough", "bedroom"), None, policy_version=None)
    answer(store, "P01", day, p, response="accept", index=1)
    with pytest.raises(AlreadyRecorded, match="interaction 1 of day 1 of participant P01 is recorded already; "
                                              "the next one is 2"):
        answer(store, "P01", day, p, response="reject", index=1)
    with pytest.raises(AlreadyRecorded):
        answer(store, "P01", day, p, user_action="pain check", index=1)
    df = store.interactions_frame("P01")
    assert list(df["response"]) == ["accept"]  # the first answer stands
    answer(store, "P01", day, p, response="no response", index=2)
    assert len(store.interactions_frame("P01")) == 2
    with pytest.raises(CacasError, match="index"):
        answer(store, "P01", day, p, response="accept", index=0)
    assert len(store.interactions_frame("P01")) == 2


def test_questionnaire_timing_names_the_day_as_it_stands(store):
    assert questionnaire_timing(day_status(store, "P01")) == ""  # no day yet (the answer is refused)
    day = start_day(store, "P01")
    assert questionnaire_timing(day_status(store, "P01")) == f"It was given during day 1 of {STUDY_DAYS}."
    store.close_day("P01", day)
    assert questionnaire_timing(day_status(store, "P01")) == f"It was given after day 1 of {STUDY_DAYS}."
    finished = dataclasses.replace(day_status(store, "P01"), day=STUDY_DAYS, finished=True)
    assert questionnaire_timing(finished) == ""  # asked after the study, as the paper does


def test_a_day_past_the_studys_seven_says_so():
    """An imported study (or one the library ran longer) can have day 21: not "21 of 7"."""
    assert day_of(3) == f"3 of {STUDY_DAYS}" and day_of(STUDY_DAYS) == f"{STUDY_DAYS} of {STUDY_DAYS}"
    assert day_of(21) == f"21, past the study's {STUDY_DAYS}"
    status = DayStatus(21, True, 2, 300, 20, False, False, 2)
    assert questionnaire_timing(status) == f"It was given during day 21, past the study's {STUDY_DAYS}."


def test_every_version_is_scored_on_the_same_test_states_whatever_the_adaptation_seed(tmp_path, monkeypatch, policy):
    """Fig. 4's test states are the participant's, not the adaptation's: a run with another seed
    is scored on the states every other version is (the Adaptation page's table uses them too)."""
    import json

    import cacas.adaptation
    from cacas.adaptation import fig4_metrics
    from cacas.policy import policy_from_bytes
    from cacas.study_day import adapt_day

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    path = tmp_path / "s.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P01")
        s.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"},
                                   {"activity": ["use stove"], "action": "remind to turn off"}])
        start_day(s, "P01")
        s.record_interaction("P01", 1, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="do nothing", response="accept", type="type_2", user_action="pain check")
        s.record_interaction("P01", 1, activity="cough", scene="bedroom", hour=9, interval_minutes=5,
                             robot_action="chitchat", response="others")  # left unanswered
    said = []
    adapt_day(path, "P01", 1, method="nn", seed=99_999, progress=lambda f, m: said.append(m))
    # the progress counts what gives user data, as the tablet's counter does
    assert "adapting with nn from 1 recorded interaction of day 1 (1 more saved, unanswered or asked for while " \
           "doing nothing, which give no user data)" in said
    with StudyStore(path) as s:
        runs = s.adaptations_frame("P01")
        described = s.get_preferences("P01")
        adapted = policy_from_bytes(s.load_policy("P01", version=s.active_policy("P01").version))
    recorded = [json.loads(m)["by_preference"] for m in runs["metrics"]]
    expected = fig4_metrics(adapted, described)  # the page's test states (seed 0)
    assert [p["states"] for p in recorded[-1]] == [p["states"] for p in expected["by_preference"]]
    assert [p["states"] for p in recorded[0]] == [p["states"] for p in recorded[-1]]  # the initial policy's too
    assert runs["preference_accuracy"].iloc[-1] == pytest.approx(expected["preference_accuracy"])
    # each run names the version of the described preferences it was scored against
    assert [json.loads(m)["preferences_version"] for m in runs["metrics"]] == [1, 1]


def _day_one_with_a_request(path) -> None:
    with StudyStore(path) as s:
        s.add_participant("P01")
        s.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
        start_day(s, "P01")
        s.record_interaction("P01", 1, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="do nothing", response="accept", type="type_2", user_action="pain check")


def test_a_day_is_adapted_once(tmp_path, monkeypatch, policy):
    """Walkthrough: an Adaptation tab drawn before day 1 was adapted elsewhere adapted it again
    during day 2 (the same data twice; a new policy put in force in the middle of day 2), without a
    word. Refused before training and, for two servers finishing together, when saving."""
    import cacas.adaptation
    from cacas.study_day import adapt_day

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    path = tmp_path / "s.sqlite"
    _day_one_with_a_request(path)
    adapt_day(path, "P01", 1, method="nn")
    with pytest.raises(AlreadyAdapted, match="day 1 of participant P01 is adapted already"):
        adapt_day(path, "P01", 1, method="nn")
    with StudyStore(path) as s:
        start_day(s, "P01")
        s.record_interaction("P01", 2, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
    with pytest.raises(CacasError, match="day 1 of participant P01 cannot be adapted any more: day 2 has begun"):
        adapt_day(path, "P01", 1, method="nn")
    with StudyStore(path) as s:  # the last line of defence: the save itself, in one transaction
        with pytest.raises(CacasError, match="cannot be adapted any more: day 2 has begun; nothing was saved"):
            s.save_adapted_policy("P01", 1, "nn", policy.to_bytes(), {}, 1.0, {})
        s.close_day("P01", 2)
        version = s.save_adapted_policy("P01", 2, "nn", policy.to_bytes(), {"epochs": 1}, 1.0, {"x": 1})
        with pytest.raises(AlreadyAdapted, match=r"day 2 of participant P01 is adapted already \(policy version 2"):
            s.save_adapted_policy("P01", 2, "nn", policy.to_bytes(), {}, 1.0, {})
        assert [(p.version, p.day, p.active) for p in s.policy_versions("P01")] == [(1, 1, False), (2, 2, True)]
        runs = s.adaptations_frame("P01")
        assert [(d, None if pd.isna(v) else int(v)) for d, v in zip(runs["day"], runs["policy_version"])] == \
            [(0, None), (1, 1), (2, version)]


def test_a_day_without_interactions_or_that_does_not_exist_is_not_adapted(store, monkeypatch, policy):
    """Refused before anything is written: the day stays open, no adaptation is noted as begun."""
    import cacas.adaptation
    from cacas.study_day import adapt_day

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    store.open_day("P01")
    with pytest.raises(CacasError, match="^participant P01 has no day 2$"):
        adapt_day(store.path, "P01", 2, method="nn")
    with pytest.raises(CacasError, match="^day 1 of participant P01 has no interactions; nothing to adapt from$"):
        adapt_day(store.path, "P01", 1, method="nn")
    assert [(d.day, d.is_open) for d in store.days("P01")] == [(1, True)]
    assert store.events(what="adapt_start").empty and store.policy_versions("P01") == []


def test_the_adapted_policy_and_its_run_are_saved_together(tmp_path, monkeypatch, policy):
    """Walkthrough: killed between saving the policy and recording its run, a day showed as
    adapted with no run (no log, no accuracy, no way to adapt it again). One transaction now: a
    run that fails to be recorded leaves neither (and no file)."""
    path = tmp_path / "s.sqlite"
    _day_one_with_a_request(path)

    def killed_while_recording_the_run(*args, **kwargs):  # inside the transaction, after the policy's rows
        raise CacasError("the process died here")
    monkeypatch.setattr(StudyStore, "_insert_adaptation", killed_while_recording_the_run)
    with StudyStore(path) as s:
        s.close_day("P01", 1)
        with pytest.raises(CacasError, match="died"):
            s.save_adapted_policy("P01", 1, "nn", policy.to_bytes(), {}, 1.0, {})
        assert s.policy_versions("P01") == [] and s.active_policy("P01") is None
        assert s.adaptations_frame("P01").empty
        assert not list((path.parent / "policies").rglob("*.pt"))
        assert day_status(s, "P01").waiting_for_adaptation


def test_the_initial_policys_score_is_recorded_with_the_first_adaptation_or_not_at_all(tmp_path, policy):
    """Review: the day-0 run (Fig. 4's day 1) was recorded before the adaptation's transaction, so
    a second tab refused at the save still left one, beside the first tab's."""
    path = tmp_path / "s.sqlite"
    _day_one_with_a_request(path)
    with StudyStore(path) as s:
        s.close_day("P01", 1)
        s.save_policy("P01", 1, "nn", policy.to_bytes())  # the other tab's, saved first
        with pytest.raises(CacasError, match="adapted already"):
            s.save_adapted_policy("P01", 1, "cacas", policy.to_bytes(), {}, 1.0, {},
                                  initial_metrics={"preference_accuracy": 0.2})
        assert s.adaptations_frame("P01").empty
        s.add_participant("P02")
        for day in (1, 2):
            s.open_day("P02")
            s.record_interaction("P02", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                                 robot_action="pain check", response="accept")
            s.close_day("P02", day)
            s.save_adapted_policy("P02", day, "cacas", policy.to_bytes(), {}, 1.0, {},
                                  initial_metrics={"preference_accuracy": 0.2})
        runs = s.adaptations_frame("P02")
        assert list(runs["day"]) == [0, 1, 2] and runs["preference_accuracy"].iloc[0] == 0.2


def test_the_adaptation_reads_the_day_once_it_is_closed(tmp_path, monkeypatch, policy):
    """Walkthrough: an answer saved between reading the day's data and closing the day was kept on
    the day but not adapted from."""
    import cacas.adaptation
    import cacas.study_day
    from cacas.study_day import adapt_day

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    path = tmp_path / "s.sqlite"
    _day_one_with_a_request(path)
    real_close = StudyStore.close_day

    def close_after_one_more_answer(self, participant, day):  # the tablet's answer arrives just before
        with StudyStore(path) as other:
            other.record_interaction("P01", 1, activity="cough", scene="bedroom", hour=9, interval_minutes=5,
                                     robot_action="pain check", response="accept")
        return real_close(self, participant, day)
    monkeypatch.setattr(StudyStore, "close_day", close_after_one_more_answer)
    said = []
    adapt_day(path, "P01", 1, method="nn", progress=lambda f, m: said.append(m))
    assert any(m.startswith("adapting with nn from 2 recorded interactions of day 1") for m in said)
    with StudyStore(path) as s:
        assert json.loads(s.adaptations_frame("P01")["metrics"].iloc[-1])["interactions"] == 2


def test_an_answer_is_told_from_another_screens_answer(store, policy):
    """A second click on the same answer is silent on the session page; only another screen's
    answer to the interaction gets its notice."""
    from cacas.study_day import answer, is_same_answer, propose, recorded_answer

    start_day(store, "P01")
    proposal = propose(policy, Context.from_token("3.6.20.2"))
    response = "accept" if proposal.robot_speaks else "no response"
    answer(store, "P01", 1, proposal, response=response, index=1)
    first = recorded_answer(store, "P01", 1, 1)
    assert recorded_answer(store, "P01", 1, 2) is None
    assert is_same_answer(first, proposal, response=response)
    assert not is_same_answer(first, proposal, response="reject")
    assert not is_same_answer(first, proposal, user_action="chitchat")
    assert not is_same_answer({**first, "activity": "cough"}, proposal, response=response)
    # two tablets at one participant's address (lan): the same activity, action and answer in another room, at
    # another time of day or another time since the last activity is another screen's answer, not this one
    for other in ({"scene": "bathroom"}, {"time_slot": first["time_slot"] + 1}, {"interval": 200}):
        assert not is_same_answer({**first, **other}, proposal, response=response), other


def test_the_days_count_is_of_recorded_interactions(store):
    """The ~15 a day are interactions the paper records (answered, or asked for); one saved
    without an answer counts apart, and the next interaction's number counts every one saved."""
    day = store.open_day("P01")
    assert (day_status(store, "P01").recorded_today, day_status(store, "P01").unanswered_today) == (0, 0)
    kw = dict(activity="cough", scene="bedroom", hour=8, interval_minutes=5)
    store.record_interaction("P01", day, robot_action="pain check", response="accept", **kw)
    store.record_interaction("P01", day, robot_action="chitchat", response="others", **kw)  # no response
    store.record_interaction("P01", day, robot_action="do nothing", response="others", **kw)  # nothing needed
    store.record_interaction("P01", day, robot_action="do nothing", response="accept", type="type_2",
                             user_action="pain check", **kw)
    status = day_status(store, "P01")
    assert (status.interactions_today, status.recorded_today, status.unanswered_today) == (4, 2, 2)


def test_an_adaptation_the_app_was_stopped_during_is_known_afterwards(tmp_path, monkeypatch, policy):
    """Review: after the server was killed mid-adaptation, the page offered 'Adapt after day 1' as if
    nothing had happened. The start is logged; a day still waiting has an unfinished adaptation, an
    adapted day none."""
    import cacas.adaptation
    from cacas.study_day import adapt_day, unfinished_adaptation

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    path = tmp_path / "s.sqlite"
    _day_one_with_a_request(path)
    with StudyStore(path) as s:
        assert unfinished_adaptation(s, "P01", 1) is None

    def killed(*args, **kwargs):  # the process dies while training: nothing after this runs
        raise KeyboardInterrupt
    monkeypatch.setattr(cacas.adaptation, "adapt_policy", killed)
    with pytest.raises(KeyboardInterrupt):
        adapt_day(path, "P01", 1, method="nn")
    monkeypatch.undo()
    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    with StudyStore(path) as s:
        assert day_status(s, "P01").waiting_for_adaptation
        unfinished = unfinished_adaptation(s, "P01", 1)
        assert unfinished["method"] == "nn" and unfinished["at"].startswith("20")
    adapt_day(path, "P01", 1, method="nn")
    with StudyStore(path) as s:
        assert unfinished_adaptation(s, "P01", 1) is None


def test_a_damaged_policy_in_force_stops_the_adaptation_before_it_changes_anything(tmp_path, monkeypatch, policy):
    """Walkthrough (a policy file changed on disk): 'Close day 2 and adapt' closed day 2, logged an
    adaptation begun, then failed with the file's sha256 mismatch alone, so the page said the app was
    probably stopped during it and to adapt again, which failed the same way. The policy in force is
    read before anything is written: the day stays open and the message says what to do."""
    import cacas.adaptation
    from cacas.study_day import adapt_day

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    path = tmp_path / "s.sqlite"
    _day_one_with_a_request(path)
    adapt_day(path, "P01", 1, method="nn")
    with StudyStore(path) as s:
        start_day(s, "P01")
        s.record_interaction("P01", 2, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
        damaged = s.active_policy("P01").path
        damaged.write_bytes(damaged.read_bytes()[:-10] + b"0123456789")
        events = len(s.events("P01"))
    with pytest.raises(CacasError, match=r"^" + re.escape(
            f"{damaged}: policy version 1 of participant P01 does not match its recorded sha256 (the file was changed "
            "or damaged); day 2 is adapted from the policy in force: put another version in force (Adaptation page, "
            "Policy versions), or put the file back from a backup, then adapt again; nothing was changed") + "$"):
        adapt_day(path, "P01", 2, method="nn")
    with StudyStore(path) as s:
        assert day_status(s, "P01").open and len(s.events("P01")) == events
        s.set_active_policy("P01", None)  # the initial policy in force: the day is adapted from it
    assert adapt_day(path, "P01", 2, method="nn").policy_version == 2


def test_a_saved_policy_that_is_not_a_policy_names_its_file(store):
    """Walkthrough: a bundle whose policy file was replaced, with policies.csv's sha256 and size made to
    match, imports; the tablet then said "The robot's policy cannot be loaded (not a CACAS policy file
    (UnpicklingError))", naming no file or version. The file, version and participant are named."""
    from cacas.study_day import policy_in_force

    day = start_day(store, "P01")
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
    store.close_day("P01", day)
    store.save_policy("P01", day, "cacas", b"not a torch file")
    path = store.active_policy("P01").path
    with pytest.raises(CacasError, match=r"^" + re.escape(f"{path}: policy version 1 of participant P01 is not a "
                                                          "CACAS policy file (UnpicklingError)") + "$"):
        policy_in_force(store, "P01")


def test_a_policy_of_a_given_version_is_loaded_whichever_is_in_force(store):
    """The interaction at hand keeps the policy it was first proposed with (on_tablet.TabletBoard.policy_for):
    policy_of_version loads that version, or the initial policy for None, whatever is in force now."""
    from cacas.study_day import policy_in_force, policy_of_version

    first = ReshapedPolicy(DiscreteSAC(SACConfig(), seed=1), None, beta=1.0)
    second = ReshapedPolicy(DiscreteSAC(SACConfig(), seed=2), None, beta=1.0)
    initial = object()
    v1 = store.save_policy("P01", 0, "cacas", first.to_bytes())
    v2 = store.save_policy("P01", 0, "cacas", second.to_bytes())
    state = spaces.State(spaces.ACTIVITIES.index("cough"), spaces.SCENES.index("bedroom"), 3, 2)
    probabilities = lambda p: p.action_probabilities([state])[0]  # noqa: E731
    loaded, version = policy_of_version(store, "P01", v1)
    assert version == v1 and np.allclose(probabilities(loaded), probabilities(first))
    assert policy_of_version(store, "P01", None, initial_loader=lambda: initial) == (initial, None)
    in_force, version = policy_in_force(store, "P01")  # the newest, saved last, is in force
    assert version == v2 and np.allclose(probabilities(in_force), probabilities(second))


def test_a_policy_adapted_after_the_last_day_is_the_final_one_not_one_for_day_8():
    """Walkthrough: after day 7 the Adaptation page said "policy version 7 is in force from day 8"; the
    study has 7 days."""
    from cacas.study_day import STUDY_DAYS, in_force_words

    assert in_force_words(1) == "in force from day 2"
    assert in_force_words(STUDY_DAYS - 1) == f"in force from day {STUDY_DAYS}"
    assert in_force_words(STUDY_DAYS) == f"the study's final policy (day {STUDY_DAYS} was its last day)"
