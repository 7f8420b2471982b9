import io

import numpy as np
import pandas as pd
import pytest
import torch

from cacas import records, spaces
from cacas.d4a import load_d4a
from cacas.errors import CacasError
from cacas.policy import BanditPolicy, MLPPolicy, ReshapedPolicy, accept_pairs, policy_from_bytes
from cacas.sac import DiscreteSAC, SACConfig


def _states(n=20, seed=0):
    rng = np.random.default_rng(seed)
    return np.stack([rng.integers(k, size=n) for _, k in spaces.STATE_PARTS], axis=1)


def test_eq5_gives_a_probability_distribution_and_mixes_with_beta():
    sac = DiscreteSAC(SACConfig(hidden=16), seed=0)
    s = _states()
    mlp = MLPPolicy(hidden=16, epochs=50).fit(s, np.full(len(s), 3))
    pi = ReshapedPolicy(sac, mlp, beta=0.7)
    p = pi.action_probabilities(s)
    assert p.shape == (20, 14) and np.all(p >= 0) and np.allclose(p.sum(1), 1.0, atol=1e-5)
    expected = 0.7 * sac.action_probabilities(spaces.encode_states(s)) + 0.3 * mlp.action_probabilities(s)
    assert np.allclose(p, expected, atol=1e-6)
    assert list(pi.greedy(s)) == list(p.argmax(1))
    assert ReshapedPolicy(sac, None).beta == 1.0 and ReshapedPolicy(None, mlp).beta == 0.0
    with pytest.raises(CacasError, match="beta"):
        ReshapedPolicy(sac, mlp, beta=1.5)


def test_decide_takes_a_state_object():
    pi = ReshapedPolicy(DiscreteSAC(SACConfig(hidden=16)), None)
    a, p = pi.decide(spaces.State.from_names("cough", "bedroom", 3, 10))
    assert 0 <= a < 14 and a == p.argmax() and np.isclose(p.sum(), 1)


def test_mlp_policy_learns_accepted_actions():
    s = _states(40)
    actions = s[:, 0] % 3 + 1
    mlp = MLPPolicy(epochs=300).fit(s, actions)
    assert (mlp.action_probabilities(s).argmax(1) == actions).mean() > 0.9


def test_bandit_counts_the_proposal_a_request_answered_as_lost():
    rows = _interactions()
    corrected = rows.iloc[[2]].assign(robot_action="chitchat")  # proposed chitchat, asked for a pain check
    bandit = BanditPolicy(load_d4a().table).fit(corrected)
    cough, slot = spaces.activity_index("cough"), 4
    assert bandit.losses[cough, slot, spaces.action_index("chitchat")] == 1
    assert bandit.losses[cough, slot, spaces.DO_NOTHING_ACTION] == 0
    assert bandit.wins[cough, slot, spaces.action_index("pain check")] == 1


def test_policy_bytes_round_trip_and_bad_bytes():
    s = _states()
    pi = ReshapedPolicy(DiscreteSAC(SACConfig(hidden=16)), MLPPolicy(hidden=8, epochs=5).fit(s, s[:, 0] % 14))
    back = policy_from_bytes(pi.to_bytes())
    assert np.allclose(back.action_probabilities(s), pi.action_probabilities(s))
    with pytest.raises(CacasError, match="not a CACAS policy"):
        policy_from_bytes(b"hello")
    for other in ({"state_dict": {}}, {"kind": "sound model"}, [1, 2]):  # torch files that are not a policy
        buf = io.BytesIO()
        torch.save(other, buf)
        with pytest.raises(CacasError, match=r"^not a CACAS policy file \(no policy kind recorded\)$"):
            policy_from_bytes(buf.getvalue())


def _interactions():
    base = {"participant": "P01", "method": "cacas", "day": 1, "time": "08:00", "scene": "kitchen",
            "time_slot": 4, "interval": 10, "task": "do nothing", "previous_action": "do nothing",
            "previous_response": "others", "user_action": ""}
    rows = [dict(base, index=0, activity="use stove", type="type_1", robot_action="set a timer", response="accept"),
            dict(base, index=1, activity="use stove", type="type_1", robot_action="chitchat", response="reject"),
            dict(base, index=2, activity="cough", type="type_2", robot_action="do nothing", response="accept",
                 user_action="pain check"),
            dict(base, index=3, activity="cough", type="type_1", robot_action="chitchat", response="others")]
    return pd.DataFrame(rows, columns=records.INTERACTION_COLUMNS)


def test_accept_pairs_take_accepted_and_requested_actions_only():
    s, a = accept_pairs(_interactions())
    assert [spaces.ACTIONS[x] for x in a] == ["set a timer", "pain check"]
    assert list(s[:, 0]) == [spaces.activity_index("use stove"), spaces.activity_index("cough")]


def test_accept_pairs_learn_what_the_user_data_d_still_holds_as_accept():
    """Table III trains MLP_policy on D: an accept the participant later took back (the same action
    rejected in the same context) is not learnt, as remove_duplicate drops it from D; accepted again
    after that, it is. A request with no sound activity is not in D (IV-C.1)."""
    base = _interactions().iloc[[0]]
    took_back = pd.concat([base, base.assign(index=5, response="reject")])
    assert len(accept_pairs(took_back)[1]) == 0
    again = pd.concat([took_back, base.assign(index=6, previous_action="chitchat")])
    s, a = accept_pairs(again)
    assert [spaces.ACTIONS[x] for x in a] == ["set a timer", "set a timer"]  # both accepts: D's latest is accept
    assert [spaces.ACTIONS[x] for x in s[:, 5]] == ["do nothing", "chitchat"]
    other_room = pd.concat([base, base.assign(index=5, scene="bedroom", response="reject")])  # another S_u
    assert len(accept_pairs(other_room)[1]) == 1
    idle_request = _interactions().iloc[[2]].assign(activity="do nothing")
    assert len(accept_pairs(idle_request)[1]) == 0
    # nor when the same action was accepted in that idle context before (D holds that accept): learnt once
    idle_accept = idle_request.assign(index=1, type="type_1", robot_action="pain check", user_action="")
    assert len(accept_pairs(pd.concat([idle_accept, idle_request]))[1]) == 1
    # taken back by asking for something else when the robot proposed it again: the request is learnt
    asked_instead = pd.concat([base, base.assign(index=5, type="type_2", user_action="remind to turn off")])
    assert [spaces.ACTIONS[x] for x in accept_pairs(asked_instead)[1]] == ["remind to turn off"]


def test_a_bandit_loaded_from_its_file_does_not_replay_its_draws_after_a_reload():
    """A loaded bandit was seeded 0: each load (the tablet's, after a server restart) drew the same
    Thompson sequence again. A bandit made with a seed (the simulation's) still repeats it."""
    d4a = load_d4a().table
    data = BanditPolicy(d4a).to_bytes()  # the prior only: wide posteriors, the draws vary
    st = _states(200)

    def draws(policy):
        return [policy.sample(st).tolist() for _ in range(3)]

    first, second = policy_from_bytes(data), policy_from_bytes(data)
    assert draws(first) != draws(second)  # 600 draws: equal only by a chance of less than 1e-100
    assert draws(BanditPolicy(d4a, seed=5)) == draws(BanditPolicy(d4a, seed=5))  # cacas simulate's
    # a generator passed in gives the draws (the tablet's, cacas.study_day.proposal_draws), whatever the policy's
    assert first.sample(st, np.random.default_rng(7)).tolist() == second.sample(st, np.random.default_rng(7)).tolist()
    action, probs = first.decide(spaces.State.from_names("cough", "bedroom", 8, 20), rng=np.random.default_rng(7))
    assert 0 <= action < spaces.N_ACTIONS and np.isclose(probs.sum(), 1)


def test_bandit_learns_from_feedback_and_round_trips():
    bandit = BanditPolicy(load_d4a().table).fit(pd.concat([_interactions()] * 5))
    st = records.policy_states(_interactions())
    g = bandit.greedy(st)
    assert spaces.ACTIONS[g[0]] == "set a timer" and spaces.ACTIONS[g[2]] == "pain check"
    p = bandit.action_probabilities(st)
    assert np.allclose(p.sum(1), 1)
    back = policy_from_bytes(bandit.to_bytes())
    assert np.allclose(back.action_probabilities(st), p)
