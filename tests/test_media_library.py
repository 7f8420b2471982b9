"""What the sound and scene libraries share (cacas.media_library): the temporary files a killed
writer leaves are removed by the next writer; adding files is synced and takes turns."""

import fcntl
import os
import subprocess
import sys
import time

import numpy as np
import pytest
import soundfile as sf

from cacas import media_library
from cacas.audio.features import SUPPORTED_EXTENSIONS
from cacas.audio.library import clip_paths, generate_library, import_folder
from cacas.errors import CacasError


def _dead_pid() -> int:
    """The pid of a process that has ended (its number is not reused this quickly)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def _old(*paths):
    then = time.time() - media_library.LEFTOVER_AGE - 60
    for p in paths:
        os.utime(p, (then, then))


def test_a_killed_writers_temporary_files_are_removed_by_the_next_one(tmp_path):
    """kill -9 in `cacas sound generate` left hidden .tmp files in the library for good (nothing
    reads them, but they took the space of the clips); the next generate or import removes those
    of processes that are gone, and leaves those of a writer still running."""
    folder = tmp_path / "cough"
    folder.mkdir()
    dead = folder / f".synthetic_0_000.ogg.{_dead_pid()}.tmp"
    running = folder / f".synthetic_0_001.ogg.{os.getpid()}.tmp"
    mine = folder / "notes.1.tmp"  # not a staging file's name: not ours to remove
    for f in (dead, running, mine):
        f.write_bytes(b"half a clip")
    _old(dead, running, mine)
    generate_library(1, seconds=1.0, root=tmp_path, activities=["cough"])
    assert not dead.exists() and running.exists() and mine.exists()
    assert [p.name for p in clip_paths("cough", tmp_path)] == ["synthetic_0_000.ogg"]
    assert media_library.remove_leftovers(tmp_path / "absent", SUPPORTED_EXTENSIONS) == []


def test_only_old_staging_files_of_the_librarys_types_are_removed(tmp_path):
    """Review: any hidden '.<x>.<number>.tmp' went (another program's '.cache.40000.tmp' in a folder
    given as --out), a pid too large for the system crashed every generate and import, and a
    process id alone does not tell that a writer in another container is gone (recent files stay)."""
    folder = tmp_path / "cough"
    folder.mkdir()
    gone = _dead_pid()
    others = [folder / f".cache.{gone}.tmp", folder / ".clip.ogg.99999999999999999999.tmp",
              folder / f".recent.ogg.{gone}.tmp"]
    removed = folder / f".clip.ogg.{gone}.tmp"
    for f in others + [removed]:
        f.write_bytes(b"x")
    _old(*others[:2], removed)
    assert media_library.remove_leftovers(tmp_path, SUPPORTED_EXTENSIONS) == [removed]
    assert all(f.exists() for f in others)


def _clip_folder(tmp_path, name="src"):
    """A researcher's folder of one cough clip (cough/c1.wav)."""
    src = tmp_path / name / "cough"
    src.mkdir(parents=True)
    t = np.arange(16000) / 16000
    sf.write(src / "c1.wav", 0.3 * np.sin(2 * np.pi * 440 * t), 16000)
    return src.parent


def test_added_files_are_synced_before_their_renames_and_their_folder_after(tmp_path, monkeypatch):
    """Safety round: the copies were renamed into place unsynced, so a power cut soon after an Add
    could leave empty or cut clips under the new names."""
    src, events = _clip_folder(tmp_path), []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(fd):
        events.append(("fsync", os.readlink(f"/proc/self/fd/{fd}")))
        return real_fsync(fd)

    def replace(a, b):
        events.append(("rename", str(a), str(b)))
        return real_replace(a, b)
    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    [added] = import_folder(src, tmp_path / "sounds")
    renames = [e for e in events if e[0] == "rename"]
    assert len(renames) == 1 and renames[0][2] == str(added)
    at = events.index(renames[0])
    assert ("fsync", renames[0][1]) in events[:at]  # the copy's content, before its rename
    assert ("fsync", str(added.parent)) in events[at:]  # the rename, after it


def test_adding_holds_the_library_s_lock_from_the_copy_check_to_the_last_rename(tmp_path, monkeypatch):
    """Safety round: two researchers adding the same clip at one moment (two browsers, or the app and
    `cacas sound import`) each found it new, and both copies went in, counted twice in training.
    The check for copies and the renames happen under one lock, which another adder waits for."""
    root = tmp_path / "sounds"
    held = []

    def lock_is_held() -> bool:
        fd = os.open(media_library.adding_lock(root), os.O_RDWR)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        finally:
            os.close(fd)
        return False

    real_check, real_place = media_library._refuse_copies, media_library.Staging.place

    def check(*args, **kwargs):
        held.append(("check", lock_is_held()))
        return real_check(*args, **kwargs)

    def place(self):
        real_place(self)
        held.append(("placed", lock_is_held()))
    monkeypatch.setattr(media_library, "_refuse_copies", check)
    monkeypatch.setattr(media_library.Staging, "place", place)
    import_folder(_clip_folder(tmp_path), root)
    assert held == [("check", True), ("placed", True)]
    assert not lock_is_held()  # given back
    # the next adder, after the lock, sees the clip just placed: the same clip again is refused
    with pytest.raises(CacasError, match=r"the same clip is already in the library as cough/c1\.wav"):
        import_folder(_clip_folder(tmp_path, "again"), root)
