"""Connections to the study database: recognising the file, pragmas, short write transactions.

Safety (issue 4): every write runs in one short ``BEGIN IMMEDIATE`` transaction that is committed
before the call returns, with ``synchronous=FULL`` in WAL mode, so an acknowledged write survives
the writer being killed. Several processes may read and write at once: WAL lets readers run next
to one writer, ``busy_timeout`` makes a writer wait for the lock, and a transaction that still
meets SQLITE_BUSY is rolled back and retried whole (it wrote nothing).
"""

from __future__ import annotations

import os
import random
import sqlite3
import time
from pathlib import Path
from typing import Callable, TypeVar

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

from cacas.errors import CacasError
from cacas.store.schema import APPLICATION_ID, SCHEMA_VERSION, TABLES, migrate

T = TypeVar("T")

#: How long one statement waits for another process's lock (milliseconds).
BUSY_TIMEOUT_MS = 10_000
#: How often a whole write transaction is retried after SQLITE_BUSY / "database is locked".
WRITE_RETRIES = 8


#: Files SQLite keeps beside a database (and this package's writer lock): never databases themselves.
SIDECARS = ("-wal", "-shm", "-journal", "-writer.lock")


def is_sidecar(path: Path) -> bool:
    """A file SQLite (or :class:`WriterQueue`) keeps beside a database: not to be opened as one."""
    return Path(path).name.endswith(SIDECARS)


class NotAStudyDatabase(CacasError):
    """The file is not a CACAS study database (missing, a folder, a file SQLite keeps beside a
    database, not SQLite, another application's), as opposed to one that cannot be read now."""


def open_study_file(path: Path) -> sqlite3.Connection:
    """A read-only connection (:func:`_open_for_reading`) to ``path`` once it is known to be a
    CACAS study database (its application_id); else :class:`NotAStudyDatabase`, or CacasError
    for a study database that cannot be read, naming the file.

    The file is read through SQLite alone, never with a descriptor of our own: closing any
    descriptor of a file drops every POSIX lock the process holds on it, SQLite's included
    (sqlite.org, "How To Corrupt An SQLite Database File", 2.2). A header read with open() while
    the app held the database open let the next process that closed a connection (``cacas
    export``) take itself for the last one and remove the WAL, and the app's later answers went to
    a deleted file. SQLite's own connections in one process share their locks, so opening and
    closing one here is safe."""
    path = Path(path)
    if not path.exists():
        raise NotAStudyDatabase(f"{path}: no such study database")
    if not path.is_file():
        raise NotAStudyDatabase(f"{path}: is not a file; expected a CACAS study database (.sqlite)")
    if is_sidecar(path):
        raise NotAStudyDatabase(f"{path}: is a file SQLite keeps beside a database, not a study database")
    if path.stat().st_size == 0:
        raise NotAStudyDatabase(f"{path}: is not a study database (not an SQLite file)")
    try:
        conn = _open_for_reading(path)
    except sqlite3.Error as exc:
        raise _unreadable(path, exc) from None
    try:
        app_id = conn.execute("PRAGMA application_id").fetchone()[0]
    except sqlite3.DatabaseError as exc:
        conn.close()
        if _not_sqlite(exc):
            raise NotAStudyDatabase(f"{path}: is not a study database (not an SQLite file)") from None
        if _busy(path, exc):
            raise _busy(path, exc) from None
        raise _unreadable(path, exc) from None
    if app_id != APPLICATION_ID:
        conn.close()
        raise NotAStudyDatabase(f"{path}: is not a study database (an SQLite file of another application)")
    return conn


def _check_whole(conn: sqlite3.Connection) -> None:
    """SQLite's quick_check before anything is written: a file damaged past its first pages opened,
    and then every page showed "database disk image is malformed" (data steward's audit). A damage
    it finds is the same message as one found on opening (a DatabaseError with "malformed")."""
    problems = [r[0] for r in conn.execute("PRAGMA quick_check(3)").fetchall()]
    if problems != ["ok"]:
        said = " ".join("; ".join(problems).split())  # one line: quick_check's lines and indents joined
        raise sqlite3.DatabaseError(f"database disk image is malformed: {said[:200]}")


def _not_sqlite(exc: sqlite3.Error) -> bool:
    return "not a database" in str(exc).lower()


#: What a reading refused by the disk (:func:`disk_trouble`) adds to its message.
_DISK_HINT = ("; the disk may be full, or the file or its folder cannot be written (SQLite writes its -shm file "
              "beside the database to read it): free some disk space (or check the permissions) and try again")


#: What a reading SQLite could not open in a folder that cannot be written adds to its message.
_READ_ONLY_HINT = ("; SQLite writes a -shm file beside a study database to read it, and this folder cannot be "
                   "written (read-only media such as a write-protected USB stick or a DVD, a read-only network share, "
                   "or no permission); copy the folder (the database with the policies folder beside it) to a "
                   "writable place and use the copy")


def _unreadable(path: Path, exc: sqlite3.Error) -> CacasError:
    """The message for a study database SQLite could not read: with what to do when the disk
    refused (:func:`disk_trouble`), or when SQLite could not open its -shm file beside the database
    because the folder cannot be written (safety audit L8: ``cacas export`` of a database on
    read-only media said only "cannot be read (unable to open database file)")."""
    hint = ""
    if disk_trouble(exc):
        hint = _DISK_HINT
    elif "unable to open" in str(exc).lower() and not os.access(path.parent, os.W_OK):
        hint = _READ_ONLY_HINT
    return CacasError(f"{path}: cannot be read ({exc}){hint}")


def disk_trouble(exc: sqlite3.Error) -> bool:
    """SQLite's error says the disk refused a write or a read (a full disk, a file size limit, a
    failing device), not that the file is damaged or another application's: SQLITE_IOERR and
    SQLITE_FULL. Opening a study database in WAL mode writes its -shm file even to read it, so a
    full disk fails it with "disk I/O error" (safety audit: that was called "not a study database")."""
    return any(words in str(exc).lower() for words in ("disk i/o error", "disk is full"))


def _busy(path: Path, exc: sqlite3.Error) -> CacasError | None:
    """The message for opening a study database another connection held locked past the busy
    timeout (quick_check, the switch to WAL, the first read): busy, to try again; None for another
    error. It was called "not a study database (database is locked)" (safety audit L2)."""
    if isinstance(exc, WriteRefused):  # the schema's check (one transaction), retried while busy
        if not exc.busy:
            return None
        exc = exc.__context__ or "database is locked"
    elif not (isinstance(exc, sqlite3.OperationalError) and is_busy(exc)):
        return None
    return CacasError(f"{path}: the study database is busy ({exc}): another program held it for more than "
                      f"{BUSY_TIMEOUT_MS / 1000:g} s while it was being opened; nothing was changed, and the file is "
                      "fine. Try again in a moment, once that program is done with it")


def _configure(conn: sqlite3.Connection, readonly: bool) -> None:
    conn.execute(f"PRAGMA busy_timeout = {BUSY_TIMEOUT_MS}")
    conn.execute("PRAGMA foreign_keys = ON")
    if not readonly:
        conn.execute("PRAGMA synchronous = FULL")


def is_busy(exc: sqlite3.OperationalError) -> bool:
    """SQLite's error says another connection holds the lock (SQLITE_BUSY, "database is locked")."""
    msg = str(exc).lower()
    return "locked" in msg or "busy" in msg


class WriterQueue:
    """A kernel lock (``flock`` on ``<database>-writer.lock``) that writers of this package take
    around each write transaction.

    SQLite's busy handler polls with growing sleeps, so a writer that commits in a tight loop can
    starve another for seconds; waiters blocked on ``flock`` are woken when it is released, which
    keeps every writer's wait near the length of the others' transactions. The lock is released
    by the kernel when a process dies, and SQLite's own locking (busy_timeout + retry) still
    protects against writers that do not take it. Without ``fcntl`` (Windows) it does nothing.
    """

    def __init__(self, db_path: Path):
        self.path = Path(f"{db_path}-writer.lock")
        self._fd = None
        if fcntl is not None:
            try:
                self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError:
                self._fd = None

    def __enter__(self):
        if self._fd is not None:
            fcntl.flock(self._fd, fcntl.LOCK_EX)
        return self

    def __exit__(self, *exc):
        if self._fd is not None:
            fcntl.flock(self._fd, fcntl.LOCK_UN)

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def transact(conn: sqlite3.Connection, fn: Callable[[sqlite3.Connection], T],
             queue: WriterQueue | None = None) -> T:
    """Run ``fn(conn)`` in one ``BEGIN IMMEDIATE`` ... ``COMMIT`` and return its result.

    Any exception rolls everything back (nothing written) and propagates; SQLITE_BUSY is retried
    with a short random back-off, up to :data:`WRITE_RETRIES` times; a write the database
    refuses (still busy, read-only, disk full) becomes one CacasError. With a ``queue``, the
    transaction runs while holding it (see :class:`WriterQueue`).
    """
    if queue is not None:
        with queue:
            return transact(conn, fn)
    for attempt in range(WRITE_RETRIES + 1):
        try:
            conn.execute("BEGIN IMMEDIATE")
        except sqlite3.OperationalError as exc:
            if is_busy(exc) and attempt < WRITE_RETRIES:
                time.sleep(random.uniform(0.005, 0.05) * (attempt + 1))
                continue
            raise refused(exc) from None
        try:
            result = fn(conn)
            conn.execute("COMMIT")
            return result
        except sqlite3.OperationalError as exc:
            conn.execute("ROLLBACK") if conn.in_transaction else None
            if is_busy(exc) and attempt < WRITE_RETRIES:
                time.sleep(random.uniform(0.005, 0.05) * (attempt + 1))
                continue
            raise refused(exc) from None
        except BaseException:
            if conn.in_transaction:
                conn.execute("ROLLBACK")
            raise
    raise AssertionError("unreachable")  # pragma: no cover


class WriteRefused(CacasError):
    """A write the database refused (:func:`transact`): the database's or its disk's doing, not
    the data's (an import says so of the database it builds, not of the bundle). ``busy``: another
    connection held the lock past the retries."""

    busy = False


def refused(exc: sqlite3.Error) -> CacasError:
    """A write the database refused: still busy after the retries, or a read-only file or
    folder, a full disk, a damaged file (a :class:`WriteRefused`)."""
    if is_busy(exc):
        refused = WriteRefused(f"the study database is busy ({exc}); try again")
        refused.busy = True
        return refused
    return WriteRefused(f"the study database cannot be written ({exc}); nothing was saved. Check that its file and "
                        "folder are writable and the disk has room")


def read(conn: sqlite3.Connection, fn: Callable[[sqlite3.Connection], T]) -> T:
    """Run several reads ``fn(conn)`` on one consistent snapshot (a deferred transaction; inside
    an enclosing one, that one's snapshot)."""
    if conn.in_transaction:
        return fn(conn)
    conn.execute("BEGIN")
    try:
        return fn(conn)
    finally:
        conn.execute("COMMIT")


def _init_schema(conn: sqlite3.Connection, path: Path) -> None:
    """Create or migrate the schema (one transaction), or refuse a foreign / newer file."""

    def check_and_migrate(c: sqlite3.Connection) -> bool:
        app_id = c.execute("PRAGMA application_id").fetchone()[0]
        version = c.execute("PRAGMA user_version").fetchone()[0]
        if app_id == APPLICATION_ID:
            if version > SCHEMA_VERSION:
                raise CacasError(f"{path}: study database schema version {version} is newer than this "
                                 f"CACAS Studio understands ({SCHEMA_VERSION}); update CACAS Studio")
            if version == SCHEMA_VERSION:
                return False
            migrate(c, version)
            return True
        tables = c.execute("SELECT count(*) FROM sqlite_master").fetchone()[0]
        if app_id != 0 or version != 0 or tables:
            raise CacasError(f"{path}: is not a study database (an SQLite file of another application)")
        migrate(c, 0)
        return True

    changed = transact(conn, check_and_migrate)
    if changed:
        # the new header (application_id) into the main file at once: a copy of the file alone is
        # recognised too
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")


def _open_for_reading(path: Path) -> sqlite3.Connection:
    """A connection that never creates the file (URI ``mode=rw``, or ``mode=ro`` for a file we
    may not write) and refuses writes (``query_only``). ``mode=rw`` lets SQLite remove the WAL
    index files it needs for reading when the last connection closes, so reading a closed study
    database leaves its folder as it was; the database itself is never changed."""
    uri = path.resolve().as_uri()
    mode = "rw" if os.access(path, os.W_OK) and os.access(path.parent, os.W_OK) else "ro"
    conn = sqlite3.connect(f"{uri}?mode={mode}", uri=True, isolation_level=None, check_same_thread=False,
                           timeout=BUSY_TIMEOUT_MS / 1000)
    conn.execute("PRAGMA query_only = ON")
    return conn


def _migrated_in_memory(conn: sqlite3.Connection) -> sqlite3.Connection:
    """A read-only copy in memory of the older study database open on ``conn``, brought up to
    :data:`SCHEMA_VERSION` there (the file is never changed: ``cacas export`` reads a database
    the app has not opened since an update). ``conn`` is closed."""
    try:
        copy = sqlite3.connect(":memory:", isolation_level=None, check_same_thread=False)
        conn.backup(copy)
    finally:
        conn.close()
    transact(copy, lambda c: migrate(c, c.execute("PRAGMA user_version").fetchone()[0]))
    _configure(copy, readonly=True)
    copy.execute("PRAGMA query_only = ON")
    return copy


def connect(path: Path, readonly: bool = False) -> sqlite3.Connection:
    """Open the study database at ``path``.

    ``readonly=False``: create the file and schema if missing, migrate an older schema, switch
    to WAL. ``readonly=True``: the file must already be a study database; it is opened with
    ``mode=ro`` so nothing is created or changed. Anything else raises CacasError naming the file.
    """
    path = Path(path)
    if readonly:
        conn = open_study_file(path)
        try:
            _configure(conn, readonly=True)
            version = conn.execute("PRAGMA user_version").fetchone()[0]
            names = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        except sqlite3.DatabaseError as exc:
            conn.close()
            raise (_busy(path, exc) or CacasError(f"{path}: cannot be read as a study database ({exc})")) from None
        if not set(TABLES) <= names or not 1 <= version <= SCHEMA_VERSION:
            conn.close()
            remedy = ("it was written by a newer CACAS Studio: update this one" if version > SCHEMA_VERSION
                      else "it is incomplete")
            raise CacasError(f"{path}: study database schema version {version} cannot be read here "
                             f"(this CACAS Studio reads versions 1 to {SCHEMA_VERSION}; {remedy})")
        if version < SCHEMA_VERSION:
            return _migrated_in_memory(conn)
        return conn
    if path.exists():  # a file that is not SQLite's is refused by SQLite itself, unchanged (below)
        if not path.is_file():
            raise CacasError(f"{path}: is not a file; expected a CACAS study database (.sqlite)")
    else:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise CacasError(f"{path}: cannot create its folder ({exc})") from None
    try:
        conn = sqlite3.connect(str(path), isolation_level=None, check_same_thread=False,
                               timeout=BUSY_TIMEOUT_MS / 1000)
    except sqlite3.Error as exc:
        raise CacasError(f"{path}: cannot open the study database ({exc})") from None
    try:
        _configure(conn, readonly=False)
        _check_whole(conn)
        _init_schema(conn, path)
        mode = conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
        if str(mode).lower() != "wal":
            raise CacasError(f"{path}: cannot switch the study database to WAL mode (got {mode})")
    except sqlite3.DatabaseError as exc:
        conn.close()
        if _not_sqlite(exc):
            raise CacasError(f"{path}: is not a study database (not an SQLite file)") from None
        if disk_trouble(exc):  # a full disk: SQLite cannot size the -shm (or -wal) file it needs
            raise CacasError(f"{path}: the study database cannot be opened now ({exc}); nothing was changed. The "
                             "disk may be full, or the file or its folder cannot be written: free some disk space "
                             "(or check the permissions) and open it again; the file is not damaged by this, do not "
                             "replace it") from None
        if _busy(path, exc):  # another connection's lock, past the busy timeout: the file is fine
            raise _busy(path, exc) from None
        if "unable to open" in str(exc) or "readonly" in str(exc):
            raise CacasError(f"{path}: cannot open the study database for writing ({exc}); check that the file and "
                             "its folder are writable") from None
        if "malformed" in str(exc).lower():  # a study database's header, damaged further on (truncated, ...)
            raise CacasError(f"{path}: the database file is damaged ({exc}); nothing was changed. Restore it from "
                             "a backup or an export") from None
        raise CacasError(f"{path}: is not a study database ({exc})") from None
    except WriteRefused as exc:  # the schema's check met the lock through all its retries
        conn.close()
        if exc.busy:
            raise _busy(path, exc) from None
        raise
    except BaseException:
        conn.close()
        raise
    return conn
