import json

import numpy as np
import pytest

from cacas.adaptation import preference_accuracy, preferences_learnt
from cacas.jobs import RUNNER
from cacas.policy import policy_from_bytes

from apphelpers import cache_of, no_exception, texts
from studies import answered_day, cough_day

PAGE = "pages/adaptation.py"


def _button(at, label):
    return next(b for b in at.button if b.label == label)


def _day_with_interactions(store, code="P01"):
    store.add_participant(code)
    store.save_preferences(code, [{"activity": ["cough"], "action": "pain check"},
                                  {"activity": ["use stove"], "scene": ["kitchen"], "action": "remind to turn off"}])
    day = store.open_day(code)
    for i, (act, scene, robot, resp) in enumerate([("cough", "bedroom", "chitchat", "reject"),
                                                   ("cough", "bedroom", "pain check", "accept"),
                                                   ("use stove", "kitchen", "set a timer", "reject")]):
        store.record_interaction(code, day, activity=act, scene=scene, hour=8, interval_minutes=30,
                                 robot_action=robot, response=resp)
    store.record_interaction(code, day, activity="use stove", scene="kitchen", hour=18, interval_minutes=5,
                             robot_action="do nothing", response="accept", type="type_2",
                             user_action="remind to turn off")
    return day


def test_page_before_any_day(app, store, quick_policy):
    store.add_participant("P01")
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert "has not started day 1" in texts(at)


def test_the_method_is_chosen_by_the_name_the_figures_give_it(app, store, quick_policy):
    """The Options' Method listed codes ('cacas-no-pr'), where Results' figures say 'CACAS w/o PR'."""
    _day_with_interactions(store)
    at = app(PAGE, participant="P01")
    no_exception(at)
    method = at.selectbox(key="adapt-method")
    assert method.options == ["CACAS", "CACAS w/o PR", "ORL", "NN", "Bandit (TS)", "SAC on user data"]
    assert method.value == "cacas"


def test_close_day_and_adapt(app, store, quick_policy):
    day = _day_with_interactions(store)
    at = app(PAGE, participant="P01")
    no_exception(at)
    # 4 of about 15: closing, which cannot be undone, waits for the researcher to say so (walkthrough: one
    # click closed a day of 2 interactions)
    assert _button(at, f"Close day {day} and adapt").disabled
    at.checkbox(key=f"close-short-P01-{day}").check().run()
    assert at.checkbox(key=f"close-short-P01-{day}").label == f"Close day {day} with 4 of about 15 interactions"
    _button(at, f"Close day {day} and adapt").click().run()
    job = RUNNER.get(f"adapt:{store.path}:P01:{day}")
    assert job is not None
    assert job.wait(600), "adaptation did not finish"  # generous: a loaded machine only slows it
    assert job.status == "done", job.error
    at.run()
    no_exception(at)
    # the day is closed, a new policy version is in force, the run is recorded with its metric
    assert not store.days("P01")[0].is_open
    active = store.active_policy("P01")
    assert active is not None and active.day == day
    runs = store.adaptations_frame("P01")
    assert list(runs["day"]) == [0, 1]  # day 0: the initial policy's accuracy (Fig. 4, day 1)
    assert [e.label for e in at.expander if e.label.startswith("Adaptation runs")] == [
        "Adaptation runs (1 after study days, 1 scoring the initial policy as day 0)"]  # it said "(2)" for one
    # each run's accuracy is its policy's, on Fig. 4's test states (seed 0, the page's default)
    described = store.get_preferences("P01")
    adapted = policy_from_bytes(store.load_policy("P01", version=active.version))
    assert runs["preference_accuracy"].iloc[0] == pytest.approx(preference_accuracy(quick_policy, described))
    assert runs["preference_accuracy"].iloc[-1] == pytest.approx(preference_accuracy(adapted, described))
    assert f"policy version {active.version} is in force from day 2" in texts(at)
    assert "contexts** (most frequent first, then the most recent)" in texts(at)
    assert "Day 1 is closed and adapted" in texts(at)
    # each described preference, before and after, on Fig. 4's test states
    learnt = next(d.value for d in at.dataframe if "after" in d.value.columns and "label" in d.value.columns)
    assert list(learnt["action"]) == ["pain check", "remind to turn off"]
    # in percent: before is the initial policy, after the adapted one, on the same test states
    expected = preferences_learnt(quick_policy, adapted, described)
    np.testing.assert_allclose(learnt[["before", "after"]].to_numpy(dtype=float),
                               100 * expected[["before", "after"]].to_numpy(dtype=float))
    # beside Fig. 4's draws, the states each covers as the Participants page counts them, each said where shown
    # (walkthrough: "128 test states" for a preference the Participants page said covers 72)
    assert list(learnt["covers"]) == [p.covered_count() for p in described.preferences]
    assert list(learnt["states"]) == list(expected["states"])
    assert "**States covered**: the S1-S4 states the preference covers, as the Participants page" in texts(at)
    assert "**Fig. 4 draws**: how many of Fig. 4's 400 test states fell in it" in texts(at)
    # every column in view at 1280 px, the participant's words wrapping instead of cut (walkthrough: "When I
    # drink water in the morning, remind me to take m")
    grid = next(d for d in at.dataframe if "covers" in d.value.columns)
    widths = {name: c.get("width") for name, c in json.loads(grid.proto.columns).items()}
    assert set(widths) >= set(learnt.columns) and sum(widths[c] for c in learnt.columns) <= 818, widths
    assert grid.proto.row_height > 64
    saved = store.preference_versions("P01")[0]["created_at"]  # which version is scored, and when it was saved
    assert f"P01's described preferences** (version 1, the latest, saved {saved[:10]} {saved[11:16]} UTC)" in texts(at)
    # roll back: the banner no longer claims the new version is in force; What changed shows the step back
    at.selectbox(key=f"rollback-version-P01-{active.version}-{active.version}").set_value(0)
    _button(at, "Put in force").click().run()
    no_exception(at)
    assert store.active_policy("P01") is None
    shown = next(m for m in at.metric if m.label == "Policy in force")
    assert (shown.value, shown.delta) == ("initial", f"rolled back; newest: version {active.version}")
    assert f"policy version {active.version} is in force" not in texts(at)
    assert "since then the initial policy was put in force" in texts(at)
    # the run's accuracy is named as the new version's, not read as the policy's now in force (walkthrough)
    assert f"Version {active.version}'s preference accuracy (Fig. 4): " in texts(at)
    assert "The initial policy is in force from P01's next interaction." in texts(at)  # the toast names it
    assert next(s for s in at.selectbox if s.label == "After").value == 0
    assert next(s for s in at.selectbox if s.label == "Before").value == active.version


def test_rollback_to_the_initial_policy(app, store, quick_policy):
    day = _day_with_interactions(store)
    store.close_day("P01", day)
    store.save_policy("P01", day, "cacas", quick_policy.to_bytes())
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert not any("The initial policy is in force (no version above)" in c.value for c in at.caption)
    at.selectbox(key="rollback-version-P01-1-1").set_value(0)
    _button(at, "Put in force").click().run()
    no_exception(at)
    assert store.active_policy("P01") is None
    # the versions table has no row in force then: said under it
    assert any("The initial policy is in force (no version above)" in c.value for c in at.caption)


def test_a_comparison_run_is_not_an_adaptation_and_a_baseline_adaptation_is(app, store, quick_policy):
    """Results' 'Compare methods' records runs without a policy: the closed day still waits for
    its adaptation (the page offers it, the tablet agrees). A day adapted with a baseline is
    adapted: the page says so and the next day can start."""
    from cacas.study_day import day_status, start_day

    day = _day_with_interactions(store)
    store.close_day("P01", day)
    store.record_adaptation("P01", day, "nn", {"comparison": True}, 0.1, {"preference_accuracy": 0.5})
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert day_status(store, "P01").waiting_for_adaptation
    assert any(b.label == f"Adapt after day {day}" for b in at.button)
    assert "closed and adapted" not in texts(at)
    at.session_state["adapt-method"] = "nn"
    _button(at, f"Adapt after day {day}").click().run()
    job = RUNNER.get(f"adapt:{store.path}:P01:{day}")
    assert job.wait(600) and job.status == "done", job.error  # generous: a loaded machine only slows it
    at.run()
    no_exception(at)
    assert store.active_policy("P01").method == "nn"
    assert f"Day {day} is closed and adapted" in texts(at)
    assert not day_status(store, "P01").waiting_for_adaptation
    assert start_day(store, "P01") == day + 1



def test_a_day_another_tab_adapted_first_is_said_so_not_called_a_failure(app, store, quick_policy):
    """Review: a stale tab's click on 'Adapt after day 1', after another tab had adapted it, was shown
    as 'The adaptation failed: ...' in red under the green 'closed and adapted'. Nothing is wrong:
    the page says the other adaptation is in force and this click saved nothing."""
    day = _day_with_interactions(store)
    store.close_day("P01", day)
    at = app(PAGE, participant="P01")  # drawn while day 1 waits for its adaptation
    no_exception(at)
    store.save_adapted_policy("P01", day, "cacas", quick_policy.to_bytes(), {}, 1.0, {})  # the other tab's
    at.session_state["adapt-method"] = "nn"
    _button(at, f"Adapt after day {day}").click().run()
    job = RUNNER.get(f"adapt:{store.path}:P01:{day}")
    assert job.wait(600) and job.status == "failed"
    at.run()
    no_exception(at)
    assert not at.error
    assert [i.value for i in at.info] == [f"Day {day} had been adapted already, in another tab or by another server: "
                                          "this click saved nothing (the policy versions are below)."]
    assert f"Day {day} is closed and adapted" in texts(at)
    assert [(v.version, v.method) for v in store.policy_versions("P01")] == [(1, "cacas")]


def test_a_stale_tabs_click_keeps_the_adaptation_this_server_finished(app, store, quick_policy):
    """Review: a second tab's click on 'Adapt after day 1', after the first tab's adaptation finished in
    this server, replaced the finished job (the first tab lost its 'Adapted with ...' and its log)."""
    day = _day_with_interactions(store)
    store.close_day("P01", day)
    first, second = app(PAGE, participant="P01"), app(PAGE, participant="P01")
    first.session_state["adapt-method"] = "nn"
    _button(first, f"Adapt after day {day}").click().run()
    job = RUNNER.get(f"adapt:{store.path}:P01:{day}")
    assert job.wait(600) and job.status == "done", job.error
    _button(second, f"Adapt after day {day}").click().run()
    no_exception(second)
    assert RUNNER.get(f"adapt:{store.path}:P01:{day}") is job  # not replaced
    assert f"Day {day} was adapted already, in another tab: this click did nothing." in [w.value for w in second.warning]
    first.run()
    assert any(m.value.startswith("Adapted with NN in ") for m in first.success)
    assert len(store.policy_versions("P01")) == 1


def test_a_double_click_on_close_and_adapt_adapts_once_and_says_nothing_more(app, store, quick_policy, monkeypatch):
    """Walkthrough: a double click on "Close day 2 and adapt" left, once the adaptation was over, a yellow "This
    adaptation is already running (started in another tab?)" beside "Adapted with cacas ...": the second click
    (its callback called while the first click's run draws) found the run going, and its note stayed."""
    from pages import ui

    clicks = {}
    real = ui.button

    def button(where, label, on_click, **kw):  # the button's callback, to call it again as a second click does
        clicks[label] = (on_click, kw.get("args", ()), kw.get("kwargs") or {})
        return real(where, label, on_click, **kw)

    monkeypatch.setattr(ui, "button", button)
    day = _day_with_interactions(store)
    at = app(PAGE, participant="P01")
    at.checkbox(key=f"close-short-P01-{day}").check().run()
    label = f"Close day {day} and adapt"
    _button(at, label).click().run()
    at.session_state[ui._MISSED_CLICK] = clicks[label]  # the double click's second click: called first thing
    at.run()
    job = RUNNER.get(f"adapt:{store.path}:P01:{day}")
    assert job.wait(600) and job.status == "done", job.error
    at.session_state[ui._MISSED_CLICK] = clicks[label]  # and a second click that arrives after the run is over
    at.run()
    at.run()
    no_exception(at)
    assert [w.value for w in at.warning] == []
    assert any(m.value.startswith("Adapted with CACAS in ") for m in at.success)
    assert len(store.policy_versions("P01")) == 1


def test_an_adaptation_the_app_was_stopped_during_is_said_so(app, store, quick_policy):
    """Review: after a kill mid-adaptation the page offered 'Adapt after day 1' with no word of the
    run that saved nothing. It says so (this server knows no such run), until the day is adapted."""
    day = _day_with_interactions(store)
    store.note_adaptation_started("P01", day, "cacas")  # what adapt_day logs before closing the day
    store.close_day("P01", day)
    at = app(PAGE, participant="P01")
    no_exception(at)
    started = store.events("P01", what="adapt_start")["at"].iloc[-1]
    assert [w.value for w in at.warning] == [
        f"An adaptation of day {day} with CACAS, begun {started[:10]} {started[11:16]} UTC, saved nothing: the app "
        "was probably stopped during it, or it failed. The day's data are all kept; adapt again (unless another "
        "server is adapting it now)."]
    at.session_state["adapt-method"] = "nn"
    _button(at, f"Adapt after day {day}").click().run()
    job = RUNNER.get(f"adapt:{store.path}:P01:{day}")
    assert job.wait(600) and job.status == "done", job.error
    at.run()
    no_exception(at)
    assert not at.warning and f"Day {day} is closed and adapted" in texts(at)


def test_what_changed_and_roll_back_follow_the_newest_version(app, store, quick_policy):
    """After a new version is saved, the comparison and the roll-back start at the policy in
    force (the widgets kept the earlier choice)."""
    day = _day_with_interactions(store)
    store.close_day("P01", day)
    store.save_policy("P01", day, "cacas", quick_policy.to_bytes())
    at = app(PAGE, participant="P01")
    no_exception(at)
    after = next(s for s in at.selectbox if s.label == "After")
    assert after.value == 1 and next(s for s in at.selectbox if s.label == "Before").value == 0
    store.save_policy("P01", day, "cacas", quick_policy.to_bytes())  # e.g. adapted again: version 2 in force
    at.run()
    no_exception(at)
    assert next(s for s in at.selectbox if s.label == "After").value == 2
    assert next(s for s in at.selectbox if s.label == "Before").value == 1
    assert next(s for s in at.selectbox if s.label == "Policy").value == 2


def test_a_percentage_in_text_is_rounded_as_the_tables_round_it():
    from pages.ui import percent

    # the banner said 72% and the versions table ("%.0f%%") 73% for the same 0.725
    assert percent(0.725) == "73%" and percent(0.724) == "72%" and percent(0.0) == "0%" and percent(1.0) == "100%"
    assert percent(None) == "–" and percent(float("nan")) == "–"


def test_a_day_of_about_15_interactions_closes_without_asking(app, store, quick_policy):
    store.add_participant("P01")
    day = answered_day(store, interval_minutes=30)
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert not _button(at, f"Close day {day} and adapt").disabled and not at.checkbox


def test_the_adaptation_page_and_the_tablet_keep_a_policy_version_in_one_cache(app, store, quick_policy):
    """The Adaptation page's comparison and the tablet's proposals each kept a cache of policies of their own (32
    each): a version both used was in memory twice, and the two held up to 64 policies (~110 MB, the long-run
    benchmark's count). One cache now (pages.ui.policy_version), bounded."""
    from pages import ui
    from test_page_session import PAGE as SESSION, _choose

    ui.policy_version.clear()
    day = _day_with_interactions(store)
    store.close_day("P01", day)
    for _ in range(2):
        store.save_policy("P01", day, "cacas", quick_policy.to_bytes())  # versions 1 and 2 (in force)
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert [next(s for s in at.selectbox if s.label == label).value for label in ("Before", "After")] == [1, 2]
    cache = cache_of("pages.ui.policy_version")
    assert cache is not None and len(cache._mem_cache) == 2 and cache.max_entries == ui.POLICIES_KEPT
    assert cache_of("__main__._load") is None  # the page's own, gone
    tablet = app(SESSION, participant="P01")
    _button(tablet, "Start day 2").click().run()
    _choose(tablet)  # a proposal of version 2, the one in force
    assert len(tablet.chat_message) == 1
    _button(tablet, "Accept").click().run()
    assert store.interactions_frame("P01", method=None, extra=True).iloc[-1]["policy_version"] == 2
    assert len(cache._mem_cache) == 2  # version 2 again, not a second copy


def test_what_changed_uses_the_policy_of_the_participant_who_has_the_code_now(app, store, quick_policy):
    """Policies are cached by participant and version: after a removal, a new participant given the
    same code starts again at version 1 and "What changed" showed the removed participant's policy."""
    from cacas.adaptation import policy_changes
    from cacas.policy import ReshapedPolicy
    from cacas.sac import DiscreteSAC, SACConfig

    shown = []
    for seed in (1, 2):
        day = _day_with_interactions(store)
        store.close_day("P01", day)
        policy = ReshapedPolicy(DiscreteSAC(SACConfig(), seed=seed), None, beta=1.0, method="cacas")
        store.save_policy("P01", day, "cacas", policy.to_bytes())
        at = app(PAGE, participant="P01")
        no_exception(at)
        table = next(d.value for d in at.dataframe if {"activity", "after"} <= set(d.value.columns))  # What changed
        expected = policy_changes(quick_policy, policy_from_bytes(store.load_policy("P01", version=1)),
                                  store.interactions_frame("P01", method=None))
        shown.append((table["after"].tolist(), expected["action_after"].tolist()))
        if seed == 1:
            store.remove_participant("P01", confirm="P01")
    assert shown[1][0] == shown[1][1]  # the new participant's own version 1


def test_closing_a_day_while_the_tablet_shows_a_proposal_is_warned(app, store, quick_policy):
    """The participant's answer to a proposal still on the tablet is not saved once the day is
    closed; the page said so only in a tooltip (walkthrough)."""
    from test_page_session import _choose

    _day_with_interactions(store)
    tab = app("pages/session.py", participant="P01", view="tablet")
    _choose(tab)  # interaction 5 of day 1 on the tablet, not answered yet
    at = app(PAGE, participant="P01")
    no_exception(at)
    warned = [w.value for w in at.warning if "tablet shows a proposal" in w.value]
    assert len(warned) == 1 and warned[0].startswith("P01's tablet shows a proposal (use stove, shown")
    assert warned[0].endswith("let the participant answer it before closing the day, or the answer is not saved.")
    label = "Accept" if any(b.label == "Accept" for b in tab.button) else "Nothing needed"
    next(b for b in tab.button if b.label == label).click().run()  # answered: nothing to warn about
    assert not [w for w in app(PAGE, participant="P01").warning if "tablet shows a proposal" in w.value]


def test_after_the_last_day_the_page_says_the_study_is_done_not_that_day_8_can_start(app, store, quick_policy):
    """Review: after day 7's adaptation the page said "day 8 can start on the tablet", while the
    tablet said all 7 days were done."""
    from cacas.study_day import STUDY_DAYS

    _day_with_interactions(store)
    for day in range(1, STUDY_DAYS + 1):
        if day > 1:
            store.open_day("P01")
        store.close_day("P01", day)
        store.save_policy("P01", day, "cacas", f"policy after day {day}".encode())
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert f"Day {STUDY_DAYS} is closed and adapted: all {STUDY_DAYS} study days are done" in texts(at)
    assert f"day {STUDY_DAYS + 1} can start" not in texts(at)


def test_the_adaptation_after_the_last_day_says_the_final_policy_not_day_8(app, store, quick_policy):
    """Walkthrough: after day 7's adaptation the page said "policy version 7 is in force from day 8"."""
    import pandas as pd

    from cacas.study_day import STUDY_DAYS, DayAdaptation

    _day_with_interactions(store)
    for day in range(1, STUDY_DAYS + 1):
        if day > 1:
            store.open_day("P01")
        store.close_day("P01", day)
        store.save_adapted_policy("P01", day, "cacas", quick_policy.to_bytes(), {}, 1.0, {})
    done = DayAdaptation("P01", STUDY_DAYS, "cacas", STUDY_DAYS, 1.5, [], None, pd.DataFrame())
    job, _ = RUNNER.start(f"adapt:{store.path}:P01:{STUDY_DAYS}", lambda progress: done)  # the page's adaptation
    assert job.wait(10) and job.status == "done"
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert (f"Adapted with CACAS in 1.5 s; policy version {STUDY_DAYS} is the study's final policy (day {STUDY_DAYS} "
            "was its last day).") in [m.value for m in at.success]
    assert f"day {STUDY_DAYS + 1}" not in texts(at)


def test_what_changed_over_one_context_says_it_in_the_singular(app, store, quick_policy):
    """Walkthrough: "The robot's action in each of A02's 1 contexts"."""
    day = cough_day(store, hour=7.5, interval_minutes=12)
    store.close_day("P01", day)
    store.save_policy("P01", day, "cacas", quick_policy.to_bytes())
    at = app(PAGE, participant="P01")
    no_exception(at)
    assert "The robot's action in P01's **1 context** (most frequent first" in texts(at)
    assert "1 contexts" not in texts(at)


def test_the_adaptation_runs_download_is_named_after_the_study_and_the_participant(app, store, quick_policy,
                                                                                   downloads):
    """Walkthrough: Results' tables are named after the study (interactions-default.csv), this page's
    'adaptations-P01.csv' was not: two studies' P01 met in a Downloads folder."""
    import io

    import pandas as pd

    day = _day_with_interactions(store)
    store.close_day("P01", day)
    store.record_adaptation("P01", day, "nn", {"comparison": True}, 0.1, {"preference_accuracy": 0.5})
    at = app(PAGE, participant="P01")
    no_exception(at)
    table = pd.read_csv(io.BytesIO(downloads["adaptations-default-P01.csv"]))
    assert list(table["day"]) == [day] and list(table["method"]) == ["nn"]
    assert "Download adaptations-P01.csv" in [b.label for b in at.get("download_button")]


def test_a_proposal_the_tablet_showed_after_the_page_was_drawn_stops_the_first_click_on_close(app, store,
                                                                                            quick_policy):
    """A study day with several tablets (lan): the page follows the tablet every few seconds, but a proposal shown
    just before "Close day N and adapt" was not on the page yet, and closing lost the answer the participant was
    about to give. The click closes nothing then and says why; a second click closes the day anyway."""
    from test_page_session import _choose

    day = _day_with_interactions(store)
    at = app(PAGE, participant="P01")
    at.checkbox(key=f"close-short-P01-{day}").check().run()
    assert not [w for w in at.warning if "tablet shows a proposal" in w.value]
    tab = app("pages/session.py", participant="P01", view="tablet")
    _choose(tab)  # interaction 5 on the tablet, after the page was drawn
    _button(at, f"Close day {day} and adapt").click().run()
    no_exception(at)
    assert RUNNER.get(f"adapt:{store.path}:P01:{day}") is None and store.days("P01")[0].is_open
    assert ("Day 1 was not closed: P01's tablet showed a proposal after this page was drawn (above). Click "
            "again to close the day anyway.") in [w.value for w in at.warning]
    answer = next(b for b in tab.button if b.label in ("Accept", "Nothing needed"))
    answer.click().run()  # answered meanwhile: the note goes with the proposal
    assert not [w for w in at.run().warning if "was not closed" in w.value]
    _choose(tab, activity="cough", scene="bedroom")  # the next proposal, after the page was drawn again
    _button(at, f"Close day {day} and adapt").click().run()
    assert [w.value for w in at.warning if "was not closed" in w.value]
    _button(at, f"Close day {day} and adapt").click().run()  # seen, and closed anyway
    job = RUNNER.get(f"adapt:{store.path}:P01:{day}")
    assert job is not None and job.wait(600) and job.status == "done", job and job.error
    assert not store.days("P01")[0].is_open
