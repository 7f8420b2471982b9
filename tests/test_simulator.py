import numpy as np
import pytest

from cacas import spaces
from cacas.d4a import load_d4a
from cacas.errors import CacasError
from cacas.preferences import parse_personas
from cacas.simulator import (ContextSource, ResponseModel, StateGenerator, current_task, dialog_state,
                             preference_states)

P = parse_personas({"participants": [{"id": "P01", "preferences": [
    {"activity": ["use stove"], "scene": ["kitchen"], "hours": [[6, 10]], "action": "set a timer"},
    {"activity": ["cough"], "action": "pain check"}]}]})[0]
STOVE, COUGH = spaces.activity_index("use stove"), spaces.activity_index("cough")


def test_generate_response_preference_first_d4a_second():
    d4a = load_d4a()
    rm = ResponseModel(d4a.table, P)
    timer, off = spaces.action_index("set a timer"), spaces.action_index("remind to turn off")
    covered = [STOVE, spaces.scene_index("kitchen"), 3, 0, 0, 0, 2]
    outside = [STOVE, spaces.scene_index("bedroom"), 3, 0, 0, 0, 2]
    states = np.array([covered, covered, covered, outside, outside])
    actions = np.array([timer, off, 0, timer, off])
    out = rm.respond(states, actions)
    assert list(out[:3]) == [spaces.ACCEPT, spaces.REJECT, spaces.OTHERS]
    assert out[3] == d4a.response(STOVE, timer) and out[4] == d4a.response(STOVE, off)
    assert d4a.response(STOVE, off) == spaces.ACCEPT  # the generic user would accept it


def test_generate_state_steps_a_day_every_k_minutes():
    gen = StateGenerator(ContextSource.generic(), n_days=3, k_minutes=30, rng=np.random.default_rng(0))
    assert gen.steps_per_day == 48
    slots = []
    while not gen.done:
        s = gen.generate_state()
        assert s.shape == (3, 7)
        for part, (_, size) in enumerate(spaces.STATE_PARTS):
            assert s[:, part].min() >= 0 and s[:, part].max() < size
        gen.observe(np.full(3, 2), np.full(3, spaces.ACCEPT))
        slots.append(s[0, 2])
    assert slots == sorted(slots) and slots[0] == 0 and slots[-1] == 11
    assert len(slots) == 48
    with pytest.raises(CacasError, match="the simulated day is over: it has 48 states, one every 30 minutes"):
        gen.generate_state()


@pytest.mark.parametrize("k", [7.2, 14.4, 28.8, 57.6, 6.4, 0.2])
def test_a_simulated_day_has_24_x_60_over_k_steps_where_k_divides_the_day(k):
    """Section IV-B.3: "there will be 24 x 60 / K epochs in one day". 1440 // 7.2 is 199.0 in floating point (7.2 is
    a little above 7.2), so a day of K = 7.2 had 199 steps and ended at 23:45-23:52, its last step left out."""
    from cacas.simulator import steps_per_day

    assert steps_per_day(k) == round(24 * 60 / k)
    assert [steps_per_day(x) for x in (10, 30, 7, 720, 1000)] == [144, 48, 205, 2, 1]  # 7: 205 whole steps, 1435 min


def test_the_last_step_of_a_day_stays_in_the_last_slot():
    """A step's time is jittered within it (t*K + U(0, K)): with K = 720, 720 + the largest float below 720 rounds to
    1440.0, the 24:00 that has no slot (slot 12 of 12: an IndexError deep in the draw)."""
    k = 720.0

    class LastMoment:  # each step at the very end of its K minutes
        def __init__(self, rng):
            self.rng = rng

        def __getattr__(self, name):
            return getattr(self.rng, name)

        def uniform(self, low, high, size=None):
            return np.full(size, np.nextafter(high, 0)) if high == k else self.rng.uniform(low, high, size)

    gen = StateGenerator(ContextSource.generic(), 2, k, LastMoment(np.random.default_rng(0)))
    gen.generate_state()
    gen.observe(np.zeros(2, int), np.full(2, spaces.OTHERS))
    assert list(gen.generate_state()[:, 2]) == [11, 11]


def test_generate_state_history_feeds_s6_s7_and_is_seeded():
    def run(seed):
        gen = StateGenerator(ContextSource.generic(), 2, 10, np.random.default_rng(seed))
        first = gen.generate_state()
        gen.observe(np.array([5, 0]), np.array([spaces.REJECT, spaces.OTHERS]))
        return first, gen.generate_state()
    a1, b1 = run(1)
    a2, b2 = run(1)
    assert np.array_equal(a1, a2) and np.array_equal(b1, b2)
    assert list(b1[:, 5]) == [5, 0] and list(b1[:, 6]) == [spaces.REJECT, spaces.OTHERS]
    assert np.all(a1[:, 5] == 0) and np.all(a1[:, 6] == spaces.OTHERS)


def test_user_data_makes_recorded_activities_more_likely():
    contexts = np.array([[COUGH, 0, 3, 2]] * 10)
    src = ContextSource.from_user_data(contexts, recorded_share=0.8)
    gen = StateGenerator(src, 50, 60, np.random.default_rng(0))
    acts = np.concatenate([gen.generate_state()[:, 0] for _ in range(24)])
    assert (acts == COUGH).mean() > 0.6
    base = StateGenerator(ContextSource.generic(), 50, 60, np.random.default_rng(0))
    acts0 = np.concatenate([base.generate_state()[:, 0] for _ in range(24)])
    assert (acts0 == COUGH).mean() < 0.1


def test_activities_follow_each_state_own_time_slot_for_any_k():
    """With K = 45 minutes a step can straddle two time slots (90-135 min): the activity is
    drawn for the slot S3 the state carries, not for the slot the step began in."""
    slot_activity = np.zeros((spaces.N_SLOTS, spaces.N_ACTIVITIES))
    slot_activity[0::2, COUGH] = 1.0   # even slots: only coughing
    slot_activity[1::2, STOVE] = 1.0   # odd slots: only the stove
    src = ContextSource(np.full(spaces.N_ACTIVITIES, 1 / spaces.N_ACTIVITIES), ContextSource.generic().scene_table,
                        slot_activity)
    gen = StateGenerator(src, 40, 45, np.random.default_rng(0))
    rows = []
    while not gen.done:
        rows.append(gen.generate_state())
        gen.observe(np.zeros(40, int), np.full(40, spaces.OTHERS))
    s = np.concatenate(rows)
    assert set(s[s[:, 2] % 2 == 0, 0]) == {COUGH} and set(s[s[:, 2] % 2 == 1, 0]) == {STOVE}
    assert len(set(s[:, 2])) == spaces.N_SLOTS


def test_current_task_and_dialog_state():
    t = current_task(np.array([3, 3, 3, 0]), np.array([spaces.ACCEPT, spaces.REJECT, spaces.ACCEPT, spaces.ACCEPT]),
                     np.array([2.0, 2.0, 30.0, 1.0]))
    assert list(t) == [3, 0, 0, 0]
    s0 = dialog_state("cough", "bedroom", 7.5, 3)
    assert s0.task == 0 and s0.action == 0 and s0.response == spaces.OTHERS and s0.interval == 2
    prev = {"type": "type_2", "robot_action": "do nothing", "response": "accept", "user_action": "pain check"}
    s1 = dialog_state("cough", "bedroom", 7.5, 3, prev)
    assert s1.action == spaces.action_index("pain check") and s1.response == spaces.ACCEPT
    assert s1.task == spaces.action_index("pain check")  # accepted 3 minutes ago: still in progress
    prev = {"type": "type_1", "robot_action": "chitchat", "response": "reject", "user_action": ""}
    s2 = dialog_state("cough", "bedroom", 7.5, 60, prev)
    assert (s2.task, s2.action, s2.response) == (0, spaces.action_index("chitchat"), spaces.REJECT)


def test_preference_states_are_covered():
    ctx = preference_states(P, 300, np.random.default_rng(0))
    mask = P.coverage_mask()
    assert all(mask[tuple(c[:4])] for c in ctx)
    assert set(ctx[:, 0]) == {STOVE, COUGH}


def test_preference_states_draw_the_robot_task_a_preference_names():
    busy = parse_personas({"participants": [{"id": "P09", "preferences": [
        {"activity": ["cough"], "action": "pain check"},
        {"activity": ["use stove"], "task": ["set a timer", "chitchat"], "action": "remind to turn off"}]}]})[0]
    ctx = preference_states(busy, 400, np.random.default_rng(0))
    assert ctx.shape == (400, 5)
    stove = ctx[:, 0] == STOVE
    assert 100 < stove.sum() < 300
    tasks = {spaces.action_index("set a timer"), spaces.action_index("chitchat")}
    assert set(ctx[stove, 4]) == tasks  # the robot busy with a task the preference names
    assert set(ctx[~stove, 4]) == {spaces.DO_NOTHING_ACTION}  # elsewhere the robot is idle
    table = busy.preferred_action_table()
    assert (table[tuple(ctx.T)] >= 0).all()  # every state drawn is one a preference covers


def test_preference_states_without_tasks_keep_the_same_random_stream():
    """Preferences that name no task draw exactly what they drew before S5 was added."""
    rng = np.random.default_rng(7)
    which = rng.integers(2, size=50)
    cells = [np.argwhere(p.coverage_mask()) for p in P.preferences]
    expected = np.empty((50, 4), dtype=np.int64)
    for k, c in enumerate(cells):
        idx = np.flatnonzero(which == k)
        expected[idx] = c[rng.integers(len(c), size=len(idx))]
    ctx = preference_states(P, 50, np.random.default_rng(7))
    assert (ctx[:, :4] == expected).all() and (ctx[:, 4] == spaces.DO_NOTHING_ACTION).all()


def test_generate_response_gives_no_response_to_doing_nothing_where_quiet_is_preferred():
    """Doing nothing gets "others" (no response) also where the participant's preference is "do
    nothing", as a simulated study day answers it (it was "accept": a reward for silence that the
    participant never gives)."""
    quiet = parse_personas({"participants": [{"id": "P01", "preferences": [
        {"activity": ["snore"], "action": "do nothing"}]}]})[0]
    rm = ResponseModel(load_d4a().table, quiet)
    snore = [spaces.activity_index("snore"), spaces.scene_index("bedroom"), 1, 0, 0, 0, 2]
    chat = spaces.action_index("chitchat")
    out = rm.respond(np.array([snore, snore]), np.array([spaces.DO_NOTHING_ACTION, chat]))
    assert list(out) == [spaces.OTHERS, spaces.REJECT]
