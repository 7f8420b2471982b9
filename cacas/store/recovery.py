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

Only what a process no longer running left behind is touched (the process id is in the name).
"""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

from cacas.errors import CacasError

_REMOVAL = re.compile(r"\.removed-(?P<code>.+)-(?P<pid>\d+)-\d+")
_IMPORT = re.compile(r"\..+\.importing-(?P<pid>\d+)(?:-wal|-shm|-journal|-writer\.lock)?")


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def finish_interrupted_removals(store) -> list[Path]:
    """Put back or delete the files of removals killed mid-way (module docstring); returns the
    folders dealt with."""
    done = []
    if not store.policy_dir.is_dir():
        return done
    for trash in sorted(store.policy_dir.glob(".removed-*")):
        m = _REMOVAL.fullmatch(trash.name)
        if not m or not trash.is_dir() or _running(int(m["pid"])):
            continue
        code = m["code"]
        beside = store._named_beside(code)
        if beside is None:  # a study database that cannot be read now: nothing is certain to be unused
            continue
        here = {row[0] for row in store._read(lambda c: c.execute("SELECT path FROM policies").fetchall())}
        for f in sorted(p for p in trash.rglob("*") if p.is_file()):
            rel = f"{code}/{f.relative_to(trash).as_posix()}"
            home = store.policy_dir / rel
            if rel in here | beside and not home.exists():
                home.parent.mkdir(parents=True, exist_ok=True)
                os.replace(f, home)
        shutil.rmtree(trash, ignore_errors=True)
        done.append(trash)
    return done


def delete_abandoned_imports(folder: Path) -> list[Path]:
    """Delete the hidden databases (and their SQLite files) of imports killed mid-way in
    ``folder`` (module docstring); returns the files deleted."""
    gone = []
    for f in sorted(Path(folder).glob(".*.importing-*")):
        m = _IMPORT.fullmatch(f.name)
        if m and f.is_file() and not _running(int(m["pid"])):
            f.unlink(missing_ok=True)
            gone.append(f)
    return gone


def tidy(store) -> None:
    """Both of the above, for a database just opened for writing; best effort (what cannot be
    done now is left for the next opening)."""
    try:
        delete_abandoned_imports(store.path.parent)
        finish_interrupted_removals(store)
    except (OSError, CacasError):
        pass
