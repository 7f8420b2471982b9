"""What a lab's Windows laptop does differently from Linux, run here: Windows' file rules
(:mod:`windows_rules`: no fcntl, an open file cannot be deleted or replaced, no folder opened as
a file, fsync only through a descriptor that may write)."""

import os

import pytest

from cacas.store import StudyStore
from studies import policy_bytes
from windows_rules import windows_files  # noqa: F401


@pytest.fixture
def store(tmp_path, windows_files):
    s = StudyStore(tmp_path / "study.sqlite")
    s.add_participant("P01", "25-34")
    s.save_policy("P01", 0, "cacas", policy_bytes("initial P01"))
    s.add_participant("P02", "25-34")
    s.save_policy("P02", 0, "cacas", policy_bytes("initial P02"))
    yield s
    s.close()


def test_a_participants_removal_deletes_their_files_and_says_it_is_done(store):
    """The removal held its lock file (recovery.busy) open while it deleted the folder holding it: on
    Windows the lock file stayed, and every withdrawal with policy files ended with "could not be
    deleted: delete that folder by hand" (the rows were gone, the files too but the lock)."""
    store.remove_participant("P01", "P01")
    assert sorted(p.name for p in store.policy_dir.iterdir()) == ["P02"]
    assert store.list_participants()[0].code == "P02"


def test_a_removal_that_fails_puts_the_files_back_and_leaves_no_folder_aside(store, monkeypatch):
    """Rolled back (here the disk refused the sync after the moves), the files go home and the
    folder they were moved to goes: with its lock file still open, it stayed on Windows."""
    from cacas.errors import CacasError
    from cacas.store import people

    before = sorted(p.name for p in (store.policy_dir / "P01").iterdir())

    def disk_refuses(folder):
        raise OSError(5, "Input/output error")
    monkeypatch.setattr(people.files, "fsync_folder", disk_refuses)
    with pytest.raises((OSError, CacasError)):
        store.remove_participant("P01", "P01")
    monkeypatch.setattr(people.files, "fsync_folder", lambda folder: None)
    assert sorted(p.name for p in (store.policy_dir / "P01").iterdir()) == before
    assert sorted(p.name for p in store.policy_dir.iterdir()) == ["P01", "P02"]
    assert [p.code for p in store.list_participants()] == ["P01", "P02"]
