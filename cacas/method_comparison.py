"""Fig. 4 on a human study: every method adapted from the same days (paper, Section V-B.1).

"We did not redo the experiment using the 3 comparison methods since it will take a long time.
Therefore, we used the interaction data each day to adapt those models and tested them by
generating data using the described preferences." :func:`compare_methods` does that for a study
database: for each participant with described preferences, each method's chain of policies
adapted after each closed day (from the initial policy), scored on the described preferences
(:func:`cacas.study_day.scored_on_preferences`) and recorded as adaptation runs of that method,
so the exported daily.csv and by_preference.csv have every method's. Participants run side by
side in worker processes (:mod:`cacas.parallel`); the main process, the database's one writer,
records each run as it comes.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import pandas as pd

from cacas.study_day import Progress, day_status, described_now, scored_on_preferences, scored_version


@dataclass(frozen=True)
class ComparisonPiece:
    """One participant's share of :func:`compare_methods`: their interactions, the described
    preferences (and version) each day's runs are scored on (``scoring``: day -> (preferences,
    version)), the (method, day) runs they have, and each method's closed days to adapt through.
    Picklable: it goes to a worker process as it is."""

    code: str
    scoring: dict
    have: frozenset
    chains: dict
    data: pd.DataFrame
    seed: int

    @property
    def units(self) -> int:
        """Progress units: one for each method's initial policy, one per adaptation."""
        return sum(1 + len(days) for days in self.chains.values())


@dataclass(frozen=True)
class Compared:
    """What :func:`compare_methods` recorded: ``adapted``, policies adapted after a study day and
    scored (Fig. 4's day d+1), and ``initial``, scores of the initial policy (day 0: Fig. 4's day 1),
    one per method and participant. "15 runs recorded" said neither (walkthrough)."""

    adapted: int = 0
    initial: int = 0
    #: the participants with described preferences and a closed day (what there was to compare; None: not
    #: counted): 0 said "no new run; each method has one for every closed day" of a study with no closed day
    participants: int | None = None

    @property
    def runs(self) -> int:
        return self.adapted + self.initial

    def words(self) -> str:
        """"9 adaptations after study days and 6 scores of the initial policy (day 0)"; "" for none."""
        def counted(n: int, word: str) -> str:
            return f"{n:,} {word}{'' if n == 1 else 's'}"

        said = ([counted(self.adapted, "adaptation") + " after study days"] if self.adapted else []) \
            + ([counted(self.initial, "score") + " of the initial policy (day 0)"] if self.initial else [])
        return " and ".join(said)


def compare_participant(initial, piece: ComparisonPiece, report: Callable, record: Callable) -> None:
    """The comparison runs of one participant: for each method, the initial policy scored (day 0)
    and its chain adapted day by day (seeded ``seed + day``), every run not yet recorded handed to
    ``record(code, day, method, parameters, duration_s, metrics)``; ``report(units_done, message)``
    as it goes (within an adaptation too, so a stop acts there)."""
    from cacas.adaptation import adapt_policy

    done = 0
    for method, days in piece.chains.items():
        policy = initial
        if (method, 0) not in piece.have:
            record(piece.code, 0, method, {"initial": True}, 0.0, scored_on_preferences(initial, *piece.scoring[0]))
        done += 1
        for day in days:
            what = f"{piece.code}: {method} after day {day}"
            report(done, what)
            result = adapt_policy(policy, piece.data[piece.data["day"] <= day], method=method, seed=piece.seed + day,
                                  progress=lambda f, _, at=done, what=what: report(at + f, what))
            policy = result.policy
            if (method, day) not in piece.have:
                record(piece.code, day, method, dict(result.parameters, comparison=True), float(result.duration_s),
                       scored_on_preferences(policy, *piece.scoring[day]))
            done += 1


def _comparison_worker(initial_bytes: bytes, piece: ComparisonPiece, queue, stop) -> None:
    """:func:`compare_participant` in a worker process: progress and runs go to the main
    process, which records them (one writer: the study database's own process)."""
    import torch

    from cacas import parallel
    from cacas.jobs import Stopped
    from cacas.policy import policy_from_bytes

    torch.set_num_threads(1)
    report = parallel.reporter(queue, stop)
    if stop.is_set():
        raise Stopped("stopped on request")
    compare_participant(policy_from_bytes(initial_bytes), piece,
                        lambda units, message: report("progress", piece.code, units, message),
                        lambda *run: report("run", *run))


def scoring_versions(store, code: str, runs: pd.DataFrame, days: list[int], latest: tuple) -> dict:
    """Per day, the described preferences (and version) its comparison runs are scored on: the
    version the day's first recorded run was scored on (normally the study's own adaptation), so
    that every method's run of a day is scored on the same preferences, those of the day's time
    (a baseline's run made after the preferences were edited was scored on the new version while
    the study's own run of the same day kept the old one: on day 1, the same initial policy got two
    accuracies); ``latest`` ((preferences, version) now) for a day no run has yet."""
    first: dict[int, int] = {}
    for day, metrics in zip(runs["day"].astype(int), runs["metrics"]):  # in the order recorded
        version = scored_version(metrics)
        if version is not None:
            first.setdefault(day, version)
    described = {latest[1]: latest[0]}
    scoring = {}
    for day in days:
        version = first.get(day, latest[1])
        if version not in described:
            described[version] = store.get_preferences(code, version)
        scoring[day] = (described[version], version)
    return scoring


def compare_methods(db_path: str | Path, methods: tuple[str, ...] | None = None,
                    study: str | None = None, seed: int = 0, progress: Progress | None = None,
                    jobs: int = 1) -> Compared:
    """Fig. 4 on the human study (Section V-B.1): "we used the interaction data each day to adapt
    those models and tested them by generating data using the described preferences".

    For every participant with described preferences and every closed day d, each method (default:
    the paper's four, ``experiment.PAPER_METHODS``) adapts from days 1..d (its own chain, starting
    from the initial policy) and the result is scored with ``fig4_metrics``; runs are recorded as
    adaptations of that method (day 0: the initial policy), so the exported daily.csv and
    by_preference.csv have each method's. Runs already recorded are kept: the method the study
    adapted with (CACAS, or another a researcher chose) has its days already, and a method is
    adapted only as far as its last day without a run. Returns the runs recorded (:class:`Compared`).
    Participants run side by side in ``jobs`` worker processes (the Results page: one per core;
    the runs are the same whatever ``jobs``, and each is recorded as soon as it is made, so a
    stopped comparison keeps them).
    """
    from cacas.adaptation import load_initial_policy
    from cacas.experiment import PAPER_METHODS
    from cacas.store import StudyStore

    methods = PAPER_METHODS if methods is None else methods
    say = progress or (lambda f, m: None)
    store = StudyStore(db_path)
    try:
        initial = load_initial_policy()
        pieces, eligible = [], 0
        # the exact code's order, as before participants were listed case-blind: the runs are recorded
        # (and adaptations.csv numbered) in the order they always were
        for p in sorted(store.list_participants(study), key=lambda p: p.code):
            person, version = described_now(store, p.code)
            closed = [d.day for d in store.days(p.code) if not d.is_open]
            if person is None or not closed:
                continue
            eligible += 1
            runs = store.adaptations_frame(p.code)
            have = set(zip(runs["method"], runs["day"].astype(int)))
            # a closed day waiting for its adaptation is the study's own method's to adapt (and put in
            # force): a comparison run of that method there would stand in for it on Results
            saved = store.policy_versions(p.code)
            own = saved[-1].method if saved else "cacas"
            waiting = closed[-1] if day_status(store, p.code).waiting_for_adaptation else None
            chains = {}
            for method in methods:
                missing = [d for d in [0] + closed if (method, d) not in have
                           and not (method == own and d == waiting)]
                if missing:
                    chains[method] = [d for d in closed if d <= max(missing)]
            if chains:
                scoring = scoring_versions(store, p.code, runs, [0] + closed, (person, version))
                pieces.append(ComparisonPiece(p.code, scoring, frozenset(have), chains,
                                              store.interactions_frame(p.code, method=None), seed))
        total = max(1, sum(piece.units for piece in pieces))
        recorded = {"adapted": 0, "initial": 0}

        def record(code, day, method, parameters, duration_s, metrics) -> None:
            store.record_adaptation(code, day, method, parameters, duration_s, metrics)
            recorded["initial" if int(day) == 0 else "adapted"] += 1

        jobs = max(1, min(jobs, len(pieces)))
        if jobs == 1:
            before = 0
            for piece in pieces:
                compare_participant(initial, piece, lambda units, m, at=before: say((at + units) / total, m), record)
                before += piece.units
        else:
            from cacas import parallel

            done = {piece.code: 0.0 for piece in pieces}

            def tick(kind, *item) -> None:
                if kind == "run":
                    record(*item)
                    return
                code, units, message = item
                done[code] = units
                say(sum(done.values()) / total, message)
            say(0.0, f"{len(pieces)} participants side by side in {jobs} worker processes")
            parallel.run_parallel(_comparison_worker, initial.to_bytes(), pieces, jobs, tick,
                                  what="participants' comparisons",
                                  keep=lambda kind, *item: record(*item) if kind == "run" else None)
        done = Compared(**recorded, participants=eligible)
        say(1.0, f"Recorded {done.words()}." if done.runs else "No new run recorded.")
        return done
    finally:
        store.close()
