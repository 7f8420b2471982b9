"""The User Modeling Algorithm (UMA, Table II), the user model f_mu and the Decision Model (DM).

User data D (Section IV-C.1):
* D_f: a robot-initiated interaction (type_1) answered by the user: (S_u, UR) with S6 = the
  robot's action. "If the user does not respond, the interaction is not recorded" (V-B.1).
* D_i: a user-initiated interaction (type_2): S6 replaced by the requested action, "accept";
  only "if ... there is a sound activity" (a request with the activity "do nothing" is carried
  out and logged, not recorded in D).
* D_g: generate_new: the 13 other actions in that S_u, "reject" (the robot doing nothing
  included: "the robot action do nothing is regarded as rejected in the current state").
* remove_duplicate: "For the same S_u, the latest data sample from D_f and D_i can replace the
  data in D_f, D_i and D_g" (IV-C.1). A D_g sample is assumed, not observed: it replaces only an
  earlier D_g sample, and an answer the participant gave for that S_u (D_f, D_i) stays.

The user model f_mu is an MLP 91 -> 3 (accept / reject / others) retrained every N interactions
(:class:`UMA`). The adaptation runs after each study day and replays the day's interactions into
UMA (:meth:`UMA.replay`); with N = 1 (``CACAAConfig.user_model_interval``, the default) f_mu is
retrained on all of D at every adaptation.
The DM (Table III) takes f_mu's answer when it is not "others" and its probability exceeds
``threshold``; otherwise the generic user simulator answers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from cacas import nets, records, spaces

SOURCES = ("D_f", "D_i", "D_g")


@dataclass
class UserSample:
    su: tuple[int, ...]  # S1..S6 indices
    response: int
    source: str
    order: int


class UserData:
    """D = D_f U D_i U D_g, keyed by S_u so that the latest sample for an S_u replaces older ones."""

    def __init__(self) -> None:
        self._samples: dict[tuple[int, ...], UserSample] = {}
        self._order = 0
        self.interactions = 0

    def __len__(self) -> int:
        return len(self._samples)

    def remove_duplicate(self, su: tuple[int, ...]) -> None:
        """Drop any earlier sample with this S_u (from D_f, D_i or D_g)."""
        self._samples.pop(su, None)

    def _add(self, su: tuple[int, ...], response: int, source: str) -> None:
        held = self._samples.get(su)
        if source == "D_g" and held is not None and held.source != "D_g":
            return  # an observed answer is not replaced by an assumed one (IV-C.1)
        self.remove_duplicate(su)
        self._order += 1
        self._samples[su] = UserSample(su, response, source, self._order)

    @staticmethod
    def generate_new(su: tuple[int, ...]) -> list[tuple[int, ...]]:
        """D_g: the S_u of the 13 actions other than the user-initiated one (each to be "reject")."""
        return [su[:5] + (a,) for a in range(spaces.N_ACTIONS) if a != su[5]]

    def data_collection(self, state: tuple[int, ...] | np.ndarray, tp: str, robot_action: int,
                        response: int, user_action: int | None = None) -> None:
        """Table II's data_collection for one interaction (state: S1..S5 or more, indices)."""
        ctx = tuple(int(x) for x in state[:5])
        self.interactions += 1
        if tp == records.ROBOT_INITIATED:
            if robot_action == spaces.DO_NOTHING_ACTION or response == spaces.OTHERS:
                return  # nothing proposed, or no response: not recorded (Section V-B.1)
            self._add(ctx + (int(robot_action),), int(response), "D_f")
        elif tp == records.USER_INITIATED:
            if ctx[0] == spaces.DO_NOTHING_ACTIVITY:
                return  # IV-C.1: a request is recorded "if ... there is a sound activity"
            su = ctx + (int(user_action),)  # S_u[-1] = UR
            for new in self.generate_new(su):  # the 13 other actions: never this S_u itself
                self._add(new, spaces.REJECT, "D_g")
            if robot_action not in (spaces.DO_NOTHING_ACTION, int(user_action)):
                # the participant answered the robot's proposal by asking for something else (the
                # tablet's "Or ask the robot yourself"): an observed answer to it, which replaces an
                # earlier one in this S_u as any D_f sample does (a D_g reject would not)
                self._add(ctx + (int(robot_action),), spaces.REJECT, "D_f")
            self._add(su, spaces.ACCEPT, "D_i")
        else:
            raise ValueError(f"unknown conversation type {tp!r}; valid: type_1, type_2")

    @classmethod
    def from_interactions(cls, interactions: pd.DataFrame) -> "UserData":
        """D from interaction rows (records.INTERACTION_COLUMNS), in the order they happened."""
        data = cls()
        if len(interactions) == 0:
            return data
        df = interactions.sort_values(["day", "index"], kind="stable")
        states = records.policy_states(df)
        robot = [spaces.action_index(a) for a in df["robot_action"]]
        resp = [spaces.response_index(r) for r in df["response"]]
        users = [spaces.action_index(u) if isinstance(u, str) and u else None for u in df["user_action"]]
        for s, tp, a, r, u in zip(states, df["type"], robot, resp, users):
            data.data_collection(s, tp, a, r, u)
        return data

    def holds_accept(self, su: tuple[int, ...]) -> bool:
        """Whether D's sample for ``su`` (S1..S6 indices) is "accept" (the latest answer to it)."""
        held = self._samples.get(tuple(su))
        return held is not None and held.response == spaces.ACCEPT

    def subset(self, source: str) -> list[UserSample]:
        return [s for s in self._samples.values() if s.source == source]

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(S_u one-hot (n, 91), response indices (n,)) of D."""
        if not self._samples:
            return np.zeros((0, spaces.USER_INPUT_DIM), np.float32), np.zeros(0, np.int64)
        rows = list(self._samples.values())
        su = np.array([r.su + (spaces.OTHERS,) for r in rows])
        return spaces.encode_states(su, parts=6), np.array([r.response for r in rows])

    def support(self) -> np.ndarray:
        """(33, 14) bool: where the user data speaks for the user. Every action of an activity
        recorded in D, except "do nothing", which only D_g judges (after the participant asked for
        something during that activity); see :class:`DecisionModel`."""
        sup = np.zeros((spaces.N_ACTIVITIES, spaces.N_ACTIONS), bool)
        for r in self._samples.values():
            sup[r.su[0]] = True
        nothing = np.zeros(spaces.N_ACTIVITIES, bool)
        for r in self._samples.values():
            if r.su[5] == spaces.DO_NOTHING_ACTION:
                nothing[r.su[0]] = True
        sup[:, spaces.DO_NOTHING_ACTION] = nothing
        return sup

    def answered_pairs(self) -> np.ndarray:
        """(33, 14) bool: the activity-action pairs D holds a sample of (the participant's answer
        to that action during that activity, a request for it, or D_g's reject of it); see
        :class:`DecisionModel`."""
        pairs = np.zeros((spaces.N_ACTIVITIES, spaces.N_ACTIONS), bool)
        for r in self._samples.values():
            pairs[r.su[0], r.su[5]] = True
        return pairs

    def contexts(self) -> np.ndarray:
        """The recorded S1..S4 contexts (one per sample of D_f and D_i)."""
        rows = [r.su[:4] for r in self._samples.values() if r.source != "D_g"]
        return np.array(rows, dtype=np.int64).reshape(-1, 4)


class UserModel:
    """f_mu: an MLP from S_u (91-D) to the response (accept / reject / others)."""

    def __init__(self, hidden: int = 64, epochs: int = 150, seed: int = 0):
        self.hidden, self.epochs, self.seed = hidden, epochs, seed
        self.net = nets.mlp(spaces.USER_INPUT_DIM, hidden, spaces.N_RESPONSES, seed)
        self.trained_on = 0

    def fit(self, data: UserData) -> "UserModel":
        x, y = data.arrays()
        self.net = nets.mlp(spaces.USER_INPUT_DIM, self.hidden, spaces.N_RESPONSES, self.seed)
        if len(y):
            nets.fit_classifier(self.net, x, y, epochs=self.epochs, seed=self.seed)
        self.trained_on = len(y)
        return self

    def predict_proba(self, states: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """(n, 3) response probabilities for ``actions`` judged in ``states`` (n, >=5 indices)."""
        s = np.asarray(states)
        su = np.concatenate([s[:, :5], np.asarray(actions).reshape(-1, 1)], axis=1)
        return nets.predict_proba(self.net, spaces.encode_states(su, parts=6))


class UMA:
    """Table II: collect data interaction by interaction, retrain f_mu every N interactions
    (``idx % N == 0``; idx counts every interaction, recorded or not)."""

    def __init__(self, update_interval: int = 15, seed: int = 0):
        if not isinstance(update_interval, int) or isinstance(update_interval, bool) or update_interval < 1:
            raise ValueError(f"the user model's update interval N is {update_interval!r}; valid: an integer >= 1")
        self.N = update_interval
        self.data = UserData()
        self.model = UserModel(seed=seed)
        self.is_new = False
        self.fitted_interactions = 0  # idx at f_mu's last retraining

    @classmethod
    def replay(cls, interactions: pd.DataFrame, update_interval: int = 1, seed: int = 0) -> "UMA":
        """Table II over recorded interactions (records.INTERACTION_COLUMNS), in the order they
        happened, as stepping them one by one leaves it: ``data`` is D of them all, and f_mu was
        last retrained at the last idx with idx % N == 0, on D as it was then (trained once here,
        not every N). With N = 1, f_mu is trained on all of D."""
        uma = cls(update_interval, seed)
        ordered = interactions.sort_values(["day", "index"], kind="stable") if len(interactions) else interactions
        uma.data = UserData.from_interactions(ordered)
        uma.fitted_interactions = len(ordered) // uma.N * uma.N
        if uma.fitted_interactions:
            seen = ordered.iloc[:uma.fitted_interactions]
            uma.model.fit(uma.data if uma.fitted_interactions == len(ordered) else UserData.from_interactions(seen))
        uma.is_new = uma.fitted_interactions > 0 and uma.fitted_interactions == len(ordered)
        return uma

    def fitted_rows(self, interactions: pd.DataFrame) -> pd.DataFrame:
        """The interactions (in the order they happened) f_mu was last retrained on."""
        if not len(interactions):
            return interactions
        return interactions.sort_values(["day", "index"], kind="stable").iloc[:self.fitted_interactions]

    def step(self, state, tp: str, robot_action: int, response: int, user_action: int | None = None) -> UserModel:
        self.data.data_collection(state, tp, robot_action, response, user_action)
        self.is_new = self.data.interactions % self.N == 0
        if self.is_new:
            self.model.fit(self.data)
            self.fitted_interactions = self.data.interactions
        return self.model


class DecisionModel:
    """DM (Table III): f_mu's response if it is not "others" and its probability > threshold,
    otherwise the generic user simulator's response (``fallback``).

    Our reading adds where f_mu is asked at all (``support``, from :meth:`UserData.support`):
    for activities the participant has never been seen doing, f_mu's output is extrapolation and
    the generic simulator answers; and "do nothing" is judged by f_mu only where the participant
    has asked for something during that activity (the only data about the robot doing nothing).
    Without this, an MLP trained mostly on rejections answers "reject" everywhere, and SAC can
    no longer tell the participant's actions apart.

    And f_mu's "accept" counts only for an activity-action pair D holds (``answered``, from
    :meth:`UserData.answered_pairs`). An accept for a pair the participant was never asked about
    is carried over from other activities or actions (a participant who wants a call for help
    after falls and coughs is "accepting" it after using the stove), and it makes the robot
    propose what nobody asked for; the generic simulator answers such pairs instead. f_mu's
    rejections stand: a wrong reject only sends SAC to other actions, or to silence, where the
    participant can ask (letting D4A answer every unasked pair, rejects included, made CACAS fall
    to 0.59 on the example personas in an experiment).
    """

    def __init__(self, user_model: UserModel | None, fallback, threshold: float = 0.7,
                 support: np.ndarray | None = None, answered: np.ndarray | None = None):
        self.user_model = user_model
        self.fallback = fallback
        self.threshold = threshold
        self.support = support
        self.answered = answered

    def respond(self, states: np.ndarray, actions: np.ndarray) -> np.ndarray:
        fallback = self.fallback.respond(states, actions)
        if self.user_model is None or self.user_model.trained_on == 0:
            return fallback
        proba = self.user_model.predict_proba(states, actions)
        pred = proba.argmax(1)
        confident = (pred != spaces.OTHERS) & (proba.max(1) > self.threshold)
        activity, actions = np.asarray(states)[:, 0], np.asarray(actions)
        if self.support is not None:
            confident &= self.support[activity, actions]
        if self.answered is not None:
            confident &= (pred != spaces.ACCEPT) | self.answered[activity, actions]
        return np.where(confident, pred, fallback)
