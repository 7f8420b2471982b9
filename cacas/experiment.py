"""Simulated studies (design.md, the ``cacas simulate`` contract), as tidy tables.

Simulated participants follow their described preferences: each day they act in about
``interactions`` contexts their preferences cover, in time order; the robot acts with the policy
in force as on the tablet (``decide``: Eq. 4; the bandit by a Thompson draw); the participant
accepts the preferred action, rejects another one, sometimes does not respond
(``no_response_rate``), and asks for the preferred action when the robot does nothing (a
user-initiated, type_2 interaction). Optionally (``ask_after_reject``, default 0: design.md's
participant) they answer a share of the wrong proposals by asking for the preferred action
instead, as the tablet's "Or ask the robot yourself" lets people do: a type_2 interaction that
rejects the robot's proposal.

Day 1 uses the initial policy (CACAA step 1). After each day every method adapts from the same
interactions (as in the paper's Fig. 4: the interactions come from the closed loop of the first
method, CACAS by default), so the policy in force on day d has seen days 1..d-1. ``daily`` holds
the closed-loop method's success rate (Fig. 3) and every method's preference accuracy (Fig. 4);
``by_preference`` the same accuracy broken down by described preference (which preferences each
method learnt, and when).

With ``loop="each"`` every method instead runs its own study in closed loop: the robot acts
with that method's policy and the method adapts from the interactions its own actions brought
about, so each has a success rate (Fig. 3 for every method). The simulated participant's random
stream starts the same for every method (common random numbers): day 1, lived with the same
initial policy, is identical for all, and later days differ only through the methods' actions.
The paper's Section IV-C.2 names what this shows: a supervised policy "when it comes to
performing as an agent policy" has only the "accept" data its own proposals earned.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from cacas import parallel, records, spaces
from cacas.adaptation import CACAAConfig, METHODS, accuracy_by_preference, adapt_policy, evaluation_states, \
    load_initial_policy, preference_accuracy
from cacas.d4a import D4A, load_d4a
from cacas.errors import CacasError
from cacas.jobs import Stopped
from cacas.policy import policy_from_bytes
from cacas.preferences import Participant
from cacas.simulator import current_task, preference_states

PAPER_METHODS = records.PAPER_METHODS
#: Who acts in the simulated study: the first method, every method adapting from its interactions
#: (the paper's Fig. 4), or each method in a closed loop of its own.
LOOPS = ("first", "each")
Progress = Callable[[float, str], None]


@dataclass
class StudyResult:
    daily: pd.DataFrame          # records.DAILY_COLUMNS
    interactions: pd.DataFrame   # records.INTERACTION_COLUMNS
    by_preference: pd.DataFrame  # records.BY_PREFERENCE_COLUMNS


#: Bounds of a simulated study (:data:`cacas.records.MAX_DAYS` says why).
MAX_DAYS, MAX_INTERACTIONS, MAX_SEED = records.MAX_DAYS, records.MAX_INTERACTIONS, records.MAX_SEED


#: How :func:`check_study_arguments` names each size: the command line's options.
OPTION_NAMES = {"days": "--days", "interactions": "--interactions", "seed": "--seed",
                "no_response_rate": "--no-response-rate", "ask_after_reject": "--ask-after-reject"}


def study_argument_problems(days: int, interactions: int, no_response_rate: float,
                            ask_after_reject: float = 0.0, seed: int = 0, names: dict | None = None) -> list[str]:
    """Every problem with a study's sizes, in the order of the arguments (empty when all are
    valid). The messages name each size as ``names`` does (default :data:`OPTION_NAMES`, the
    command-line options; the Simulation lab passes its labels)."""
    n = {**OPTION_NAMES, **(names or {})}
    problems = []
    if not 1 <= days <= MAX_DAYS:
        problems.append(f"{n['days']} {days} is invalid; valid: a whole number of days from 1 to {MAX_DAYS}")
    if not 1 <= interactions <= MAX_INTERACTIONS:
        problems.append(f"{n['interactions']} {interactions} is invalid; valid: a whole number from 1 to "
                        f"{MAX_INTERACTIONS} (one a minute)")
    if not 0 <= seed <= MAX_SEED:
        problems.append(f"{n['seed']} {seed} is invalid; valid: a whole number from 0 to {MAX_SEED}")
    if not 0 <= no_response_rate < 1:
        problems.append(f"{n['no_response_rate']} {no_response_rate} is invalid; valid: 0 <= rate < 1")
    if not 0 <= ask_after_reject <= 1:
        problems.append(f"{n['ask_after_reject']} {ask_after_reject} is invalid; valid: 0 <= rate <= 1")
    return problems


def check_study_arguments(days: int, interactions: int, no_response_rate: float,
                          ask_after_reject: float = 0.0, seed: int = 0, names: dict | None = None) -> None:
    """A study's sizes, checked before any work: a CacasError with the first problem of
    :func:`study_argument_problems` (one line, as the command line reports a bad option)."""
    problems = study_argument_problems(days, interactions, no_response_rate, ask_after_reject, seed, names)
    if problems:
        raise CacasError(problems[0])


def check_loop(loop: str) -> str:
    """One of :data:`LOOPS` (any case, spaces trimmed), or a CacasError naming the valid ones."""
    loop = str(loop).strip().lower()
    if loop not in LOOPS:
        raise CacasError(f"--loop {loop!r} is invalid; valid: first (every method adapts from the first "
                         "method's interactions, as the paper's Fig. 4) or each (every method in its own closed loop)")
    return loop


def check_methods(methods: Sequence[str]) -> tuple[str, ...]:
    methods = tuple(m.strip().lower() for m in methods if m.strip())
    bad = [m for m in methods if m not in METHODS]
    if bad or not methods:
        raise CacasError(f"unknown method {bad[0]!r}; valid: {', '.join(METHODS)}" if bad
                         else f"no method given; valid: {', '.join(METHODS)}")
    twice = next((m for i, m in enumerate(methods) if m in methods[:i]), None)
    if twice is not None:  # a typo for another method, more likely than a wish to run one twice
        raise CacasError(f"method {twice!r} is listed twice; valid: each of {', '.join(METHODS)} at most once")
    return methods


def simulated_day(policy, participant: Participant, day: int, n_interactions: int,
                  rng: np.random.Generator, no_response_rate: float, method: str,
                  ask_after_reject: float = 0.0, d4a: D4A | None = None) -> list[dict]:
    """One simulated study day of ``participant`` with the robot acting by ``policy``. With
    ``ask_after_reject`` > 0, that share of the proposals the participant would reject become
    requests for the preferred action instead (never for "do nothing", which is not a request);
    at 0 the random stream is the same as without the option. Where no preference covers the
    state (one that names robot tasks, S5, while the robot is busy with another), the
    participant answers as ``generate_response`` does: by the D4A pairs (``d4a``, the shipped
    file by default), and asks for nothing."""
    d4a = d4a or load_d4a()
    n = max(1, int(rng.poisson(n_interactions)))
    ctx = preference_states(participant, n, rng)
    minute = ctx[:, 2] * 120 + rng.integers(0, 120, n)
    order = np.argsort(minute, kind="stable")
    ctx, minute = ctx[order], minute[order]
    table = participant.preferred_action_table()
    rows = []
    prev_action, prev_response = spaces.DO_NOTHING_ACTION, spaces.OTHERS
    for i in range(n):
        act, scene, slot, interval = (int(v) for v in ctx[i, :4])
        # S5 is the robot's, from the day so far: the action accepted at the previous interaction,
        # while in progress by the day's clock (S4 is the time since the previous *activity*)
        since = minute[i] - minute[i - 1] if i else np.inf
        task = int(current_task(np.array([prev_action]), np.array([prev_response]), np.array([since]))[0])
        state = np.array([[act, scene, slot, interval, task, prev_action, prev_response]])
        robot = policy.decide(state[0])[0]  # as on the tablet: Eq. 4, or the bandit's Thompson draw
        preferred = int(table[act, scene, slot, interval, task])
        silent = rng.random() < no_response_rate
        user_action = ""
        if robot == spaces.DO_NOTHING_ACTION:
            if preferred not in (-1, spaces.DO_NOTHING_ACTION) and not silent:
                tp, response, user_action = records.USER_INITIATED, "accept", spaces.ACTIONS[preferred]
            else:
                tp, response = records.ROBOT_INITIATED, "others"
        else:
            tp = records.ROBOT_INITIATED
            if silent:
                response = "others"
            elif preferred == -1:  # preference first, D4A second
                response = spaces.RESPONSES[d4a.response(act, robot)]
            else:
                response = "accept" if robot == preferred else "reject"
            if response == "reject" and ask_after_reject > 0 and preferred not in (-1, spaces.DO_NOTHING_ACTION) \
                    and rng.random() < ask_after_reject:
                tp, response, user_action = records.USER_INITIATED, "accept", spaces.ACTIONS[preferred]
        rows.append({  # index: numbered from 1 in its day, as on the tablet and in `cacas export`
            "participant": participant.id, "method": method, "day": day, "index": i + 1,
            "time": f"{minute[i] // 60:02d}:{minute[i] % 60:02d}", "activity": spaces.ACTIVITIES[act],
            "scene": spaces.SCENES[scene], "time_slot": slot, "interval": spaces.INTERVAL_BINS[interval],
            "task": spaces.ACTIONS[task], "previous_action": spaces.ACTIONS[prev_action],
            "previous_response": spaces.RESPONSES[prev_response], "type": tp,
            "robot_action": spaces.ACTIONS[robot], "response": response, "user_action": user_action,
        })
        if tp == records.USER_INITIATED:  # the robot carries out the confirmed request
            prev_action, prev_response = preferred, spaces.ACCEPT
        else:
            prev_action, prev_response = robot, spaces.response_index(response)
    return rows


#: The work of a simulated study's last day (lived and scored, never adapted from) beside an
#: adaptation's: about nothing. Counted as a whole day, it made a 3-day run's bar jump by a third at
#: each participant's end, and the time left read twice the time the run took (walkthrough).
LAST_DAY_WORK = 0.05


def work_done(days_done: float, days: int) -> float:
    """A participant's simulated work done, in days adapted from (:func:`simulate_study`'s
    progress): ``days_done`` (a fraction while a day's methods adapt) up to ``days - 1``, then the
    last day at :data:`LAST_DAY_WORK`."""
    adapted = min(days_done, days - 1)
    return adapted + max(0.0, days_done - adapted) * LAST_DAY_WORK


def simulate_study(participants: Sequence[Participant], days: int = 7, interactions: int = 15,
                   methods: Sequence[str] = PAPER_METHODS, seed: int = 0, no_response_rate: float = 0.1,
                   progress: Progress | None = None, config: CACAAConfig | None = None,
                   d4a: D4A | None = None, initial_policy=None, eval_states: int = 400,
                   jobs: int | None = None, ask_after_reject: float = 0.0, loop: str = "first",
                   places: Sequence[int] | None = None) -> StudyResult:
    """Run a whole simulated study; the same seed gives the same tables whatever ``jobs``, the
    number of worker processes (default 1; more need the caller's script to guard its entry
    point with ``if __name__ == "__main__":``, which the workers' fork server imports). ``loop``: see
    :data:`LOOPS` and the module's docstring.

    ``places``: each participant's place in the persona file they come from (default 0, 1, 2, ...
    in the order given). A participant's random streams depend on (seed, place) only, so a run
    of some of a file's participants, given their places, gives each of them the rows the whole
    file's run gives them."""
    check_study_arguments(days, interactions, no_response_rate, ask_after_reject, seed)
    places = list(range(len(participants))) if places is None else [int(i) for i in places]
    if len(places) != len(participants) or len(set(places)) != len(places) or min(places, default=0) < 0:
        raise CacasError(f"places {places} are invalid for {len(participants)} participants; valid: one distinct "
                         "whole number >= 0 for each participant (their places in the persona file)")
    methods = check_methods(methods)
    loop = check_loop(loop)
    d4a = d4a or load_d4a()
    # CACAA step 1 is trained against the D4A pairs: a table of the researcher's own, or a config
    # that trains step 1 otherwise, gets its own initial policy (trained once, kept beside the shipped one)
    # "initial policy for mine.csv: round 3/30 ...": the training's own "initial policy: " said once (walk3b)
    initial = initial_policy or load_initial_policy(
        d4a=d4a, config=config, progress=(lambda f, m: progress(
            0.0, f"initial policy for {d4a.source or 'this D4A table'}: {m.removeprefix('initial policy: ')}"))
        if progress else None)
    jobs = max(1, min(jobs or 1, len(participants)))
    args = [(person, p_i, days, interactions, methods, seed, no_response_rate, config, d4a, eval_states,
             ask_after_reject, loop) for p_i, person in zip(places, participants)]
    total = len(participants) * work_done(days, days)
    where = dict.fromkeys(places, 0.0)  # each participant's work done (in adapted days), by place

    def tick(p_i: int, days_done: float, message: str) -> None:
        where[p_i] = work_done(days_done, days)
        if progress:
            progress(min(sum(where.values()) / total, 1.0), message)

    if progress:  # then a report per method adapted and per participant-day
        who = f"{len(participants)} participant{'s' if len(participants) != 1 else ''}"
        progress(0.0, f"simulating {who} from day 1 "
                      f"({len(methods)} method{'s' if len(methods) != 1 else ''}"
                      f"{', each in its own closed loop' if loop == 'each' and len(methods) > 1 else ''}, "
                      f"{jobs} worker process{'es' if jobs != 1 else ''})")
    if jobs == 1:
        results = [simulate_participant(initial, *a, report=tick) for a in args]
    else:
        results = parallel.run_parallel(_worker, initial.to_bytes(), args, jobs, tick,
                                        what="participants' studies")
    inter = pd.DataFrame([r for rows, _, _ in results for r in rows], columns=records.INTERACTION_COLUMNS)
    accuracy = pd.DataFrame([r for _, acc, _ in results for r in acc])
    by_preference = pd.concat([b for _, _, b in results], ignore_index=True)
    preferred = {p.id: p.preferred_action_table() for p in participants}
    return StudyResult(combine_daily(inter, accuracy, methods, preferred, loop), inter, by_preference)


default_jobs = parallel.default_jobs


def participant_test_states(person: Participant, p_i: int, seed: int, n: int) -> np.ndarray:
    """Fig. 4's test states of the participant at place ``p_i`` (seeded by study and place)."""
    return evaluation_states(person, n, seed=seed * 7919 + p_i)


#: adaptation_seed's arithmetic form is collision-free below these (and kept there, so results
#: published with it stay reproducible): days 1..13 adapted after (a study of up to 14 days)
#: and 990 participants.
_ARITHMETIC_DAYS, _ARITHMETIC_PARTICIPANTS = 13, 990


def adaptation_seed(seed: int, p_i: int, day: int, method: str) -> int:
    """The seed of ``method``'s adaptation after ``day`` for the participant at place ``p_i``.

    Up to day 13 and participant 990: seed * 100003 + p_i * 101 + day * 7 + the method's index
    (distinct there). Beyond, where that formula would give two adaptations the same random
    stream, numpy's SeedSequence hashes (seed, participant, day, method) to 63 bits. The method
    enters by its name, not its place in the list, so a method's results do not depend on which
    other methods run beside it (given the same closed-loop method)."""
    k = METHODS.index(method)
    if day <= _ARITHMETIC_DAYS and p_i < _ARITHMETIC_PARTICIPANTS:
        return seed * 100_003 + p_i * 101 + day * 7 + k
    return int(np.random.SeedSequence([seed, p_i, day, k]).generate_state(1, np.uint64)[0] >> 1)


def policies_in_force(initial, person: Participant, p_i: int, days: int, interactions: int,
                      methods: tuple[str, ...], seed: int, no_response_rate: float,
                      config: CACAAConfig | None, d4a: D4A, ask_after_reject: float = 0.0, loop: str = "first",
                      progress: Progress | None = None):
    """One participant's simulated study, day by day: yields (day, {method: policy in force that
    day}, {closed-loop method: its interaction rows so far}) before the day's interactions are
    added to those same lists, so once the generator is exhausted they hold every day's rows.
    ``progress(f, message)``: f, the share of the day's adaptations done (every method's, in turn),
    reported as the methods' SAC training goes (a stop request can act within an adaptation).
    With ``loop="first"`` the first method acts in closed loop and after each day every method
    adapts from all its interactions so far; with ``loop="each"`` every method acts and adapts
    from its own. Random streams depend on (seed, participant index) only, and every closed loop
    starts from the same stream."""
    actors = methods[:1] if loop == "first" else methods
    rngs = {m: np.random.default_rng([seed, p_i]) for m in actors}
    in_force = {m: initial for m in methods}
    rows: dict[str, list[dict]] = {m: [] for m in actors}
    for day in range(1, days + 1):
        yield day, in_force, rows
        for m in actors:
            rows[m] += simulated_day(in_force[m], person, day, interactions, rngs[m], no_response_rate, m,
                                     ask_after_reject, d4a)
        if day < days:
            data = {m: pd.DataFrame(rows[m], columns=records.INTERACTION_COLUMNS) for m in actors}
            adapted = {}
            for k, m in enumerate(methods):
                say = None if progress is None else (
                    lambda f, _, k=k, m=m: progress((k + f) / len(methods), f"adapting {m} after day {day} of {days}"))
                adapted[m] = adapt_policy(in_force[m], data[m if m in data else actors[0]], m,
                                          seed=adaptation_seed(seed, p_i, day, m), config=config, d4a=d4a,
                                          progress=say).policy
            in_force = adapted


def simulate_participant(initial, person: Participant, p_i: int, days: int, interactions: int,
                         methods: tuple[str, ...], seed: int, no_response_rate: float,
                         config: CACAAConfig | None, d4a: D4A, eval_states: int,
                         ask_after_reject: float = 0.0, loop: str = "first",
                         report: Callable[[int, float, str], None] | None = None
                         ) -> tuple[list[dict], list[dict], pd.DataFrame]:
    """One participant's simulated study: (interaction rows, preference-accuracy rows, the
    accuracy by preference: records.BY_PREFERENCE_COLUMNS). Its random streams depend on (seed,
    the participant's place ``p_i``) only, so the result is the same whether participants run one after
    another or in parallel. ``report(p_i, days_done, message)`` follows it: days_done grows by a
    fraction as each method adapts, and is a whole number once a day is lived and adapted from."""
    test_states = participant_test_states(person, p_i, seed, eval_states)
    acc_rows: list[dict] = []
    by_preference: list[pd.DataFrame] = []
    rows: dict[str, list[dict]] = {}
    current = [1]  # the day being lived or adapted from
    adapting = None if report is None else (
        lambda f, msg: report(p_i, current[0] - 1 + f, f"participant {person.id}: {msg}"))
    for day, in_force, rows in policies_in_force(initial, person, p_i, days, interactions, methods, seed,
                                                 no_response_rate, config, d4a, ask_after_reject, loop,
                                                 progress=adapting):
        current[0] = day
        if day > 1 and report:  # the previous day was lived and adapted from
            report(p_i, day - 1, f"participant {person.id}: day {day - 1} of {days} done")
        for m in methods:
            acc_rows.append({"participant": person.id, "method": m, "day": day,
                             "preference_accuracy": preference_accuracy(in_force[m], person, states=test_states)})
            by_preference.append(accuracy_by_preference(in_force[m], person, test_states)
                                 .assign(participant=person.id, method=m, day=day))
    if report:
        report(p_i, days, f"participant {person.id}: day {days} of {days} done")
    return ([r for m in rows for r in rows[m]], acc_rows,
            pd.concat(by_preference, ignore_index=True)[records.BY_PREFERENCE_COLUMNS])


def _worker(initial_bytes: bytes, args: tuple, queue, stop) -> tuple[list[dict], list[dict], pd.DataFrame]:
    """One participant's simulated study in a worker process (:func:`cacas.parallel.run_parallel`)."""
    import torch

    torch.set_num_threads(1)
    report = parallel.reporter(queue, stop)
    if stop.is_set():  # a participant queued before a stop never starts
        raise Stopped("stopped on request")
    return simulate_participant(policy_from_bytes(initial_bytes), *args, report=report)


def combine_daily(interactions: pd.DataFrame, accuracy: pd.DataFrame, methods: Sequence[str],
                  preferred: dict[str, np.ndarray] | None = None, loop: str = "first") -> pd.DataFrame:
    """daily.csv rows for every method (:func:`cacas.records.daily_table`): the closed-loop
    method (the first) has its own success rate (and, given the participants' ``preferred``
    action tables, its success ceiling); the others adapted from the same interactions, so they
    share its interaction and feedback counts and have an empty success rate. With
    ``loop="each"`` every method's rows come from its own interactions, counts and cumulative
    feedback included (each is a study of its own). Methods in the order given."""
    if loop == "each":
        daily = pd.concat([records.daily_table(interactions[interactions["method"] == m],
                                               accuracy[accuracy["method"] == m], preferred) for m in methods],
                          ignore_index=True)
    else:
        daily = records.daily_table(interactions, accuracy, preferred)
    order = {m: i for i, m in enumerate(methods)}
    daily = daily.sort_values(["participant", "method", "day"], key=lambda c: c.map(order) if c.name == "method" else c)
    return daily.reset_index(drop=True)


def summary_table(daily: pd.DataFrame) -> pd.DataFrame:
    """Mean success rate (and its ceiling, where daily has one) and preference accuracy per
    method and day (the printed table)."""
    g = daily.groupby(["method", "day"], sort=False)
    means = dict(success_rate=("success_rate", "mean"))
    if "success_ceiling" in daily.columns:
        means["success_ceiling"] = ("success_ceiling", "mean")
    out = g.agg(**means, preference_accuracy=("preference_accuracy", "mean"),
                cumulative_feedback=("cumulative_feedback", "mean")).reset_index()
    return out
