"""Robot action policies: the MLP policy, policy reshaping (Eq. 5) and the bandit baseline.

* :class:`MLPPolicy` (Section IV-C.2): an MLP with the SAC policy's input and output sizes
  (94 -> 14), trained on the "accept" user data only: (state, accepted action) pairs.
* :class:`ReshapedPolicy`: Eq. 5, pi(s) = beta * pi_theta(s) + (1 - beta) * MLP_policy(s),
  beta = 0.7 by default. beta = 1 is the SAC policy alone (CACAS w/o PR, ORL); beta = 0 the MLP
  policy alone (the NN baseline). The robot's action is the argmax (Eq. 4).
* :class:`BanditPolicy`: a contextual Thompson-sampling bandit (a baseline the paper lacks).

Every policy has ``action_probabilities(states)``, ``decide(state)``, ``to_bytes()``; use
:func:`policy_from_bytes` to load any of them.
"""

from __future__ import annotations

import io
import numpy as np
import pandas as pd
import torch

from cacas import nets, records, spaces
from cacas.checkpoints import load_checkpoint
from cacas.errors import CacasError
from cacas.sac import DiscreteSAC

DEFAULT_BETA = 0.7


def _state_matrix(states) -> np.ndarray:
    """Accept State objects, index rows (n, 7) or one-hot rows (n, 94); return one-hot (n, 94)."""
    if isinstance(states, spaces.State):
        states = [states]
    arr = states if isinstance(states, np.ndarray) else np.array(
        [s.as_tuple() if isinstance(s, spaces.State) else tuple(s) for s in states])
    if arr.ndim == 2 and arr.shape[1] == spaces.STATE_DIM:
        return arr.astype(np.float32)
    return spaces.encode_states(arr.astype(np.int64))


def accept_pairs(interactions: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """The "accept" user data as (policy states (n, 7) indices, accepted action indices): a
    robot action the participant accepted, or the action the participant asked for (type_2),
    where the user data D (Table II) still holds that S_u as "accept" (Table III:
    MLP_policy <- MLP_policy(D)): an accept the participant later took back (rejected the same
    action in the same context S1-S5) is not learnt, as remove_duplicate drops it from D, and a
    request made with no sound activity, which D does not record (IV-C.1), is not either. Each
    accept keeps the policy state it was given in (S6-S7, which S_u lacks), so a context
    accepted again counts again."""
    from cacas.user_model import UserData

    if len(interactions) == 0:
        return np.zeros((0, 7), np.int64), np.zeros(0, np.int64)
    states = records.policy_states(interactions)
    t1 = ((interactions["type"] == records.ROBOT_INITIATED) & (interactions["response"] == "accept")
          & (interactions["robot_action"] != "do nothing")).to_numpy()
    t2 = records.is_recorded_request(interactions).to_numpy()  # not a request made with no sound activity
    actions = np.array([spaces.action_index(u if tp == records.USER_INITIATED else r)
                        if ok else -1 for u, r, tp, ok in
                        zip(interactions["user_action"], interactions["robot_action"], interactions["type"],
                            t1 | t2)])
    data = UserData.from_interactions(interactions)
    keep = (t1 | t2) & np.array([ok and data.holds_accept(tuple(int(v) for v in s[:5]) + (int(a),))
                                 for s, a, ok in zip(states, actions, t1 | t2)], dtype=bool)
    return states[keep], actions[keep]


class MLPPolicy:
    """MLP_policy: 94 -> 14, trained with cross-entropy on accepted (state, action) pairs."""

    def __init__(self, hidden: int = 64, epochs: int = 150, seed: int = 0):
        self.hidden, self.epochs, self.seed = hidden, epochs, seed
        self.net = nets.mlp(spaces.STATE_DIM, hidden, spaces.N_ACTIONS, seed)
        self.trained_on = 0

    def fit(self, states: np.ndarray, actions: np.ndarray) -> "MLPPolicy":
        self.net = nets.mlp(spaces.STATE_DIM, self.hidden, spaces.N_ACTIONS, self.seed)
        if len(actions):
            nets.fit_classifier(self.net, _state_matrix(states), actions, epochs=self.epochs, seed=self.seed)
        self.trained_on = int(len(actions))
        return self

    def action_probabilities(self, states) -> np.ndarray:
        return nets.predict_proba(self.net, _state_matrix(states))


class ReshapedPolicy:
    """Eq. 5: pi = beta * pi_theta + (1 - beta) * MLP_policy (either part may be absent)."""

    kind = "reshaped"

    def __init__(self, sac: DiscreteSAC | None, mlp: MLPPolicy | None = None, beta: float = DEFAULT_BETA,
                 method: str = "cacas"):
        if sac is None and mlp is None:
            raise ValueError("a policy needs the SAC policy, the MLP policy or both")
        if not 0.0 <= beta <= 1.0:
            raise CacasError(f"beta {beta} is invalid; valid: 0 <= beta <= 1")
        self.sac, self.mlp, self.method = sac, mlp, method
        self.beta = 1.0 if mlp is None else 0.0 if sac is None else beta

    def action_probabilities(self, states) -> np.ndarray:
        """(n, 14) probability rows (each a distribution over the 14 actions)."""
        x = _state_matrix(states)
        out = np.zeros((len(x), spaces.N_ACTIONS), np.float64)
        if self.sac is not None and self.beta > 0:
            out += self.beta * self.sac.action_probabilities(x)
        if self.mlp is not None and self.beta < 1:
            out += (1 - self.beta) * self.mlp.action_probabilities(x)
        return out

    def greedy(self, states) -> np.ndarray:
        """Eq. 4 over the reshaped distribution."""
        return self.action_probabilities(states).argmax(1)

    def decide(self, state: spaces.State, rng: np.random.Generator | None = None) -> tuple[int, np.ndarray]:
        """Eq. 4's action and the distribution. ``rng`` is not used (the argmax draws nothing): every
        policy's ``decide`` takes one (:meth:`BanditPolicy.decide` draws from it)."""
        p = self.action_probabilities([state])[0]
        return int(p.argmax()), p

    def to_bytes(self) -> bytes:
        buf = io.BytesIO()
        torch.save({"kind": self.kind, "method": self.method, "beta": self.beta,
                    "sac": None if self.sac is None else self.sac.state_dict(),
                    "mlp": None if self.mlp is None else {"hidden": self.mlp.hidden,
                                                          "state": self.mlp.net.state_dict(),
                                                          "trained_on": self.mlp.trained_on}}, buf)
        return buf.getvalue()

    @classmethod
    def _from_dict(cls, d: dict) -> "ReshapedPolicy":
        sac = None if d["sac"] is None else DiscreteSAC.from_state_dict(d["sac"])
        mlp = None
        if d["mlp"] is not None:
            mlp = MLPPolicy(hidden=d["mlp"]["hidden"])
            mlp.net.load_state_dict(d["mlp"]["state"])
            mlp.net.eval()
            mlp.trained_on = d["mlp"]["trained_on"]
        return cls(sac, mlp, d["beta"], d.get("method", "cacas"))


class BanditPolicy:
    """A contextual bandit over (activity, time slot) with Beta-Bernoulli Thompson sampling.

    Each context-action pair has a Beta posterior of "accepted"; its prior comes from the D4A
    pairs (accept: Beta(2, 1), reject: Beta(1, 2), others: Beta(1, 1)) and the activity-level
    counts are shared across time slots at half weight, so a new slot starts from what the
    activity taught. ``decide`` and ``sample`` draw (exploration: how the robot acts with it, on the
    tablet and in a closed-loop simulation); Fig. 4's accuracy uses
    the posterior mean (``action_probabilities`` is a softmax of the means, sharp).

    Its draws come from ``rng``: seeded by ``seed`` when it is made (an adaptation, as in
    ``cacas simulate``, which never loads a bandit from a file: the same --seed, the same
    daily.csv); a bandit loaded from its file (:func:`policy_from_bytes`: the one a tablet uses)
    draws from fresh entropy, see :meth:`_from_dict`. A caller may pass a generator of its own to
    ``sample`` / ``decide`` (the tablet does: :func:`cacas.study_day.proposal_draws`).
    """

    kind = "bandit"

    def __init__(self, d4a_table: np.ndarray, seed: int = 0):
        d4a = np.asarray(d4a_table)
        self.alpha0 = np.where(d4a == spaces.ACCEPT, 2.0, 1.0)  # (33, 14)
        self.beta0 = np.where(d4a == spaces.REJECT, 2.0, 1.0)
        shape = (spaces.N_ACTIVITIES, spaces.N_SLOTS, spaces.N_ACTIONS)
        self.wins = np.zeros(shape)
        self.losses = np.zeros(shape)
        self.method = "bandit"
        self.rng = np.random.default_rng(seed)

    def fit(self, interactions: pd.DataFrame) -> "BanditPolicy":
        """Counts from the recorded user data (:func:`cacas.records.is_recorded`, as every method
        adapts from): accepted actions win; rejected ones lose, and so does the
        robot's own action when the participant asked for something ("do nothing" when it stayed
        quiet, the proposal they answered with a request otherwise; not when the request is that
        proposal, as in the user data D)."""
        self.wins[:] = 0
        self.losses[:] = 0
        if len(interactions) == 0:
            return self
        s = records.policy_states(interactions)
        recorded = records.is_recorded(interactions)  # the data every method adapts from
        for (act, _, slot, *_), tp, ra, resp, ua, ok in zip(s, interactions["type"], interactions["robot_action"],
                                                             interactions["response"], interactions["user_action"],
                                                             recorded):
            if not ok:
                continue
            if tp == records.USER_INITIATED:
                self.wins[act, slot, spaces.action_index(ua)] += 1
                if spaces.action_index(ra) != spaces.action_index(ua):  # a request for its own proposal: won only
                    self.losses[act, slot, spaces.action_index(ra)] += 1
            else:
                (self.wins if resp == "accept" else self.losses)[act, slot, spaces.action_index(ra)] += 1
        return self

    def _posterior(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        act, slot = states[:, 0], states[:, 2]
        a = self.alpha0[act] + self.wins[act, slot] + 0.5 * self.wins[act].sum(1)
        b = self.beta0[act] + self.losses[act, slot] + 0.5 * self.losses[act].sum(1)
        return a, b

    @staticmethod
    def _indices(states) -> np.ndarray:
        if isinstance(states, np.ndarray) and states.ndim == 2 and states.shape[1] == 7:
            return states.astype(np.int64)
        return np.array([s.as_tuple() for s in spaces.decode_states(_state_matrix(states))])

    def action_probabilities(self, states) -> np.ndarray:
        a, b = self._posterior(self._indices(states))
        mean = a / (a + b)
        e = np.exp((mean - mean.max(1, keepdims=True)) * 50.0)
        return e / e.sum(1, keepdims=True)

    def greedy(self, states) -> np.ndarray:
        return self.action_probabilities(states).argmax(1)

    def sample(self, states, rng: np.random.Generator | None = None) -> np.ndarray:
        """Thompson sampling: for each state, the action whose draw from its Beta posterior is
        highest (what the robot does with this policy, in a study or a closed-loop simulation).
        The draws come from ``rng`` if given, else from the policy's own generator."""
        a, b = self._posterior(self._indices(states))
        return (self.rng if rng is None else rng).beta(a, b).argmax(1)

    def decide(self, state: spaces.State, rng: np.random.Generator | None = None) -> tuple[int, np.ndarray]:
        return int(self.sample([state], rng)[0]), self.action_probabilities([state])[0]

    def to_bytes(self) -> bytes:
        buf = io.BytesIO()
        torch.save({"kind": self.kind, "alpha0": self.alpha0, "beta0": self.beta0, "wins": self.wins,
                    "losses": self.losses}, buf)
        return buf.getvalue()

    @classmethod
    def _from_dict(cls, d: dict) -> "BanditPolicy":
        """The bandit of a policy file, drawing from fresh entropy (``np.random.default_rng()``).

        The file keeps the posteriors, not a generator: a loaded bandit was seeded 0, so each load
        (the tablet's, after every server restart, once the Adaptation page had put a bandit in
        force) replayed the same Thompson draws. Fresh entropy cannot replay, and costs no
        reproducibility that was ever there: ``cacas simulate`` adapts its bandits in memory,
        seeded, and never loads one from a file. The tablet passes a generator of its own to
        :meth:`decide` (:func:`cacas.study_day.proposal_draws`), so its proposal stays put through
        a page rerun; this generator serves every other caller."""
        p = cls(np.zeros((spaces.N_ACTIVITIES, spaces.N_ACTIONS), np.int64))
        p.alpha0, p.beta0, p.wins, p.losses = d["alpha0"], d["beta0"], d["wins"], d["losses"]
        p.rng = np.random.default_rng()
        return p


def policy_checkpoint(data: bytes) -> dict:
    """What a policy file written by ``to_bytes`` holds (read weights only: a file from a bundle cannot run code),
    without building the policy; bytes that are not a policy file raise CacasError. An import checks each policy
    file it brings with this (~6 ms a file; building a CACAS policy, its SAC's replay memory allocated, takes
    ~150 ms)."""
    try:
        d = load_checkpoint(data)
    except Exception as exc:  # noqa: BLE001 - any unpickling failure means "not a policy file"
        raise CacasError(f"not a CACAS policy file ({exc.__class__.__name__})") from None
    if not isinstance(d, dict) or d.get("kind") not in _KINDS:
        raise CacasError("not a CACAS policy file (no policy kind recorded)")
    return d


def policy_from_bytes(data: bytes):
    """Load any policy written by ``to_bytes``; bytes that are not a policy raise CacasError."""
    d = policy_checkpoint(data)
    return _KINDS[d["kind"]]._from_dict(d)


_KINDS = {ReshapedPolicy.kind: ReshapedPolicy, BanditPolicy.kind: BanditPolicy}

