import numpy as np
import pandas as pd
import pytest

from cacas import records, spaces
from cacas.simulator import ResponseModel
from cacas.user_model import UMA, DecisionModel, UserData, UserModel

COUGH = spaces.activity_index("cough")
PAIN = spaces.action_index("pain check")
TIMER = spaces.action_index("set a timer")
STATE = (COUGH, 0, 3, 2, 0, 0, 2)


def test_type_1_answered_goes_to_d_f_and_no_response_is_not_recorded():
    d = UserData()
    d.data_collection(STATE, records.ROBOT_INITIATED, PAIN, spaces.ACCEPT)
    d.data_collection(STATE, records.ROBOT_INITIATED, TIMER, spaces.OTHERS)  # no response
    d.data_collection(STATE, records.ROBOT_INITIATED, spaces.DO_NOTHING_ACTION, spaces.OTHERS)
    assert [(s.su[5], s.response) for s in d.subset("D_f")] == [(PAIN, spaces.ACCEPT)]
    assert len(d) == 1 and d.interactions == 3


def test_generate_new_gives_13_rejects_for_the_other_actions():
    su = STATE[:5] + (TIMER,)
    new = UserData.generate_new(su)
    assert len(new) == 13 and su not in new
    assert {n[5] for n in new} == set(range(14)) - {TIMER}
    assert all(n[:5] == su[:5] for n in new)


def test_type_2_gives_d_i_accept_and_d_g_rejects():
    d = UserData()
    d.data_collection(STATE, records.USER_INITIATED, spaces.DO_NOTHING_ACTION, spaces.ACCEPT, TIMER)
    assert [(s.su[5], s.response) for s in d.subset("D_i")] == [(TIMER, spaces.ACCEPT)]
    d_g = d.subset("D_g")
    assert len(d_g) == 13 and all(s.response == spaces.REJECT for s in d_g)
    assert spaces.DO_NOTHING_ACTION in {s.su[5] for s in d_g}  # the robot doing nothing was wrong


def test_a_request_with_no_sound_activity_is_not_recorded():
    """IV-C.1: a request is recorded (D_i, and D_g's 13 rejects) "if the user intent belongs to
    one of the Agent Actions ... except do nothing and there is a sound activity"."""
    d = UserData()
    idle = (spaces.DO_NOTHING_ACTIVITY,) + STATE[1:]
    d.data_collection(idle, records.USER_INITIATED, spaces.DO_NOTHING_ACTION, spaces.ACCEPT, TIMER)
    assert len(d) == 0 and d.interactions == 1
    d.data_collection(STATE, records.USER_INITIATED, spaces.DO_NOTHING_ACTION, spaces.ACCEPT, TIMER)
    assert len(d) == 14 and d.holds_accept(STATE[:5] + (TIMER,)) and not d.holds_accept(STATE[:5] + (PAIN,))


def test_remove_duplicate_latest_sample_wins_across_sources():
    d = UserData()
    d.data_collection(STATE, records.USER_INITIATED, 0, spaces.ACCEPT, TIMER)  # D_g rejects pain check
    assert {s.su[5]: s.response for s in d.subset("D_g")}[PAIN] == spaces.REJECT
    d.data_collection(STATE, records.ROBOT_INITIATED, PAIN, spaces.ACCEPT)  # later: pain check accepted
    assert PAIN not in {s.su[5] for s in d.subset("D_g")}
    assert [(s.su[5], s.response) for s in d.subset("D_f")] == [(PAIN, spaces.ACCEPT)]
    assert len(d) == 14  # one sample per S_u
    d.data_collection(STATE, records.ROBOT_INITIATED, TIMER, spaces.REJECT)  # the request, rejected later
    assert not d.subset("D_i") and len(d) == 14


def test_an_observed_answer_is_not_replaced_by_a_generated_reject():
    """IV-C.1: "the latest data sample from D_f and D_i can replace the data in D_f, D_i and D_g";
    D_g's samples are assumed, so a later request keeps what the participant answered before."""
    d = UserData()
    d.data_collection(STATE, records.ROBOT_INITIATED, PAIN, spaces.ACCEPT)  # pain check accepted
    d.data_collection(STATE, records.USER_INITIATED, 0, spaces.ACCEPT, TIMER)  # later, a timer asked for
    assert [(s.su[5], s.response) for s in d.subset("D_f")] == [(PAIN, spaces.ACCEPT)]
    assert PAIN not in {s.su[5] for s in d.subset("D_g")} and len(d.subset("D_g")) == 12
    d.data_collection(STATE, records.USER_INITIATED, 0, spaces.ACCEPT, PAIN)  # asked for: D_i replaces D_f
    assert not d.subset("D_f") and {s.su[5] for s in d.subset("D_i")} == {TIMER, PAIN}  # both requests stay
    assert len(d.subset("D_g")) == 12 and len(d) == 14


def test_a_proposal_answered_by_a_request_is_an_observed_reject_that_replaces_an_earlier_accept():
    """A request made in answer to the robot's proposal (the tablet's "Or ask the robot yourself")
    rejects the proposal as observed (D_f), so it replaces what the participant answered before in
    that S_u: an accept taken back is no longer held (as a D_g reject it was kept, and MLP_policy
    still learnt the accept)."""
    d = UserData()
    d.data_collection(STATE, records.ROBOT_INITIATED, PAIN, spaces.ACCEPT)  # day 1: pain check accepted
    d.data_collection(STATE, records.USER_INITIATED, PAIN, spaces.ACCEPT, TIMER)  # later: a timer instead
    assert not d.holds_accept(STATE[:5] + (PAIN,)) and d.holds_accept(STATE[:5] + (TIMER,))
    assert [(s.su[5], s.response) for s in d.subset("D_f")] == [(PAIN, spaces.REJECT)]
    assert len(d.subset("D_g")) == 12 and len(d) == 14  # one sample per S_u still
    quiet = UserData()  # the robot quiet: only D_g's assumed rejects, as before
    quiet.data_collection(STATE, records.USER_INITIATED, spaces.DO_NOTHING_ACTION, spaces.ACCEPT, TIMER)
    assert not quiet.subset("D_f") and len(quiet.subset("D_g")) == 13


def test_a_different_context_is_a_different_s_u():
    d = UserData()
    d.data_collection(STATE, records.ROBOT_INITIATED, PAIN, spaces.ACCEPT)
    d.data_collection((COUGH, 1) + STATE[2:], records.ROBOT_INITIATED, PAIN, spaces.REJECT)
    assert len(d.subset("D_f")) == 2


def _frame(rows):
    base = {"participant": "P01", "method": "cacas", "time": "08:00", "scene": "bedroom", "time_slot": 4,
            "interval": 10, "task": "do nothing", "previous_action": "do nothing",
            "previous_response": "others", "user_action": ""}
    return pd.DataFrame([{**base, **r} for r in rows], columns=records.INTERACTION_COLUMNS)


def test_from_interactions_matches_data_collection():
    df = _frame([
        {"day": 1, "index": 0, "activity": "cough", "type": "type_1", "robot_action": "pain check", "response": "reject"},
        {"day": 1, "index": 1, "activity": "cough", "type": "type_2", "robot_action": "do nothing",
         "response": "accept", "user_action": "show compassion"},
    ])
    d = UserData.from_interactions(df)
    # the rejected pain check stays as answered (D_f); D_g generates the 12 other rejects
    assert len(d.subset("D_i")) == 1 and len(d.subset("D_g")) == 12 and len(d.subset("D_f")) == 1
    x, y = d.arrays()
    assert x.shape == (14, 91) and sorted(np.bincount(y, minlength=3)) == [0, 1, 13]


def test_uma_retrains_every_n_interactions():
    """Table II: the user model is retrained at every N-th interaction (3rd, 6th, ...), not once."""
    uma = UMA(update_interval=3)
    retrained = []
    for n in range(1, 8):
        if n % 3:
            uma.step(STATE, records.ROBOT_INITIATED, PAIN, spaces.ACCEPT)
        else:
            uma.step(STATE, records.USER_INITIATED, 0, spaces.ACCEPT, TIMER)
        if uma.is_new:
            retrained.append(n)
            assert uma.model.trained_on == len(uma.data)
        elif n < 3:
            assert uma.model.trained_on == 0
    assert retrained == [3, 6]


class _Fixed:
    def __init__(self, proba):
        self.proba, self.trained_on = np.asarray(proba), 1

    def predict_proba(self, states, actions):
        return np.repeat(self.proba[None], len(states), axis=0)


def test_decision_model_threshold():
    fallback = ResponseModel(np.full((33, 14), spaces.OTHERS))
    states = np.array([STATE])
    confident = DecisionModel(_Fixed([0.9, 0.05, 0.05]), fallback, threshold=0.7)
    assert confident.respond(states, np.array([PAIN]))[0] == spaces.ACCEPT
    unsure = DecisionModel(_Fixed([0.6, 0.3, 0.1]), fallback, threshold=0.7)
    assert unsure.respond(states, np.array([PAIN]))[0] == spaces.OTHERS  # the simulator answers
    says_others = DecisionModel(_Fixed([0.05, 0.05, 0.9]), ResponseModel(np.full((33, 14), spaces.REJECT)), 0.7)
    assert says_others.respond(states, np.array([PAIN]))[0] == spaces.REJECT  # "no response" -> simulator


def test_decision_model_support_limits_the_user_model_to_recorded_activities():
    d = UserData()
    d.data_collection(STATE, records.ROBOT_INITIATED, PAIN, spaces.REJECT)
    sup = d.support()
    assert sup[COUGH, PAIN] and sup[COUGH, TIMER] and not sup[COUGH, spaces.DO_NOTHING_ACTION]
    assert not sup[spaces.activity_index("sneeze")].any()
    dm = DecisionModel(_Fixed([0.02, 0.96, 0.02]), ResponseModel(np.full((33, 14), spaces.ACCEPT)), 0.7, sup)
    states = np.array([STATE, STATE, (spaces.activity_index("sneeze"),) + STATE[1:]])
    out = dm.respond(states, np.array([TIMER, spaces.DO_NOTHING_ACTION, TIMER]))
    assert list(out) == [spaces.REJECT, spaces.ACCEPT, spaces.ACCEPT]


def test_decision_model_takes_an_accept_only_for_an_activity_action_pair_the_data_hold():
    d = UserData()
    d.data_collection(STATE, records.ROBOT_INITIATED, PAIN, spaces.ACCEPT)  # cough: pain check accepted
    answered = d.answered_pairs()
    assert answered[COUGH, PAIN] and answered.sum() == 1
    generic = ResponseModel(np.full((33, 14), spaces.REJECT))
    says_accept = DecisionModel(_Fixed([0.96, 0.02, 0.02]), generic, 0.7, d.support(), answered)
    states = np.array([STATE, STATE])
    # pain check was answered: f_mu's accept stands; a timer never was: the generic user answers
    assert list(says_accept.respond(states, np.array([PAIN, TIMER]))) == [spaces.ACCEPT, spaces.REJECT]
    says_reject = DecisionModel(_Fixed([0.02, 0.96, 0.02]), ResponseModel(np.full((33, 14), spaces.ACCEPT)), 0.7,
                                d.support(), answered)
    assert list(says_reject.respond(states, np.array([PAIN, TIMER]))) == [spaces.REJECT, spaces.REJECT]  # rejects stand


def test_user_model_fits_its_data():
    d = UserData()
    d.data_collection(STATE, records.USER_INITIATED, 0, spaces.ACCEPT, TIMER)
    m = UserModel(epochs=200).fit(d)
    p = m.predict_proba(np.array([STATE] * 2), np.array([TIMER, PAIN]))
    assert p[0].argmax() == spaces.ACCEPT and p[1].argmax() == spaces.REJECT


def _rows(n):
    """n interactions of one day: the participant asks for a timer while using the stove, each
    in another time slot (so each is its own S_u)."""
    return pd.DataFrame([{"participant": "P01", "method": "cacas", "day": 1, "index": i, "time": "08:00",
                          "activity": "use stove", "scene": "kitchen", "time_slot": i % 12, "interval": 30,
                          "task": "do nothing", "previous_action": "do nothing", "previous_response": "others",
                          "type": "type_2", "robot_action": "do nothing", "response": "accept",
                          "user_action": "set a timer"} for i in range(n)], columns=records.INTERACTION_COLUMNS)


def test_uma_replay_is_table_ii_stepped_interaction_by_interaction():
    rows = _rows(5)
    replayed = UMA.replay(rows, update_interval=2)
    stepped = UMA(update_interval=2)
    for s, tp, u in zip(records.policy_states(rows), rows["type"], rows["user_action"]):
        stepped.step(s, tp, spaces.DO_NOTHING_ACTION, spaces.ACCEPT, spaces.action_index(u))
    assert replayed.fitted_interactions == stepped.fitted_interactions == 4  # idx 4 % 2 == 0; idx 5 is not
    assert replayed.model.trained_on == stepped.model.trained_on == 4 * 14  # D as it was at idx 4
    assert len(replayed.data) == len(stepped.data) == 5 * 14  # D holds all five
    assert not replayed.is_new and not stepped.is_new
    assert list(replayed.fitted_rows(rows)["index"]) == [0, 1, 2, 3]
    x = records.policy_states(rows)
    timer = np.full(5, spaces.action_index("set a timer"))
    # both models learnt the participant's request, and are the same model (seeded networks)
    assert (replayed.model.predict_proba(x, timer).argmax(1) == spaces.ACCEPT).all()
    np.testing.assert_allclose(replayed.model.predict_proba(x, timer), stepped.model.predict_proba(x, timer))


def test_uma_replay_with_n_1_trains_on_all_of_d():
    uma = UMA.replay(_rows(3), update_interval=1)
    assert uma.is_new and uma.fitted_interactions == 3 and uma.model.trained_on == len(uma.data) == 42
    empty = UMA.replay(_rows(0))
    assert empty.model.trained_on == 0 and len(empty.data) == 0 and not empty.is_new


@pytest.mark.parametrize("bad", [0, -3, 1.5, True])
def test_uma_update_interval_must_be_a_positive_integer(bad):
    with pytest.raises(ValueError, match="update interval N is .*; valid: an integer >= 1"):
        UMA(update_interval=bad)
