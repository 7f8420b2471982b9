"""What a removal or an import killed mid-way leaves beside the database (cacas.store.recovery)."""

import subprocess
import sys

from cacas.store import StudyStore, recovery


def _dead_pid() -> int:
    """The id of a process that has ended."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def _participant_with_a_policy(path) -> str:
    with StudyStore(path) as s:
        s.add_participant("P03")
        s.open_day("P03")
        s.close_day("P03", 1)
        s.save_policy("P03", 1, "cacas", b"P03's policy")
        return s.active_policy("P03").path.relative_to(s.policy_dir).as_posix()


def test_a_removal_killed_before_its_commit_gets_its_files_back(tmp_path):
    """Walkthrough: killed after the files were moved aside and before the commit, the participant
    was still in the study with every policy file gone (the tablet could not load the robot's
    policy, the export failed)."""
    path = tmp_path / "study.sqlite"
    rel = _participant_with_a_policy(path)
    home = tmp_path / "policies" / rel
    trash = tmp_path / "policies" / f".removed-P03-{_dead_pid()}-123"
    (trash / home.name).parent.mkdir(parents=True)
    home.rename(trash / home.name)  # where the killed removal left it
    with StudyStore(path) as s:  # the next opening puts it back
        assert s.load_policy("P03") == b"P03's policy"
    assert not trash.exists()


def test_a_removal_killed_after_its_commit_has_its_files_deleted(tmp_path):
    path = tmp_path / "study.sqlite"
    rel = _participant_with_a_policy(path)
    home = tmp_path / "policies" / rel
    kept = home.read_bytes()
    with StudyStore(path) as s:
        s.remove_participant("P03", confirm="P03")
    trash = tmp_path / "policies" / f".removed-P03-{_dead_pid()}-123"  # as if deleting it had been cut short
    trash.mkdir()
    (trash / home.name).write_bytes(kept)
    StudyStore(path).close()
    assert not trash.exists() and not home.exists()


def test_a_removal_running_now_is_left_alone(tmp_path):
    path = tmp_path / "study.sqlite"
    _participant_with_a_policy(path)
    trash = tmp_path / "policies" / ".removed-P03-1-123"  # process 1 runs: a removal in progress
    trash.mkdir()
    (trash / "day1-cacas-x.pt").write_bytes(b"x")
    StudyStore(path).close()
    assert (trash / "day1-cacas-x.pt").exists()


def test_the_hidden_database_of_an_import_killed_mid_way_is_deleted(tmp_path):
    """Walkthrough: a killed `cacas import` left `.study.sqlite.importing-<pid>`, a full copy of the
    study's data that removing a participant could not reach (and that kept their files)."""
    dead = _dead_pid()
    left = [tmp_path / f".study.sqlite.importing-{dead}", tmp_path / f".study.sqlite.importing-{dead}-wal"]
    for f in left:
        f.write_bytes(b"half an import")
    running = tmp_path / ".study.sqlite.importing-1"
    running.write_bytes(b"an import going on")
    StudyStore(tmp_path / "study.sqlite").close()
    assert not any(f.exists() for f in left) and running.exists()
    assert recovery.delete_abandoned_imports(tmp_path) == []
