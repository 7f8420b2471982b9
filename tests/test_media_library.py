"""What the sound and scene libraries share (cacas.media_library): the temporary files a killed
writer leaves are removed by the next writer."""

import os
import subprocess
import sys

from cacas import media_library
from cacas.audio.library import clip_paths, generate_library


def _dead_pid() -> int:
    """The pid of a process that has ended (its number is not reused this quickly)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


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
    generate_library(1, seconds=1.0, root=tmp_path, activities=["cough"])
    assert not dead.exists() and running.exists() and mine.exists()
    assert [p.name for p in clip_paths("cough", tmp_path)] == ["synthetic_0_000.ogg"]
    assert media_library.remove_leftovers(tmp_path / "absent") == []
