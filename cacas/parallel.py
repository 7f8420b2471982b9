"""Independent pieces of long work (one participant each) in worker processes, one per core.

:func:`run_parallel` serves the simulated study (``cacas simulate``, the Simulation lab) and the
human study's method comparison (Results): each piece runs in a worker process that a fork server
forks (:func:`worker_context`; safe with torch's thread pools, which the fork server never starts),
reports through a queue that the main process drains into ``tick``, and
ends at its next report once the main process asks it to stop (``tick`` raised: a Stop button,
:class:`cacas.jobs.Stopped`, or Ctrl-C). Work kept by the main process as the reports arrive
(a comparison's runs) stays; pieces not started never start.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import threading
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from multiprocessing.managers import SyncManager
from pathlib import Path
from typing import Any, Callable, Sequence

from cacas.jobs import Stopped


#: What one worker process holds at its peak, in bytes: torch and a participant's networks and
#: replay memories (measured: 0.71 GB of its own, 1.07 GB resident, a 6-method, 4-day study of
#: ~15 interactions a day, torch 2.14 on Linux, 2026-11-28), rounded up.
WORKER_MEMORY = int(0.8 * 2**30)

GB = 2**30


def cores() -> int:
    """The cores this process may run on (a CPU affinity or a job scheduler's share, where the
    system says so), at least 1."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


#: Where Linux shows the memory of the machine and of this process's control group (a container's
#: memory limit, a systemd unit's MemoryMax, a job scheduler's share). Tests point these elsewhere.
PROC_MEMINFO = Path("/proc/meminfo")
PROC_CGROUP = Path("/proc/self/cgroup")
CGROUP_ROOT = Path("/sys/fs/cgroup")
#: A cgroup v1 limit this large is "no limit" (the kernel writes 2**63 rounded down to a page).
_NO_LIMIT = 2**60


def available_memory() -> int | None:
    """Bytes of memory new processes can take without swapping or being killed for it: Linux's own
    estimate, MemAvailable in /proc/meminfo, or less where this process's control group (a
    container's) has a memory limit that leaves less (:func:`cgroup_available_memory`); on Windows,
    the physical memory available (:func:`windows_available_memory`); None where none can be read
    (macOS: its memory is compressed and swapped, and no count of workers is refused for it)."""
    from cacas.store.files import ON_WINDOWS

    if ON_WINDOWS:
        return windows_available_memory()
    found = []
    try:
        with open(PROC_MEMINFO, encoding="utf-8") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
                    break
    except (OSError, ValueError, IndexError):
        pass
    limited = cgroup_available_memory()
    if limited is not None:
        found.append(limited)
    return min(found) if found else None


def windows_available_memory() -> int | None:
    """Windows' physical memory available now (``GlobalMemoryStatusEx``'s ``ullAvailPhys``, bytes);
    None if it cannot be asked. Without it every worker process a core was started there, whatever
    the memory: 16 of ~1 GB each on a laptop of 16 logical cores and 16 GB, and Windows ends a
    process that finds no memory to commit (torch's own libraries fail to load: "The paging file
    is too small for this operation to complete")."""
    import ctypes

    class MemoryStatus(ctypes.Structure):  # MEMORYSTATUSEX
        _fields_ = [("dwLength", ctypes.c_uint32), ("dwMemoryLoad", ctypes.c_uint32),  # DWORD: 32 bits
                    *((name, ctypes.c_ulonglong) for name in (
                        "ullTotalPhys", "ullAvailPhys", "ullTotalPageFile", "ullAvailPageFile", "ullTotalVirtual",
                        "ullAvailVirtual", "ullAvailExtendedVirtual"))]

    status = MemoryStatus()
    status.dwLength = ctypes.sizeof(MemoryStatus)
    try:
        asked = ctypes.windll.kernel32.GlobalMemoryStatusEx(ctypes.byref(status))
    except (AttributeError, OSError):
        return None
    return int(status.ullAvailPhys) if asked else None


def _read_number(path: Path) -> int | None:
    """The whole number a cgroup file holds; None if missing, unreadable or "max" (no limit)."""
    try:
        text = path.read_text(encoding="utf-8").strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


def _reclaimable(folder: Path, keys: tuple[str, ...]) -> int:
    """The page cache the kernel can drop for new processes (inactive file pages), from the
    ``memory.stat`` in ``folder``: the first of ``keys`` it holds; 0 if none."""
    try:
        stat = dict(line.split()[:2] for line in (folder / "memory.stat").read_text(encoding="utf-8").splitlines()
                    if len(line.split()) >= 2)
    except OSError:
        return 0
    for key in keys:
        if stat.get(key, "").isdigit():
            return int(stat[key])
    return 0


def cgroup_available_memory() -> int | None:
    """Bytes this process's control group (a container's, a systemd unit's) can still take before
    its memory limit, at the tightest of its own and its ancestors' limits: the limit less what the
    group uses, not counting the page cache the kernel drops for new processes (inactive file
    pages; ``memory.current`` counts all of the cache, which would understate it). cgroup v2:
    ``memory.max`` ("max": no limit), ``memory.current``, ``memory.stat``'s ``inactive_file``;
    v1: ``memory.limit_in_bytes``, ``memory.usage_in_bytes``, ``total_inactive_file``. None where
    no limit is set or none can be read (another system, no cgroup file system)."""
    try:
        lines = PROC_CGROUP.read_text(encoding="utf-8").splitlines()
    except OSError:
        return None
    groups = []  # (the hierarchy's folder, this process's group in it, its files' names)
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        _, controllers, where = parts
        if controllers == "" and (CGROUP_ROOT / "cgroup.controllers").exists():  # v2, mounted at the root
            groups.append((CGROUP_ROOT, where, ("memory.max", "memory.current", ("inactive_file",))))
        elif "memory" in controllers.split(","):  # v1's memory controller
            groups.append((CGROUP_ROOT / "memory", where, ("memory.limit_in_bytes", "memory.usage_in_bytes",
                                                            ("total_inactive_file", "inactive_file"))))
    found = []
    for root, where, (limit_name, usage_name, cache_keys) in groups:
        # the group and every group above it up to the root (in a container, often the root alone:
        # its own group is the root of what it sees, and the path named may not be there)
        folder = root.joinpath(*[part for part in where.split("/") if part not in ("", ".", "..")])
        chain = [folder, *folder.parents]
        for level in chain[:chain.index(root) + 1] if root in chain else [root]:
            limit = _read_number(level / limit_name)
            usage = _read_number(level / usage_name)
            if limit is None or usage is None or limit >= _NO_LIMIT:
                continue
            found.append(max(0, limit - max(0, usage - _reclaimable(level, cache_keys))))
    return min(found) if found else None


def memory_jobs() -> int | None:
    """How many worker processes the available memory holds (:data:`WORKER_MEMORY` each), at
    least 1; None where the available memory is unknown."""
    available = available_memory()
    return None if available is None else max(1, available // WORKER_MEMORY)


def default_jobs() -> int:
    """Worker processes for work of independent participants: one per core, at most as many as
    the available memory holds (:func:`memory_jobs`)."""
    fit = memory_jobs()
    return min(cores(), fit) if fit is not None else cores()


def plan_jobs(requested: int | None, pieces: int, option: str = "--jobs") -> tuple[int, list[str]]:
    """The worker processes to run ``pieces`` independent pieces (participants) in, for
    ``requested`` (None: :func:`default_jobs`), and a note for each way the choice may surprise:
    more workers than cores (allowed: they take turns, so the run is not faster), or more than
    the available memory holds (then as many as it holds: a worker killed for memory loses the
    run, while the results do not depend on the number). At most one per piece, said in neither."""
    notes = []
    jobs = max(1, min(requested or cores(), pieces))
    asked = f"{option} {requested}" if requested is not None else "one worker process per core"
    fit, available = memory_jobs(), available_memory()
    if fit is not None and jobs > fit:
        # a container's (control group's) limit is not what `free` shows: say when it is the one that holds
        where = " under this process's control group (container) memory limit" \
            if cgroup_available_memory() == available else ""
        notes.append(f"{asked}: {jobs} worker processes need about {jobs * WORKER_MEMORY / GB:.1f} GB "
                     f"({WORKER_MEMORY / GB:.1f} GB each) and {available / GB:.1f} GB of memory is available"
                     f"{where}; running {fit} (the results are the same whatever the number)")
        jobs = fit
    n_cores = cores()
    if jobs > n_cores:
        notes.append(f"{asked}: {jobs} worker processes on {n_cores} core{'s' if n_cores != 1 else ''} take "
                     "turns, so the run is not faster than with one per core")
    return jobs, notes


def ignore_interrupt() -> None:
    """Worker and manager processes leave Ctrl-C to the main process, which stops them through
    the stop event: interrupted themselves, the pool's workers went on to the next piece."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _exit_with_parent() -> None:
    """End this worker or manager process when the main process is gone: killed outright
    (``kill -9``, the kernel's out-of-memory killer, a crashed app server) it cannot stop them, and
    they stayed for good, orphans holding a Python with torch each (a daemon thread waits on the
    parent's sentinel, which a worker process has, spawned or forked by the fork server)."""
    parent = mp.parent_process()
    if parent is None:
        return

    def watch() -> None:
        parent.join()  # returns once the parent process has ended
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def start_process(environ: dict[str, str] | None = None) -> None:
    """The initializer of the worker and manager processes: Ctrl-C left to the main process
    (:func:`ignore_interrupt`), and the process ends when the main process is gone. ``environ``: the
    main process's environment when the pool started, which a process the fork server forks would
    not have otherwise (it has the fork server's, of its own start; e.g. a ``CACAS_STUDY_DATA`` set
    since). The working directory and ``sys.path`` come with every process started
    (multiprocessing's preparation data)."""
    ignore_interrupt()
    if environ is not None and environ != os.environ:
        os.environ.clear()
        os.environ.update(environ)
    _exit_with_parent()


#: The modules whose functions run in the worker processes (a simulated study's participants, a
#: comparison's), imported once by the fork server (:func:`worker_context`), with torch and pandas;
#: and torch._dynamo, which torch.optim imports at the first optimizer a process makes (every SAC and
#: MLP training), in each worker of each run otherwise (1.4 s idle; a later 2-participant, 1-day study
#: run in one process took 1.0-1.7 s with it, 0.3-0.4 s without, at load 4-5).
WORKER_MODULES = ("cacas.experiment", "cacas.method_comparison", "torch._dynamo")


def worker_context():
    """The multiprocessing context the workers start in: a fork server that imports the main module
    and :data:`WORKER_MODULES` once, then forks each worker and manager process from itself, where
    the system has one (Linux, macOS); spawn elsewhere.

    Spawned, every worker imported torch, pandas and cacas (and, in the app, the Streamlit script)
    itself, on every run: a simulated study of 2 participants x 1 day in the app's process took
    35-37 s a run against 2.5-5 s with the fork server, which stays for the process's later runs
    (load 6-10, docs/performance.md). A fork server is a process of its own, started fresh and
    single-threaded, so, unlike a plain fork of the main process, its children inherit no thread (the
    app server's, torch's intra-op pool) nor lock held by one. The pieces' random streams are seeded
    from their arguments, so the results are the same with either start method. The fork server's
    modules are those of its start: a change of the code on disk reaches the workers once the
    process (the app server, ``cacas simulate``) starts again."""
    if "forkserver" not in mp.get_all_start_methods():
        return mp.get_context("spawn")
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(["__main__", *WORKER_MODULES])  # in effect when the server starts, once
    return ctx


class InterruptHeld:
    """Ctrl-C (SIGINT) held back while worker processes start, until :meth:`release`.

    The signal is blocked in this thread, and a process started meanwhile inherits the block, so
    Ctrl-C (sent to the whole process group) cannot end it while it imports, before
    :func:`ignore_interrupt` runs: it died with a traceback, and the pool's feeder could hang
    writing to it (the standard library starts its resource tracker the same way). In this
    process, on the main thread, a Ctrl-C that another thread takes (torch's, which do not block
    it) is noted rather than raised mid-spawn, and raised at :meth:`release`: held, not lost."""

    def __init__(self) -> None:
        self.mask = None
        if hasattr(signal, "pthread_sigmask"):
            from multiprocessing import resource_tracker

            resource_tracker.ensure_running()  # started by the first spawn, it unblocks Ctrl-C here
            self.mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        self.pressed: list[int] = []
        self.swapped = None  # the handler to put back; None: not swapped (not the main thread, or not Python's)
        previous = signal.getsignal(signal.SIGINT)
        if threading.current_thread() is threading.main_thread() and previous is not None:
            signal.signal(signal.SIGINT, lambda signum, frame: self.pressed.append(signum))
            self.swapped = previous
        self.held = True

    def release(self) -> None:
        """The mask and handler as they were; a Ctrl-C pressed meanwhile arrives now. Once only.
        Unblocked first, while the noting handler is still in place (a pending Ctrl-C is noted, not
        raised between the two steps, which left Ctrl-C blocked for good)."""
        if not self.held:
            return
        self.held = False
        if self.mask is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, self.mask)  # a blocked, pending one arrives
        if self.swapped is not None:
            signal.signal(signal.SIGINT, self.swapped)
        if self.pressed:
            signal.raise_signal(signal.SIGINT)


def reporter(queue, stop) -> Callable[..., None]:
    """A worker's ``report(*item)``: puts ``item`` on the queue for the main process's ``tick``,
    or raises :class:`Stopped` once the main process asked every worker to stop."""
    def report(*item) -> None:
        if stop.is_set():  # stopped (or failed) in the main process: end here
            raise Stopped("stopped on request")
        queue.put(item)
    return report


class NotStarted(Stopped):
    """A piece that a worker process took from the pool's queue once the stop was asked: its work
    never began (the pool hands each worker one call ahead, which ``Future.cancel`` cannot take back)."""


def _piece(worker: Callable, shared: bytes, piece: Any, queue, stop):
    """Runs one piece in a worker process, unless the main process has asked every worker to stop
    (then :class:`NotStarted`: counted as never started, not as ended early)."""
    if stop.is_set():
        raise NotStarted("stopped before it started")
    return worker(shared, piece, queue, stop)


def run_parallel(worker: Callable, shared: bytes, pieces: Sequence[Any], jobs: int,
                 tick: Callable[..., None], what: str = "pieces of work",
                 keep: Callable[..., None] | None = None) -> list:
    """``worker(shared, piece, queue, stop)`` for every piece in ``jobs`` worker processes
    (``worker`` a module-level function; ``shared`` bytes every piece needs, e.g. a policy);
    every item a worker puts on ``queue`` (:func:`reporter`) comes to ``tick(*item)`` in the main
    process as it runs. If ``tick`` raises, or a worker fails, every worker ends at its next
    report and the pieces not started never start; the items still on the queue then go to
    ``keep(*item)`` (work already made, e.g. a comparison's runs, is kept); the exception goes on
    with a note of how many pieces (``what``) ended early.
    Returns the workers' results in the order of ``pieces``."""
    ctx = worker_context()
    manager = SyncManager(ctx=ctx)
    held = InterruptHeld()
    try:
        manager.start(start_process)
        with manager, ProcessPoolExecutor(jobs, mp_context=ctx, initializer=start_process,
                                          initargs=(dict(os.environ),)) as pool:
            queue, stop = manager.Queue(), manager.Event()
            futures = []
            try:
                for piece in pieces:  # one by one: a Ctrl-C meanwhile stops those submitted (below)
                    futures.append(pool.submit(_piece, worker, shared, piece, queue, stop))
                held.release()  # the workers have started: a Ctrl-C meanwhile arrives here
                pending = set(futures)
                while pending:
                    finished, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                    while not queue.empty():
                        tick(*queue.get())
                    failed = next((f.exception() for f in finished if f.exception() is not None), None)
                    if failed is not None:  # one piece failed: the others stop now, not at their end
                        raise failed
                while not queue.empty():
                    tick(*queue.get())
            except BaseException as exc:  # a stop request, Ctrl-C, or a worker's failure
                stop.set()
                for f in futures:
                    f.cancel()  # those still in the pool's own queue; one already handed to a worker: _piece
                wait(futures)
                while keep is not None and not queue.empty():  # made before the stop, not yet taken
                    keep(*queue.get())
                # never started: cancelled, or taken by a worker after the stop (_piece); ended early: stopped
                # at a report, once begun
                never = sum(f.cancelled() or isinstance(f.exception(), NotStarted) for f in futures)
                ended = sum(not f.cancelled() and isinstance(f.exception(), Stopped)
                            and not isinstance(f.exception(), NotStarted) for f in futures)
                exc.add_note(f"{ended} of {len(futures)} {what} ended early in their worker process, "
                             f"{never} never started")
                raise
            return [f.result() for f in futures]
    finally:
        held.release()
