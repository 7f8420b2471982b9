import numpy as np
import pandas as pd
import pytest

from cacas import records, spaces
from cacas.errors import CacasError
from cacas.adaptation import METHODS
from cacas.experiment import LAST_DAY_WORK, MAX_DAYS, adaptation_seed, simulate_study, simulated_day, summary_table
from cacas.preferences import parse_personas

PEOPLE = parse_personas({"participants": [
    {"id": "P01", "preferences": [{"activity": ["use stove"], "scene": ["kitchen"], "action": "set a timer"},
                                  {"activity": ["cough"], "action": "pain check"}]},
    {"id": "P02", "preferences": [{"activity": ["watch TV"], "action": "chitchat"}]}]})


class Acts:
    """A test policy acts as the app's do (``decide``: the action for one state) by its ``greedy``."""

    def decide(self, state):
        return int(self.greedy(np.asarray([state]))[0]), None


class Always(Acts):
    def __init__(self, action):
        self.action = action

    def greedy(self, states):
        return np.full(len(states), self.action)


def test_simulated_participant_accepts_rejects_and_asks():
    rng = np.random.default_rng(0)
    asked = pd.DataFrame(simulated_day(Always(0), PEOPLE[0], 1, 30, rng, 0.0, "cacas"))
    assert (asked["type"] == "type_2").all() and (asked["response"] == "accept").all()
    assert set(asked["user_action"]) == {"set a timer", "pain check"}
    wrong = pd.DataFrame(simulated_day(Always(2), PEOPLE[0], 1, 30, rng, 0.0, "cacas"))
    assert (wrong["response"] == "reject").all() and (wrong["type"] == "type_1").all()
    silent = pd.DataFrame(simulated_day(Always(2), PEOPLE[0], 1, 200, rng, 0.5, "cacas"))
    assert 0.35 < (silent["response"] == "others").mean() < 0.65
    assert list(asked["time"]) == sorted(asked["time"])  # a day in time order
    assert 15 <= len(asked) <= 45  # about 30 a day


def test_participant_may_answer_a_wrong_proposal_with_a_request():
    wrong = Always(spaces.action_index("chitchat"))
    never = pd.DataFrame(simulated_day(wrong, PEOPLE[0], 1, 30, np.random.default_rng(0), 0.0, "cacas"))
    same = pd.DataFrame(simulated_day(wrong, PEOPLE[0], 1, 30, np.random.default_rng(0), 0.0, "cacas", 0.0))
    pd.testing.assert_frame_equal(never, same)  # the option at 0 draws nothing: the same study
    always = pd.DataFrame(simulated_day(wrong, PEOPLE[0], 1, 30, np.random.default_rng(0), 0.0, "cacas", 1.0))
    assert (always["type"] == "type_2").all() and (always["robot_action"] == "chitchat").all()
    assert (always["response"] == "accept").all() and set(always["user_action"]) == {"set a timer", "pain check"}
    half = pd.DataFrame(simulated_day(wrong, PEOPLE[0], 1, 400, np.random.default_rng(1), 0.0, "cacas", 0.5))
    assert 0.4 < (half["type"] == "type_2").mean() < 0.6
    assert set(half.loc[half["type"] == "type_1", "response"]) == {"reject"}
    # "do nothing" is not a request: a leave-me-alone participant only rejects
    quiet = parse_personas({"participants": [{"id": "Q", "preferences": [
        {"activity": ["watch TV"], "action": "do nothing"}]}]})[0]
    alone = pd.DataFrame(simulated_day(wrong, quiet, 1, 30, np.random.default_rng(0), 0.0, "cacas", 1.0))
    assert (alone["response"] == "reject").all()


def test_a_leave_me_alone_preference_gives_no_accept_data():
    """Where the participant prefers "do nothing", the robot's actions are rejected and its silence
    is not answered with a request: the "accept" data (NN's only data) never hold that context."""
    from cacas.policy import accept_pairs

    quiet = parse_personas({"participants": [{"id": "Q", "preferences": [
        {"activity": ["watch TV"], "action": "do nothing"}]}]})[0]
    rng = np.random.default_rng(0)
    acting = pd.DataFrame(simulated_day(Always(2), quiet, 1, 30, rng, 0.0, "cacas"))
    idle = pd.DataFrame(simulated_day(Always(0), quiet, 1, 30, rng, 0.0, "cacas"))
    assert (acting["response"] == "reject").all()
    assert (idle["type"] == "type_1").all() and (idle["response"] == "others").all()
    assert len(accept_pairs(pd.concat([acting, idle]))[1]) == 0


def test_study_tables_follow_the_contract(small_config, small_initial):
    res = simulate_study(PEOPLE, days=2, interactions=6, methods=["cacas", "nn"], seed=1,
                         config=small_config, initial_policy=small_initial)
    d = res.daily
    assert list(d.columns[:7]) == ["participant", "method", "day", "success_rate", "preference_accuracy",
                                   "cumulative_feedback", "interactions"]
    assert len(d) == 2 * 2 * 2 and list(res.interactions.columns) == records.INTERACTION_COLUMNS
    assert d.loc[d.method == "nn", "success_rate"].isna().all()
    assert d.loc[d.method == "cacas", "success_rate"].between(0, 1).all()
    assert d["preference_accuracy"].between(0, 1).all()
    cacas = d[d.method == "cacas"].sort_values(["participant", "day"])
    for _, g in cacas.groupby("participant"):
        assert g["cumulative_feedback"].is_monotonic_increasing
    # the day-1 policy is the initial one for every method
    day1 = d[d.day == 1].groupby("participant")["preference_accuracy"].nunique()
    assert (day1 == 1).all()
    table = summary_table(d)
    assert set(table["method"]) == {"cacas", "nn"}
    # Fig. 4 by described preference: every participant, method, day and preference; the
    # state-weighted accuracy is daily.csv's (these preferences do not overlap)
    b = res.by_preference
    assert list(b.columns) == records.BY_PREFERENCE_COLUMNS and len(b) == (2 + 1) * 2 * 2
    assert list(b.loc[(b.participant == "P01") & (b.method == "nn") & (b.day == 1), "action"]) == \
        ["set a timer", "pain check"]
    weighted = b.groupby(["participant", "method", "day"])[["correct", "states"]].sum()
    merged = d.set_index(["participant", "method", "day"])["preference_accuracy"]
    assert (weighted["correct"] / weighted["states"]).to_dict() == pytest.approx(merged.to_dict())
    assert (b["accuracy"] == b["correct"] / b["states"]).all()


def test_success_ceiling_of_a_simulated_study(small_config, small_initial):
    """Simulated participants act where their preferences name an action (ceiling 1), except
    where they want to be left alone: there even a perfect robot cannot succeed. Of the recorded
    interactions, as the success rate: a quiet robot where quiet is wanted is not one."""
    people = parse_personas({"participants": [
        {"id": "A", "preferences": [{"activity": ["cough"], "action": "pain check"}]},
        {"id": "Q", "preferences": [{"activity": ["cough"], "action": "pain check"},
                                    {"activity": ["watch TV"], "action": "do nothing"}]}]})
    res = simulate_study(people, days=2, interactions=10, methods=["cacas", "nn"], seed=2, config=small_config,
                         initial_policy=small_initial)
    d = res.daily.set_index(["participant", "method", "day"])
    assert (d.xs("A")["success_ceiling"].xs("cacas") == 1.0).all()
    inter = res.interactions[res.interactions["participant"] == "Q"]
    shares = []
    for day in (1, 2):
        today = inter[inter["day"] == day]
        recorded = today[records.is_recorded(today)]
        shares.append((recorded["activity"] == "cough").mean())
        assert d.loc[("Q", "cacas", day), "success_ceiling"] == pytest.approx(shares[-1])
        assert d.loc[("Q", "cacas", day), "success_rate"] <= shares[-1]
        assert d.loc[("Q", "cacas", day), "interactions"] == len(recorded)
        assert d.loc[("Q", "cacas", day), "unanswered"] == len(today) - len(recorded) > 0
    assert 0 < min(shares) < 1   # the initial policy spoke where Q wants quiet, and was rejected
    assert d.xs("nn", level="method")["success_ceiling"].isna().all()
    assert "success_ceiling" in summary_table(res.daily).columns


def test_each_closed_loop_has_the_success_ceiling_of_its_own_interactions(small_config, small_initial):
    quiet = parse_personas({"participants": [{"id": "Q", "preferences": [
        {"activity": ["cough"], "action": "pain check"}, {"activity": ["watch TV"], "action": "do nothing"}]}]})
    res = simulate_study(quiet, days=3, interactions=8, methods=["cacas", "nn"], loop="EACH", seed=1,
                         config=small_config, initial_policy=small_initial)
    preferred = {"Q": quiet[0].preferred_action_table()}
    for m in ("cacas", "nn"):
        own = records.daily_table(res.interactions[res.interactions["method"] == m], preferred=preferred)
        np.testing.assert_allclose(res.daily[res.daily["method"] == m]["success_ceiling"], own["success_ceiling"])
    assert (res.daily["success_ceiling"] < 1).any()  # the quiet preference lowers it


def test_adaptation_seeds_never_collide_within_a_study():
    # 40 participants x a year of days x every method, for two study seeds: one stream each
    for seed in (0, 1):
        seeds = {adaptation_seed(seed, p_i, day, m) for p_i in range(40) for day in range(1, MAX_DAYS + 1)
                 for m in METHODS}
        assert len(seeds) == 40 * MAX_DAYS * len(METHODS)
    assert adaptation_seed(0, 0, 1, "cacas") != adaptation_seed(1, 0, 1, "cacas")
    # unchanged where the arithmetic form was collision-free, so published results reproduce
    assert adaptation_seed(2, 3, 6, "nn") == 2 * 100_003 + 3 * 101 + 6 * 7 + METHODS.index("nn")


def test_same_seed_same_tables(small_config, small_initial):
    kw = dict(days=2, interactions=5, methods=["cacas", "orl"], config=small_config, initial_policy=small_initial)
    a = simulate_study(PEOPLE[:1], seed=3, **kw)
    b = simulate_study(PEOPLE[:1], seed=3, **kw)
    pd.testing.assert_frame_equal(a.daily, b.daily)
    pd.testing.assert_frame_equal(a.interactions, b.interactions)


@pytest.mark.parametrize("places", [[0, 0], [1], [-1, 2], [0, 1, 2]])
def test_places_must_be_one_distinct_place_per_participant(places):
    with pytest.raises(CacasError, match=r"places .* are invalid for 2 participants; valid: one distinct whole"):
        simulate_study(PEOPLE[:2], days=1, interactions=2, methods=["nn"], places=places)


def test_each_method_in_its_own_closed_loop(small_config, small_initial):
    kw = dict(days=3, interactions=10, seed=5, config=small_config, initial_policy=small_initial)
    res = simulate_study(PEOPLE, methods=["cacas", "nn"], loop="each", **kw)
    inter, d = res.interactions, res.daily
    assert set(inter["method"]) == {"cacas", "nn"}
    assert d["success_rate"].notna().all()  # every method has a success rate of its own
    key = ["participant", "day", "index", "activity", "scene", "time", "robot_action", "response"]
    by = {m: inter[inter["method"] == m][key].reset_index(drop=True) for m in ("cacas", "nn")}
    day1 = {m: f[f["day"] == 1] for m, f in by.items()}
    pd.testing.assert_frame_equal(day1["cacas"], day1["nn"])  # same initial policy, same participant stream
    assert not by["cacas"].equals(by["nn"])  # later days follow each method's own actions
    for m in ("cacas", "nn"):  # counts and cumulative feedback from the method's own interactions
        own = records.daily_table(inter[inter["method"] == m])
        mine = d[d["method"] == m].reset_index(drop=True)
        assert list(mine["interactions"]) == list(own["interactions"])
        assert list(mine["cumulative_feedback"]) == list(own["cumulative_feedback"])
    # each method adapted from its own data: the same policies as a study it runs alone
    alone = simulate_study(PEOPLE, methods=["nn"], **kw)
    pd.testing.assert_frame_equal(d[d["method"] == "nn"].reset_index(drop=True), alone.daily)
    # later days follow each method's own actions: NN's loop is the one NN runs alone
    pd.testing.assert_frame_equal(inter[inter["method"] == "nn"].reset_index(drop=True), alone.interactions)
    # the default protocol is unchanged: the first method acts, the others have no success rate
    first = simulate_study(PEOPLE, methods=["cacas", "nn"], **kw)
    assert set(first.interactions["method"]) == {"cacas"}
    assert first.daily.query("method == 'nn'")["success_rate"].isna().all()
    pd.testing.assert_frame_equal(first.interactions, inter[inter["method"] == "cacas"].reset_index(drop=True))


def test_workers_spawned_as_on_windows_give_the_same_tables(small_config, small_initial, monkeypatch):
    """Windows has no fork server (multiprocessing's start methods there: spawn alone): each worker is
    a fresh Python that imports what it runs and gets everything else pickled. Run so for real here,
    the tables are those of one process."""
    import multiprocessing as mp

    from cacas import parallel

    monkeypatch.setattr(parallel, "worker_context", lambda: mp.get_context("spawn"))
    kw = dict(days=1, interactions=3, methods=["cacas", "nn"], seed=3, config=small_config,
              initial_policy=small_initial)
    one, two = simulate_study(PEOPLE, jobs=1, **kw), simulate_study(PEOPLE, jobs=2, **kw)
    pd.testing.assert_frame_equal(one.daily, two.daily)
    pd.testing.assert_frame_equal(one.interactions, two.interactions)
    pd.testing.assert_frame_equal(one.by_preference, two.by_preference)


@pytest.mark.parametrize("kw,needle", [({"days": 0}, "--days 0"), ({"interactions": 0}, "--interactions 0"),
                                       ({"methods": ["cacas", "dqn"]}, "unknown method 'dqn'"),
                                       ({"no_response_rate": 1.5}, "--no-response-rate 1.5"),
                                       ({"ask_after_reject": -0.1}, "--ask-after-reject -0.1"),
                                       ({"loop": "all"}, "--loop 'all' is invalid; valid: first .* or each")])
def test_bad_arguments(kw, needle, small_initial):
    with pytest.raises(CacasError, match=needle):
        simulate_study(PEOPLE, initial_policy=small_initial, **kw)


@pytest.mark.parametrize("methods", [["cacas", "nn"], ["nn", "bandit"]])
def test_parallel_workers_give_the_same_tables(methods, small_config, small_initial):
    # ["nn", "bandit"] creates no SAC agent while adapting: the MLP's initial weights once came
    # from torch's global stream, i.e. from whichever participant the worker had run before
    kw = dict(days=2, interactions=4, methods=methods, seed=2, config=small_config,
              initial_policy=small_initial)
    ticks, words = [], []
    one = simulate_study(PEOPLE, jobs=1, **kw)
    two = simulate_study(PEOPLE, jobs=2, progress=lambda f, m: (ticks.append(f), words.append(m)), **kw)
    pd.testing.assert_frame_equal(one.daily, two.daily)
    pd.testing.assert_frame_equal(one.interactions, two.interactions)
    pd.testing.assert_frame_equal(one.by_preference, two.by_preference)
    # at once, what is starting; then the participant-days, reported from the workers
    assert ticks[0] == 0.0 and words[0] == f"simulating {len(PEOPLE)} participants from day 1 (2 methods, 2 worker processes)"
    assert ticks[-1] == 1.0 and words[-1].endswith("day 2 of 2 done")
    # reports as each method adapts, not only once a participant-day is over: 2 people x 1 day
    # adapted from x 2 methods, each reported at least once, besides the 4 participant-days
    for m in methods:
        assert sum(f"adapting {m} after day 1 of 2" in w for w in words) >= len(PEOPLE)
    assert sum(w.endswith(" done") for w in words) == 2 * len(PEOPLE)


def test_progress_moves_within_a_day_and_never_back(small_config, small_initial):
    """One worker (the Simulation lab): a report per method adapted, rising to 1.0; a stop
    request raised from a report ends the study there (jobs.Stopped), not a day later."""
    from cacas.jobs import Stopped

    kw = dict(days=3, interactions=4, methods=["cacas", "nn"], seed=2, config=small_config,
              initial_policy=small_initial, jobs=1)
    seen = []
    simulate_study(PEOPLE[:1], progress=lambda f, m: seen.append((f, m)), **kw)
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[0] == 0.0 and fractions[-1] == 1.0
    within_day_1 = [f for f, m in seen if "after day 1 of 3" in m]
    one_day = 1 / (2 + LAST_DAY_WORK)  # the participant's work: two days adapted from, then the last day
    assert within_day_1 and 0 < min(within_day_1) and max(within_day_1) <= one_day
    assert any(0 < f < one_day for f in within_day_1)  # between the day's start and its end
    # the last day (lived and scored, not adapted from: about no work) moves the bar by 5 %, not a third:
    # a 3-day run's time left read twice the time the run took (walkthrough)
    assert [f for f, m in seen if m.endswith("day 2 of 3 done")] == [pytest.approx(2 * one_day)]
    assert 2 * one_day > 0.95

    def stop_at_nn(f, m):
        if "adapting nn after day 1" in m:
            raise Stopped("stopped on request")
    with pytest.raises(Stopped):
        simulate_study(PEOPLE[:1], progress=stop_at_nn, **kw)


def test_a_stop_ends_every_worker_process_at_its_next_report(small_config, small_initial):
    """Two worker processes (the Simulation lab, cacas simulate): a stop at the first report from
    a worker ends both participants' studies in their workers, not after their last day."""
    from cacas.jobs import Stopped

    def stop_at_first_worker_report(f, m):
        if m.startswith("participant "):
            raise Stopped("stopped on request")
    with pytest.raises(Stopped) as stopped:
        simulate_study(PEOPLE[:2], days=5, interactions=4, methods=["cacas", "nn"], seed=2, config=small_config,
                       initial_policy=small_initial, jobs=2, progress=stop_at_first_worker_report)
    # the second worker process may take its participant only after the stop (it starts more slowly): never started
    assert stopped.value.__notes__[0] in ("2 of 2 participants' studies ended early in their worker process, "
                                          "0 never started",
                                          "1 of 2 participants' studies ended early in their worker process, "
                                          "1 never started")


def test_ctrl_c_ends_every_worker_process_at_its_next_report_and_queued_participants_never_start(
        small_config, small_initial):
    """Ctrl-C in the main process (KeyboardInterrupt) stops the workers as a stop request does
    (walkthrough: `cacas simulate` with workers exited 103 s after Ctrl-C, having run every
    participant: the interrupted workers went on to the next ones, and the pool waited)."""
    def interrupt_at_first_worker_report(f, m):
        if m.startswith("participant "):
            raise KeyboardInterrupt
    three = parse_personas({"participants": [{"id": f"P0{i}", "preferences": [
        {"activity": ["cough"], "action": "pain check"}]} for i in (1, 2, 3)]})
    with pytest.raises(KeyboardInterrupt) as interrupted:
        simulate_study(three, days=5, interactions=4, methods=["cacas", "nn"], seed=2, config=small_config,
                       initial_policy=small_initial, jobs=2, progress=interrupt_at_first_worker_report)
    # the third is queued behind the two running: cancelled, or taken by a worker after the stop (the pool
    # hands one call ahead to its workers), never run; the second worker process may take its participant
    # only after the stop too
    assert interrupted.value.__notes__[0] in (
        "2 of 3 participants' studies ended early in their worker process, 1 never started",
        "1 of 3 participants' studies ended early in their worker process, 2 never started")


def test_a_method_gives_the_same_results_whichever_methods_run_beside_it(small_config, small_initial):
    kw = dict(days=3, interactions=5, seed=4, config=small_config, initial_policy=small_initial)
    two = simulate_study(PEOPLE, methods=["cacas", "nn"], **kw).daily
    three = simulate_study(PEOPLE, methods=["cacas", "orl", "nn"], **kw).daily
    nn_two, nn_three = (d[d["method"] == "nn"].reset_index(drop=True) for d in (two, three))
    assert nn_two["preference_accuracy"].nunique() > 1  # it learns: the comparison means something
    pd.testing.assert_frame_equal(nn_two, nn_three)


def test_outside_every_preference_the_simulated_participant_answers_by_the_d4a_pairs():
    """A preference that applies while the robot sets a timer: with the robot idle, no preference
    covers the stove, so the participant answers as generate_response does (D4A second) and
    asks for nothing."""
    from cacas.d4a import load_d4a
    busy = parse_personas({"participants": [{"id": "P09", "preferences": [
        {"activity": ["use stove"], "task": ["set a timer"], "action": "remind to turn off"}]}]})[0]
    d4a = load_d4a()
    stove, off = spaces.activity_index("use stove"), spaces.action_index("remind to turn off")
    chat = spaces.action_index("chitchat")
    for action in (off, chat):
        day = pd.DataFrame(simulated_day(Always(action), busy, 1, 30, np.random.default_rng(0), 0.0, "cacas"))
        assert "set a timer" not in set(day["task"])  # the robot never set a timer: not the preference's state
        assert set(day["response"]) == {spaces.RESPONSES[d4a.response(stove, action)]}
    idle = pd.DataFrame(simulated_day(Always(0), busy, 1, 30, np.random.default_rng(0), 0.0, "cacas"))
    assert (idle["type"] == "type_1").all() and (idle["response"] == "others").all()  # no request
    assert d4a.response(stove, off) == spaces.ACCEPT and d4a.response(stove, chat) != spaces.ACCEPT


class Preferred(Acts):
    """The robot always proposes what the participant prefers: every proposal is accepted."""

    def __init__(self, person):
        self.table = person.preferred_action_table()

    def greedy(self, states):
        s = np.asarray(states)
        return np.maximum(self.table[s[:, 0], s[:, 1], s[:, 2], s[:, 3], s[:, 4]], 0)


def test_the_robots_task_s5_is_in_progress_by_the_days_clock():
    """S5 is the action accepted at the previous interaction for TASK_DURATION_MIN minutes of the
    day's clock (the rows' times), whatever the participant's S4 (time since their previous
    activity, drawn from the preferences)."""
    from cacas.simulator import TASK_DURATION_MIN
    busy_rows = 0
    for seed in range(6):
        day = pd.DataFrame(simulated_day(Preferred(PEOPLE[0]), PEOPLE[0], 1, 120, np.random.default_rng(seed),
                                         0.0, "cacas"))
        minutes = day["time"].map(lambda t: int(t[:2]) * 60 + int(t[3:]))
        since = minutes.diff()
        running = (day["previous_response"] == "accept") & (day["previous_action"] != "do nothing") \
            & (since < TASK_DURATION_MIN)
        expected = day["previous_action"].where(running, "do nothing")
        assert list(day["task"]) == list(expected)
        busy_rows += int(running.sum())
    assert busy_rows > 0  # the check saw tasks in progress, not only idle rows


@pytest.mark.parametrize("what", ["d4a", "config"])
def test_a_study_with_its_own_d4a_table_or_config_starts_from_an_initial_policy_of_its_own(what, monkeypatch,
                                                                                          small_config):
    """CACAA step 1 trains against the D4A pairs with the config's step-1 settings: `--d4a FILE`
    used the shipped table's cached initial policy, and so did a config of one's own."""
    import cacas.experiment
    from cacas.d4a import D4A, load_d4a

    table = load_d4a().table.copy()
    table[:, 1:] = table[:, :0:-1]  # the spoken actions' answers reversed; "do nothing" stays unanswered
    own = D4A(table, source="mine.csv") if what == "d4a" else small_config
    seen = []

    class Stop(Exception):
        pass

    def loader(**kwargs):
        seen.append(kwargs[what])
        raise Stop

    monkeypatch.setattr(cacas.experiment, "load_initial_policy", loader)
    with pytest.raises(Stop):
        cacas.experiment.simulate_study(PEOPLE[:1], days=1, **{what: own})
    assert seen == [own]


def test_the_progress_of_training_an_initial_policy_says_initial_policy_once(monkeypatch):
    """The bar read "initial policy for mine.csv: initial policy: round 1/30 ..." (walk3b): once is enough."""
    import cacas.experiment
    from cacas.d4a import D4A, load_d4a

    class Stop(Exception):
        pass

    def loader(progress=None, **kwargs):
        progress(1 / 30, "initial policy: round 1/30 of 4 simulated days side by side")
        raise Stop

    said = []
    monkeypatch.setattr(cacas.experiment, "load_initial_policy", loader)
    with pytest.raises(Stop):
        cacas.experiment.simulate_study(PEOPLE[:1], days=1, d4a=D4A(load_d4a().table, source="mine.csv"),
                                        progress=lambda f, m: said.append(m))
    assert said == ["initial policy for mine.csv: round 1/30 of 4 simulated days side by side"]


def test_interactions_are_numbered_from_1_in_their_day_as_in_a_human_study(small_config, small_initial):
    """interactions.csv's index counts as the tablet and `cacas export` do (walkthrough: 0-based here,
    1-based in the export)."""
    inter = simulate_study(PEOPLE[:1], days=2, interactions=3, methods=["cacas"], config=small_config,
                           initial_policy=small_initial).interactions
    for _, day in inter.groupby("day"):
        assert list(day["index"]) == list(range(1, len(day) + 1))


def test_in_a_closed_loop_the_bandit_acts_by_thompson_sampling():
    """The bandit explores as it would with people (BanditPolicy.decide draws from its Beta
    posteriors); the other policies act by Eq. 4 (Always has no ``sample``: greedy)."""
    from cacas.d4a import load_d4a
    from cacas.policy import BanditPolicy

    def day(seed):
        bandit = BanditPolicy(load_d4a().table, seed=seed)
        rows = pd.DataFrame(simulated_day(bandit, PEOPLE[0], 1, 60, np.random.default_rng(0), 0.0, "bandit"))
        return rows, bandit
    rows, bandit = day(0)
    greedy = [spaces.ACTIONS[a] for a in bandit.greedy(records.policy_states(rows))]
    assert (rows["robot_action"] != greedy).sum() >= 5  # draws, not the posterior mean's argmax
    again, _ = day(0)
    pd.testing.assert_frame_equal(rows, again)  # seeded: the same day again
    assert not rows["robot_action"].equals(day(1)[0]["robot_action"])


def test_a_simulated_study_adapts_from_the_interactions_alone(small_config, small_initial):
    """No-preference-leak guard for the simulated study (test_adaptation guards adapt_policy
    itself): every method's policy in force on day 2 is exactly the one adapt_policy makes from
    the day-1 interactions with the study's seed, config and D4A pairs, so nothing else of the
    participant (whose described preferences drive the simulated person and Fig. 4 only, the
    paper: "the system has no access to them") reaches the adaptation: no per-participant D4A
    table, config or policy."""
    from cacas.adaptation import adapt_policy, evaluation_states
    from cacas.d4a import load_d4a
    from cacas.experiment import policies_in_force

    d4a, seed, person = load_d4a(), 5, PEOPLE[0]
    states = evaluation_states(person, 200, seed=1)
    checked = []
    for day, in_force, rows in policies_in_force(small_initial, person, 0, 2, 8, METHODS, seed, 0.1, small_config,
                                                 d4a):
        if day < 2:
            continue
        data = pd.DataFrame(rows["cacas"], columns=records.INTERACTION_COLUMNS)
        assert set(data["day"]) == {1} and records.is_recorded(data).sum() > 0
        for m in METHODS:
            alone = adapt_policy(small_initial, data, m, seed=adaptation_seed(seed, 0, 1, m), config=small_config,
                                 d4a=load_d4a()).policy
            assert np.array_equal(in_force[m].action_probabilities(states), alone.action_probabilities(states)), m
            checked.append(m)
    assert checked == list(METHODS)


def test_simulate_study_the_command_and_the_lab_start_from_one_set_of_defaults():
    """Docs walkthrough: the Simulation lab's form and `cacas simulate` kept their defaults in two literal copies
    (and simulate_study a third); the command and the form read records.SIMULATION_DEFAULTS, and the function's
    keywords default to the same (the form against the command: tests/app/test_page_simulation.py)."""
    import inspect

    from cacas.cli import build_parser

    keywords = inspect.signature(simulate_study).parameters
    assert {name: keywords[name].default for name in records.SIMULATION_DEFAULTS} == dict(records.SIMULATION_DEFAULTS)
    command = vars(build_parser().parse_args(["simulate", "--personas", "p.json", "--out", "o"]))
    assert {name: command[name] for name in records.SIMULATION_DEFAULTS if name != "methods"} == {
        name: value for name, value in records.SIMULATION_DEFAULTS.items() if name != "methods"}
    assert command["methods"] == ",".join(records.SIMULATION_DEFAULTS["methods"])
