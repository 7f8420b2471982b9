"""The command line's progress bar for ``progress(fraction, message)`` callbacks: one line on
stderr, redrawn in place, with elapsed time and an estimate of what is left.

Drawn only when stderr is a terminal (not in logs or pipes) and not ``quiet``, so that a command
that fails still prints exactly one error line. Use it as a context manager
(``with ProgressBar(quiet=...) as bar: work(progress=bar)``) so the line is ended however the work
stops.
"""

from __future__ import annotations

import sys
import time


class ProgressBar:
    def __init__(self, label: str = "", quiet: bool = False, stream=None, width: int = 30):
        self.label, self.width = label, width
        self.stream = stream or sys.stderr
        self.quiet = quiet or not (hasattr(self.stream, "isatty") and self.stream.isatty())
        self.start = time.perf_counter()
        self.last = ""

    def __call__(self, fraction: float, message: str = "") -> None:
        if self.quiet:
            return
        fraction = min(max(fraction, 0.0), 1.0)
        elapsed = time.perf_counter() - self.start
        eta = f", ~{elapsed / fraction - elapsed:.0f}s left" if fraction > 0 else ""
        prefix = f"{self.label} " if self.label else ""
        fits = min(150, self.columns() - 1)  # a narrow terminal: a shorter bar, the percentage still seen
        width = max(5, min(self.width, fits - len(prefix) - 28))
        filled = int(round(width * fraction))
        line = (f"{prefix}[{'#' * filled}{'-' * (width - filled)}] {fraction:4.0%} "
                f"{elapsed:.0f}s{eta}  {message}")[:fits]
        end = "\n" if fraction >= 1.0 else ""
        self.stream.write("\r" + line.ljust(min(len(self.last), fits)) + end)
        self.stream.flush()
        self.last = "" if end else line

    def columns(self) -> int:
        """The terminal's width, read at each redraw (it may be resized): a longer line wraps, and
        the carriage return then goes back to the start of its last part only, so that every redraw
        added a line (an 80-column terminal filled with bars). Unknown: no limit of its own."""
        import os

        try:
            return os.get_terminal_size(self.stream.fileno()).columns or 10_000
        except (AttributeError, OSError, ValueError):  # no fileno (io.UnsupportedOperation is both)
            return 10_000

    def __enter__(self) -> "ProgressBar":
        return self

    def __exit__(self, *exc) -> None:
        self.done()

    def done(self) -> None:
        """End the line if the work stopped before 100 % (e.g. early stopping, an error)."""
        if not self.quiet and self.last:
            self.stream.write("\n")
            self.last = ""
