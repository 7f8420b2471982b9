"""method_comparison: Fig. 4 on a human study, every method adapted from the same days, in one
process or in worker processes, a stop keeping the runs recorded."""

import json

import pytest

from cacas.policy import ReshapedPolicy
from cacas.sac import DiscreteSAC, SACConfig
from cacas.store import StudyStore
from cacas.study_day import day_status, start_day


@pytest.fixture
def policy():
    return ReshapedPolicy(DiscreteSAC(SACConfig(), seed=0), None, beta=1.0, method="initial")


def two_adapted_days(path, code: str, method: str, policy, **interaction) -> None:
    """A participant who described coughs -> pain check, with two closed days of one cough each,
    each adapted with ``method`` (``policy`` saved as that day's version, in force)."""
    with StudyStore(path) as s:
        s.add_participant(code)
        s.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
        for day in (1, 2):
            start_day(s, code)
            s.record_interaction(code, day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                                 **interaction)
            s.close_day(code, day)
            s.record_adaptation(code, day, method, {}, 1.0, {"preference_accuracy": 0.5},
                                s.save_policy(code, day, method, policy.to_bytes(), activate=True))


def test_compare_methods_scores_each_method_per_day(tmp_path, monkeypatch, policy):
    import cacas.adaptation
    from cacas.export import export_tables
    from cacas.method_comparison import compare_methods

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    path = tmp_path / "c.sqlite"
    two_adapted_days(path, "P01", "cacas", policy, robot_action="do nothing", response="accept", type="type_2",
                     user_action="pain check")
    seen = []
    real_adapt = cacas.adaptation.adapt_policy

    def adapt_reporting_halfway(*args, progress=None, **kw):  # as SAC training reports its rounds
        progress(0.5, "round 1/2")
        return real_adapt(*args, **kw)
    monkeypatch.setattr(cacas.adaptation, "adapt_policy", adapt_reporting_halfway)
    done = compare_methods(path, methods=("nn",), progress=lambda f, m: seen.append((f, m)))
    assert (done.adapted, done.initial) == (2, 1)  # days 1, 2 adapted; the initial policy scored (day 0)
    monkeypatch.setattr(cacas.adaptation, "adapt_policy", real_adapt)
    # 3 units (initial policy, day 1, day 2): each adaptation's own progress shows between its ends,
    # so a stop request acts within an adaptation
    assert seen == [(1 / 3, "P01: nn after day 1"), (1.5 / 3, "P01: nn after day 1"),
                    (2 / 3, "P01: nn after day 2"), (2.5 / 3, "P01: nn after day 2"),
                    (1.0, "Recorded 2 adaptations after study days and 1 score of the initial policy (day 0).")]
    assert compare_methods(path, methods=("nn",)).runs == 0  # already there: nothing recorded twice
    with StudyStore(path) as s:
        runs = s.adaptations_frame("P01")
        nn = runs[runs["method"] == "nn"]
        assert list(nn["day"]) == [0, 1, 2] and nn["preference_accuracy"].between(0, 1).all()
        # NN learnt the request: on day 2 (adapted from day 1) it prefers pain check for coughs
        assert nn["preference_accuracy"].iloc[1] == 1.0
        assert [json.loads(m)["preferences_version"] for m in nn["metrics"]] == [1, 1, 1]
        daily = export_tables(s)["daily"]
        by_pref = export_tables(s)["by_preference"]
    assert set(daily.loc[daily["method"] == "nn", "day"]) == {1, 2}
    # the same runs, by described preference (one here): day 2's NN learnt it
    nn = by_pref[by_pref["method"] == "nn"].set_index("day")
    assert list(nn.index) == [1, 2] and (nn["action"] == "pain check").all() and (nn["states"] == 400).all()
    assert nn.loc[2, "accuracy"] == 1.0 and nn.loc[2, "correct"] == 400


def test_every_methods_run_of_a_day_is_scored_on_the_preferences_of_its_time(tmp_path, monkeypatch, policy):
    """Preferences edited mid-study (walkthrough): the study's own runs of days 0-2 were scored on
    version 1, and the baselines' runs of the same days, made after version 2 was saved, on version
    2: on day 1 the same initial policy had two accuracies. Each day's runs now share the version
    of the day's first run; a day adapted after the edit is scored on the new version."""
    import cacas.adaptation
    from cacas.export import export_tables
    from cacas.method_comparison import compare_methods

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    path = tmp_path / "c.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P01")
        s.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
        s.record_adaptation("P01", 0, "cacas", {"initial": True}, 0.0, {"preference_accuracy": 0.1,
                                                                       "preferences_version": 1})
        for day in (1, 2, 3):
            if day == 3:  # the participant describes coughs differently before day 3 is adapted
                s.save_preferences("P01", [{"activity": ["cough"], "action": "show compassion"}])
            start_day(s, "P01")
            s.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                                 robot_action="pain check", response="accept")
            s.close_day("P01", day)
            s.record_adaptation("P01", day, "cacas", {}, 1.0, {"preference_accuracy": 0.5,
                                                                "preferences_version": 1 if day < 3 else 2},
                                s.save_policy("P01", day, "cacas", policy.to_bytes(), activate=True))
    assert compare_methods(path, methods=("nn",)).runs == 4
    with StudyStore(path) as s:
        runs = s.adaptations_frame("P01")
        nn = runs[runs["method"] == "nn"]
        assert list(nn["day"]) == [0, 1, 2, 3]
        assert [json.loads(m)["preferences_version"] for m in nn["metrics"]] == [1, 1, 1, 2]
        by_pref = export_tables(s)["by_preference"]
    # the baseline's rows of days 1-3 (the policies of days 0-2 in force) name the preference of their time
    nn = by_pref[by_pref["method"] == "nn"]
    assert list(nn["day"]) == [1, 2, 3] and (nn["action"] == "pain check").all()


def test_compare_methods_leaves_out_who_has_no_described_preferences_or_closed_day(tmp_path, monkeypatch, policy):
    """Fig. 4's accuracy needs described preferences, and a comparison needs a closed day: a
    participant without either gets no comparison run (not a run scored on nothing)."""
    import cacas.adaptation
    from cacas.method_comparison import compare_methods

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    path = tmp_path / "c.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P02")  # described preferences, their first day still open
        s.save_preferences("P02", [{"activity": ["cough"], "action": "pain check"}])
        start_day(s, "P02")
        s.add_participant("P03")  # a closed day, no described preferences
        s.open_day("P03")
        s.close_day("P03", 1)
    done = compare_methods(path, methods=("nn",))
    assert done.runs == 0
    assert done.participants == 0  # nothing to compare: the page says so (walkthrough), not "every day has its runs"
    with StudyStore(path) as s:
        assert s.adaptations_frame("P02").empty and s.adaptations_frame("P03").empty


def test_compare_methods_fills_in_every_method_a_participant_lacks(tmp_path, monkeypatch, policy):
    """By default the paper's four methods: a participant whose study adapted with NN gets CACAS,
    CACAS w/o PR and ORL (Fig. 4 left them out for good: the comparison never ran CACAS, and the
    caption said to compare again); NN's recorded days are not adapted again, and a method missing
    only day 1 is adapted no further than day 1."""
    import cacas.adaptation
    from cacas.adaptation import AdaptationResult
    from cacas.export import export_tables
    from cacas.experiment import PAPER_METHODS
    from cacas.plots import incomplete_comparisons
    from cacas.method_comparison import compare_methods

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    adapted = []

    def fake_adapt(before, data, method, seed=0, progress=None):
        adapted.append((method, int(data["day"].max())))
        return AdaptationResult(policy, [], {"method": method}, 0.0)
    monkeypatch.setattr(cacas.adaptation, "adapt_policy", fake_adapt)
    path = tmp_path / "c.sqlite"
    two_adapted_days(path, "E05", "nn", policy, robot_action="pain check", response="accept")  # the study's NN
    with StudyStore(path) as s:
        s.record_adaptation("E05", 0, "nn", {"initial": True}, 0.0, {"preference_accuracy": 0.5})
        s.record_adaptation("E05", 0, "orl", {}, 0.0, {"preference_accuracy": 0.5})
        s.record_adaptation("E05", 1, "orl", {}, 1.0, {"preference_accuracy": 0.5})
        s.record_adaptation("E05", 0, "cacas-no-pr", {}, 0.0, {"preference_accuracy": 0.5})
        s.record_adaptation("E05", 1, "cacas-no-pr", {}, 1.0, {"preference_accuracy": 0.5})
        s.record_adaptation("E05", 2, "cacas-no-pr", {}, 1.0, {"preference_accuracy": 0.5})
    assert PAPER_METHODS == ("cacas", "cacas-no-pr", "orl", "nn")
    assert compare_methods(path).runs == 4  # CACAS days 0, 1, 2; ORL day 2
    assert sorted(adapted) == [("cacas", 1), ("cacas", 2), ("orl", 1), ("orl", 2)]  # ORL's chain through day 2
    with StudyStore(path) as s:
        runs = s.adaptations_frame("E05")
        assert sorted(runs.loc[runs["method"] == "cacas", "day"]) == [0, 1, 2]
        daily = export_tables(s)["daily"]
    assert incomplete_comparisons(daily).empty  # E05 is in Fig. 4 on every day
    adapted.clear()
    assert compare_methods(path).runs == 0 and adapted == []  # all there: nothing adapted again
    # a day closed and waiting for the study's own adaptation (NN's here) gets no NN comparison run,
    # which Results would show as that day's policy; the other methods are compared on it
    with StudyStore(path) as s:
        start_day(s, "E05")
        s.record_interaction("E05", 3, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
        s.close_day("E05", 3)
    assert compare_methods(path).runs == 3
    assert sorted(m for m, day in adapted if day == 3) == ["cacas", "cacas-no-pr", "orl"]
    with StudyStore(path) as s:
        assert day_status(s, "E05").waiting_for_adaptation
        assert not ((s.adaptations_frame("E05")["method"] == "nn") & (s.adaptations_frame("E05")["day"] == 3)).any()


def test_compare_methods_in_worker_processes_records_the_same_runs(tmp_path, monkeypatch, policy):
    """Large-study walkthrough: the comparison ran in the server's own thread (24 participants x 7
    days: about 10 minutes, and the pages slowed to 15-23 s meanwhile). Participants now run side
    by side in worker processes; the main process records each run as it comes, the same runs as
    one process makes."""
    import cacas.adaptation
    from cacas.method_comparison import compare_methods

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)  # sent to the workers
    paths = [tmp_path / "one.sqlite", tmp_path / "two.sqlite"]
    for path in paths:
        for code in ("P01", "P02", "P03"):
            two_adapted_days(path, code, "cacas", policy, robot_action="do nothing", response="accept",
                             type="type_2", user_action="pain check")
    seen = []
    assert compare_methods(paths[0], methods=("nn", "cacas-no-pr")).runs == 18  # 3 x 2 methods x days 0-2
    assert compare_methods(paths[1], methods=("nn", "cacas-no-pr"), jobs=2,
                           progress=lambda f, m: seen.append((f, m))).runs == 18
    assert seen[-1] == (1.0, "Recorded 12 adaptations after study days and 6 scores of the initial policy (day 0).") and all(0 <= f <= 1 for f, _ in seen)
    assert any(m.startswith("P02: cacas-no-pr after day") for _, m in seen)  # the workers' progress came through
    frames = []
    for path in paths:
        with StudyStore(path) as s:
            runs = s.adaptations_frame()
            frames.append(runs[runs["method"] != "cacas"].sort_values(["participant", "method", "day"])
                          [["participant", "method", "day", "preference_accuracy", "metrics"]].reset_index(drop=True))
    assert frames[0].equals(frames[1])


def test_a_stopped_comparison_in_worker_processes_keeps_the_runs_recorded(tmp_path, monkeypatch, policy):
    import cacas.adaptation
    from cacas.jobs import Stopped
    from cacas.method_comparison import compare_methods

    monkeypatch.setattr(cacas.adaptation, "load_initial_policy", lambda *a, **k: policy)
    path = tmp_path / "c.sqlite"
    for code in ("P01", "P02"):
        two_adapted_days(path, code, "cacas", policy, robot_action="pain check", response="accept")

    def stop_after_a_run(f, m):
        with StudyStore(path) as s:
            if (s.adaptations_frame()["method"] == "nn").sum() >= 2:
                raise Stopped("stopped on request")
    with pytest.raises(Stopped) as stopped:
        compare_methods(path, methods=("nn",), jobs=2, progress=stop_after_a_run)
    assert "participants' comparisons ended early in their worker process" in stopped.value.__notes__[0]
    with StudyStore(path) as s:
        kept = int((s.adaptations_frame()["method"] == "nn").sum())
    assert 2 <= kept <= 6  # what was made before the stop is recorded; the rest is made by comparing again
    assert compare_methods(path, methods=("nn",)).runs == 6 - kept
