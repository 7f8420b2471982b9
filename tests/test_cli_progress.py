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
