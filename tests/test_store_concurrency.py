"""Safety of the study database (issue 4, item 2): a writer killed with SIGKILL loses no
acknowledged interaction; several processes (and threads) writing at once lose and mix nothing."""

import os
import signal
import sqlite3
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from cacas.errors import CacasError
from cacas.store import StudyStore

ROOT = Path(__file__).resolve().parents[1]

# A writer process: records interactions for one participant/day and prints each returned row id
# (the acknowledgement the page would show) as soon as the call returns.
WRITER = r"""
import os, sys, time
from cacas.store import StudyStore
path, who, day, n, tag = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
go = sys.argv[6] if len(sys.argv) > 6 else None
store = StudyStore(path)
if go:  # start together with the other writers
    print("ready", flush=True)
    while not os.path.exists(go):
        time.sleep(0.001)
acts = ["cough", "sneeze", "use stove", "watch TV"]
for i in range(n):
    rid = store.record_interaction(who, day, activity=acts[i % 4], scene="kitchen", hour=(i % 24),
                                   interval_minutes=i % 300, robot_action="chitchat",
                                   response=["accept", "reject", "others"][i % 3],
                                   time=f"2026-01-01T00:00:00.000Z", method=tag)
    print(rid, flush=True)
print("done", flush=True)
"""


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _writer(path, who, day, n, tag, go=None):
    extra = [str(go)] if go else []
    return subprocess.Popen([sys.executable, "-c", WRITER, str(path), who, str(day), str(n), tag, *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())


def _setup(path, *codes):
    with StudyStore(path) as s:
        for c in codes:
            s.add_participant(c)
            s.open_day(c)


def test_sigkill_mid_stream_keeps_every_acknowledged_interaction(tmp_path):
    path = tmp_path / "study.sqlite"
    _setup(path, "P01")
    proc = _writer(path, "P01", 1, 100_000, "cacas")
    acked = []
    try:
        for line in proc.stdout:
            acked.append(int(line))
            if len(acked) == 300:
                proc.send_signal(signal.SIGKILL)  # while it is writing the next ones
                break
    finally:
        proc.kill()
        proc.wait(timeout=30)
        # lines printed between our last read and the kill were acknowledged too
        acked += [int(x) for x in proc.stdout.read().split() if x.isdigit()]
    assert proc.returncode == -signal.SIGKILL
    assert len(acked) >= 300
    con = sqlite3.connect(path)
    try:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        ids = {r[0] for r in con.execute("SELECT id FROM interactions")}
        idx = [r[0] for r in con.execute("SELECT idx FROM interactions ORDER BY id")]
    finally:
        con.close()
    assert set(acked) <= ids
    assert idx == list(range(1, len(idx) + 1))  # no gap, no half-written row
    with StudyStore(path) as s:  # and the study carries on
        info = s.resume("P01")
        assert info.interactions_today == len(ids)
        s.record_interaction("P01", 1, activity="cough", scene="bedroom", hour=8, interval_minutes=0,
                             robot_action="pain check", response="accept")
        assert s.resume("P01").total_interactions == len(ids) + 1


def test_two_processes_writing_at_once_lose_nothing(tmp_path):
    path = tmp_path / "study.sqlite"
    _setup(path, "P01", "P02")
    n, go = 300, tmp_path / "go"
    procs = {tag: _writer(path, who, 1, n, f"writer-{tag}", go)
             for tag, who in (("a", "P01"), ("b", "P01"), ("c", "P02"))}
    for proc in procs.values():
        assert proc.stdout.readline().strip() == "ready"
    go.touch()
    acked = {}
    for tag, proc in procs.items():
        out, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
        lines = out.split()
        assert lines[-1] == "done"
        acked[tag] = [int(x) for x in lines[:-1]]
    # they did write at the same time: each one's rows interleave with the others'
    assert min(acked["a"]) < max(acked["b"]) and min(acked["b"]) < max(acked["a"])
    with StudyStore(path) as s:
        df = s.interactions_frame(method=None)
        rows = s._conn.execute("SELECT id, method FROM interactions").fetchall()
    assert len(df) == 3 * n
    by_method = {}
    for rid, method in rows:
        by_method.setdefault(method, set()).add(rid)
    for tag in procs:
        assert by_method[f"writer-{tag}"] == set(acked[tag])
    p1 = df[df["participant"] == "P01"]
    assert sorted(p1["index"]) == list(range(1, 2 * n + 1))  # one shared day, indices never collide
    for tag in ("a", "b"):  # each writer's rows in its own order
        own = p1[p1["method"] == f"writer-{tag}"]
        assert own["index"].is_monotonic_increasing
        assert own["activity"].tolist() == [["cough", "sneeze", "use stove", "watch TV"][i % 4] for i in range(n)]
    assert sorted(df[df["participant"] == "P02"]["index"]) == list(range(1, n + 1))


def test_one_store_shared_by_threads(tmp_path):
    store = StudyStore(tmp_path / "study.sqlite")
    store.add_participant("P01")
    day = store.open_day("P01")
    errors = []

    def work(k):
        try:
            for i in range(50):
                store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=k,
                                         interval_minutes=i, robot_action="pain check", response="accept")
                store.resume("P01")
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert store.resume("P01").interactions_today == 200
    assert sorted(store.interactions_frame("P01")["index"]) == list(range(1, 201))
    store.close()


def _in_another_process(code: str, path: Path) -> str:
    out = subprocess.run([sys.executable, "-c", code, str(path)], env=_env(), capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip()


COUNT = r"""
import sys
from cacas.store import StudyStore
with StudyStore(sys.argv[1], readonly=True) as s:
    print(len(s.interactions_frame(None, method=None)))
"""


def test_opening_the_database_again_in_a_process_keeps_its_locks(tmp_path):
    """Every new StudyStore read the file's header with open() and close(); closing any descriptor
    of a file drops all of the process's POSIX locks on it, SQLite's included (sqlite.org
    "How To Corrupt" 2.2). An adaptation (a second StudyStore in the server), then any other
    process closing its connection (`cacas export`), and that process took itself for the last
    one: it removed the WAL, and every answer the app wrote afterwards went to a deleted file while
    the tablet said "Saved" (helper's walkthrough: 38 answers lost at the next restart)."""
    path = tmp_path / "study.sqlite"
    app = StudyStore(path)  # the server's own store, open all along
    app.add_participant("P01")
    day = app.open_day("P01")
    kw = dict(activity="cough", scene="bedroom", hour=8, interval_minutes=5, robot_action="pain check",
              response="accept")
    app.record_interaction("P01", day, **kw)
    for readonly in (False, True):  # an adaptation's store, and a read-only one (the store's own checks)
        StudyStore(path, readonly=readonly).close()
    assert _in_another_process(COUNT, path) == "1"  # `cacas export`: opens, reads, closes
    assert Path(f"{path}-wal").exists()  # the app's connection still holds it
    app.record_interaction("P01", day, **kw)  # acknowledged to the participant
    assert _in_another_process(COUNT, path) == "2"
    app.close()
    assert _in_another_process(COUNT, path) == "2"


# --- one write transaction meeting a busy database (store.db.transact) ------------------------------

def _tries(conn):
    return [n for (n,) in conn.execute("SELECT name FROM studies WHERE name LIKE 'try%' ORDER BY name")]


def test_a_transaction_that_meets_a_busy_database_is_retried_whole(tmp_path, monkeypatch):
    """SQLITE_BUSY inside a transaction: what it wrote is rolled back and the whole transaction
    runs again (another writer between two attempts sees neither half)."""
    from cacas.store import db
    monkeypatch.setattr(db.time, "sleep", lambda s: None)
    conn = db.connect(tmp_path / "study.sqlite")
    attempts = []

    def fn(c):
        attempts.append(len(attempts))
        c.execute("INSERT INTO studies (name, description, created_at) VALUES (?, '', '')", (f"try{len(attempts)}",))
        if len(attempts) < 3:
            raise sqlite3.OperationalError("database is locked")
        return "committed"

    assert db.transact(conn, fn) == "committed"
    assert _tries(conn) == ["try3"] and not conn.in_transaction
    conn.close()


def test_a_database_busy_beyond_the_retries_is_one_message_and_writes_nothing(tmp_path, monkeypatch):
    from cacas.store import db
    monkeypatch.setattr(db.time, "sleep", lambda s: None)
    conn = db.connect(tmp_path / "study.sqlite")
    attempts = []

    def fn(c):
        attempts.append(1)
        c.execute("INSERT INTO studies (name, description, created_at) VALUES ('try', '', '')")
        raise sqlite3.OperationalError("database is locked")

    with pytest.raises(CacasError, match=r"^the study database is busy \(database is locked\); try again$"):
        db.transact(conn, fn)
    assert len(attempts) == db.WRITE_RETRIES + 1 and _tries(conn) == []

    def disk_full(c):
        attempts.append(1)
        c.execute("INSERT INTO studies (name, description, created_at) VALUES ('try', '', '')")
        raise sqlite3.OperationalError("database or disk is full")

    attempts.clear()
    with pytest.raises(CacasError, match=r"^the study database cannot be written \(database or disk is full\); "
                                         r"nothing was saved"):
        db.transact(conn, disk_full)
    assert len(attempts) == 1 and _tries(conn) == []  # not retried: waiting does not free a disk
    conn.close()


def test_a_write_waits_for_another_writers_transaction(tmp_path, monkeypatch):
    """BEGIN IMMEDIATE refused while another connection writes: retried after a pause, and
    written once the other has committed."""
    from cacas.store import db
    path = tmp_path / "study.sqlite"
    conn = db.connect(path)
    conn.execute("PRAGMA busy_timeout = 0")  # SQLite's own wait off: the retry is what is tested
    other = sqlite3.connect(path, isolation_level=None)
    other.execute("BEGIN IMMEDIATE")
    pauses = []

    def pause(seconds):
        pauses.append(seconds)
        if len(pauses) == 2:
            other.execute("COMMIT")

    monkeypatch.setattr(db.time, "sleep", pause)
    db.transact(conn, lambda c: c.execute("INSERT INTO studies (name, description, created_at) VALUES ('try', '', '')"))
    assert len(pauses) == 2 and _tries(conn) == ["try"]
    other.execute("BEGIN IMMEDIATE")
    monkeypatch.setattr(db.time, "sleep", lambda s: None)
    with pytest.raises(CacasError, match=r"^the study database is busy \(database is locked\); try again$"):
        db.transact(conn, lambda c: c.execute("INSERT INTO studies (name, description, created_at) "
                                              "VALUES ('try2', '', '')"))
    other.execute("ROLLBACK")
    assert _tries(conn) == ["try"]
    other.close()
    conn.close()
