"""The plumbing of :class:`cacas.store.StudyStore`: its connection, locks, record types and
the helpers every method group uses (participant and day lookup, the event log)."""

from __future__ import annotations

import contextlib
import json
import os
import sqlite3
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence, TypeVar

import pandas as pd

from cacas import records
from cacas.errors import CacasError, did_you_mean
from cacas.paths import study_data_dir
from cacas.store import db
from cacas.store import validate as v

T = TypeVar("T")

#: The study every database has, so the app works out of the box.
DEFAULT_STUDY = "default"
#: Environment variable that overrides the default database path.
DB_ENV = "CACAS_DB"


def default_db_path() -> Path:
    """``$CACAS_DB`` if set, else ``study_data/cacas.sqlite`` (see :func:`cacas.paths.study_data_dir`)."""
    env = os.environ.get(DB_ENV)
    return Path(env) if env else study_data_dir() / "cacas.sqlite"


@dataclass(frozen=True)
class Study:
    name: str
    description: str
    created_at: str


@dataclass(frozen=True)
class ParticipantInfo:
    """A participant: pseudonymous code, study, age range, notes, the policy version in force."""

    code: str
    study: str
    age_range: str
    notes: str
    active_policy: int | None
    created_at: str
    updated_at: str


@dataclass(frozen=True)
class PersonasImport:
    """What :meth:`StudyStore.import_personas` did with each participant of a persona file (each
    group in the file's order)."""

    codes: tuple[str, ...]             # every participant of the file, in its order
    added: tuple[str, ...] = ()        # new to the study, with the file's preferences
    replaced: tuple[str, ...] = ()     # in the study with other preferences: the file's are their new version
    first: tuple[str, ...] = ()        # in the study without preferences: the file's are their first version
    unchanged: tuple[str, ...] = ()    # the file's preferences are their latest version already: nothing written


@dataclass(frozen=True)
class DayInfo:
    day: int
    opened_at: str
    closed_at: str | None

    @property
    def is_open(self) -> bool:
        return self.closed_at is None


@dataclass(frozen=True)
class PolicyVersion:
    """A policy checkpoint: adapted with ``method`` from days 1..``day`` (0: the initial policy)."""

    version: int
    day: int
    method: str
    path: Path
    sha256: str
    size: int
    created_at: str
    active: bool


@dataclass(frozen=True)
class ResumeInfo:
    """Where a participant's study stands, from the database alone.

    ``day``: the latest study day (0 before the first); ``day_open``: whether it is still open;
    ``interactions_today``: interactions recorded on ``day``; ``total_interactions``: all days;
    ``policy_version``: the policy in force (None: the initial policy).
    """

    day: int
    day_open: bool
    interactions_today: int
    total_interactions: int
    policy_version: int | None


class StoreBase:
    """Connection handling shared by the method groups of StudyStore (see its docstring)."""

    def __init__(self, path: str | Path | None = None, readonly: bool = False):
        # the file itself, not a link to it: its policies/ folder, writer lock and SQLite's -wal and
        # -shm files sit beside it, whichever path (or link) opened it
        self.opened_as = Path(path) if path is not None else default_db_path()
        self.path = self.opened_as.resolve()
        self.readonly = readonly
        #: whether this opening created the database file (the app says so: a mistyped $CACAS_DB
        #: otherwise looked like a study that had lost its participants)
        self.created = not readonly and not self.path.exists()
        self._lock = threading.RLock()
        self._conn = db.connect(self.path, readonly=readonly)
        self._queue = None if readonly else db.WriterQueue(self.path)

    # --- plumbing ------------------------------------------------------------------------------
    @property
    def policy_dir(self) -> Path:
        """Folder of the policy checkpoints, beside the database file."""
        return self.path.parent / "policies"

    def close(self) -> None:
        with self._lock:
            self._conn.close()
            if self._queue is not None:
                self._queue.close()

    def __del__(self):  # a store dropped without close(): release the connection and lock file
        try:
            self.close()
        except Exception:
            pass

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _write(self, fn: Callable[[sqlite3.Connection], T]) -> T:
        if self.readonly:
            raise CacasError(f"{self.path}: opened read-only; nothing was written")
        with self._lock:
            if getattr(self, "_snapshot", False):
                raise RuntimeError("StudyStore.snapshot() is for reads; write outside the with-block")
            return db.transact(self._conn, fn, self._queue)

    @staticmethod
    @contextlib.contextmanager
    def _overwriting(c: sqlite3.Connection):
        """Rows deleted inside the block have their bytes overwritten in the file (SQLite's
        ``secure_delete``), not left in free pages: a participant's withdrawal, a questionnaire answer
        removed (its comments are the participant's words)."""
        c.execute("PRAGMA secure_delete = ON")
        try:
            yield c
        finally:
            c.execute("PRAGMA secure_delete = OFF")

    def _empty_log(self) -> None:
        """After :meth:`_overwriting`'s deletes commit: the write-ahead log's copies of the old pages are
        folded in and the log emptied, when no reader holds it (best effort: the next checkpoint does it)."""
        try:
            with self._lock:
                self._conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        except Exception:  # noqa: BLE001
            pass

    @contextlib.contextmanager
    def snapshot(self):
        """``with store.snapshot(): ...``: every read inside sees the database as it was when the
        block began, even while other processes write (used by the export, so its tables agree).
        Reads only: a write inside raises."""
        with self._lock:
            self._conn.execute("BEGIN")
            self._conn.execute("SELECT COUNT(*) FROM studies").fetchone()  # the snapshot starts here
            self._snapshot = True
            try:
                yield self
            finally:
                self._snapshot = False
                self._conn.execute("COMMIT")

    def data_stamp(self) -> tuple[int, int]:
        """A stamp of the database's contents, for a cache of what is read from it: it changes whenever
        anything is written, by this store or by any other connection or process (a ``cacas import``, a
        comparison's worker processes), and costs two cheap queries. SQLite's ``PRAGMA data_version``
        changes when another connection commits; this connection's own writes are counted by
        ``total_changes`` (rows inserted, updated or deleted since it opened). A write rolled back changes
        the stamp too (a needless re-read, never a stale one)."""
        with self._lock:
            return self._conn.execute("PRAGMA data_version").fetchone()[0], self._conn.total_changes

    def _read(self, fn: Callable[[sqlite3.Connection], T]) -> T:
        with self._lock:
            return db.read(self._conn, fn)

    def _frame(self, sql: str, params: Sequence = ()) -> pd.DataFrame:
        with self._lock:
            cur = self._conn.execute(sql, params)
            cols = [d[0] for d in cur.description]
            return pd.DataFrame(cur.fetchall(), columns=cols)

    @staticmethod
    def _event(c: sqlite3.Connection, what: str, participant: str | None = None, **details: Any) -> None:
        c.execute("INSERT INTO events (at, what, participant, details) VALUES (?, ?, ?, ?)",
                  (v.now(), what, participant, json.dumps(details, sort_keys=True, default=str)))

    @staticmethod
    def _pid(c: sqlite3.Connection, code: Any) -> int:
        row = c.execute("SELECT id FROM participants WHERE code = ?", (str(code).strip(),)).fetchone()
        if row is None:
            known = records.by_code(r[0] for r in c.execute("SELECT code FROM participants"))[:21]
            more = ", ..." if len(known) > 20 else ""
            listed = ", ".join(known[:20]) + more if known else "none yet; add one first"
            twins = [r[0] for r in c.execute("SELECT code FROM participants WHERE code = ? COLLATE NOCASE",
                                             (str(code).strip(),))]
            raise CacasError(f"unknown participant {code!r}; {did_you_mean(code, twins)}known participants: {listed}")
        return row[0]

    @staticmethod
    def _study_id(c: sqlite3.Connection, name: str) -> int:
        row = c.execute("SELECT id FROM studies WHERE name = ?", (name,)).fetchone()
        if row is None:
            names = [r[0] for r in c.execute("SELECT name FROM studies ORDER BY name")]
            raise CacasError(f"unknown study {name!r}; {did_you_mean(name, names)}known studies: {', '.join(names)}")
        return row[0]

    @staticmethod
    def _day_row(c: sqlite3.Connection, pid: int, code: str, day: Any):
        day = v.integer(day, "day", 1)
        row = c.execute("SELECT day, closed_at FROM days WHERE participant_id = ? AND day = ?",
                        (pid, day)).fetchone()
        if row is None:
            last = c.execute("SELECT MAX(day) FROM days WHERE participant_id = ?", (pid,)).fetchone()[0]
            have = f"days 1..{last}" if last else "no day yet; open day 1 first"
            raise CacasError(f"participant {code} has no day {day}; they have {have}")
        return row

    @staticmethod
    def _check_version(c: sqlite3.Connection, pid: int, code: str, version: Any) -> int | None:
        if version is None:
            return None
        version = v.integer(version, "policy version", 1)
        if c.execute("SELECT 1 FROM policies WHERE participant_id = ? AND version = ?",
                     (pid, version)).fetchone() is None:
            have = [r[0] for r in c.execute("SELECT version FROM policies WHERE participant_id = ? "
                                            "ORDER BY version", (pid,))]
            raise CacasError(f"participant {code} has no policy version {version}; saved versions: "
                             f"{', '.join(map(str, have)) or 'none (the initial policy is in force)'}")
        return version
