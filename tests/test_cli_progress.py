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


def test_silent_on_a_pipe_or_when_quiet():
    pipe = io.StringIO()
    ProgressBar(stream=pipe)(0.3, "x")
    quiet = Tty()
    bar = ProgressBar(quiet=True, stream=quiet)
    bar(0.3, "x")
    bar.done()
    assert pipe.getvalue() == "" and quiet.getvalue() == ""


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
