"""cacas.parallel: pieces of work in worker processes, reports through a queue, stop at the next report."""

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cacas import parallel
from cacas.jobs import Stopped


def _report_for_a_while(shared: bytes, piece: int, queue, stop) -> int:
    """A piece that reports for about 5 s, unless stopped."""
    report = parallel.reporter(queue, stop)
    for n in range(500):
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


def _fail_once_piece_1_began(shared: bytes, piece: int, queue, stop) -> int:
    """Piece 1 marks the file ``shared`` names, then reports for about 5 s; piece 0 fails once it is marked
    (so piece 1 has begun when the stop comes: a piece its worker takes only after it never starts)."""
    began = Path(shared.decode())
    if piece == 0:
        while not began.exists():
            time.sleep(0.01)
        raise ValueError("piece 0 failed")
    began.touch()
    return _report_for_a_while(b"", piece, queue, stop)


def test_a_failing_piece_stops_the_others_at_once(tmp_path):
    """Review: the other workers ran to their end before the failure was said."""
    with pytest.raises(ValueError, match="piece 0 failed") as failed:
        parallel.run_parallel(_fail_once_piece_1_began, str(tmp_path / "began").encode(), [0, 1], 2,
                              lambda *item: None)
    # piece 1 (5 s of reports) ended early, stopped, not at its end
    assert failed.value.__notes__ == ["1 of 2 pieces of work ended early in their worker process, 0 never started"]


def _report_until_stopped(shared: bytes, piece: int, queue, stop) -> int:
    """A piece that reports, then waits for the stop and reports again (which raises Stopped)."""
    report = parallel.reporter(queue, stop)
    report("began", piece)
    stop.wait()
    report("after the stop", piece)
    return piece


def test_a_piece_a_worker_took_from_the_queue_after_a_stop_counts_as_never_started():
    """One worker: piece 0 runs, piece 1 waits in the pool's queue handed to the worker (which
    ``Future.cancel`` cannot take back), piece 2 in the pool's own. Stopped at piece 0's first report,
    piece 1 was counted as ended early though its work never began."""
    began = []

    def tick(*item):
        began.append(item)
        raise Stopped("stopped on request")
    with pytest.raises(Stopped) as stopped:
        parallel.run_parallel(_report_until_stopped, b"", [0, 1, 2], 1, tick)
    assert began == [("began", 0)]
    assert stopped.value.__notes__ == ["1 of 3 pieces of work ended early in their worker process, 2 never started"]


def test_what_was_made_before_a_stop_is_kept():
    """Review: items the workers had queued when the main process stopped were dropped; ``keep`` has them."""
    ticked, kept = [], []

    def tick(*item):
        ticked.append(item)
        if len(ticked) == 5:
            time.sleep(0.5)  # meanwhile the workers, reporting every 10 ms, queue more
            raise Stopped("stopped on request")
    with pytest.raises(Stopped):
        parallel.run_parallel(_report_for_a_while, b"", [0, 1], 2, tick, keep=lambda *item: kept.append(item))
    assert len(ticked) == 5 and kept and not set(ticked) & set(kept)  # each item once, to tick or to keep


def _ctrl_c_blocked_here(shared: bytes, piece: int, queue, stop) -> bool:
    """Whether this worker process has Ctrl-C blocked: inherited from its start (nothing in the worker
    blocks it), so it was blocked while the process imported, before its initializer ran."""
    import signal
    return signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, [])


FIRST_RUN = """
import signal, sys
from cacas import parallel
from tests.test_parallel import _ctrl_c_blocked_here

if __name__ == "__main__":
    before = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    print(parallel.run_parallel(_ctrl_c_blocked_here, b"", [0, 1], 2, lambda *item: None),
          signal.SIGINT in before, signal.pthread_sigmask(signal.SIG_BLOCK, []) == before)
"""


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="no signal masks on this platform")
def test_workers_start_with_ctrl_c_held_and_the_caller_gets_it_back(tmp_path):
    """Ctrl-C within ~0.1 s of the workers starting killed them mid-import (tracebacks) and could hang
    `cacas simulate`: a worker process starts with Ctrl-C blocked, and the caller's mask is restored.
    In a fresh process, as `cacas simulate` is: there the first spawn starts multiprocessing's resource
    tracker, which unblocked Ctrl-C in the caller before the workers started."""
    script = tmp_path / "first_run.py"
    script.write_text(FIRST_RUN)
    root = Path(__file__).parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, cwd=root,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["[True,", "True]", "False", "True"]


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="no signal masks on this platform")
def test_a_ctrl_c_pressed_while_the_workers_start_arrives_once_they_have_started(monkeypatch):
    """A Ctrl-C while the pieces are being submitted is held until all are (not raised mid-spawn,
    which left a process without its start-up data), then stops the workers as at any other moment."""
    submit = parallel.ProcessPoolExecutor.submit
    pressed = []

    def submit_and_press(self, *args, **kwargs):
        future = submit(self, *args, **kwargs)
        if not pressed:  # Ctrl-C as the first worker starts
            pressed.append(True)
            os.kill(os.getpid(), signal.SIGINT)
        return future
    monkeypatch.setattr(parallel.ProcessPoolExecutor, "submit", submit_and_press)
    with pytest.raises(KeyboardInterrupt) as interrupted:
        parallel.run_parallel(_report_for_a_while, b"", [0, 1, 2], 2, lambda *item: None)
    assert pressed
    # stopped by run_parallel once the 3 were submitted (before: raised as the first was, outside the
    # stop's reach, and the pool waited for every piece's end, with no note); a piece its worker took
    # only after the stop never started, so all 3 may have
    counts = re.fullmatch(r"([0-3]) of 3 pieces of work ended early in their worker process, ([0-3]) never started",
                          interrupted.value.__notes__[0])
    assert counts and int(counts[1]) + int(counts[2]) == 3


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="no signal masks on this platform")
def test_a_ctrl_c_held_arrives_once_at_release_and_leaves_nothing_blocked():
    before = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    handler = signal.getsignal(signal.SIGINT)
    held = parallel.InterruptHeld()
    assert signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, [])
    os.kill(os.getpid(), signal.SIGINT)  # pending (blocked here), or noted where another thread takes it
    time.sleep(0.05)
    with pytest.raises(KeyboardInterrupt):
        held.release()
    assert signal.pthread_sigmask(signal.SIG_BLOCK, []) == before and signal.getsignal(signal.SIGINT) is handler
    held.release()  # once only: nothing more arrives


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="no signal masks on this platform")
def test_a_ctrl_c_raised_as_the_handler_is_put_back_leaves_nothing_blocked(monkeypatch):
    """Review: the handler was put back before the mask, so a Ctrl-C another thread took between the
    two raised there and left Ctrl-C blocked in the main thread for good."""
    before = signal.pthread_sigmask(signal.SIG_BLOCK, [])
    held = parallel.InterruptHeld()
    real = signal.signal

    def put_back_then_interrupted(signum, handler):  # the restored handler runs at once: Ctrl-C
        real(signum, handler)
        raise KeyboardInterrupt
    monkeypatch.setattr(parallel.signal, "signal", put_back_then_interrupted)
    with pytest.raises(KeyboardInterrupt):
        held.release()
    monkeypatch.undo()
    assert signal.pthread_sigmask(signal.SIG_BLOCK, []) == before


def _report_for_a_minute(shared: bytes, piece: int, queue, stop) -> int:
    report = parallel.reporter(queue, stop)
    for n in range(600):
        report("made", piece, n)
        time.sleep(0.1)
    return piece


KILLED_RUN = """
import multiprocessing, sys
from cacas import parallel
from tests.test_parallel import _report_for_a_minute

said = []
def tick(*item):
    if not said:  # the workers and the manager, once they report
        said.append(1)
        print(" ".join(str(p.pid) for p in multiprocessing.active_children()), flush=True)

if __name__ == "__main__":
    parallel.run_parallel(_report_for_a_minute, b"", [0, 1], 2, tick)
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as fh:  # a zombie (ended, not yet reaped) is gone
        return fh.read().split(")")[-1].split()[0] != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_worker_processes_end_when_the_main_process_is_killed_outright(tmp_path):
    """Helper's bug hunt: after `kill -9` of the main process (or the out-of-memory killer) the
    manager and worker processes stayed for good, orphaned."""
    script = tmp_path / "killed_run.py"
    script.write_text(KILLED_RUN)
    root = Path(__file__).parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    main = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True, env=env, cwd=root)
    pids = []
    try:
        pids = [int(p) for p in main.stdout.readline().split()]
        assert len(pids) >= 3  # the manager and two workers
        main.kill()
        main.wait(timeout=30)
        deadline = time.time() + 20
        while time.time() < deadline and any(_alive(p) for p in pids):
            time.sleep(0.2)
        assert not [p for p in pids if _alive(p)]
    finally:
        main.kill()
        for pid in pids:  # whatever is left of this test's own processes
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


def test_default_jobs_is_one_per_core_as_far_as_the_memory_holds(monkeypatch):
    """The app's Simulation lab and Results page run one worker per core too (default_jobs)."""
    import cacas.parallel as parallel

    monkeypatch.setattr(parallel, "cores", lambda: 8)
    monkeypatch.setattr(parallel, "available_memory", lambda: 3 * 2**30)
    assert parallel.default_jobs() == 3
    monkeypatch.setattr(parallel, "available_memory", lambda: 2**20)
    assert parallel.default_jobs() == 1
    monkeypatch.setattr(parallel, "available_memory", lambda: None)
    assert parallel.default_jobs() == 8


def test_available_memory_is_read_from_linux_meminfo():
    """MemAvailable, in bytes: at most the machine's memory (MemTotal)."""
    import sys

    import cacas.parallel as parallel

    if not sys.platform.startswith("linux"):
        pytest.skip("/proc/meminfo is Linux's")
    total = next(int(line.split()[1]) * 1024 for line in open("/proc/meminfo") if line.startswith("MemTotal:"))
    assert 0 < parallel.available_memory() <= total



def _fake_linux(tmp_path, monkeypatch, membership: str, available_gb: float = 16):
    """A fake /proc (meminfo, self/cgroup) and /sys/fs/cgroup under ``tmp_path``; returns the fake
    cgroup root."""
    import cacas.parallel as parallel

    (tmp_path / "meminfo").write_text(f"MemTotal:       {32 * 2**20} kB\n"
                                      f"MemFree:        {2**20} kB\n"
                                      f"MemAvailable:   {int(available_gb * 2**20)} kB\n")
    (tmp_path / "cgroup").write_text(membership)
    root = tmp_path / "sys" / "fs" / "cgroup"
    root.mkdir(parents=True)
    monkeypatch.setattr(parallel, "PROC_MEMINFO", tmp_path / "meminfo")
    monkeypatch.setattr(parallel, "PROC_CGROUP", tmp_path / "cgroup")
    monkeypatch.setattr(parallel, "CGROUP_ROOT", root)
    return root


def _group(folder, **files):
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name.replace("_", ".", 1)).write_text(f"{text}\n")


def test_a_containers_memory_limit_caps_the_available_memory_cgroup_v2(tmp_path, monkeypatch):
    """CLI audit: --jobs' memory cap read MemAvailable alone, the machine's; in a container limited
    to 2 GB on a 32 GB machine it planned 16 GB of workers, and the kernel killed them. The limit
    less the group's use counts, not its page cache the kernel drops (inactive_file): memory.current
    counts the cache too. The tightest of the group's and its ancestors' limits holds."""
    import cacas.parallel as parallel

    root = _fake_linux(tmp_path, monkeypatch, "0::/\n")
    _group(root, cgroup_controllers="cpu memory", memory_max=2 * 2**30, memory_current=int(1.5 * 2**30),
           memory_stat=f"anon {2**29}\nfile {2**30}\ninactive_file {2**29}\nactive_file {2**29}")
    assert parallel.available_memory() == 2**30  # 2 GB - (1.5 GB - 0.5 GB of cache it can drop)
    monkeypatch.setattr(parallel, "cores", lambda: 8)
    assert parallel.default_jobs() == 1
    jobs, notes = parallel.plan_jobs(4, 10)
    assert jobs == 1 and ("and 1.0 GB of memory is available under this process's control group (container) "
                          "memory limit; running 1") in notes[0]
    (root / "memory.max").write_text("max\n")  # no limit: the machine's MemAvailable
    assert parallel.available_memory() == 16 * 2**30
    assert parallel.default_jobs() == 8
    jobs, notes = parallel.plan_jobs(40, 40)  # the machine's memory holds: said without the container
    assert jobs == 20 and "and 16.0 GB of memory is available; running 20" in notes[0]
    # a systemd unit or a job scheduler's group below the root, limited above it
    (tmp_path / "cgroup").write_text("0::/user.slice/job-7\n")
    _group(root / "user.slice", memory_max=3 * 2**30, memory_current=2**30)
    _group(root / "user.slice" / "job-7", memory_max="max", memory_current=2**29)
    assert parallel.available_memory() == 2 * 2**30
    _group(root / "user.slice" / "job-7", memory_max=2**30, memory_current=2**29)
    assert parallel.available_memory() == 2**29


def test_a_containers_memory_limit_caps_the_available_memory_cgroup_v1(tmp_path, monkeypatch):
    """cgroup v1 (older Docker, this machine): memory.limit_in_bytes, a huge number when there is no
    limit; inside a container the group's path named in /proc/self/cgroup is often not there (the
    container sees its own group as the root)."""
    import cacas.parallel as parallel

    root = _fake_linux(tmp_path, monkeypatch, "5:cpuacct,cpu:/docker/abc\n4:memory:/docker/abc\n0::/\n")
    _group(root / "memory", memory_limit_in_bytes=3 * 2**30, memory_usage_in_bytes=2**30,
           memory_stat=f"cache {2**29}\ninactive_file 0\ntotal_inactive_file {2**28}")
    assert parallel.available_memory() == 2 * 2**30 + 2**28
    (root / "memory" / "memory.limit_in_bytes").write_text("9223372036854771712\n")  # no limit
    assert parallel.available_memory() == 16 * 2**30


def test_without_a_cgroup_file_system_the_machines_memory_is_used(tmp_path, monkeypatch):
    import cacas.parallel as parallel

    _fake_linux(tmp_path, monkeypatch, "0::/\n", available_gb=3)  # v2 named, nothing mounted
    assert parallel.cgroup_available_memory() is None and parallel.available_memory() == 3 * 2**30
    (tmp_path / "cgroup").unlink()
    (tmp_path / "meminfo").unlink()
    assert parallel.available_memory() is None


def _what_the_worker_has(shared: bytes, piece: int, queue, stop) -> tuple:
    """What a worker process has when its piece begins: the simulated study's module imported (before
    anything in the piece imports it), what torch.optim imports at a process's first optimizer, and the
    environment variable ``shared`` names."""
    return ("cacas.experiment" in sys.modules and "torch" in sys.modules, "torch._dynamo" in sys.modules,
            os.environ.get(shared.decode()))


def test_the_workers_start_with_the_studys_modules_imported_and_the_callers_environment(monkeypatch):
    """Profile: every worker process was spawned and imported torch, pandas and cacas itself, on every run
    (a 2-participant, 1-day study in one process: 35-37 s a run, 2.5-5 s with a fork server that imports
    them once). The fork server's workers still see the environment of the run, not of its own start.
    Each worker also imported torch._dynamo at its first SAC or MLP training (torch.optim's first optimizer,
    1.4 s idle); the fork server imports it once too."""
    for run in ("first", "second"):
        monkeypatch.setenv("CACAS_TEST_RUN", run)  # set after the first run started the fork server
        got = parallel.run_parallel(_what_the_worker_has, b"CACAS_TEST_RUN", [0, 1], 2, lambda *item: None)
        assert got == [(True, True, run), (True, True, run)]
