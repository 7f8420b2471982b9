"""A large human study's database for the page benchmarks (``scripts/bench_pages.py``).

    python3 scripts/bench_pages_db.py DB [--participants 24] [--days 7] [--interactions 15]

PARTICIPANTS x DAYS closed and CACAS-adapted study days of INTERACTIONS interactions each (about
10 % unanswered, 10 % requests, the policy's 14 probabilities and the recognisers' guesses as the
tablet records them), the example personas' described preferences (cycled), a policy version per
day (the shipped initial policy's bytes, ~640 KB: the Adaptation page loads two versions), Fig. 4
metrics scored by ``fig4_metrics`` (once per persona, then jittered), the three baselines' runs of a
method comparison (cacas-no-pr, orl, nn) for every day, and a questionnaire answer from everyone.
No training: it takes about a minute.

Written so, every record is a few milliseconds after the one before: the whole study on one afternoon,
participant after participant. ``--calendar`` writes it as a study runs instead, on a clock of its own
(as ``cacas.store.validate.now``): day d of everyone on the d-th calendar day from 9:00 (a participant's
interactions 30 s apart in an 8-minute slot of their own, their adaptation in the evening, the questionnaire
after their last day), then, the morning after, the method comparison of every participant-day at once, as
"Compare methods" records it (its runs 2 s apart: one line of the Overview's recent activity). For what reads the study by time (the Overview's
recent activity, "last recorded").

    python3 scripts/bench_pages_db.py DB --participants 60 --days 21 --calendar   # the scale walk's study
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one
from cacas import spaces  # noqa: E402
from cacas.store import StudyStore  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


class _Clock:
    """The study's time for ``--calendar``, as ``cacas.store.validate.now`` while the study is written: set with
    :meth:`at`, a millisecond on at each record (records one after another sort in that order, as ``now``'s)."""

    def __init__(self, start):
        from datetime import timedelta

        self.t, self.ms = start, timedelta(milliseconds=1)

    def at(self, t) -> None:
        self.t = t

    def now(self) -> str:
        from cacas.store import validate

        self.t += self.ms
        return validate._utc_text(self.t)


def build(path: Path, participants: int = 24, days: int = 7, interactions: int = 15, seed: int = 0,
          calendar: bool = False) -> StudyStore:
    from datetime import datetime, timedelta, timezone

    from cacas.adaptation import load_initial_policy
    from cacas.store import validate
    from cacas.study_day import described_now, scored_on_preferences

    rng = np.random.default_rng(seed)
    personas = json.loads((ROOT / "study_data/personas/example.json").read_text())["participants"]
    policy_bytes = (ROOT / "study_data/models/initial_policy.pt").read_bytes()
    initial = load_initial_policy()
    first_day = datetime.now(timezone.utc).replace(hour=9, minute=0, second=0, microsecond=0) - timedelta(days=days + 1)
    clock = _Clock(first_day - timedelta(days=1))
    real_now = validate.now
    if calendar:
        validate.now = clock.now
    try:
        store = StudyStore(path)
        scored: dict[int, dict] = {}
        codes = [f"P{p:03d}" for p in range(participants)]
        for p, code in enumerate(codes):
            store.add_participant(code, age_range="65+")
            store.save_preferences(code, personas[p % len(personas)]["preferences"])
            prefs, pv = described_now(store, code)
            if p % len(personas) not in scored:
                scored[p % len(personas)] = scored_on_preferences(initial, prefs, pv)
            for method in ("cacas", "cacas-no-pr", "orl", "nn"):
                store.record_adaptation(code, 0, method, {"initial": True}, 0.0, scored[p % len(personas)])

        def jitter(m: dict) -> dict:
            out = dict(m, preference_accuracy=float(min(1.0, m["preference_accuracy"] + rng.random() * 0.5)))
            out["by_preference"] = [dict(r, correct=int(rng.integers(r["states"] + 1))) for r in m["by_preference"]]
            return out

        version: dict[str, int | None] = dict.fromkeys(codes)

        def study_day(p: int, code: str) -> int:
            day = store.open_day(code)
            prev_action, prev_resp = "do nothing", "others"
            for i in range(interactions):
                probs = rng.dirichlet(np.ones(spaces.N_ACTIONS) * 0.3)
                action = spaces.ACTIONS[int(probs.argmax())]
                act = spaces.ACTIVITIES[int(rng.integers(spaces.N_ACTIVITIES))]
                scene = spaces.SCENES[int(rng.integers(spaces.N_SCENES))]
                u = rng.random()
                kw = dict(activity=act, scene=scene, hour=float(7 + i % 15) + rng.random(),
                          interval_minutes=float(rng.integers(1, 240)), task="do nothing",
                          previous_action=prev_action, previous_response=prev_resp, robot_action=action,
                          probabilities=probs, recognised_activity=act, recognised_scene=scene,
                          policy_version=version[code])
                if calendar:  # a participant's day in a slot of its own, an interaction every 30 s
                    clock.at(first_day + timedelta(days=day - 1, minutes=8 * p, seconds=30 * i))
                if u < 0.1:
                    resp = "others"
                    store.record_interaction(code, day, response=resp, **kw)
                elif u < 0.2:
                    resp = "accept"
                    # a request for another action than the robot's proposal (an import refuses the proposal)
                    others = [a for a in spaces.ACTIONS[1:] if a != action]
                    want = others[int(rng.integers(len(others)))]
                    store.record_interaction(code, day, type="type_2", response=resp, user_action=want, **kw)
                else:
                    resp = "accept" if rng.random() < 0.4 + 0.08 * day else "reject"
                    store.record_interaction(code, day, response=resp, **kw)
                prev_action, prev_resp = action, resp
            return day

        def evening(p: int, code: str, day: int) -> None:
            base = scored[p % len(personas)]
            if calendar:
                clock.at(first_day + timedelta(days=day - 1, hours=10, minutes=p))  # the evening's adaptations
            store.close_day(code, day)
            metrics = dict(jitter(base), interactions=interactions * day, policy_before=version[code])
            version[code] = store.save_adapted_policy(code, day, "cacas", policy_bytes,
                                                      {"log": ["bench"], "seed": 0}, 1.3 + rng.random(), metrics)
            if not calendar:
                comparison(p, code, day)
            elif day == days:  # the questionnaire after the last day, before the comparison
                questionnaire(p, code)

        def questionnaire(p: int, code: str) -> None:
            store.record_questionnaire(code, int(rng.integers(6, 11)), "fine" if p % 3 else "")

        def comparison(p: int, code: str, day: int) -> None:
            for method in ("cacas-no-pr", "orl", "nn"):
                store.record_adaptation(code, day, method, {"comparison": True, "seed": 0}, 1.0 + rng.random(),
                                        jitter(scored[p % len(personas)]))

        if calendar:
            for day in range(1, days + 1):
                for p, code in enumerate(codes):  # side by side: each in a slot of their own
                    study_day(p, code)
                for p, code in enumerate(codes):
                    evening(p, code, day)
            clock.at(first_day + timedelta(days=days))  # "Compare methods" the morning after the study, 9:00:
            for day in range(1, days + 1):  # every participant-day at once, a run every 2 s
                for p, code in enumerate(codes):
                    clock.at(clock.t + timedelta(seconds=2))
                    comparison(p, code, day)
        else:
            for p, code in enumerate(codes):
                for _ in range(days):
                    evening(p, code, study_day(p, code))
                questionnaire(p, code)
    finally:
        validate.now = real_now
    return store


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("db")
    ap.add_argument("--participants", type=int, default=24)
    ap.add_argument("--days", type=int, default=7)
    ap.add_argument("--interactions", type=int, default=15)
    ap.add_argument("--calendar", action="store_true",
                    help="each study day on a calendar day of its own, the method comparison after the last")
    args = ap.parse_args()
    if Path(args.db).exists():
        sys.exit(f"{args.db} exists")
    s = build(Path(args.db), args.participants, args.days, args.interactions, calendar=args.calendar)
    from cacas.export import export_tables
    t = export_tables(s)
    print({k: len(v) for k, v in t.items()})
    s.close()


if __name__ == "__main__":
    main()
