"""Long work in the background: training, simulation and adaptation run in threads.

The dashboard's pages start long work here instead of in the page script, so that

* the page shows progress (``Job.fraction``, ``Job.message``, ``Job.log``) and the other pages,
  in this or another browser tab, keep answering while it runs;
* a second click (or a second tab) does not start the same work twice: :meth:`JobRunner.start`
  returns the job already running under that key;
* the work finishes even if the browser tab that started it is closed; whatever it must keep is
  written by the work itself (e.g. through the study store), not by the page.

The work is a function that takes a keyword argument ``progress``: a callable
``progress(fraction, message)`` with ``fraction`` in 0..1, the convention of the library's long
functions (``adapt_policy``, ``simulate_study``, the recognisers' training). No streamlit here.
"""

from __future__ import annotations

import threading
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, Callable

RUNNING, DONE, FAILED, STOPPED = "running", "done", "failed", "stopped"


class Stopped(Exception):
    """Raised inside the work by its ``progress`` callback once someone asked the job to stop.
    Work that writes its results only at its end (training, simulation, adaptation) then writes
    nothing; work that records as it goes (``method_comparison.compare_methods``) keeps what it recorded,
    so what a stopped job left is for its page to say."""


@dataclass
class Job:
    """One piece of background work and what it has reported so far."""

    key: str
    label: str
    #: what the page that started it keeps of it for the pages that show it while it runs (the Simulation
    #: lab's form shows the running study's choices), never handed to the work
    details: Any = None
    status: str = RUNNING
    fraction: float = 0.0
    message: str = ""
    log: list[str] = field(default_factory=list)
    result: Any = None
    error: str | None = None
    exception: BaseException | None = field(default=None, repr=False)  # what ``error`` says, for its type
    #: when it started and ended, by the wall clock (seconds since the epoch: what a page says, "ended 22:06 UTC")
    started: float = field(default_factory=lambda: time.time())
    finished: float | None = None
    #: the monotonic clock at its start, and its duration once ended: :attr:`elapsed`, which the wall clock (set
    #: back an hour, a laptop's clock synchronised) made -3595 s, and the time left with it
    _since: float = field(default_factory=lambda: time.monotonic(), repr=False)
    _took: float | None = field(default=None, repr=False)
    #: (elapsed s, fraction) at the first report of some work done: what came before it (starting
    #: worker processes, a first optimizer) is no measure of the pace (:func:`cacas.app_support.time_left`)
    first_step: tuple[float, float] | None = None
    _done: threading.Event = field(default_factory=threading.Event, repr=False)
    _stop: threading.Event = field(default_factory=threading.Event, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def stop(self) -> None:
        """Ask the work to stop: its next progress report raises :class:`Stopped`."""
        self._stop.set()

    @property
    def stopping(self) -> bool:
        return self._stop.is_set() and self.running

    def progress(self, fraction: float, message: str = "") -> None:
        """The ``progress`` callback handed to the work: record the fraction and a log line;
        raise :class:`Stopped` if the job was asked to stop."""
        if self._stop.is_set():
            raise Stopped(f"{self.label}: stopped on request")
        with self._lock:
            self.fraction = min(1.0, max(0.0, float(fraction)))
            if self.first_step is None and self.fraction > 0:
                self.first_step = (self.elapsed, self.fraction)
            if message:
                self.message = str(message)
                if not self.log or self.log[-1] != self.message:
                    self.log.append(self.message)

    @property
    def running(self) -> bool:
        return self.status == RUNNING

    @property
    def elapsed(self) -> float:
        """Seconds since it started, or that it took once ended (the monotonic clock's)."""
        return self._took if self._took is not None else time.monotonic() - self._since

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the work ends (tests and command-line use); True if it has ended."""
        return self._done.wait(timeout)

    def snapshot(self) -> dict[str, Any]:
        """A consistent copy of what a page shows."""
        with self._lock:
            return {"key": self.key, "label": self.label, "status": self.status,
                    "fraction": self.fraction, "message": self.message, "log": list(self.log),
                    "error": self.error, "elapsed": self.elapsed, "first_step": self.first_step}


def _let_go_of_frames(exc: BaseException) -> None:
    """Clear the local variables of the frames ``exc`` (and the exceptions it was raised from, or during) passed
    through. The runner keeps a failed job, and its exception for the page to tell kinds apart, until the server
    stops: its traceback held every frame the failure went through and all they referred to (a training's
    model and data, an adaptation's policies and tables) for as long (long run's left-alone item). The type,
    message and the log's last line are kept."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        traceback.clear_frames(exc.__traceback__)
        exc = exc.__cause__ or exc.__context__


class JobRunner:
    """Runs work in daemon threads, at most one job per key at a time."""

    def __init__(self) -> None:
        self._jobs: dict[str, Job] = {}
        self._lock = threading.Lock()

    def start(self, key: str, work: Callable[..., Any], *args: Any, label: str = "", details: Any = None,
              **kwargs: Any) -> tuple[Job, bool]:
        """Start ``work(*args, progress=job.progress, **kwargs)`` under ``key``, with ``label`` and
        ``details`` (:attr:`Job.details`) for the pages that show it.

        Returns ``(job, started)``: if a job with this key is still running, that job and False
        (a second click does not start the work twice); otherwise a new job and True.
        """
        with self._lock:
            current = self._jobs.get(key)
            if current is not None and current.running:
                return current, False
            job = Job(key=key, label=label or key, details=details)
            self._jobs[key] = job

        def body() -> None:
            try:
                result = work(*args, progress=job.progress, **kwargs)
            except Stopped:
                with job._lock:
                    job.log.append("stopped on request")
                    job.status = STOPPED
            except BaseException as exc:  # the page shows the message; the log keeps the trace. Not only
                # Exception: a SystemExit (a library calling sys.exit()) left the job "running" for good, and
                # its key (a participant's day to adapt) could not be started again until the server restarted
                with job._lock:
                    job.error = str(exc) or exc.__class__.__name__
                    job.exception = exc
                    job.log.append(traceback.format_exc(limit=3).strip().splitlines()[-1])
                    job.status = FAILED
                _let_go_of_frames(exc)
            else:
                with job._lock:
                    job.result = result
                    job.fraction = 1.0
                    job.status = DONE
            finally:
                job._took = time.monotonic() - job._since
                job.finished = time.time()
                job._done.set()

        threading.Thread(target=body, name=f"cacas-job:{key}", daemon=True).start()
        return job, True

    def get(self, key: str) -> Job | None:
        """The job last started under ``key`` (running or ended), or None."""
        with self._lock:
            return self._jobs.get(key)

    def stop(self, key: str) -> bool:
        """Ask the running job under ``key`` to stop at its next progress report; False if none runs."""
        with self._lock:
            job = self._jobs.get(key)
        if job is None or not job.running:
            return False
        job.stop()
        return True

    def forget(self, key: str) -> None:
        """Drop an ended job (a running one stays: stop it first, :meth:`stop`)."""
        with self._lock:
            job = self._jobs.get(key)
            if job is not None and not job.running:
                del self._jobs[key]

    def running(self) -> list[Job]:
        with self._lock:
            return [j for j in self._jobs.values() if j.running]


#: The process-wide runner: every browser tab of one ``streamlit run`` shares it.
RUNNER = JobRunner()
