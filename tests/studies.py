"""A small study day for tests (:func:`cough_day`) and small policy files (:func:`policy_bytes`). Import them into
a test module: ``from studies import cough_day, policy_bytes``."""

import zlib
from functools import lru_cache


def cough_day(store, code: str = "P01", answers=(("pain check", "accept"),), hour: float = 8,
              interval_minutes: float = 5) -> int:
    """``code`` added to ``store`` with one described preference (a cough -> a pain check) and day 1 opened, on
    which a cough in the bedroom is answered once per ``answers`` ((robot action, response), ...); the day."""
    store.add_participant(code)
    store.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
    day = store.open_day(code)
    for robot_action, response in answers:
        store.record_interaction(code, day, activity="cough", scene="bedroom", hour=hour,
                                 interval_minutes=interval_minutes, robot_action=robot_action, response=response)
    return day


def answered_day(store, code: str = "P01", interactions: int = 15, interval_minutes: float = 5) -> int:
    """A day of ``code`` (added already) opened, with ``interactions`` coughs in the bedroom answered "accept" to a
    pain check (the day's plan met at 15); the day."""
    day = store.open_day(code)
    for _ in range(interactions):
        store.record_interaction(code, day, activity="cough", scene="bedroom", hour=8,
                                 interval_minutes=interval_minutes, robot_action="pain check", response="accept")
    return day


@lru_cache(maxsize=None)
def policy_bytes(label: str = "a policy") -> bytes:
    """A real policy file, small and quick to write (a contextual bandit's, ~0.2 ms), whose bytes differ with
    ``label``: where a test needs a saved policy but never its decisions. An import loads each policy file it
    brings (made-up bytes are refused), as the tablet will."""
    import numpy as np

    from cacas.policy import BanditPolicy

    policy = BanditPolicy(np.zeros((33, 14), np.int64))
    policy.wins = policy.wins + zlib.crc32(label.encode()) % 997  # a count of its own: bytes of their own
    return policy.to_bytes()
