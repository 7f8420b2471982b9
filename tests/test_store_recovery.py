"""What a removal or an import killed mid-way leaves beside the database (cacas.store.recovery)."""

import os
import signal
import subprocess
import sys
import textwrap

from cacas import export
from cacas.store import StudyStore, recovery
from studies import policy_bytes


def _participant_with_a_policy(path, code="P03") -> str:
    with StudyStore(path) as s:
        s.add_participant(code)
        s.open_day(code)
        s.close_day(code, 1)
        s.save_policy(code, 1, "cacas", policy_bytes(f"{code}'s policy"))
        return s.active_policy(code).path.relative_to(s.policy_dir).as_posix()


def _left_aside(tmp_path, rel, content=None):
    """A removal's folder of moved-aside files, as a killed removal leaves it (its lock file not held)."""
    home = tmp_path / "policies" / rel
    trash = tmp_path / "policies" / ".removed-P03-4242-123"
    trash.mkdir(parents=True, exist_ok=True)
    (trash / recovery.REMOVAL_LOCK).touch()
    if content is None:
        home.rename(trash / home.name)
    else:
        (trash / home.name).write_bytes(content)
    return home, trash


def test_a_removal_killed_before_its_commit_gets_its_files_back(tmp_path):
    """Walkthrough: killed after the files were moved aside and before the commit, the participant
    was still in the study with every policy file gone (the tablet could not load the robot's
    policy, the export failed). Killed for real here, in the middle of moving the files."""
    path = tmp_path / "study.sqlite"
    _participant_with_a_policy(path)
    remover = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import os, sys, time
        from cacas.store import StudyStore
        real = os.replace
        def replace_then_hang(a, b):
            real(a, b)
            print("moved aside", flush=True)
            time.sleep(120)
        os.replace = replace_then_hang
        StudyStore({str(path)!r}).remove_participant("P03", "P03")
        """)], stdout=subprocess.PIPE, text=True, env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    try:
        assert remover.stdout.readline().strip() == "moved aside"
        trash = next((tmp_path / "policies").glob(".removed-P03-*"))
        assert not recovery._abandoned(trash / recovery.REMOVAL_LOCK)  # the removal holds it while it runs
        remover.send_signal(signal.SIGKILL)
        remover.wait(10)
    finally:
        remover.kill()
    with StudyStore(path) as s:  # the next opening puts the file back: the removal never committed
        assert s.load_policy("P03") == policy_bytes("P03's policy")
    assert not list((tmp_path / "policies").glob(".removed-*"))


def test_a_removal_killed_after_its_commit_has_its_files_deleted(tmp_path):
    path = tmp_path / "study.sqlite"
    rel = _participant_with_a_policy(path)
    kept = (tmp_path / "policies" / rel).read_bytes()
    with StudyStore(path) as s:
        s.remove_participant("P03", confirm="P03")
    home, trash = _left_aside(tmp_path, rel, content=kept)  # as if deleting it had been cut short
    StudyStore(path).close()
    assert not trash.exists() and not home.exists()


def test_a_file_another_database_beside_names_goes_back(tmp_path):
    """policies/ is shared by the databases in one folder: a moved-aside file a neighbour names is
    theirs, whatever this database says."""
    path = tmp_path / "study.sqlite"
    rel = _participant_with_a_policy(path)
    with StudyStore(path) as s:
        s.remove_participant("P03", confirm="P03")
    pilot = tmp_path / "pilot.sqlite"
    assert _participant_with_a_policy(pilot) == rel  # the same code, the same bytes: the same file name
    home, trash = _left_aside(tmp_path, rel)
    StudyStore(path).close()
    assert home.read_bytes() == policy_bytes("P03's policy") and not trash.exists()
    with StudyStore(pilot, readonly=True) as s:
        assert s.load_policy("P03") == policy_bytes("P03's policy")


def test_a_removal_running_now_or_unknown_is_left_alone(tmp_path):
    """A folder whose lock is held (a removal in another thread or process) or that has no lock
    file (nothing is known of it) is not touched."""
    path = tmp_path / "study.sqlite"
    rel = _participant_with_a_policy(path)
    home, trash = _left_aside(tmp_path, rel)
    with recovery.busy(trash / recovery.REMOVAL_LOCK):  # held by this process, on another descriptor
        StudyStore(path).close()
        assert (trash / home.name).exists() and not home.exists()
    (trash / recovery.REMOVAL_LOCK).unlink()
    StudyStore(path).close()
    assert (trash / home.name).exists()
    (trash / recovery.REMOVAL_LOCK).touch()
    StudyStore(path).close()
    assert home.exists() and not trash.exists()


def test_the_hidden_database_of_an_import_killed_mid_way_is_deleted(tmp_path):
    """Walkthrough: a killed `cacas import` left `.study.sqlite.importing-<pid>`, a full copy of the
    study's data that removing a participant could not reach (and that kept their files)."""
    killed = tmp_path / ".study.sqlite.importing-4242"
    left = [killed, tmp_path / f"{killed.name}-wal", recovery.import_lock(killed)]
    for f in left:
        f.write_bytes(b"half an import")
    running = tmp_path / ".study.sqlite.importing-4343"
    running.write_bytes(b"an import going on")
    with recovery.busy(recovery.import_lock(running)):
        StudyStore(tmp_path / "study.sqlite").close()
        assert not any(f.exists() for f in left) and running.exists()
    unknown = tmp_path / ".other.sqlite.importing-99999999999999999999"  # no lock file: not touched
    unknown.write_bytes(b"?")
    assert recovery.delete_abandoned_imports(tmp_path) == [running, recovery.import_lock(running)]
    assert unknown.exists()


def test_policies_kept_beside_a_link_move_beside_the_file(tmp_path):
    """Review: a study run through a link kept its policies beside the link until they moved beside
    the file; opened after the update, the tablet could not find them. They move at the opening."""
    real = tmp_path / "real" / "study.sqlite"
    rel = _participant_with_a_policy(real)
    link = tmp_path / "elsewhere" / "current.sqlite"
    link.parent.mkdir()
    link.symlink_to(real)
    (link.parent / "policies" / rel).parent.mkdir(parents=True)
    (tmp_path / "real" / "policies" / rel).rename(link.parent / "policies" / rel)  # where the old code wrote it
    with StudyStore(link) as s:
        assert s.load_policy("P03") == policy_bytes("P03's policy")
    assert not (link.parent / "policies" / rel).exists()


def test_a_killed_removal_beside_an_unreadable_database_is_left_until_it_can_be_read(tmp_path):
    """A study database beside that cannot be read may name the moved-aside files: they are
    neither deleted nor put back until it can be read (or is gone)."""
    path = tmp_path / "study.sqlite"
    rel = _participant_with_a_policy(path)
    kept = (tmp_path / "policies" / rel).read_bytes()
    with StudyStore(path) as s:
        s.remove_participant("P03", confirm="P03")
    home, trash = _left_aside(tmp_path, rel, content=kept)
    intact = tmp_path / "other" / "intact.sqlite"
    StudyStore(intact).close()
    damaged = tmp_path / "damaged.sqlite"  # a study database's header, damaged further on
    damaged.write_bytes(intact.read_bytes()[:100] + b"\0" * 4000)
    StudyStore(path).close()
    assert (trash / home.name).read_bytes() == kept and not home.exists()
    damaged.unlink()
    StudyStore(path).close()
    assert not trash.exists() and not home.exists()


def test_a_tidy_that_fails_does_not_stop_the_database_opening(tmp_path, monkeypatch):
    """Putting right what a killed removal left is best effort: a failure (a folder that cannot be
    read now) is left for the next opening, and the database opens."""
    path = tmp_path / "study.sqlite"
    _participant_with_a_policy(path)

    def unreadable(store):
        raise PermissionError(13, "Permission denied")
    monkeypatch.setattr(recovery, "finish_interrupted_removals", unreadable)
    with StudyStore(path) as s:
        assert s.load_policy("P03") == policy_bytes("P03's policy")


def _hang_after_writing(call: str, path) -> subprocess.Popen:
    """A process running ``call`` (Python, with StudyStore and export imported) that stops for good
    right after it has written its first policy file, before the row naming it is committed."""
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import time
        from cacas import export
        from cacas.store import StudyStore, files
        real = files.atomic_write
        def write_then_hang(target, data):
            real(target, data)
            print(target, flush=True)
            time.sleep(120)
        files.atomic_write = write_then_hang
        {call}
        """)], stdout=subprocess.PIPE, text=True, env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))


def test_a_policy_file_whose_save_was_killed_before_its_row_is_deleted_at_the_next_opening(tmp_path):
    """A policy file is written before its row: an adaptation killed in between left a file no row
    names in policies/<code>/, which nothing named or removed until the participant's removal. While
    the save runs (file written, row not yet), another process's opening leaves the file alone."""
    path = tmp_path / "study.sqlite"
    kept = _participant_with_a_policy(path)
    saver = _hang_after_writing(f"StudyStore({str(path)!r}).save_policy('P03', 1, 'nn', b'cut short')", path)
    try:
        written = tmp_path / saver.stdout.readline().strip()
        assert written.read_bytes() == b"cut short"
        StudyStore(path).close()  # a save going on in another process: its file stays
        assert written.is_file()
        saver.send_signal(signal.SIGKILL)
        saver.wait(10)
    finally:
        saver.kill()
    with StudyStore(path) as s:
        assert not written.exists() and [v.path.name for v in s.policy_versions("P03")] == [kept.split("/")[1]]
        assert s.load_policy("P03") == policy_bytes("P03's policy")
        s.save_policy("P03", 1, "nn", b"cut short")  # the same save, run again, is whole
        assert s.load_policy("P03", version=2) == b"cut short"
    assert sorted(f.name for f in (tmp_path / "policies" / "P03").iterdir()) == sorted(
        [kept.split("/")[1], written.name])  # no marker left either


def test_the_policy_files_of_an_import_killed_before_its_database_was_linked_are_deleted(tmp_path):
    """`cacas import` writes the bundle's policy files, then links the new database into place:
    killed in between, its hidden database was deleted at the next opening but the files stayed,
    named by no database."""
    source = tmp_path / "a" / "study.sqlite"
    _participant_with_a_policy(source)
    with StudyStore(source) as s:
        s.save_policy("P03", 1, "nn", policy_bytes("a second one"))
    bundle = export.export_study(source, tmp_path / "out").bundle
    target = tmp_path / "b" / "study.sqlite"
    importer = _hang_after_writing(f"export.import_bundle({str(bundle)!r}, {str(target)!r})", target)
    try:
        written = tmp_path / importer.stdout.readline().strip()
        StudyStore(tmp_path / "b" / "pilot.sqlite").close()  # an import going on: its files stay
        assert written.is_file()
        importer.send_signal(signal.SIGKILL)
        importer.wait(10)
    finally:
        importer.kill()
    StudyStore(tmp_path / "b" / "pilot.sqlite").close()
    assert not target.exists() and not (tmp_path / "b" / "policies" / "P03").exists()
    assert not [f for f in (tmp_path / "b").iterdir() if ".importing-" in f.name]
    export.import_bundle(bundle, target)  # imported again, whole
    with StudyStore(target) as s:
        assert s.load_policy("P03", version=1) == policy_bytes("P03's policy")


def test_a_file_no_row_names_is_deleted_only_after_a_write_that_was_cut_short(tmp_path):
    """A file no row names, without the marker a cut-short write leaves (of a database moved out of
    the folder, say), stays; so does a marked one a database beside names, and every one while a
    database beside cannot be read."""
    path = tmp_path / "study.sqlite"
    rel = _participant_with_a_policy(path)
    folder = tmp_path / "policies" / "P03"
    stray = folder / "day1-cacas-0123abcd.pt"
    stray.write_bytes(b"a moved database's policy")
    cut = folder / "day1-orl-89abcdef.pt"
    cut.write_bytes(b"cut short")
    tmp = folder / ".day1-orl-89abcdef.pt.4242.tmp"
    tmp.write_bytes(b"cut")
    markers = [folder / ".day1-orl-89abcdef.pt.4242.saving", folder / f".{rel.split('/')[1]}.4343.saving"]
    for marker in markers:
        marker.touch()
    damaged = tmp_path / "damaged.sqlite"  # a study database's header, damaged further on
    damaged.write_bytes(path.read_bytes()[:100] + b"\0" * 4000)
    StudyStore(path).close()
    assert all(f.exists() for f in (stray, cut, tmp, *markers))
    damaged.unlink()
    with StudyStore(path) as s:
        assert s.load_policy("P03") == policy_bytes("P03's policy")  # marked, but named
    assert sorted(f.name for f in folder.iterdir()) == sorted([rel.split("/")[1], stray.name])


def test_ctrl_c_while_a_save_waits_for_the_policies_lock_closes_its_descriptor(tmp_path, monkeypatch):
    """Review: only OSError was caught around the shared lock: a Ctrl-C while waiting for it (a
    cleanup holding it) left the folder's descriptor open."""
    import pytest

    def interrupted(fd, how):
        raise KeyboardInterrupt
    monkeypatch.setattr(recovery.fcntl, "flock", interrupted)
    opened = []
    real_open = os.open

    def recording_open(path, flags, *args):
        fd = real_open(path, flags, *args)
        opened.append(fd)
        return fd
    monkeypatch.setattr(recovery.os, "open", recording_open)
    with pytest.raises(KeyboardInterrupt):
        with recovery.saving(tmp_path / "policies"):
            pass
    monkeypatch.undo()
    assert len(opened) == 1
    with pytest.raises(OSError):  # closed again
        os.fstat(opened[0])


def test_a_cut_short_save_keeps_a_file_a_case_twin_names_where_letter_case_is_not_told_apart(tmp_path, case_twin):
    """Safety audit L4, the cleanup at opening: where the file system does not tell letter case
    apart (macOS's default), P01 and p01 share one folder, policies/P01/ as the disk names it. A
    save of p01's killed after its row was committed (before its marker was removed) left the
    marker there, and the cleanup compared the marker's path, P01/..., with p01's row, p01/...,
    letter for letter: it deleted p01's policy in force. A link stands in for such a file system
    (policies/p01 is policies/P01), and the probe is told so, as in test_store_remove's L4 test."""
    path = tmp_path / "study.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P01")
        s.save_policy("P01", 0, "cacas", policy_bytes("P01's policy"))
        case_twin(s)
        s.save_policy("p01", 0, "cacas", policy_bytes("p01's policy"))
        (rel,) = s.policies_frame().query("participant == 'p01'")["path"]
    assert rel.startswith("p01/")
    name = rel.split("/")[1]
    (tmp_path / "policies" / "P01" / f".{name}.4242.saving").touch()  # in the folder as the disk names it
    (tmp_path / "policies" / "P01" / f".{name}.4242.tmp").write_bytes(b"p01's pol")
    with StudyStore(path) as s:
        assert s.load_policy("p01") == policy_bytes("p01's policy")
        assert s.load_policy("P01") == policy_bytes("P01's policy")
    left = sorted(f.name for f in (tmp_path / "policies" / "P01").iterdir())
    assert len(left) == 2 and name in left and not [n for n in left if n.startswith(".")]  # the marker, its tmp: gone
