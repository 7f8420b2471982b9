import io

import pytest

from cacas.cli.progress import ProgressBar


class Tty(io.StringIO):
    def isatty(self):
        return True


def test_draws_in_place_on_a_terminal_and_ends_the_line():
    out = Tty()
    bar = ProgressBar("simulate", stream=out)
    bar(0.5, "participant P01")
    bar(1.0, "done")
    text = out.getvalue()
    assert text.count("\r") == 2 and text.endswith("\n") and "50%" in text and "100%" in text
    assert "simulate [###" in text and "participant P01" in text


def test_silent_on_a_pipe_for_short_work_or_when_quiet():
    pipe = io.StringIO()
    bar = ProgressBar(stream=pipe)
    bar(0.3, "x")
    bar(1.0, "done")
    bar.done()
    quiet = Tty()
    bar = ProgressBar(quiet=True, stream=quiet)
    bar(0.3, "x")
    bar.done()
    assert pipe.getvalue() == "" and quiet.getvalue() == ""


class Clock:
    """time.perf_counter as the progress module reads it, moved by hand."""

    def __init__(self):
        self.now = 1000.0

    def __call__(self):
        return self.now


def test_off_a_terminal_long_work_writes_a_plain_line_a_tenth_at_most_every_10_s(monkeypatch):
    """Left alone since the CLI audit: `cacas simulate ... 2> log` (or a batch job's output) printed nothing
    for the whole 10-minute run, the bar being drawn on a terminal only. Off a terminal a plain line (no
    carriage return, no bar) is written when a tenth is crossed and 10 s have passed since the last one,
    and the 100 % line once a line was written; quiet writes nothing."""
    import cacas.cli.progress as progress

    clock = Clock()
    monkeypatch.setattr(progress.time, "perf_counter", clock)
    log = io.StringIO()
    bar = ProgressBar("simulate", stream=log)
    steps = [(5, 0.05), (5, 0.12), (1, 0.15), (5, 0.21), (9, 0.22), (30, 0.5), (1, 0.6), (60, 1.0)]
    for seconds, fraction in steps:
        clock.now += seconds
        bar(fraction, f"participant P01 at {fraction:.0%}")
    bar.done()
    assert log.getvalue().splitlines() == [
        "simulate  12% 10s, ~73s left  participant P01 at 12%",  # 5 s at 5 %: too soon; 10 s at 12 %: a tenth
        "simulate  22% 25s, ~89s left  participant P01 at 22%",  # 21 % 6 s after: too soon
        "simulate  50% 55s, ~55s left  participant P01 at 50%",
        "simulate 100% 116s  participant P01 at 100%",           # 60 % 1 s after 50 %: too soon
    ]
    assert "\r" not in log.getvalue()
    quiet = io.StringIO()
    bar = ProgressBar("simulate", quiet=True, stream=quiet)
    clock.now += 100
    bar(0.5)
    assert quiet.getvalue() == ""


def test_done_ends_an_unfinished_line():
    out = Tty()
    bar = ProgressBar(stream=out)
    bar(0.4, "early stop")
    bar.done()
    assert out.getvalue().endswith("\n")


def test_as_a_context_manager_the_line_ends_even_when_the_work_fails():
    out = Tty()
    with pytest.raises(ValueError, match="bad clip"):  # the error goes on: the bar does not swallow it
        with ProgressBar(stream=out) as bar:
            bar(0.4, "training")
            raise ValueError("bad clip")
    assert out.getvalue().endswith("\n")


class NarrowTty(Tty):
    """A terminal ``columns`` wide (its size as os.get_terminal_size reads it)."""

    def __init__(self, columns):
        super().__init__()
        self.columns = columns

    def fileno(self):
        return 99


@pytest.mark.parametrize("columns", [80, 40])
def test_the_line_fits_the_terminal_so_that_it_is_redrawn_in_place(monkeypatch, columns):
    """CLI audit: on an 80-column terminal the bar's line (about 100 characters with its message)
    wrapped, and each redraw's carriage return went back to the start of the wrapped part only:
    one new line per update, the screen filled with bars. Each line now fits the terminal."""
    import os

    out = NarrowTty(columns)
    monkeypatch.setattr(os, "get_terminal_size", lambda fd: os.terminal_size((out.columns, 24)))
    bar = ProgressBar("simulate", stream=out)
    bar(0.25, "participant P07: adapting cacas-no-pr after day 1 of 3")
    bar(0.5, "participant P07: adapting cacas after day 2 of 3")
    bar(1.0, "participant P07: day 3 of 3 done")
    lines = out.getvalue().replace("\n", "\r").split("\r")
    assert len([line for line in lines if line]) == 3
    assert all(len(line) < columns for line in lines), [len(line) for line in lines]
    assert "simulate [" in out.getvalue() and "50%" in out.getvalue()


def test_a_terminal_whose_size_cannot_be_read_gets_the_whole_line(monkeypatch):
    import os

    def unknown(fd):
        raise OSError(25, "Inappropriate ioctl for device")

    out = NarrowTty(80)
    monkeypatch.setattr(os, "get_terminal_size", unknown)
    ProgressBar("simulate", stream=out)(0.5, "participant P07: adapting cacas-no-pr after day 1 of 3")
    assert "adapting cacas-no-pr after day 1 of 3" in out.getvalue()
