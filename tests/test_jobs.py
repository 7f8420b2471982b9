import gc
import threading
import weakref

from cacas.jobs import DONE, FAILED, STOPPED, JobRunner


def test_job_reports_progress_and_result():
    runner = JobRunner()

    def work(n, progress):
        for i in range(n):
            progress((i + 1) / n, f"step {i + 1} of {n}")
        return n * 2

    job, started = runner.start("k", work, 3, label="Counting")
    assert started
    assert job.wait(10)
    assert job.status == DONE and job.result == 6 and job.fraction == 1.0
    assert job.log == ["step 1 of 3", "step 2 of 3", "step 3 of 3"]
    assert job.label == "Counting" and runner.get("k") is job


def test_a_job_keeps_when_its_first_work_was_reported():
    """The time left is measured from the first report of work done, not from the job's start."""
    runner = JobRunner()

    def work(progress):
        progress(0.0, "starting the worker processes")
        progress(0.25, "participant P01: day 1 of 4 done")
        progress(0.5, "participant P01: day 2 of 4 done")

    job, _ = runner.start("k", work)
    assert job.wait(10)
    elapsed, fraction = job.first_step
    assert fraction == 0.25 and 0 <= elapsed <= job.elapsed
    assert job.snapshot()["first_step"] == (elapsed, 0.25)
    assert JobRunner().start("idle", lambda progress: None)[0].snapshot()["first_step"] is None


def test_second_start_while_running_returns_the_same_job():
    runner = JobRunner()
    gate = threading.Event()
    calls = []

    def work(progress):
        calls.append(1)
        gate.wait(10)
        return "ok"

    first, started1 = runner.start("adapt:P01:1", work)
    second, started2 = runner.start("adapt:P01:1", work)
    assert started1 and not started2 and second is first
    other, started3 = runner.start("adapt:P02:1", work)
    assert started3 and other is not first
    assert len(runner.running()) == 2
    gate.set()
    assert first.wait(10) and other.wait(10)
    assert len(calls) == 2
    # once ended, the same key starts new work
    again, started4 = runner.start("adapt:P01:1", work)
    assert started4 and again is not first
    assert again.wait(10)


def test_failure_is_reported_not_raised():
    runner = JobRunner()

    def work(progress):
        progress(0.5, "half way")
        raise ValueError("participant P09 does not exist")

    job, _ = runner.start("bad", work)
    assert job.wait(10)
    assert job.status == FAILED
    assert job.error == "participant P09 does not exist"
    assert job.result is None
    runner.forget("bad")
    assert runner.get("bad") is None


def test_a_stopped_job_ends_at_its_next_progress_report_and_keeps_nothing(tmp_path):
    runner = JobRunner()
    started = threading.Event()
    out = tmp_path / "model.pt"

    def work(progress):
        for i in range(10_000):
            progress(i / 10_000, f"epoch {i}")
            started.set()
            threading.Event().wait(0.01)
        out.write_bytes(b"trained")  # written only at the end, like the trainers
        return "ok"

    job, _ = runner.start("train-sound", work, label="Training")
    assert started.wait(10)
    assert runner.stop("train-sound") and job.stopping
    assert job.wait(10)
    assert job.status == STOPPED and job.result is None and job.error is None
    assert job.log[-1] == "stopped on request"
    assert not out.exists()
    assert not runner.stop("train-sound")  # nothing runs under that key any more
    assert not runner.stop("no-such-job")
    again, started_again = runner.start("train-sound", lambda progress: "ok")  # the key is free again
    assert started_again and again.wait(10) and again.status == DONE


def test_a_failed_job_keeps_its_exception_for_the_page_to_tell_kinds_apart():
    """The Adaptation page tells a day another tab adapted first (AlreadyAdapted: nothing wrong)
    from a failure by the exception's type."""
    from cacas.errors import AlreadyAdapted

    runner = JobRunner()

    def work(progress):
        raise AlreadyAdapted("day 1 of participant P01 is adapted already")

    job, _ = runner.start("twice", work)
    assert job.wait(10)
    assert job.status == FAILED and isinstance(job.exception, AlreadyAdapted)
    assert job.error == "day 1 of participant P01 is adapted already"


def test_a_failed_job_keeps_its_exception_but_not_what_its_work_held():
    """A failed job stays in the runner until the server stops; its exception's traceback kept the work's frames,
    and with them what the work held (a model, tables), for as long: the type and message stay, the frames' locals go,
    those of the exception it was raised from too."""

    class Model:  # stands for a trained model or a table the work held when it failed
        pass

    held = []

    def work(progress):
        model = Model()
        held.append(weakref.ref(model))
        try:
            raise KeyError("the table lacks column 'day'")
        except KeyError as exc:
            other = Model()
            held.append(weakref.ref(other))
            raise ValueError("the adaptation failed") from exc

    runner = JobRunner()
    job, _ = runner.start("fails", work)
    assert job.wait(10)
    del work
    gc.collect()
    assert job.status == FAILED and isinstance(job.exception, ValueError) and job.error == "the adaptation failed"
    assert isinstance(job.exception.__cause__, KeyError)
    assert job.log[-1] == "ValueError: the adaptation failed"
    assert [ref() for ref in held] == [None, None]


def test_details_are_kept_for_the_pages_and_not_handed_to_the_work():
    runner = JobRunner()
    seen = {}

    def work(progress, **kwargs):
        seen.update(kwargs)
        return "ok"

    job, _ = runner.start("sim", work, label="Simulating", details={"sim-days": 3}, seed=1)
    assert job.wait(10) and job.status == DONE
    assert job.details == {"sim-days": 3} and seen == {"seed": 1}
    assert runner.start("other", work)[0].details is None


def test_work_ending_with_a_base_exception_fails_and_its_key_can_start_again():
    """A SystemExit (not an Exception) in the work left the job "running" forever: the same key then
    returned that job at every start, and the page waited for it for good."""
    import sys

    runner = JobRunner()

    def work(progress):
        progress(0.5, "half way")
        sys.exit("a library gave up")

    job, _ = runner.start("k", work)
    assert job.wait(10)
    assert job.status == FAILED and not job.running and job.error == "a library gave up"
    assert runner.running() == []
    again, started = runner.start("k", lambda progress: 42)
    assert started and again is not job and again.wait(10) and again.result == 42


def test_a_jobs_elapsed_time_is_not_moved_by_the_wall_clock(monkeypatch):
    """The clock set back an hour during a job (a laptop's clock synchronised, a virtual machine resumed) made its
    elapsed time -3595 s: the time left and "took ..." came from it. Elapsed time is the monotonic clock's; the wall
    clock says only when the job ended (short_time)."""
    from types import SimpleNamespace

    from cacas import jobs

    clock = {"wall": 1_800_000_000.0, "steady": 100.0}
    monkeypatch.setattr(jobs, "time", SimpleNamespace(time=lambda: clock["wall"], monotonic=lambda: clock["steady"]))
    go, seen = threading.Event(), {}

    def work(progress):
        go.wait(10)
        progress(0.5, "half way")
        seen["elapsed"] = job.elapsed

    job, _ = JobRunner().start("k", work)
    clock["wall"] -= 3600 - 5  # five seconds later, by a clock set back an hour
    clock["steady"] += 5
    go.set()
    assert job.wait(10)
    assert seen["elapsed"] == 5 and job.first_step == (5, 0.5)
    clock["wall"] += 60  # once ended, its elapsed time stays
    clock["steady"] += 60
    assert job.elapsed == 5 and job.snapshot()["elapsed"] == 5
    assert job.finished == 1_800_000_000.0 - 3595  # when it ended, by the wall clock
