"""The command line's progress bar for ``progress(fraction, message)`` callbacks: one line on
stderr, redrawn in place, with elapsed time and an estimate of what is left.

Drawn in place only when stderr is a terminal, and not when ``quiet``. Off a terminal (a log
file, a pipe, a batch job's output) a redrawn line is unreadable, and nothing at all left a
10-minute simulation silent in its log: there a plain line is written when the work crosses a
tenth, at most one every :data:`LOG_EVERY_S` seconds, and the last line once a line was written;
work shorter than that writes nothing, so a command that fails at once still prints exactly one
error line. Use it as a context manager
(``with ProgressBar(quiet=...) as bar: work(progress=bar)``) so the line is ended however the work
stops.
"""

from __future__ import annotations

import sys
import time


#: Off a terminal, a progress line at most this often (seconds), when the work crosses a tenth.
LOG_EVERY_S = 10.0


class ProgressBar:
    def __init__(self, label: str = "", quiet: bool = False, stream=None, width: int = 30):
        self.label, self.width = label, width
        self.stream = stream or sys.stderr
        self.quiet = quiet
        self.on_terminal = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.perf_counter()
        self.last = ""
        self.logged_at: float | None = None  # off a terminal: when the last line was written
        self.logged_tenth = 0

    def __call__(self, fraction: float, message: str = "") -> None:
        if self.quiet:
            return
        fraction = min(max(fraction, 0.0), 1.0)
        elapsed = time.perf_counter() - self.start
        eta = f", ~{elapsed / fraction - elapsed:.0f}s left" if fraction > 0 else ""
        prefix = f"{self.label} " if self.label else ""
        if not self.on_terminal:
            self._log(fraction, elapsed, eta, prefix, message)
            return
        fits = min(150, self.columns() - 1)  # a narrow terminal: a shorter bar, the percentage still seen
        width = max(5, min(self.width, fits - len(prefix) - 28))
        filled = int(round(width * fraction))
        line = (f"{prefix}[{'#' * filled}{'-' * (width - filled)}] {fraction:4.0%} "
                f"{elapsed:.0f}s{eta}  {message}")[:fits]
        end = "\n" if fraction >= 1.0 else ""
        self.stream.write("\r" + line.ljust(min(len(self.last), fits)) + end)
        self.stream.flush()
        self.last = "" if end else line

    def _log(self, fraction: float, elapsed: float, eta: str, prefix: str, message: str) -> None:
        """Off a terminal: a plain line when a tenth is crossed, :data:`LOG_EVERY_S` seconds after the
        last line (or the start); at 100 %, once a line was written."""
        tenth = int(fraction * 10 + 1e-9)
        since = elapsed if self.logged_at is None else elapsed - self.logged_at
        done = fraction >= 1.0 and self.logged_at is not None
        if not done and (tenth <= self.logged_tenth or since < LOG_EVERY_S):
            return
        self.stream.write(f"{prefix}{fraction:4.0%} {elapsed:.0f}s{eta if not done else ''}  {message}".rstrip() + "\n")
        self.stream.flush()
        self.logged_at, self.logged_tenth = elapsed, tenth

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
        if not self.quiet and self.on_terminal and self.last:
            self.stream.write("\n")
            self.last = ""
