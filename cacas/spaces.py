"""Table I of the paper: the state and action spaces, their names, sizes and one-hot encoding.

This module is the one source of truth for every name and size in the project: the 33 sound
activities (S1), 6 scenes (S2), 12 two-hour time slots (S3), 12 repeat-interval bins (S4),
14 robot tasks / actions (S5, S6) and 3 user responses (S7).

* The policy state is S1..S7 one-hot and concatenated: 33+6+12+12+14+14+3 = 94 dimensions.
* The user-model input S_u is S1..S6: 91 dimensions (Section IV-C.1); there S6 is the action
  being judged. In the policy state, where the paper says only that S6 is "the action that the
  robot needs to take", S6 is our reading: the robot's previous action, and S7 the user's
  response to it (design.md, "State (Table I): our reading"; the action to take is the policy's
  output, Eq. 4).
* The number of states, 33*6*12*12*14*14*3, is the paper's 16,765,056 (:data:`N_STATES`).

Names match case-insensitively (surrounding blanks and repeated spaces ignored); an unknown name
raises :class:`cacas.errors.CacasError` naming it (and the valid name it is close to, if one is)
and listing the valid ones.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np

from cacas.errors import CacasError, nearest

#: S1: the paper's 33 sound events, in its order (Section III), "do nothing" last.
ACTIVITIES: tuple[str, ...] = (
    "cough", "cry", "clear throat", "sneeze", "sniff", "fall down", "burp", "yawn", "snore",
    "drink water", "drink milk", "drink soup", "eat apple", "eat noodle", "eat chips",
    "wash hands", "wash clothes", "wash dishes", "use scissor", "use blender", "use stove",
    "use hair dryer", "use microwave", "use fan", "watch TV", "type keyboard", "cut food",
    "fry food", "pour water into glass", "shave", "brush teeth", "flush toilet", "do nothing",
)
#: S2: the 6 home scenes.
SCENES: tuple[str, ...] = ("bedroom", "living room", "kitchen", "bathroom", "dining room", "others")
#: S3: twelve two-hour slots; slot i is [2i, 2i+2) hours. Section IV-B.1 prints the last as
#: "[20, 24)" after "[20, 22)", a typo: "12 segments of 2 hours each" end with [22, 24).
TIME_SLOTS: tuple[tuple[int, int], ...] = tuple((2 * i, 2 * i + 2) for i in range(12))
#: S4: minutes since the previous activity other than "do nothing" (bin lower edges).
INTERVAL_BINS: tuple[int, ...] = (0, 1, 2, 5, 10, 15, 20, 30, 60, 90, 120, 200)
#: S5 / S6: the 14 agent actions, in Table I's order.
ACTIONS: tuple[str, ...] = (
    "do nothing", "show compassion", "chitchat", "remind to take medicine", "ask to offer help",
    "call someone for help", "set a timer", "pain check", "confirm sound", "record sound",
    "remind to turn off", "remind to be careful", "remind to put back", "remind to unplug",
)
#: S7: the user's response; reward +1 / -1 / 0 (Section IV-B.1).
RESPONSES: tuple[str, ...] = ("accept", "reject", "others")
REWARDS: dict[str, float] = {"accept": 1.0, "reject": -1.0, "others": 0.0}

DO_NOTHING_ACTIVITY = ACTIVITIES.index("do nothing")
DO_NOTHING_ACTION = ACTIONS.index("do nothing")
ACCEPT, REJECT, OTHERS = 0, 1, 2

N_ACTIVITIES, N_SCENES, N_SLOTS, N_INTERVALS = len(ACTIVITIES), len(SCENES), len(TIME_SLOTS), len(INTERVAL_BINS)
N_ACTIONS, N_RESPONSES = len(ACTIONS), len(RESPONSES)

#: (name, size) of each part of the policy state, in order S1..S7.
STATE_PARTS: tuple[tuple[str, int], ...] = (
    ("activity", N_ACTIVITIES), ("scene", N_SCENES), ("time_slot", N_SLOTS),
    ("interval", N_INTERVALS), ("task", N_ACTIONS), ("action", N_ACTIONS), ("response", N_RESPONSES),
)
OFFSETS: tuple[int, ...] = tuple(int(x) for x in np.cumsum([0] + [n for _, n in STATE_PARTS])[:-1])
STATE_DIM = sum(n for _, n in STATE_PARTS)  # 94
USER_INPUT_DIM = STATE_DIM - N_RESPONSES  # 91: S_u = S1..S6
N_STATES = int(np.prod([n for _, n in STATE_PARTS]))  # 16,765,056 (Section IV-B.1)


def _canon(name: str) -> str:
    return " ".join(str(name).strip().lower().split())


_LOOKUP = {
    kind: {_canon(n): i for i, n in enumerate(names)}
    for kind, names in (("activity", ACTIVITIES), ("scene", SCENES), ("action", ACTIONS),
                        ("response", RESPONSES))
}
_NAMES = {"activity": ACTIVITIES, "scene": SCENES, "action": ACTIONS, "response": RESPONSES}


def index_of(kind: str, name: str) -> int:
    """Index of ``name`` among the ``kind`` names ("activity", "scene", "action", "response").

    Case-insensitive. An unknown name raises CacasError naming it and listing the valid ones.
    """
    table = _LOOKUP[kind]
    if isinstance(name, str) and _canon(name) in table:
        return table[_canon(name)]
    valid = ", ".join(_NAMES[kind])
    raise CacasError(f"unknown {kind} {name!r}; {nearest(name, _NAMES[kind])}valid: {valid}")


def canonical(kind: str, name: str) -> str:
    """The paper's spelling of ``name`` (e.g. "Watch tv" -> "watch TV")."""
    return _NAMES[kind][index_of(kind, name)]


def activity_index(name: str) -> int:
    return index_of("activity", name)


def scene_index(name: str) -> int:
    return index_of("scene", name)


def scene_words(name: str) -> str:
    """A scene as a participant reads it: its name; "others" (any other room) is "another room"."""
    scene = SCENES[scene_index(name)]
    return "another room" if scene == "others" else scene


def in_scene(name: str) -> str:
    """Where, in words: "in the kitchen", "in another room" (the tablet said "in the others")."""
    words = scene_words(name)
    return f"in {words}" if words == "another room" else f"in the {words}"


def action_index(name: str) -> int:
    return index_of("action", name)


def response_index(name: str) -> int:
    return index_of("response", name)


def time_slot(hour: float) -> int:
    """S3: the two-hour slot of an hour of the day in [0, 24)."""
    if not 0 <= hour < 24:
        raise CacasError(f"hour {hour!r} is outside the day; valid: 0 <= hour < 24")
    return int(hour // 2)


def time_slot_label(slot: int) -> str:
    start, end = TIME_SLOTS[slot]
    return f"{start:02d}:00-{end:02d}:00"


def interval_bin(minutes: float) -> int:
    """S4: index of the largest bin value in INTERVAL_BINS not above ``minutes`` (>= 0)."""
    if minutes is None or not minutes >= 0:
        raise CacasError(f"interval {minutes!r} minutes is invalid; valid: a number of minutes >= 0")
    return int(np.searchsorted(INTERVAL_BINS, minutes, side="right") - 1)


def interval_label(index: int) -> str:
    lo = INTERVAL_BINS[index]
    return f"{lo}+ min" if index == N_INTERVALS - 1 else f"{lo}-{INTERVAL_BINS[index + 1]} min"


@dataclass(frozen=True)
class State:
    """One policy state S1..S7 as indices into the Table I name lists."""

    activity: int
    scene: int
    time_slot: int
    interval: int
    task: int = DO_NOTHING_ACTION
    action: int = DO_NOTHING_ACTION
    response: int = OTHERS

    def as_tuple(self) -> tuple[int, ...]:
        return (self.activity, self.scene, self.time_slot, self.interval, self.task, self.action,
                self.response)

    @classmethod
    def from_names(cls, activity: str, scene: str, hour: float, interval_minutes: float,
                   task: str = "do nothing", action: str = "do nothing",
                   response: str = "others") -> "State":
        return cls(activity_index(activity), scene_index(scene), time_slot(hour),
                   interval_bin(interval_minutes), action_index(task), action_index(action),
                   response_index(response))

    def names(self) -> dict[str, str]:
        """Decode back to names (the inverse of :meth:`from_names` up to binning)."""
        return {
            "activity": ACTIVITIES[self.activity], "scene": SCENES[self.scene],
            "time_slot": time_slot_label(self.time_slot), "interval": interval_label(self.interval),
            "task": ACTIONS[self.task], "action": ACTIONS[self.action],
            "response": RESPONSES[self.response],
        }


_SIZES = np.array([n for _, n in STATE_PARTS])
_OFFS = np.array(OFFSETS)


def _as_index_array(states) -> np.ndarray:
    if isinstance(states, State):
        states = [states.as_tuple()]
    arr = np.array([s.as_tuple() if isinstance(s, State) else tuple(s) for s in states]
                   if not isinstance(states, np.ndarray) else states, dtype=np.int64)
    if arr.ndim == 1:
        arr = arr[None, :]
    return arr


def encode_states(states, parts: int = 7) -> np.ndarray:
    """One-hot encode states (State objects or rows of 7 indices) to float32 (n, dim).

    ``parts=7`` gives the 94-D policy state; ``parts=6`` the 91-D user-model input S_u.
    """
    idx = _as_index_array(states)[:, :parts]
    if np.any(idx < 0) or np.any(idx >= _SIZES[:parts]):
        bad = np.argwhere((idx < 0) | (idx >= _SIZES[:parts]))[0]
        raise CacasError(f"state part {STATE_PARTS[bad[1]][0]} has index {idx[bad[0], bad[1]]}; "
                         f"valid: 0..{_SIZES[bad[1]] - 1}")
    dim = int(_SIZES[:parts].sum())
    out = np.zeros((idx.shape[0], dim), dtype=np.float32)
    rows = np.arange(idx.shape[0])[:, None]
    out[rows, idx + _OFFS[:parts]] = 1.0
    return out


def encode_user_input(state: State, judged_action: int | None = None) -> np.ndarray:
    """The 91-D user-model input S_u = S1..S6, with S6 the action being judged."""
    s = state if judged_action is None else State(*state.as_tuple()[:5], judged_action, state.response)
    return encode_states([s], parts=6)[0]


def indices_from_onehot(vectors: np.ndarray, parts: int = 7) -> np.ndarray:
    """Table I index rows (n, parts) of one-hot state rows (vectorised; no validity check: use
    :func:`decode_states` for vectors from outside the library)."""
    vec = np.atleast_2d(np.asarray(vectors))
    return np.stack([vec[:, _OFFS[p]:_OFFS[p] + _SIZES[p]].argmax(1) for p in range(parts)], axis=1)


def decode_states(vectors: np.ndarray) -> list[State]:
    """Inverse of :func:`encode_states` for 94-D (S7 decoded) or 91-D (S7 = others) vectors."""
    vec = np.atleast_2d(np.asarray(vectors))
    dim = vec.shape[1]
    parts = 7 if dim == STATE_DIM else 6 if dim == USER_INPUT_DIM else None
    if parts is None:
        raise CacasError(f"a state vector has {dim} dimensions; valid: {STATE_DIM} or {USER_INPUT_DIM}")
    for p in range(parts):
        seg = vec[:, _OFFS[p]:_OFFS[p] + _SIZES[p]]
        if not (np.isclose(seg.sum(1), 1.0).all() and np.isclose(seg.max(1), 1.0).all()):
            raise CacasError(f"state part {STATE_PARTS[p][0]} is not one-hot")
    return [State(*map(int, row)) if parts == 7 else State(*map(int, row), OTHERS)
            for row in indices_from_onehot(vec, parts)]


def parse_names(kind: str, names: Iterable[str]) -> list[int]:
    """Indices of several names of one kind (each checked by :func:`index_of`)."""
    return [index_of(kind, n) for n in names]
