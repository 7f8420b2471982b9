"""What a lab's Windows laptop does differently from Linux, run here: Windows' file rules
(:mod:`windows_rules`: no fcntl, an open file cannot be deleted or replaced, no folder opened as
a file, fsync only through a descriptor that may write)."""

import io
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


def test_a_study_exports_and_imports(store, tmp_path):
    """The import deleted its lock file (recovery.import_lock) while it still held it open: on Windows
    that failed (a PermissionError, a traceback) after the new database was in place, so the import
    said it failed, and again it said "already exists"."""
    from cacas import export

    bundle = export.export_study(store, tmp_path / "out").bundle
    target = tmp_path / "copy" / "study.sqlite"
    restored = export.import_bundle(bundle, target)
    assert restored.interactions == 0
    assert sorted(p.name for p in target.parent.iterdir()) == ["policies", "study.sqlite"]
    with StudyStore(target) as copy:
        assert [p.code for p in copy.list_participants()] == ["P01", "P02"]
        assert copy.load_policy("P02") == policy_bytes("initial P02")


def test_an_import_refused_says_why_and_leaves_nothing(store, tmp_path):
    """A refusal part-way (a policy file of other content where the bundle's would go) is said as
    itself, with nothing of the import left: it was a PermissionError on its lock file on Windows."""
    from cacas import export
    from cacas.errors import CacasError

    bundle = export.export_study(store, tmp_path / "out").bundle
    rel = store.policies_frame()["path"].iloc[0]
    target = tmp_path / "copy" / "study.sqlite"
    (target.parent / "policies" / rel).parent.mkdir(parents=True)
    (target.parent / "policies" / rel).write_bytes(b"another policy")
    with pytest.raises(CacasError, match="exists with other content"):
        export.import_bundle(bundle, target)
    assert [p.relative_to(target.parent).as_posix() for p in sorted(target.parent.rglob("*"))] == \
        ["policies", "policies/" + rel.split("/")[0], "policies/" + rel]


def test_photos_are_added_to_the_library(windows_files, tmp_path):
    """The library's staging synced each new file through a descriptor opened read-only
    (files.fsync_file), which Windows' FlushFileBuffers refuses (EBADF): every photo or clip added
    on the Sounds and scenes page, and every `cacas sound generate` / `import`, failed there."""
    from cacas import lab
    from cacas.vision.library import image_paths
    from photos import photo

    png = io.BytesIO()
    photo().save(png, format="PNG")
    root = tmp_path / "scenes"
    added = lab.add_photos("kitchen", [("our stove.png", png.getvalue())], root)
    assert [p.relative_to(root).as_posix() for p in added] == ["kitchen/our_stove.png"]
    assert image_paths("kitchen", root) == added


def test_a_read_only_photo_is_added_as_a_file_the_lab_may_change(windows_files, tmp_path):
    """A copy kept its source's read-only mode (shutil.copy2): on Windows (the read-only attribute) its
    sync through a descriptor that may write was refused, and the library file could not be deleted."""
    from cacas.vision.library import import_folder
    from photos import photo

    source = tmp_path / "dvd" / "kitchen"
    source.mkdir(parents=True)
    photo().save(source / "stove.png")
    (source / "stove.png").chmod(0o444)
    (added,) = import_folder(source.parent, tmp_path / "scenes")
    assert added.stat().st_mode & 0o200
