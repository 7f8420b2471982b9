"""cacas.parallel: pieces of work in worker processes, reports through a queue, stop at the next report."""

import time

import pytest

from cacas import parallel
from cacas.jobs import Stopped


def _report_until_stopped(shared: bytes, piece: int, queue, stop) -> int:
    """A piece that reports forever (piece 0 fails at once when ``shared`` says so)."""
    report = parallel.reporter(queue, stop)
    if shared == b"fail" and piece == 0:
        raise ValueError("piece 0 failed")
    for n in range(100_000):
        report("made", piece, n)
        time.sleep(0.01)
    return piece


def _make_three(shared: bytes, piece: int, queue, stop) -> int:
    report = parallel.reporter(queue, stop)
    for n in range(3):
        report("made", piece, n)
    return piece


def test_every_item_reaches_tick_and_the_results_come_in_order():
    seen = []
    assert parallel.run_parallel(_make_three, b"", [0, 1, 2], 2, lambda *item: seen.append(item)) == [0, 1, 2]
    assert sorted(seen) == [("made", p, n) for p in range(3) for n in range(3)]


def test_a_failing_piece_stops_the_others_at_once():
    """Review: the other workers ran to their end before the failure was said."""
    t = time.perf_counter()
    with pytest.raises(ValueError, match="piece 0 failed") as failed:
        parallel.run_parallel(_report_until_stopped, b"fail", [0, 1], 2, lambda *item: None)
    assert time.perf_counter() - t < 60  # piece 1 alone reports for 1000 s
    assert failed.value.__notes__ == ["1 of 2 pieces of work ended early in their worker process, 0 never started"]


def test_what_was_made_before_a_stop_is_kept():
    """Review: items the workers had queued when the main process stopped were dropped; ``keep`` has them."""
    ticked, kept = [], []

    def tick(*item):
        ticked.append(item)
        if len(ticked) == 5:
            time.sleep(0.5)  # meanwhile the workers, reporting every 10 ms, queue more
            raise Stopped("stopped on request")
    with pytest.raises(Stopped):
        parallel.run_parallel(_report_until_stopped, b"", [0, 1], 2, tick, keep=lambda *item: kept.append(item))
    assert len(ticked) == 5 and kept and not set(ticked) & set(kept)  # each item once, to tick or to keep
