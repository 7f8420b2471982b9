"""A study day on the tablet, and the adaptation after it (paper, Section V-B.1; Table III step 2).

The tablet page (the paper's "web page as a user interface to set the context") calls, in order:

1. :func:`start_day` - open the participant's next day, once the previous one was adapted;
2. :func:`propose` - for the context the participant set (S3 time of day, S4 time since the
   last activity, S1 activity, S2 room) and what the robot recognised, the policy in force
   decides an action (Eq. 4) and says it as a spoken-style line (:mod:`cacas.dialogue`);
3. :func:`answer` - the participant's answer is written to the study database at once: Accept /
   Reject / No response to the robot's proposal (type_1), or an action the participant asked for
   themselves and confirmed (type_2).

After the day the researcher calls :func:`adapt_day` (in a background job): close the day, adapt
the policy from all the participant's interactions so far (CACAS, or a baseline), store the new
policy version and the run. The adaptation never reads the described preferences; they are read
only afterwards, to score the new policy for Fig. 4 (``preference_accuracy`` and its breakdown
by preference, :func:`cacas.adaptation.fig4_metrics`) when they exist.

Conventions (as ``cacas simulate`` writes them, so one set of plots serves both):
* the robot doing nothing and the participant not asking for anything: type_1, robot action
  "do nothing", response "others";
* a user-initiated interaction: type_2, ``user_action`` the confirmed request, response "accept"
  (the participant's confirmation), ``robot_action`` what the robot had proposed.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping

import numpy as np
import pandas as pd

from cacas import dialogue, records, spaces
from cacas.errors import AlreadyAdapted, CacasError

Progress = Callable[[float, str], None]

#: The paper's participants "interact with the robot around 15 times a day and last for 7 days".
TARGET_INTERACTIONS = 15
STUDY_DAYS = 7
#: Answers to a robot-initiated proposal, and the response each records.
ANSWERS = {"accept": "accept", "reject": "reject", "no response": "others"}


@dataclass(frozen=True)
class Context:
    """What the participant set on the tablet: S3 slot, S4 bin, S1 activity, S2 room (indices)."""

    time_slot: int
    interval_bin: int
    activity: str
    scene: str

    @classmethod
    def from_choices(cls, time_slot: int, interval_bin: int, activity: str, scene: str) -> "Context":
        if not isinstance(time_slot, (int, np.integer)) or not 0 <= time_slot < spaces.N_SLOTS:
            raise CacasError(f"time of day {time_slot!r} is invalid; valid: slot 0..{spaces.N_SLOTS - 1}")
        if not isinstance(interval_bin, (int, np.integer)) or not 0 <= interval_bin < spaces.N_INTERVALS:
            raise CacasError(f"time since the last activity {interval_bin!r} is invalid; "
                             f"valid: bin 0..{spaces.N_INTERVALS - 1}")
        return cls(int(time_slot), int(interval_bin), spaces.canonical("activity", activity),
                   spaces.canonical("scene", scene))

    @property
    def hour(self) -> int:
        return spaces.TIME_SLOTS[self.time_slot][0]

    @property
    def interval_minutes(self) -> int:
        return spaces.INTERVAL_BINS[self.interval_bin]

    def to_token(self) -> str:
        """A short text for the URL, so that a reload returns to the same proposal."""
        return (f"{self.time_slot}.{self.interval_bin}.{spaces.activity_index(self.activity)}."
                f"{spaces.scene_index(self.scene)}")

    @classmethod
    def from_token(cls, token: str) -> "Context":
        try:
            slot, interval, act, scene = (int(x) for x in str(token).split("."))
            if not (0 <= act < len(spaces.ACTIVITIES) and 0 <= scene < len(spaces.SCENES)):
                raise IndexError(act)  # a negative index counted from the end: "-1" was "do nothing" / "others"
            return cls.from_choices(slot, interval, spaces.ACTIVITIES[act], spaces.SCENES[scene])
        except (ValueError, IndexError):
            raise CacasError(f"context {token!r} in the address is invalid") from None


@dataclass(frozen=True)
class Proposal:
    """What the robot does in a context: its action (Eq. 4), the 14 probabilities, its line."""

    context: Context
    heard: str                      # the activity the robot acts on (recognised, or as set)
    heard_confidence: float | None  # None: no recogniser, the activity as set was used
    state: spaces.State
    action: str
    probabilities: np.ndarray = field(repr=False)
    line: str
    policy_version: int | None
    seen: str | None = None         # the room the robot recognised from its camera, if it did
    sound_model: str | None = None  # the id of the sound model that heard it (recognition.model_id)
    scene_model: str | None = None  # the id of the scene model that saw the room

    @property
    def robot_speaks(self) -> bool:
        return self.action != "do nothing"


# --- the policy in force ---------------------------------------------------------------------------

def policy_in_force(store, participant: str, initial_loader: Callable | None = None):
    """(policy, version) in force for the participant: the store's active version, or the
    initial policy (CACAA step 1, version None) before the first adaptation."""
    active = store.active_policy(participant)
    return policy_of_version(store, participant, None if active is None else active.version, initial_loader)


def policy_of_version(store, participant: str, version: int | None, initial_loader: Callable | None = None):
    """(policy, version): the participant's saved policy ``version`` (:func:`saved_policy`), or the
    initial policy (CACAA step 1) for None, whichever is in force now: the interaction at hand keeps
    the policy it was first proposed with (:meth:`cacas.on_tablet.TabletBoard.policy_for`)."""
    if version is None:
        if initial_loader is None:
            from cacas.adaptation import load_initial_policy as initial_loader
        return initial_loader(), None
    return saved_policy(store, participant, version), version


def saved_policy(store, participant: str, version: int):
    """A saved policy version, checked against its sha256 (:meth:`StudyStore.load_policy`); a file
    that is not a policy (its sha256 matching, as a crafted bundle's can) is a CacasError naming the
    file, the version and the participant (it said "not a CACAS policy file" alone)."""
    from cacas.policy import policy_from_bytes

    data = store.load_policy(participant, version=version)
    try:
        return policy_from_bytes(data)
    except CacasError as exc:
        path = next((p.path for p in store.policy_versions(participant) if p.version == version), None)
        raise CacasError(f"{path}: policy version {version} of participant {participant} is {exc}") from None


def initial_policy_ready() -> bool:
    """Whether the initial policy (CACAA step 1) is on disk; if not, the first proposal trains it
    (minutes on a small machine), so the app runs :func:`prepare_initial_policy` in the background."""
    from cacas.adaptation import initial_policy_path

    return initial_policy_path().exists()


def prepare_initial_policy(progress: Progress | None = None) -> None:
    """Train and cache the initial policy if it is missing (for a background job)."""
    from cacas.adaptation import load_initial_policy

    load_initial_policy(progress=progress)


def adapted_days(store, participant: str) -> set[int]:
    """Study days after which a policy was adapted for the participant and saved (with any
    method, whether or not it is still in force). Comparison runs (:func:`cacas.method_comparison.compare_methods`)
    save no policy and do not count: they never put a policy in force."""
    return {p.day for p in store.policy_versions(participant) if p.day > 0}


@dataclass(frozen=True)
class DayStatus:
    """Where the participant's study stands today, for the tablet and the overview."""

    day: int                 # latest day (0 before the first)
    open: bool
    interactions_today: int  # saved on ``day``, answered or not (the next one's number is this + 1)
    total_interactions: int
    policy_version: int | None
    waiting_for_adaptation: bool   # the latest day is closed and not yet adapted
    finished: bool                 # STUDY_DAYS days done (closed)
    recorded_today: int = 0  # of them, the ones the paper records (answered, or asked for): the ~15 a day

    @property
    def unanswered_today(self) -> int:
        """Saved on ``day`` without a data point: a proposal left unanswered, the robot quiet
        with nothing asked, or a request made with no sound activity (saved, but not recorded:
        Section V-B, IV-C.1)."""
        return self.interactions_today - self.recorded_today

    @property
    def day_on_screen(self) -> int:
        """The day the tablet is about: the open day; a closed day while it waits for its
        adaptation (or the last one); once adapted, the next day, ready to start (1 before the
        first). The app's address carries it, so address and tablet agree."""
        if self.open or self.waiting_for_adaptation or self.finished:
            return max(self.day, 1)
        return self.day + 1


def day_status(store, participant: str, recorded_by_day: Mapping[int, int] | None = None) -> DayStatus:
    """Where ``participant``'s study stands (:class:`DayStatus`). ``recorded_by_day``: their
    recorded interactions (:func:`cacas.records.is_recorded`) per day, when the caller has read
    them already (the Overview reads a study's interactions once, not once more per participant:
    a third of its run for 60 participants); else the latest day's are read here."""
    r = store.resume(participant)
    waiting = bool(r.day and not r.day_open and r.day not in adapted_days(store, participant))
    recorded = 0
    if r.interactions_today:
        recorded = int(recorded_by_day.get(r.day, 0)) if recorded_by_day is not None else \
            int(records.is_recorded(store.interactions_frame(participant, method=None, day=r.day)).sum())
    return DayStatus(r.day, r.day_open, r.interactions_today, r.total_interactions, r.policy_version,
                     waiting, bool(r.day >= STUDY_DAYS and not r.day_open), recorded)


def day_of(day: int) -> str:
    """A study day beside the study's length (Section V-B.1: 7 days): "3 of 7"; a day past it (an
    imported study, or one the library ran longer) says so rather than "21 of 7"."""
    return f"{day} of {STUDY_DAYS}" if day <= STUDY_DAYS else f"{day}, past the study's {STUDY_DAYS}"


def questionnaire_timing(status: DayStatus) -> str:
    """A note for a questionnaire answer given before the study's end (Section V-B.1 asks it
    after the 7 days), naming the day as it stands: during an open day, or after a closed one."""
    if status.finished or status.day == 0:
        return ""
    when = "during" if status.open else "after"
    return f"It was given {when} day {day_of(status.day)}."


def waiting_for_preferences(store, participant: str, status: DayStatus) -> bool:
    """Day 1 cannot start yet: the participant has no described preferences (the study's scores,
    Fig. 4 and the success ceiling, need them)."""
    return status.day == 0 and store.get_preferences(participant) is None


def start_day(store, participant: str) -> int:
    """Open the participant's next study day (or return the open one).

    Refused after the study's :data:`STUDY_DAYS` days, while the previous day has not been adapted
    (Section V-B.1: "After adaptation, the
    participant can interact with the robot in the next day"), before day 1 while the participant
    has no described preferences (the study's scores, Fig. 4 and the success ceiling, need them),
    and while the study data folder has no readable D4A pairs (nothing is opened)."""
    status = day_status(store, participant)
    if status.open:
        return status.day
    if status.finished:  # the tablet said "All 7 days are done", while the library opened day 8 (review)
        raise CacasError(f"participant {participant} has done all {STUDY_DAYS} study days; the study has "
                         f"{STUDY_DAYS} (Section V-B.1): there is no day {status.day + 1}")
    if waiting_for_preferences(store, participant, status):
        raise CacasError(f"participant {participant} has no described preferences; describe them before day 1 "
                         "(Participants page)")
    if status.waiting_for_adaptation:
        raise CacasError(f"day {status.day} of participant {participant} is closed but the robot has not "
                         f"been adapted yet; run the adaptation first (Adaptation page)")
    from cacas.d4a import load_d4a
    from cacas.paths import study_data_blocked, study_data_problem

    try:  # checked before the day opens: the robot gets ready, and the day is adapted, with the D4A pairs
        load_d4a()
    except CacasError as exc:  # a folder without the shipped files, or a D4A file that does not parse
        why = study_data_problem() if study_data_blocked() else str(exc)
        raise CacasError(f"day {status.day + 1} of participant {participant} not started: {why}") from None
    return store.open_day(participant)


# --- one interaction ------------------------------------------------------------------------------

def clip_for(context: Context, participant: str, day: int, index: int, clips: list) -> Path | None:
    """The library clip played for this interaction: chosen by a hash of who, when and what, so
    that a page reload plays the same clip."""
    if not clips:
        return None
    key = f"{participant}|{day}|{index}|{context.to_token()}".encode()
    return Path(clips[int(hashlib.sha256(key).hexdigest(), 16) % len(clips)])


def proposal_draws(participant: str, day: int, index: int, policy: str | None = None) -> np.random.Generator:
    """The random draws of one interaction's proposal (the bandit's Thompson draw), seeded by a hash
    of who, which day, which interaction of it (the day's answers recorded so far + 1) and which
    policy (its checkpoint's sha256), as :func:`clip_for` chooses the clip.

    Not the policy's own generator: a bandit loaded from its file restarted that from the same seed
    after every server restart, so a tablet replayed the same draws day after day. Not fresh entropy
    either: the proposal is drawn again at each rerun of the page (any click before the answer, a
    reload), and it must not change under the participant's eyes; keyed so, each new interaction
    draws anew, a rerun or a restart repeats the draw of the interaction at hand only, and a
    study's proposals can be recomputed from its records."""
    key = f"{participant}|{day}|{index}|{policy or ''}".encode()
    return np.random.default_rng(np.frombuffer(hashlib.sha256(key).digest(), dtype=np.uint32))


def previous_interaction(store, participant: str, day: int) -> dict | None:
    """The day's last interaction (for S5-S7 of the next state), or None at the start of a day."""
    df = store.interactions_frame(participant, method=None)
    df = df[df["day"] == day]
    return None if df.empty else df.iloc[-1].to_dict()


def propose(policy, context: Context, previous: dict | None = None, heard: str | None = None,
            heard_confidence: float | None = None, policy_version: int | None = None,
            seen: str | None = None, sound_model: str | None = None,
            scene_model: str | None = None, draws: np.random.Generator | None = None) -> Proposal:
    """The robot's proposal: the policy state from the context (S1 is what the robot heard and S2
    the room it saw, when recognisers are installed, else as set; S5-S7 from the previous
    interaction), Eq. 4's action (the bandit's Thompson draw, from ``draws`` if given:
    :func:`proposal_draws`) and its line. ``sound_model`` / ``scene_model``: the ids of the
    models that heard and saw (kept with the answer, so a study knows which model served it)."""
    from cacas.simulator import dialog_state

    act_on = spaces.canonical("activity", heard) if heard else context.activity
    seen = spaces.canonical("scene", seen) if seen else None
    state = dialog_state(act_on, seen or context.scene, context.hour, context.interval_minutes, previous)
    action_index, probs = policy.decide(state) if draws is None else policy.decide(state, rng=draws)
    action = spaces.ACTIONS[action_index]
    return Proposal(context, act_on, heard_confidence if heard else None, state, action,
                    np.asarray(probs, dtype=float), dialogue.robot_line(act_on, action), policy_version, seen,
                    sound_model if heard else None, scene_model if seen else None)


def _normalised(probs: np.ndarray) -> list[float]:
    p = np.clip(np.asarray(probs, dtype=float), 0.0, None)
    return (p / p.sum()).tolist() if p.sum() > 0 else None


def request_accepts_proposal(proposal: Proposal, user_action: str) -> bool:
    """Whether asking for ``user_action`` is accepting the robot's proposal: the participant asked
    for exactly what the robot offered. It is recorded as accepted (a success, Fig. 3), not as a
    request of their own (which would also reject "do nothing", Section V-B)."""
    return proposal.robot_speaks and spaces.canonical("action", user_action) == proposal.action


def answer(store, participant: str, day: int, proposal: Proposal, response: str | None = None,
           user_action: str | None = None, index: int | None = None) -> int:
    """Record the participant's answer at once (committed before this returns); the row id.

    ``response``: "accept", "reject" or "no response" to the robot's proposal (type_1). Or
    ``user_action``: the action the participant asked for and confirmed (type_2; asking for
    exactly what the robot offered is accepting it, see :func:`request_accepts_proposal`). When
    the robot did nothing, "no response" records that nothing was needed. ``index``: the day's
    interaction number the proposal was made for; the answer is written once, and a second one
    for the same number (a second click, another tab) raises AlreadyRecorded and writes nothing.
    """
    if (response is None) == (user_action is None):
        raise CacasError("give either the answer to the robot (accept, reject, no response) or the "
                         "action the participant asked for, not both")
    state = proposal.state
    common = dict(
        activity=proposal.context.activity, scene=proposal.context.scene,
        time_slot=proposal.context.time_slot, interval_bin=proposal.context.interval_bin,
        hour=float(proposal.context.hour), interval_minutes=float(proposal.context.interval_minutes),
        task=spaces.ACTIONS[state.task], previous_action=spaces.ACTIONS[state.action],
        previous_response=spaces.RESPONSES[state.response], robot_action=proposal.action,
        probabilities=_normalised(proposal.probabilities),
        recognised_activity=proposal.heard if proposal.heard_confidence is not None else None,
        recognised_scene=proposal.seen, policy_version=proposal.policy_version,
        sound_model=proposal.sound_model, scene_model=proposal.scene_model,
    )
    if user_action is not None:
        wanted = spaces.canonical("action", user_action)
        if wanted == "do nothing":
            raise CacasError("'do nothing' is not a request; valid: one of the 13 other actions")
        if not request_accepts_proposal(proposal, wanted):
            return store.record_interaction(participant, day, type=records.USER_INITIATED, response="accept",
                                            user_action=wanted, index=index, **common)
        response = "accept"
    key = str(response).strip().lower()
    if key not in ANSWERS:
        raise CacasError(f"answer {response!r} is invalid; valid: {', '.join(ANSWERS)}")
    if not proposal.robot_speaks and key != "no response":
        raise CacasError("the robot did not propose anything; answer 'no response' (nothing needed) "
                         "or ask for an action")
    return store.record_interaction(participant, day, type=records.ROBOT_INITIATED, response=ANSWERS[key],
                                    index=index, **common)


def recorded_answer(store, participant: str, day: int, index: int) -> dict | None:
    """The day's interaction number ``index`` as recorded (an interactions.csv row), or None."""
    df = store.interactions_frame(participant, method=None)
    row = df[(df["day"] == day) & (df["index"] == index)]
    return None if row.empty else row.iloc[0].to_dict()


def is_same_answer(row: dict, proposal: Proposal, response: str | None = None,
                   user_action: str | None = None) -> bool:
    """``row`` (:func:`recorded_answer`) is this answer to this proposal, as :func:`answer` writes
    it: a second click on the same screen, not another screen's answer to another proposal. The
    context is compared whole (S1-S4): two tablets at one participant's address (lan) may propose
    the same action for the same activity in another room or at another time."""
    ctx = proposal.context
    if (row["activity"], row["scene"], row["time_slot"], row["interval"], row["robot_action"]) != (
            ctx.activity, ctx.scene, ctx.time_slot, ctx.interval_minutes, proposal.action):
        return False
    if user_action is not None and not request_accepts_proposal(proposal, user_action):
        wanted = spaces.canonical("action", user_action)
        return row["type"] == records.USER_INITIATED and row["user_action"] == wanted
    key = "accept" if user_action is not None else str(response).strip().lower()
    return row["type"] == records.ROBOT_INITIATED and row["response"] == ANSWERS.get(key)


# --- after the day: adaptation ---------------------------------------------------------------------

@dataclass
class DayAdaptation:
    """What :func:`adapt_day` did."""

    participant: str
    day: int
    method: str
    policy_version: int
    duration_s: float
    log: list[str]
    preference_accuracy: float | None
    changes: pd.DataFrame


def adapt_day(db_path: str | Path, participant: str, day: int, method: str = "cacas", seed: int = 0,
              progress: Progress | None = None) -> DayAdaptation:
    """Close ``day`` (if open) and adapt the participant's policy from days 1..day (Table III step 2).

    Runs in a background job with its own database connection. Stores the new policy version (in
    force from the next day) and the adaptation run with its log, parameters, duration and, when
    the participant described preferences, the new policy's preference accuracy (Fig. 4; the
    adaptation itself never reads them). Refuses a day with no interactions.
    """
    from cacas.adaptation import adapt_policy, policy_changes
    from cacas.store import StudyStore

    say = progress or (lambda f, m: None)
    store = StudyStore(db_path)
    try:
        days = {d.day: d for d in store.days(participant)}
        if day not in days:
            raise CacasError(f"participant {participant} has no day {day}")
        if max(days) != day:  # a page drawn before the next day began (save_adapted_policy checks again)
            raise CacasError(f"day {day} of participant {participant} cannot be adapted any more: day {max(days)} "
                             "has begun")
        if day in adapted_days(store, participant):
            raise AlreadyAdapted(f"day {day} of participant {participant} is adapted already (from another tab?)")
        if not len(store.interactions_frame(participant, method=None, day=day)):
            raise CacasError(f"day {day} of participant {participant} has no interactions; nothing to adapt from")
        try:  # read before anything is written: a policy file changed or damaged leaves the day as it was
            before, before_version = policy_in_force(store, participant)
        except CacasError as exc:
            if store.active_policy(participant) is None:  # the initial policy's own message says what to do
                raise
            raise CacasError(f"{exc}; day {day} is adapted from the policy in force: put another version in force "
                             "(Adaptation page, Policy versions), or put the file back from a backup, then adapt again; "
                             "nothing was changed") from None
        say(0.0, f"closing day {day}" if days[day].is_open else f"day {day} is closed")
        store.note_adaptation_started(participant, day, method)
        store.close_day(participant, day)
        data = store.interactions_frame(participant, method=None)  # read once the day is closed: all of it
        data = data[data["day"] <= day]
        recorded = int(records.is_recorded(data).sum())
        say(0.02, f"adapting with {method} from {recorded} recorded interaction{'' if recorded == 1 else 's'} of "
                  f"{'day 1' if day == 1 else f'days 1-{day}'}"
                  + (f" ({len(data) - recorded} more saved, unanswered or asked for while doing nothing, which give no user data)"
                     if recorded < len(data) else ""))
        result = adapt_policy(before, data, method=method, seed=seed,
                              progress=lambda f, m: say(0.02 + 0.9 * f, m))
        prefs, prefs_version = described_now(store, participant)
        metrics = {"interactions": int(len(data)), "policy_before": before_version}
        accuracy = initial = None
        if prefs is not None and prefs.preferences:
            say(0.94, "scoring the new policy on the described preferences (evaluation only)")
            metrics.update(scored_on_preferences(result.policy, prefs, prefs_version))
            accuracy = metrics["preference_accuracy"]
            if before_version is None:  # Fig. 4's day 1: the initial policy (CACAA step 1), recorded once
                initial = scored_on_preferences(before, prefs, prefs_version)
        version = store.save_adapted_policy(participant, day, method, result.policy.to_bytes(),
                                            dict(result.parameters, log=result.log), float(result.duration_s), metrics,
                                            initial_metrics=initial)
        changes = policy_changes(before, result.policy, data)
        say(1.0, f"policy version {version} saved; {in_force_words(day)}")
        return DayAdaptation(participant, day, method, version, float(result.duration_s), list(result.log),
                             accuracy, changes)
    finally:
        store.close()


def in_force_words(day: int) -> str:
    """When the policy adapted after ``day`` acts, in words: from the next day, or, after the study's
    last day (:data:`STUDY_DAYS`), as its final policy (it said "in force from day 8")."""
    if day >= STUDY_DAYS:
        return f"the study's final policy (day {day} was its last day)"
    return f"in force from day {day + 1}"


def unfinished_adaptation(store, participant: str, day: int) -> dict | None:
    """The last adaptation of ``day`` that began (:meth:`StudyStore.note_adaptation_started`) and
    saved nothing, as ``{"at": ..., "method": ...}``, while the day waits for its adaptation; None
    if none began or the day is adapted. The app stopped during it (or it failed, or it still runs
    in another server): the Adaptation page says so beside "Adapt after day N"."""
    if day in adapted_days(store, participant):
        return None
    started = store.events(participant, what="adapt_start")
    for at, details in zip(started["at"][::-1], started["details"][::-1]):
        details = json.loads(details)
        if details.get("day") == day:
            return {"at": at, "method": details.get("method")}
    return None


def described_now(store, participant: str) -> tuple:
    """The participant's latest described preferences and their version, read together (a version
    saved while an adaptation runs is not taken for the one it scores on); (None, None) if none."""
    versions = store.preference_versions(participant)
    if not versions:
        return None, None
    version = versions[-1]["version"]
    return store.get_preferences(participant, version), version


def scored_version(metrics: str | None) -> int | None:
    """The described preferences' version an adaptation run's metrics (its JSON, as
    ``adaptations_frame`` gives it) were scored against; None for a run not scored, or recorded
    before runs named it."""
    version = json.loads(metrics or "{}").get("preferences_version")
    return None if version is None else int(version)


def scored_on_preferences(policy, described, version: int) -> dict:
    """An adaptation run's Fig. 4 metrics (:func:`cacas.adaptation.fig4_metrics`, evaluation only)
    with ``version``, the described preferences' version they were scored against
    (``preferences_version``): preferences edited mid-study leave earlier runs scored on theirs."""
    from cacas.adaptation import EVALUATION_SEED, fig4_metrics

    return dict(fig4_metrics(policy, described, seed=EVALUATION_SEED), preferences_version=version)
