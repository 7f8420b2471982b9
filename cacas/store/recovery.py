"""What a process killed in the middle of a removal or an import leaves beside a study database,
put right when the database is next opened for writing.

* A participant's removal moves their policy files to ``policies/.removed-<code>-<pid>-<ns>/``
  inside its transaction, and deletes that folder once the transaction has committed. Killed in
  between, the files are in that folder: those a study database in the folder still names (the
  transaction did not commit) go back where they were; the others (it did) are deleted, as the
  removal promised. If a study database beside it cannot be read, the folder is kept.
* An import builds the database as ``.<name>.importing-<pid>`` beside its target and renames it
  when complete. Killed, that hidden file stays: a copy of the bundle's study data (the
  participants' interactions among them) that a later removal cannot reach. It is deleted.
* A policy file is written before the row that names it (``save_policy``, a day's adaptation;
  an import writes the bundle's files before it links the new database into place). Killed in
  between, the file stays in ``policies/<code>/`` with no row naming it, where only the
  participant's removal would reach it. Each writer leaves a marker beside the file while it
  writes (:func:`saving`); a marker left behind names a file whose save was cut short: the file
  is deleted unless a study database in the folder names it (in any letter case, where the file
  system does not tell letter case apart: ``policies/p01/`` is then ``policies/P01/``). A file no row names without such a
  marker (of a database moved out of the folder, say) is left alone: nothing says it is unused.
* A removal's moves are synced to disk before its transaction commits, but a power cut on a
  file system that loses them anyway (or a removal by a version that did not sync them) brings
  the withdrawn participant's files back to ``policies/<code>/`` with no row naming them. Files
  there that are older than the removal this database recorded for ``code`` (its
  "remove_participant" event), when no study database in the folder holds a participant ``code``
  (in any letter case) or names the file, are deleted (:func:`delete_withdrawn_files`).

Only what is no longer being worked on is touched: a removal or an import holds a kernel lock
(``flock``; on Windows ``msvcrt.locking``) on a lock file of its own while it runs (:func:`busy`),
which the kernel releases when the process ends, however it ends; another process, or another
thread, cannot take it meanwhile. (A process id in a name is not enough: after a restart another process may have it,
and in another container a running process looks gone.) Policy files' writers, of any database
in the folder (``policies/`` is shared), hold a shared lock on the ``policies`` folder from
before the file is written until its row is committed (or the file removed again); markers are
read only with that lock taken exclusively, when no writer is between its file and its row.
Windows opens no folder as a file, so there a policy file whose save or removal was cut short
(the last two points) is left as it is.
"""

from __future__ import annotations

import contextlib
import glob
import json
import os
import re
import shutil
import time
from pathlib import Path

from cacas.errors import CacasError
from cacas.store import files

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: msvcrt's locks for removals and imports (below)
    fcntl = None
try:  # Windows: a lock on the lock file's first byte (msvcrt.locking), which Windows releases when the process ends
    import msvcrt
except ImportError:
    msvcrt = None

#: The lock file a removal keeps in its folder of moved-aside files.
REMOVAL_LOCK = ".busy"
_REMOVAL = re.compile(r"\.removed-(?P<code>.+)-\d+-\d+")
_IMPORT = re.compile(r"(?P<base>\..+\.importing-\d+)(?:-wal|-shm|-journal|-writer\.lock|-busy\.lock)?")


def import_lock(tmp: Path) -> Path:
    """The lock file an import holds while it builds ``tmp`` (its hidden database)."""
    return Path(f"{tmp}-busy.lock")


def _lock(fd: int, wait: bool = True) -> None:
    """An exclusive kernel lock on the lock file open as ``fd``: ``flock``, or on Windows (no
    ``fcntl``) ``msvcrt.locking`` of its first byte, as Python's documentation describes it (retried
    while another holds it, when ``wait``); nothing where neither is (then nothing is put right
    at opening). Not waiting, OSError while another holds it."""
    if fcntl is not None:
        fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    elif msvcrt is not None:
        while True:
            try:
                msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
                return
            except OSError:
                if not wait:
                    raise
                time.sleep(0.05)


def _unlock(fd: int) -> None:
    """Release :func:`_lock` before ``fd`` is closed: flock's goes with the descriptor, but Microsoft
    says a byte-range lock closed with its file may stay a while, and asks that it be released first."""
    if fcntl is None and msvcrt is not None:
        try:
            msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)
        except OSError:  # pragma: no cover - not locked (the lock was never taken)
            pass


@contextlib.contextmanager
def busy(lock: Path):
    """Hold an exclusive kernel lock on ``lock`` (created if missing) for the ``with`` block
    (:func:`_lock`: ``flock``, or Windows' ``msvcrt.locking``): what :func:`tidy` finds locked is
    left alone."""
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o600)
    locked = False
    try:
        _lock(fd)
        locked = True
        yield
    finally:
        if locked:
            _unlock(fd)
        os.close(fd)  # releases the flock (flock locks, unlike POSIX ones, belong to this descriptor)


def _abandoned(lock: Path) -> bool:
    """Nobody holds ``lock``: the work it guarded ended, or was killed. Without a lock file (or
    without kernel locks) nothing is known, and nothing is touched. On Windows, with
    ``msvcrt.locking``: a removal or an import killed there was never put right (its withdrawn
    participant's files stayed in ``.removed-<code>-...``, or a rolled-back one's away from home)."""
    if (fcntl is None and msvcrt is None) or not lock.is_file():
        return False
    try:
        fd = os.open(lock, os.O_RDWR)
    except OSError:
        return False
    try:
        _lock(fd, wait=False)
    except OSError:
        os.close(fd)
        return False  # held: a removal or an import running now
    _unlock(fd)
    os.close(fd)
    return True


#: The marker a policy file's writer keeps beside it, from before the file is written until its
#: row is committed: ``.<file name>.<pid>.saving`` (:func:`saving`).
_SAVING = re.compile(r"\.(?P<name>.+)\.(?P<pid>\d+)\.saving")


@contextlib.contextmanager
def saving(policy_dir: Path):
    """``with saving(store.policy_dir) as mark:``, around writing policy files and committing the
    rows that name them: holds a shared ``flock`` on the policies folder, and ``mark(path)``, called
    before ``path`` is written, leaves a marker beside it until the block ends. A process killed
    inside the block leaves its markers, and :func:`delete_unsaved_policy_files` (which takes the
    lock exclusively, so never while a writer is inside) deletes the files no row names. Best
    effort: a folder that cannot be created writes no marker (the write then fails on its own,
    with its own message); one that cannot be locked (a file system without ``flock``) writes no
    marker either, and the save goes ahead: killed before its row, its file is left as before."""
    markers: list[Path] = []
    fd = None
    try:
        policy_dir.mkdir(parents=True, exist_ok=True)
        fd = os.open(policy_dir, os.O_RDONLY)
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_SH)  # waits while a cleanup holds it
    except BaseException as exc:  # OSError: no marker; Ctrl-C while waiting: the descriptor is closed too
        if fd is not None:
            os.close(fd)
        fd = None
        if not isinstance(exc, OSError):
            raise

    def mark(path: Path) -> None:
        if fd is None:
            return
        marker = Path(path).with_name(f".{Path(path).name}.{os.getpid()}.saving")
        try:
            marker.parent.mkdir(parents=True, exist_ok=True)
            marker.touch()
        except OSError:
            return
        markers.append(marker)

    try:
        yield mark
    finally:
        for marker in markers:  # before the lock is released: a marker seen under the lock is abandoned
            try:
                marker.unlink(missing_ok=True)
                marker.parent.rmdir()  # a participant's folder a failed write left empty
            except OSError:  # it holds files (or it is gone)
                pass
        if fd is not None:
            os.close(fd)  # releases the flock


@contextlib.contextmanager
def _policies_locked(folder: Path):
    """The policies folder's lock (which :func:`saving` holds, shared, while a policy file is
    written), taken exclusively without waiting; yields whether it was taken (False: a policy
    file is being written now, or the folder cannot be opened), released on leaving."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        yield False
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            yield False
            return
        yield True
    finally:
        os.close(fd)  # releases the flock


def delete_unsaved_policy_files(store) -> list[Path]:
    """Delete the policy files whose save or import was killed before a row named them (module
    docstring): those a marker left by :func:`saving` names, unless a study database in the folder
    names them (compared ignoring letter case where the file system does: :func:`files.ignores_letter_case`;
    none is deleted while one there cannot be read), with the markers and the
    writer's temporary file; returns the files deleted. Nothing is done while a writer holds the
    policies folder's lock (it is left for the next opening)."""
    folder = store.policy_dir
    if fcntl is None or not folder.is_dir():
        return []

    def markers() -> list[Path]:
        return [m for m in sorted(folder.glob("*/.*.saving"))
                if not m.parent.name.startswith(".") and _SAVING.fullmatch(m.name) and m.is_file()]

    if not markers():  # most openings: nothing was cut short
        return []
    gone: list[Path] = []
    with _policies_locked(folder) as locked:
        if not locked:
            return []  # a policy file is being written now
        beside = store._named_beside("")
        if beside is None:  # a study database beside that cannot be read may name any of them
            return []
        # where letter case is not told apart, P01's and p01's files share one folder, which a marker's
        # path names in the disk's letter case, not always its row's (safety audit L4)
        fold = str.casefold if files.ignores_letter_case(folder) else str
        named = {fold(path) for path in beside | {row[0] for row in store._read(
            lambda c: c.execute("SELECT path FROM policies").fetchall())}}
        found = markers()
        for marker in found:
            m = _SAVING.fullmatch(marker.name)
            policy = marker.with_name(m["name"])
            tmp = marker.with_name(f".{m['name']}.{m['pid']}.tmp")  # files.atomic_write's, if killed inside it
            unsaved = [] if fold(policy.relative_to(folder).as_posix()) in named else [policy]
            for f in [*unsaved, tmp]:
                if f.is_file():
                    f.unlink()
                    gone.append(f)
            marker.unlink(missing_ok=True)
        for parent in sorted({m.parent for m in found}):
            try:
                parent.rmdir()  # a participant's folder left empty
            except OSError:
                pass
        return gone


def _epoch_ns(stamp: str) -> int | None:
    """A :func:`cacas.store.validate.now` time stamp (UTC) as nanoseconds since the epoch."""
    import datetime as dt

    try:
        when = dt.datetime.fromisoformat(str(stamp).replace("Z", "+00:00"))
    except ValueError:
        return None
    if when.tzinfo is None:
        when = when.replace(tzinfo=dt.timezone.utc)
    return int(when.timestamp() * 1_000_000) * 1000


def delete_withdrawn_files(store) -> list[Path]:
    """Delete the files a withdrawn participant's removal deleted and a power cut brought back
    (module docstring): under ``policies/<code>/`` for a code this database recorded a removal of,
    when no study database in the folder (this one included) holds a participant of that code in
    any letter case, those no study database names and last modified before the removal. Nothing
    is deleted while a study database in the folder cannot be read (it may hold the code), or while
    a policy file is being written (the policies folder's lock). Returns the files deleted."""
    folder = store.policy_dir
    if fcntl is None or not folder.is_dir():
        return []
    removed: dict[str, int] = {}  # code -> when its latest removal was recorded
    for at, details in store._read(lambda c: c.execute(
            "SELECT at, details FROM events WHERE what = 'remove_participant' ORDER BY id").fetchall()):
        try:
            code = json.loads(details).get("code")
        except (TypeError, ValueError, AttributeError):
            continue
        when = _epoch_ns(at)
        if isinstance(code, str) and when is not None:
            removed[code] = when
    left = [d for d in sorted(folder.iterdir()) if d.name in removed and d.is_dir() and not d.name.startswith(".")]
    if not left:  # most openings: no withdrawn participant's folder is there
        return []
    gone: list[Path] = []
    with _policies_locked(folder) as locked:
        if not locked:
            return []  # a policy file is being written now: left for the next opening
        codes, unreadable = store._read_beside("SELECT code FROM participants")
        named, unreadable_too = store._read_beside("SELECT path FROM policies")
        if unreadable or unreadable_too:
            return []
        here = store._read(lambda c: (c.execute("SELECT code FROM participants").fetchall(),
                                      c.execute("SELECT path FROM policies").fetchall()))
        held = {str(code).casefold() for found in [*codes.values(), {r[0] for r in here[0]}] for code in found}
        names = {str(p).casefold() for found in [*named.values(), {r[0] for r in here[1]}] for p in found}
        for where in left:
            if where.name.casefold() in held:
                continue  # a participant of that code (again, or in another database): theirs
            for f in sorted(p for p in where.rglob("*") if p.is_file()):
                try:
                    if (f.relative_to(folder).as_posix().casefold() in names
                            or f.stat().st_mtime_ns > removed[where.name]):
                        continue  # named, or written after the removal: not what it deleted
                    f.unlink()
                except OSError:
                    continue
                gone.append(f)
            files.remove_empty([*(d for d in where.rglob("*") if d.is_dir()), where])
        if gone:
            files.fsync_folder(folder)
        return gone


def finish_interrupted_removals(store) -> list[Path]:
    """Put back or delete the files of removals killed mid-way (module docstring); returns the
    folders dealt with."""
    done = []
    if not store.policy_dir.is_dir():
        return done
    for trash in sorted(store.policy_dir.glob(".removed-*")):
        m = _REMOVAL.fullmatch(trash.name)
        if not m or not trash.is_dir() or not _abandoned(trash / REMOVAL_LOCK):
            continue
        code = m["code"]
        beside = store._named_beside(code)
        if beside is None:  # a study database that cannot be read now: nothing is certain to be unused
            continue
        here = {row[0] for row in store._read(lambda c: c.execute("SELECT path FROM policies").fetchall())}
        for f in sorted(p for p in trash.rglob("*") if p.is_file() and p.name != REMOVAL_LOCK):
            rel = f"{code}/{f.relative_to(trash).as_posix()}"
            home = store.policy_dir / rel
            if rel in here | beside and not home.exists():
                home.parent.mkdir(parents=True, exist_ok=True)
                os.replace(f, home)
        shutil.rmtree(trash, ignore_errors=True)
        done.append(trash)
    return done


def delete_abandoned_imports(folder: Path) -> list[Path]:
    """Delete the hidden databases (and their SQLite and lock files) of imports killed mid-way in
    ``folder`` (module docstring); returns the files deleted."""
    gone = []
    bases = {m["base"] for m in (_IMPORT.fullmatch(f.name) for f in Path(folder).glob(".*.importing-*")) if m}
    for base in sorted(bases):
        if not _abandoned(import_lock(Path(folder) / base)):
            continue
        for f in sorted(Path(folder).glob(f"{glob.escape(base)}*")):
            m = _IMPORT.fullmatch(f.name)
            if m and m["base"] == base and f.is_file():
                f.unlink(missing_ok=True)
                gone.append(f)
    return gone


def adopt_policies_beside_link(store) -> list[Path]:
    """A database opened through a symbolic link in another folder kept its policy files beside
    the link until session 19 (they are beside the file now): those it names and misses beside the
    file are moved there. Returns the files moved."""
    link_dir = store.opened_as.parent / "policies"
    if store.opened_as.parent.resolve() == store.path.parent or not link_dir.is_dir():
        return []
    moved = []
    for (rel,) in store._read(lambda c: c.execute("SELECT path FROM policies").fetchall()):
        old, new = link_dir / rel, store.policy_dir / rel
        if old.is_file() and not new.exists():
            new.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(old, new)
            moved.append(new)
    return moved


def tidy(store) -> None:
    """All of the above, for a database just opened for writing; best effort (what cannot be
    done now is left for the next opening)."""
    try:
        adopt_policies_beside_link(store)
        delete_abandoned_imports(store.path.parent)
        finish_interrupted_removals(store)
        delete_unsaved_policy_files(store)  # after the imports: a killed import's database names its files
        delete_withdrawn_files(store)
    except (OSError, CacasError):
        pass
