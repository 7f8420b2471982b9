"""Files written atomically: policy checkpoints (identified by their sha256) and output folders.

A checkpoint (the adapted policy of one participant after one day, CACAA's output, Table III)
is written to a temporary file in the target folder, flushed and fsynced, renamed into place and
the folder fsynced: a reader sees the old state or the whole new file, never part of one.

An output folder (``cacas export --out``, ``cacas simulate --out`` and ``--plot``) is written by
:func:`write_all` with :data:`CHECKSUMS`: each file's sha256, put in place before the files it
lists. A process killed between the renames (``kill -9``, a power cut) leaves files that do not
match it, which :func:`mismatched` finds (``cacas import``, the Results page's upload) and
:func:`remains` says at the next write. A folder that does not exist yet is built beside it and
renamed into place whole: killed, it is not there at all.
"""

from __future__ import annotations

import glob
import hashlib
import os
import shutil
import tempfile
from collections.abc import Iterable
from pathlib import Path

from cacas.errors import CacasError


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def file_sha256(path: Path | str) -> str:
    """The sha256 of a file's bytes (hex), read a block at a time: a study's zip of 0.8 GB (60
    participants x 21 days) is not held in memory to check it."""
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def atomic_write(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via tmp + fsync + rename (+ fsync of the folder). A failure (disk
    full, a folder that cannot be written) raises a CacasError naming the file, and leaves ``path``
    as it was (no temporary file either)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        raise CacasError(f"{path}: cannot be written ({exc.strerror or exc}); nothing was saved. Free some disk "
                         "space, or check that its folder can be written, and try again") from None
    finally:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:  # pragma: no cover - the folder went away meanwhile
            pass
    fsync_folder(path.parent)


def fsync_file(path: Path) -> None:
    """Make a file's content durable (written by another writer: a copy, an image library).
    Opened to write: Windows' ``os.fsync`` (``FlushFileBuffers``) refuses a descriptor opened
    read-only (EBADF), and every file the libraries added failed there; a file that may not be
    written (a copy keeps its source's read-only mode) is synced read-only, as POSIX allows."""
    try:
        fd = os.open(path, os.O_RDWR)
    except PermissionError:
        fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_folder(folder: Path) -> None:
    """Make renames in ``folder`` durable."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - folders cannot be opened on some systems
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def missing_folders(folder) -> list[Path]:
    """``folder`` and those above it that do not exist yet, deepest first: what creating it makes."""
    missing, here = [], Path(folder).absolute()
    while not here.exists() and here != here.parent:
        missing.append(here)
        here = here.parent
    return missing


def remove_empty(folders) -> None:
    """Remove those of ``folders`` that are empty, deepest first (a folder emptied by removing the
    one inside it goes too): the folders a command created, when it fails or is stopped."""
    for folder in sorted(map(Path, folders), key=lambda f: len(f.parts), reverse=True):
        try:
            folder.rmdir()
        except OSError:  # not empty, or gone
            pass


def _nearest_existing(path: Path) -> Path:
    """``path`` or the nearest folder above it that exists."""
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def ignores_letter_case(folder) -> bool:
    """Whether the file system holding ``folder`` (or the nearest folder above it that exists)
    takes names that differ only in letter case for one name, as macOS's and Windows' do by default
    (``policies/P01`` and ``policies/p01`` are then one folder). Found out by creating a hidden
    file with a lower-case name and looking for it in upper case; False if none can be created."""
    where = _nearest_existing(Path(folder).absolute())
    try:
        fd, name = tempfile.mkstemp(prefix=".case-probe-", dir=where)
    except OSError:
        return False
    os.close(fd)
    probe = Path(name)
    try:
        return probe.with_name(probe.name.upper()).exists()
    finally:
        probe.unlink(missing_ok=True)


#: The names Windows keeps for devices, in any letter case and with any extension after the first
#: "." (Microsoft's "Naming Files, Paths, and Namespaces"; Python's ``os.path.isreserved``): a file
#: or folder so named opens the device, or cannot be made ("policies/CON/" for participant CON).
WINDOWS_DEVICE_NAMES = frozenset({"CON", "PRN", "AUX", "NUL", "CONIN$", "CONOUT$",
                                  *(f"{port}{n}" for port in ("COM", "LPT") for n in "123456789\u00b9\u00b2\u00b3")})


def windows_device_name(name: str) -> bool:
    """``name`` (one file or folder name) is one Windows keeps for a device
    (:data:`WINDOWS_DEVICE_NAMES`): "CON", "nul.csv", "Com1.wav"; "CON1" and "icon" are not."""
    return name.split(".", 1)[0].rstrip(" ").upper() in WINDOWS_DEVICE_NAMES


def writable_folder(folder, what: str, create: bool = True, names: Iterable[str] = ()) -> Path:
    """``folder``, created if missing, after checking that files can be written in it; else a
    CacasError naming it (``what``: how the user named it, e.g. "--out results") and the problem:
    it is a file, a file stands where a folder above it would be, it cannot be created (under
    /proc, say) or files cannot be created in it, or it holds a folder where one of the files
    ``names`` is to be written (which no :func:`write_all` can replace: CLI audit, a folder named
    daily.csv refused only after the whole simulation). With ``create=False`` a missing ``folder`` is
    checked the same way (created, written in) and removed again, the folders above it kept: a
    :func:`write_all` into it then puts it in place whole, or not at all."""
    folder = Path(folder)
    if folder.is_dir():
        for name in names:
            if (folder / name).is_dir():
                raise CacasError(f"{what}: holds a folder named {name}, where this run writes its {name}; valid: a "
                                 "folder without it (move or rename that folder), or another folder")
    missing = not os.path.lexists(folder)
    if folder.exists() and not folder.is_dir():
        raise CacasError(f"{what}: is a file; valid: a folder (created if missing)")
    valid = "valid: a folder you can write to (created if missing)"
    existing = _nearest_existing(folder)
    if not existing.is_dir():
        raise CacasError(f"{what}: cannot write in this folder: {existing} is a file, not a folder; {valid}")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CacasError(f"{what}: cannot write in this folder: it cannot be created ({exc.strerror or exc}); "
                         f"{valid}") from None
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        if missing and not create:
            remove_empty([folder])
        raise CacasError(f"{what}: cannot write in this folder ({exc.strerror or exc}); {valid}") from None
    if missing and not create:
        remove_empty([folder])
    return folder


def writable_file(path, what: str, create_folders: bool = True) -> Path:
    """``path``, after checking (before any long work, creating nothing) that a file can be
    written there: it is not a folder, and its folder exists (or, with ``create_folders``, can be
    created: no file stands in the way) and files can be created in it. Else a CacasError naming
    the option and the path the user gave (``what``: the option, e.g. "--model")."""
    path = Path(path)

    def refuse(problem: str) -> CacasError:
        return CacasError(f"{what} {path}: cannot be written there: {problem}; valid: a file path in a "
                          f"folder you can write to")

    if path.is_dir():
        raise refuse("it is a folder; give a file path")
    folder = path.parent
    if not create_folders and not folder.is_dir():
        if folder.exists():
            raise refuse(f"{folder} is a file, not a folder")
        raise refuse(f"the folder {folder} does not exist")
    existing = _nearest_existing(folder)  # the nearest folder there is
    if not existing.is_dir():
        raise refuse(f"{existing} is a file, not a folder")
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as exc:
        raise refuse(f"cannot create files in {existing} ({exc.strerror or exc})") from None
    return path


def _remove_left_over(folder: Path, names) -> None:
    """Remove what an earlier :func:`write_all` of these files left when its process was killed
    (``kill -9``, a power cut): ``.<name>.<pid>.tmp`` and ``.<name>.<pid>.old`` of a process that is
    no longer running (data steward's audit: a killed export left hidden full copies of the
    interactions, 28 MB, that no later export removed; they may hold a withdrawn participant)."""
    for path in _dead_left_overs(folder, names):
        try:
            path.unlink()
        except OSError:  # another process removed it first, or the folder is read-only
            pass


#: Windows, where a process is looked up by opening it (:func:`process_running`).
ON_WINDOWS = os.name == "nt"
#: What Windows' GetExitCodeProcess says of a process that has not ended.
_STILL_ACTIVE = 259
#: OpenProcess's right to ask a process for its exit code (PROCESS_QUERY_LIMITED_INFORMATION).
_QUERY = 0x1000


def process_running(pid: int) -> bool:
    """Whether a process with this id runs (on this machine); an id no process can have: False.

    POSIX: ``os.kill(pid, 0)`` (signal 0 checks, sends nothing). Not on Windows, where 0 is
    ``signal.CTRL_C_EVENT``: ``os.kill`` sends it with ``GenerateConsoleCtrlEvent`` (Python's
    ``os.kill`` documentation) — a Ctrl-C to the console's processes, not a look-up — and the id
    of a process that has ended raised an OSError (WinError 87) that no caller expected, out of
    every ``cacas export`` / ``simulate --out`` / saved run into a folder a killed run had left
    hidden files in. There the process is opened and asked whether it has ended."""
    if ON_WINDOWS:
        import _winapi

        try:
            handle = _winapi.OpenProcess(_QUERY, False, pid)
        except OverflowError:
            return False
        except OSError as exc:
            return getattr(exc, "winerror", None) == 5  # access denied: it runs (another user's); else (87) no such process
        try:
            return _winapi.GetExitCodeProcess(handle) == _STILL_ACTIVE
        finally:
            _winapi.CloseHandle(handle)
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):  # none, or an id no process can have
        return False
    except PermissionError:  # another user's process
        return True
    return True


#: The file :func:`write_all` writes beside the files it writes (with ``checksums=True``): each
#: one's sha256 and name, one a line, as ``sha256sum`` writes them (``sha256sum -c checksums.sha256``
#: checks a folder by hand).
CHECKSUMS = "checksums.sha256"


def checksums_bytes(contents: dict[str, bytes]) -> bytes:
    """:data:`CHECKSUMS`'s bytes for ``contents`` (name -> bytes), sorted by name: the same files
    give the same bytes."""
    return "".join(f"{sha256(data)}  {name}\n" for name, data in sorted(contents.items())).encode()


def parse_checksums(data: bytes) -> dict[str, str] | None:
    """Name -> sha256 of a :data:`CHECKSUMS` file's bytes; None if they are not such a file."""
    out = {}
    try:
        lines = data.decode("utf-8").splitlines()
    except UnicodeDecodeError:
        return None
    for line in lines:
        digest, sep, name = line.partition("  ")
        if not sep or len(digest) != 64 or not all(c in "0123456789abcdef" for c in digest) or not name:
            return None
        out[name.lstrip("*")] = digest
    return out


def mismatched(folder, names=None) -> list[str] | None:
    """The files :data:`CHECKSUMS` in ``folder`` lists (of ``names``, if given) that are missing or
    do not match their sha256 there: what a write killed between its renames left, or a file
    changed since. None when the folder has no such file (written before it, or not by
    :func:`write_all`): nothing is known."""
    folder = Path(folder)
    try:
        listed = parse_checksums((folder / CHECKSUMS).read_bytes())
    except OSError:
        return None
    if listed is None:
        return None
    bad = []
    for name, digest in sorted(listed.items()):
        if names is not None and name not in names:
            continue
        try:
            ok = file_sha256(folder / name) == digest
        except OSError:
            ok = False
        if not ok:
            bad.append(name)
    return bad


def _dead_left_overs(folder: Path, names) -> list[Path]:
    """The ``.<name>.<pid>.tmp`` and ``.<name>.<pid>.old`` files of :func:`write_all`s of these
    ``names`` whose process is no longer running: what a killed one left."""
    found = []
    if not folder.is_dir():
        return found
    for name in names:
        for path in [*folder.glob(f".{name}.*.tmp"), *folder.glob(f".{name}.*.old")]:
            pid = path.name[len(name) + 2:].rsplit(".", 1)[0]
            if pid.isdigit() and int(pid) != os.getpid() and not process_running(int(pid)):
                found.append(path)
    return sorted(found)


def _staging(folder: Path) -> Path:
    """The hidden folder beside ``folder`` in which :func:`write_all` builds a new ``folder`` whole
    (``.<name>.<pid>.new``), before renaming it into place."""
    return folder.parent / f".{folder.name}.{os.getpid()}.new"


def _dead_stagings(folder: Path) -> list[Path]:
    """The :func:`_staging` folders beside ``folder`` of a process no longer running (killed while it
    built ``folder``): a real folder (not a link) of files only, as only :func:`write_all` makes them."""
    found = []
    if not folder.parent.is_dir():
        return found
    for path in folder.parent.glob(f".{glob.escape(folder.name)}.*.new"):  # (a name may hold [ ] * ?)
        pid = path.name[len(folder.name) + 2:].rsplit(".", 1)[0]
        if not (pid.isdigit() and int(pid) != os.getpid() and not process_running(int(pid))):
            continue
        try:
            if path.is_symlink() or not path.is_dir() or any(not p.is_file() or p.is_symlink() for p in path.iterdir()):
                continue
        except OSError:
            continue
        found.append(path)
    return sorted(found)


def _remove_folder_of_files(path: Path) -> None:
    """Remove ``path``, a folder of files only (a :func:`_staging` folder), as far as it can."""
    try:
        for entry in path.iterdir():
            entry.unlink(missing_ok=True)
        path.rmdir()
    except OSError:  # another process removed it first, or it cannot be written
        pass


def _listed(names: list[str]) -> str:
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def remains(folder, names) -> str:
    """What an earlier :func:`write_all` of ``names`` into ``folder`` stopped part-way (killed, or a
    power cut) left there, said in a sentence for the write about to replace it; "" if nothing:
    the files that do not match :data:`CHECKSUMS` (two runs' files side by side) and the hidden
    copies of a process no longer running (safety audit L1)."""
    folder = Path(folder)
    staged = _dead_stagings(folder)
    if staged and not os.path.lexists(folder):
        return (f"{folder} was not written: an earlier run into it was stopped part-way (killed, or a power cut) "
                f"while it built it in {_listed([p.name for p in staged])} beside it, which is removed now")
    names = list(dict.fromkeys([*names, CHECKSUMS]))  # each once: its hidden copies counted once
    left = _dead_left_overs(folder, names)
    bad = mismatched(folder, names) if left else None  # without hidden copies, a mismatch is a file changed since
    if bad:
        return (f"{folder} held what an earlier run stopped part-way (killed, or a power cut) left: {_listed(bad)} "
                f"did not match {CHECKSUMS} (files of two runs side by side), and {len(left)} hidden temporary "
                "file(s); all are replaced now")
    if left:
        return (f"{folder} held {len(left)} hidden temporary file(s) an earlier run stopped part-way (killed, or a "
                "power cut) left; its files were still those of the run before it, and are replaced now")
    return ""


def _write_new_folder(folder: Path, contents: dict[str, bytes]) -> bool:
    """Make ``folder``, which does not exist, with ``contents`` whole: built in a hidden folder
    beside it (:func:`_staging`), each file fsynced, then renamed into place and the folder above
    synced. A process killed before the rename leaves no ``folder`` (the hidden one is removed by the
    next :func:`write_all` into it, and :func:`remains` says so), and after it the whole folder: no
    mix of two runs and no half-written folder. False (nothing made) when ``folder`` has come into
    being meanwhile (the caller then writes into it); a failure raises CacasError, nothing made."""
    staging = _staging(folder)
    where = folder
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        if os.path.lexists(staging):  # this process's, from a write that could not clean up
            _remove_folder_of_files(staging)
        staging.mkdir()
        for name, data in contents.items():
            where = folder / name
            with open(staging / name, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        fsync_folder(staging)
        where = folder
        if os.path.lexists(folder):
            return False
        try:
            os.replace(staging, folder)
        except OSError:
            if os.path.lexists(folder):  # made meanwhile, with files in it (ENOTEMPTY): not replaced
                return False
            raise
    except OSError as exc:
        raise CacasError(f"{where}: cannot be written ({exc.strerror or exc}); {folder} was not made") from None
    finally:  # also on Ctrl-C (KeyboardInterrupt, or SIGTERM raised as one), which goes on up
        if os.path.lexists(staging):
            _remove_folder_of_files(staging)
    fsync_folder(folder.parent)
    return True


def in_use_hint(exc: OSError) -> str:
    """What a refusal to replace or delete a file adds on Windows, where a file another program
    has open cannot be (a CSV shown in Excel, which keeps it locked: a second ``cacas export`` or
    ``simulate --out`` into the folder said only "Permission denied"); "" elsewhere."""
    if ON_WINDOWS and isinstance(exc, PermissionError):
        return ("; on Windows a file another program has open cannot be replaced: close it there (Excel keeps a CSV "
                "it shows locked) and try again")
    return ""


def _keep_aside(target: Path, kept: Path) -> None:
    """``kept``: ``target`` as it is now, for :func:`write_all` to put back: a second name for the
    file (a hard link, nothing copied), or a copy where the file system has no hard links: FAT32 and
    exFAT, those of USB sticks and of disks a Mac and a Windows PC share, refuse ``os.link``
    (EPERM, ENOTSUP; Windows' CreateHardLink "Incorrect function"), and a second export into a
    folder there failed with "cannot be written"."""
    try:
        os.link(target, kept)
    except FileExistsError:
        raise
    except OSError:
        shutil.copyfile(target, kept)


def write_all(folder, contents: dict[str, bytes], checksums: bool = False,
              remove: tuple[str, ...] | list[str] = ()) -> dict[str, Path]:
    """Write several files into ``folder`` as one change: each to a temporary file first
    (flushed and fsynced), and only when all are written are they renamed into place, each file
    it replaces kept aside (a hard link) until all renames are done. A failure (disk full,
    read-only folder, a rename refused) puts back the files already replaced, removes the
    temporary ones and raises a CacasError naming the file: the folder's files are as they were.
    So does Ctrl-C (KeyboardInterrupt, or SIGTERM raised as one), which is then raised again.

    A process killed between two renames cannot put anything back. With ``checksums``,
    :data:`CHECKSUMS` (the files' sha256) is renamed into place first, and synced, before the
    files it lists: killed at any point after it, the files that are still the earlier run's do not
    match it (:func:`mismatched` finds them), and killed before it, the folder is the earlier run's
    whole. (Swapping in a whole new folder instead would change the folder itself: a shell or file
    browser in it, ``--out .``, files of the user's beside the outputs.) Its bytes follow from the
    files', so the same files give the same folder. A ``folder`` that does not exist yet is built
    beside it and renamed into place whole (:func:`_write_new_folder`): killed, it is not there at
    all. ``remove``: files of an earlier write to take away in the same change (an earlier run's
    figure this one does not draw), removed before :data:`CHECKSUMS` is renamed, so that one left by
    a kill is listed by the earlier file and missing (found), never unlisted beside the new files;
    put back on a failure. Returns name -> path (without CHECKSUMS)."""
    folder = Path(folder)
    written = list(contents)
    remove = [n for n in dict.fromkeys(remove) if n not in contents and n != CHECKSUMS]
    if checksums:
        contents = {CHECKSUMS: checksums_bytes(contents), **contents}
    for staged in _dead_stagings(folder):
        _remove_folder_of_files(staged)
    if not os.path.lexists(folder) and _write_new_folder(folder, contents):
        return {n: folder / n for n in written}
    _remove_left_over(folder, [*contents, *remove])
    tmps: dict[str, Path] = {}
    kept: dict[str, Path | None] = {}  # name -> the replaced file's copy (None: there was none)
    done: list[str] = []
    gone: list[str] = []  # of ``remove``, taken away so far (a copy kept until the end)
    name = ""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in contents.items():
            tmps[name] = folder / f".{name}.{os.getpid()}.tmp"
            with open(tmps[name], "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        for name in tmps:
            target = folder / name
            kept[name] = None
            if target.exists():
                kept[name] = folder / f".{name}.{os.getpid()}.old"
                kept[name].unlink(missing_ok=True)
                _keep_aside(target, kept[name])
        for name in remove:
            target = folder / name
            if os.path.isfile(target):
                kept[name] = folder / f".{name}.{os.getpid()}.old"
                kept[name].unlink(missing_ok=True)
                _keep_aside(target, kept[name])
                target.unlink()
                gone.append(name)
        for name, tmp in tmps.items():
            os.replace(tmp, folder / name)
            done.append(name)
            if name == CHECKSUMS and checksums:  # on disk before any file it lists is replaced
                fsync_folder(folder)
    except BaseException as exc:  # an OSError, or Ctrl-C / SIGTERM between two renames
        for n in [*reversed(done), *gone]:  # put back what was replaced or taken away
            try:
                if kept[n] is None:
                    (folder / n).unlink(missing_ok=True)
                else:
                    os.replace(kept[n], folder / n)
            except OSError:  # pragma: no cover - the folder went away meanwhile
                pass
        if not isinstance(exc, OSError):
            raise
        raise CacasError(f"{folder / name}: cannot be written ({exc.strerror or exc}); "
                         f"the folder's files are unchanged{in_use_hint(exc)}") from None
    finally:
        for path in [*tmps.values(), *(p for p in kept.values() if p is not None)]:
            try:
                path.unlink(missing_ok=True)
            except OSError:  # pragma: no cover - the folder went away meanwhile
                pass
    fsync_folder(folder)
    return {n: folder / n for n in written}
