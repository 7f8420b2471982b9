"""The user simulator (Section IV-B.3): ``generate_state`` and ``generate_response``.

* ``generate_response(up, s, a)``: "the user preference has the first priority and the D4A pairs
  have the second priority". Where a preference covers the state, its action is accepted, doing
  nothing gets no response ("others") and any other action is rejected; elsewhere the D4A pairs
  answer. The paper: "It first checks if the current state s and agent action a fit the user
  preference. If it does not fit, D4A pairs are used"; we read "fit" as "a preference covers the
  state" (README, "Our reading of the paper": the literal reading would let the D4A pairs accept
  most wrong proposals in covered states, against the paper's day-1 success rate of 0.30).
  :class:`ResponseModel` does this for a whole batch of states at once.
* ``generate_state(t, h, source)``: "generates a state every K minutes ... The time starts at 00:00
  and ends at 23:59 and increases by K minutes each step". :class:`StateGenerator` steps E
  parallel simulated days at once (batched for speed); the activity comes from ``source`` (the
  generic user's routine for the initial policy, or the user data D during adaptation, "in which
  the activity recorded in D has a higher probability of being selected"), the time of day from
  the clock, the repeat interval S4 from the history of activity times, and S5-S7 from the
  previous step's action and response.

All randomness comes from a ``numpy.random.Generator`` passed in: the same seed gives the same
states.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cacas import spaces
from cacas.errors import CacasError
from cacas.preferences import Participant

#: A robot task started and accepted is still "in progress" (S5) for this many minutes.
TASK_DURATION_MIN = 5.0


def current_task(prev_action: np.ndarray, prev_response: np.ndarray, minutes_since: np.ndarray) -> np.ndarray:
    """S5: the robot's task in progress: the previously accepted action for TASK_DURATION_MIN
    minutes after it was accepted, "do nothing" otherwise (vectorised)."""
    busy = (prev_response == spaces.ACCEPT) & (prev_action != spaces.DO_NOTHING_ACTION) \
        & (minutes_since < TASK_DURATION_MIN)
    return np.where(busy, prev_action, spaces.DO_NOTHING_ACTION)


class ResponseModel:
    """``generate_response``: preferences first, D4A pairs second (vectorised over states)."""

    def __init__(self, d4a_table: np.ndarray, preferences: Participant | None = None):
        self.d4a = np.asarray(d4a_table, dtype=np.int64)
        self.preferred = preferences.preferred_action_table().astype(np.int64) if preferences else None

    def preferred_actions(self, states: np.ndarray) -> np.ndarray:
        """The preferred action (or -1 where no preference covers the state), states (n, >=5)."""
        if self.preferred is None:
            return np.full(len(states), -1)
        s = np.asarray(states)
        return self.preferred[s[:, 0], s[:, 1], s[:, 2], s[:, 3], s[:, 4]]

    def respond(self, states: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """Response indices (ACCEPT / REJECT / OTHERS) to ``actions`` in ``states`` (n, 7)."""
        s = np.asarray(states)
        a = np.asarray(actions)
        d4a = self.d4a[s[:, 0], a]
        pref = self.preferred_actions(s)
        # the robot doing nothing gets no response, also where the participant wants quiet (as a
        # simulated study day answers it: experiment.simulated_day)
        by_pref = np.where(a == spaces.DO_NOTHING_ACTION, spaces.OTHERS,
                           np.where(a == pref, spaces.ACCEPT, spaces.REJECT))
        return np.where(pref >= 0, by_pref, d4a)


def generic_activity_weights() -> np.ndarray:
    """The generic user's routine: every activity equally likely, and idle ("do nothing")
    as likely as all the others together (people are idle much of the day)."""
    w = np.ones(spaces.N_ACTIVITIES)
    w[spaces.DO_NOTHING_ACTIVITY] = spaces.N_ACTIVITIES - 1
    return w / w.sum()


@dataclass
class ContextSource:
    """Where the simulated activity and scene come from.

    ``activity_weights`` (33,) is the probability of each activity at a step; ``scene_table``
    (33, 6) the probability of each scene given the activity; ``slot_activity`` optionally
    (12, 33) re-weights activities by time slot (the recorded contexts of D).
    """

    activity_weights: np.ndarray
    scene_table: np.ndarray
    slot_activity: np.ndarray | None = None

    @classmethod
    def generic(cls) -> "ContextSource":
        return cls(generic_activity_weights(), np.full((spaces.N_ACTIVITIES, spaces.N_SCENES), 1 / spaces.N_SCENES))

    @classmethod
    def from_user_data(cls, contexts: np.ndarray, recorded_share: float = 0.8) -> "ContextSource":
        """States generated from the user data D (Table III step 2): the activities recorded in D
        are chosen with probability ``recorded_share`` (in proportion to how many of the given
        contexts name them), any activity otherwise; a recorded activity happens in its recorded
        scenes and time slots more often. ``contexts``: (n, >=4) S1..S4 indices of the recorded
        data; CACAA passes D's samples (:meth:`cacas.user_model.UserData.contexts`, one per
        distinct S_u, so a context answered five times with the same action counts once, and one
        where two actions were tried counts twice)."""
        base = ContextSource.generic()
        contexts = np.asarray(contexts)
        if len(contexts) == 0:
            return base
        counts = np.bincount(contexts[:, 0], minlength=spaces.N_ACTIVITIES).astype(float)
        weights = (1 - recorded_share) * base.activity_weights + recorded_share * counts / counts.sum()
        scene = np.full((spaces.N_ACTIVITIES, spaces.N_SCENES), 0.5 / spaces.N_SCENES)
        np.add.at(scene, (contexts[:, 0], contexts[:, 1]), 1.0)
        scene /= scene.sum(1, keepdims=True)
        slot = np.full((spaces.N_SLOTS, spaces.N_ACTIVITIES), 1.0)
        np.add.at(slot, (contexts[:, 2], contexts[:, 0]), 4.0)
        slot /= slot.mean(1, keepdims=True)
        return cls(weights, scene, slot)


def steps_per_day(k_minutes: float) -> int:
    """generate_state steps of one simulated day, 00:00 to 23:59 every K minutes: the whole steps of
    24 x 60 / K (Section IV-B.3). 1440 // 7.2 is 199.0 in floating point (7.2 is stored a little above
    7.2): a K that divides the day gives its 1440 / K steps (200), the last one no longer left out."""
    return int(math.floor(round(24 * 60 / k_minutes, 9)))


class StateGenerator:
    """``generate_state`` for E parallel simulated days, K minutes a step (Section IV-B.3).

    At step t (time t*K minutes, jittered within the step) each day draws an activity from the
    source (idle steps are "do nothing"), a scene for it, the time slot S3 from the clock, the
    repeat interval S4 from the history h of activity times (including, now and then, an
    activity a few minutes before the observation), and S5-S7 from the previous step's action
    and response.
    """

    def __init__(self, source: ContextSource, n_days: int, k_minutes: float, rng: np.random.Generator,
                 follow_up_rate: float = 0.2):
        self.source = source
        self.E = n_days
        self.K = k_minutes
        self.rng = rng
        self.follow_up_rate = follow_up_rate
        self.steps_per_day = steps_per_day(k_minutes)
        self.reset()

    def reset(self) -> None:
        E = self.E
        self.t = 0
        # h: the time of the previous activity other than "do nothing"; at 00:00 it was a while ago.
        self.last_activity_time = -self.rng.uniform(0, 240, E)
        self.last_interaction_time = np.full(E, -1e9)
        self.prev_action = np.full(E, spaces.DO_NOTHING_ACTION)
        self.prev_response = np.full(E, spaces.OTHERS)

    @property
    def done(self) -> bool:
        return self.t >= self.steps_per_day

    def _draw_activities(self, slots: np.ndarray) -> np.ndarray:
        """One activity per parallel day, re-weighted by that day's time slot S3 (``slots``, (E,))."""
        w = np.broadcast_to(self.source.activity_weights, (self.E, spaces.N_ACTIVITIES))
        if self.source.slot_activity is not None:
            w = w * self.source.slot_activity[slots]
        cdf = np.cumsum(w / w.sum(1, keepdims=True), axis=1)
        u = self.rng.random((self.E, 1))
        return np.minimum((cdf <= u).sum(1), spaces.N_ACTIVITIES - 1)

    def generate_state(self) -> np.ndarray:
        """The next state of every parallel day: (E, 7) Table I indices. After 23:59 (``done``)
        there is none: asking for one is an error."""
        if self.done:
            raise CacasError(f"the simulated day is over: it has {self.steps_per_day} states, one every "
                             f"{self.K:g} minutes from 00:00; start a new StateGenerator for another day")
        E, rng = self.E, self.rng
        now = self.t * self.K + rng.uniform(0, self.K, E)
        # Activities between two K-minute observations still count in h: now and then the
        # previous activity was only a few minutes ago (short repeat intervals, S4 < 5 min).
        follow = rng.random(E) < self.follow_up_rate
        self.last_activity_time = np.where(follow, now - rng.uniform(0, 5, E), self.last_activity_time)
        # S3 from each day's clock (a step may cross a slot's end); the last step's time may round up to 24:00
        # (720 + the largest float below 720 is 1440.0), which is the last slot's end, not a slot of its own
        slot = np.minimum(now // 120, spaces.N_SLOTS - 1).astype(int)
        activity = self._draw_activities(slot)
        scene_cdf = np.cumsum(self.source.scene_table[activity], axis=1)
        scene = np.minimum((scene_cdf < rng.random((E, 1))).sum(1), spaces.N_SCENES - 1)
        interval = np.searchsorted(spaces.INTERVAL_BINS, np.maximum(now - self.last_activity_time, 0),
                                   side="right") - 1
        task = current_task(self.prev_action, self.prev_response, now - self.last_interaction_time)
        state = np.stack([activity, scene, slot, interval, task,
                          self.prev_action, self.prev_response], axis=1).astype(np.int64)
        active = activity != spaces.DO_NOTHING_ACTIVITY
        self.last_activity_time = np.where(active, now, self.last_activity_time)
        self._now = now
        self.t += 1
        return state

    def observe(self, actions: np.ndarray, responses: np.ndarray) -> None:
        """Record the robot's actions and the responses into the history (S5-S7 of the next state)."""
        self.prev_action = np.asarray(actions, dtype=np.int64)
        self.prev_response = np.asarray(responses, dtype=np.int64)
        acted = self.prev_action != spaces.DO_NOTHING_ACTION
        self.last_interaction_time = np.where(acted, self._now, self.last_interaction_time)


def dialog_state(activity: str, scene: str, hour: float, interval_minutes: float,
                 previous: dict | None = None, minutes_since_previous: float | None = None) -> spaces.State:
    """The policy state of a live interaction (the tablet page, or a simulated participant).

    S1-S4 are what the participant set (S4 is the time since their previous activity). S6 and S7
    come from the previous interaction of the day (``previous``, a mapping with the
    INTERACTION_COLUMNS keys type/robot_action/response/user_action): the robot's previous
    action (for a user-initiated one, the action the participant asked for, which the robot
    then carried out) and the participant's response. S5 is that action while it is in
    progress (accepted less than TASK_DURATION_MIN minutes ago; the participant's S4 is used
    when ``minutes_since_previous`` is not given).
    """
    s = spaces.State.from_names(activity, scene, hour, interval_minutes)
    if not previous:
        return s
    if previous.get("type") == "type_2" and previous.get("user_action"):
        prev_action = spaces.action_index(previous["user_action"])
        prev_response = spaces.ACCEPT
    else:
        prev_action = spaces.action_index(previous.get("robot_action") or "do nothing")
        prev_response = spaces.response_index(previous.get("response") or "others")
    since = interval_minutes if minutes_since_previous is None else minutes_since_previous
    task = int(current_task(np.array([prev_action]), np.array([prev_response]), np.array([since]))[0])
    return spaces.State(s.activity, s.scene, s.time_slot, s.interval, task, prev_action, prev_response)


def preference_states(participant: Participant, n: int, rng: np.random.Generator) -> np.ndarray:
    """n S1-S5 contexts (n, 5) drawn from a participant's described preferences: a preference
    chosen at random, then one of the S1-S4 states it covers, uniformly, with S5 (the robot's
    task) "do nothing" (the robot idle) where the preference allows it, else one of the tasks it
    names. Used by the simulated participant (who acts in the contexts their preferences
    describe) and by Fig. 4's evaluation; never by the adaptation."""
    prefs = participant.preferences
    cells = [np.argwhere(p.coverage_mask()) for p in prefs]
    which = rng.integers(len(cells), size=n)
    out = np.full((n, 5), spaces.DO_NOTHING_ACTION, dtype=np.int64)
    for k, c in enumerate(cells):
        idx = np.flatnonzero(which == k)
        if len(idx):
            out[idx, :4] = c[rng.integers(len(c), size=len(idx))]
    for k, p in enumerate(prefs):  # draws only for a preference that needs the robot busy
        tasks = p.task_indices()
        idx = np.flatnonzero(which == k)
        if len(idx) and spaces.DO_NOTHING_ACTION not in tasks:
            out[idx, 4] = np.asarray(tasks)[rng.integers(len(tasks), size=len(idx))]
    return out
