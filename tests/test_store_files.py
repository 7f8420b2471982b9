"""store.files: atomic single files and all-or-nothing folder writes."""

import os
import re

import pytest

from cacas.errors import CacasError
from cacas.store import StudyStore, files
from unwritable import unwritable_folder  # noqa: F401


def test_write_all_replaces_every_file(tmp_path):
    (tmp_path / "daily.csv").write_bytes(b"old daily")
    paths = files.write_all(tmp_path, {"daily.csv": b"new daily", "interactions.csv": b"new rows"})
    assert paths == {"daily.csv": tmp_path / "daily.csv", "interactions.csv": tmp_path / "interactions.csv"}
    assert (tmp_path / "daily.csv").read_bytes() == b"new daily"
    assert (tmp_path / "interactions.csv").read_bytes() == b"new rows"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["daily.csv", "interactions.csv"]  # nothing left over


def test_what_a_killed_write_left_is_removed_by_the_next(tmp_path):
    """Data steward's audit: `kill -9` during an export left .interactions.csv.<pid>.tmp (a full,
    hidden copy of the data) that no later export removed. The next write removes what a process
    no longer running left of the same files; a running writer's and other files stay."""
    import subprocess

    gone = subprocess.Popen(["true"])
    gone.wait()
    left = [tmp_path / f".a.csv.{gone.pid}.tmp", tmp_path / f".a.csv.{gone.pid}.old"]
    running = tmp_path / f".a.csv.{os.getppid()}.tmp"  # a writer still at work (our parent process)
    other = tmp_path / f".b.csv.{gone.pid}.tmp"  # another write's file: not this write's to judge
    for path in [*left, running, other]:
        path.write_text("old participant data")
    files.write_all(tmp_path, {"a.csv": b"new"})
    assert not any(p.exists() for p in left)
    assert running.exists() and other.exists()
    assert (tmp_path / "a.csv").read_bytes() == b"new"


def test_a_left_over_of_another_users_running_process_is_kept(tmp_path, monkeypatch):
    """A process we may not signal (another user's) is running: its temporary file is its write
    in progress, not a left-over."""
    def another_users(pid, sig):
        raise PermissionError(1, "Operation not permitted")
    theirs = tmp_path / ".a.csv.4242.tmp"
    theirs.write_text("their write in progress")
    monkeypatch.setattr(files.os, "kill", another_users)
    files.write_all(tmp_path, {"a.csv": b"new"})
    monkeypatch.undo()
    assert theirs.read_text() == "their write in progress" and (tmp_path / "a.csv").read_bytes() == b"new"


def test_write_all_creates_a_missing_folder(tmp_path):
    folder = tmp_path / "results" / "run1"
    assert files.write_all(folder, {"daily.csv": b"rows"}) == {"daily.csv": folder / "daily.csv"}
    assert [p.name for p in folder.iterdir()] == ["daily.csv"]


def test_a_refused_rename_puts_back_what_was_already_replaced(tmp_path, monkeypatch, fail_on_call):
    (tmp_path / "a.csv").write_bytes(b"old a")
    (tmp_path / "b.csv").write_bytes(b"old b")
    monkeypatch.setattr(files.os, "replace", fail_on_call(os.replace, 3, PermissionError(13, "Permission denied")))
    with pytest.raises(CacasError, match=r"c\.csv: cannot be written \(Permission denied\); "
                                         r"the folder's files are unchanged"):
        files.write_all(tmp_path, {"a.csv": b"new a", "b.csv": b"new b", "c.csv": b"new c"})
    monkeypatch.undo()
    assert (tmp_path / "a.csv").read_bytes() == b"old a" and (tmp_path / "b.csv").read_bytes() == b"old b"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "b.csv"]  # no c.csv, no temporary files


def test_ctrl_c_between_the_renames_puts_back_what_was_already_replaced(tmp_path, monkeypatch, fail_on_call):
    """CLI audit: Ctrl-C (KeyboardInterrupt) between two renames left the files already renamed
    new and the others old (only an OSError put them back): a folder mixing two runs."""
    (tmp_path / "a.csv").write_bytes(b"old a")
    (tmp_path / "b.csv").write_bytes(b"old b")
    monkeypatch.setattr(files.os, "replace", fail_on_call(os.replace, 2, KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):
        files.write_all(tmp_path, {"a.csv": b"new a", "b.csv": b"new b", "c.csv": b"new c"})
    monkeypatch.undo()
    assert (tmp_path / "a.csv").read_bytes() == b"old a" and (tmp_path / "b.csv").read_bytes() == b"old b"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "b.csv"]  # no c.csv, no temporary files


def test_a_file_that_was_not_there_is_removed_again(tmp_path, monkeypatch, fail_on_call):
    monkeypatch.setattr(files.os, "replace", fail_on_call(os.replace, 2))
    with pytest.raises(CacasError, match="b.csv: cannot be written"):
        files.write_all(tmp_path, {"a.csv": b"new a", "b.csv": b"new b"})
    assert list(tmp_path.iterdir()) == []


def test_writable_file_accepts_a_new_file_and_creates_nothing(tmp_path):
    target = tmp_path / "new" / "deeper" / "model.pt"
    assert files.writable_file(target, "--model") == target
    assert list(tmp_path.iterdir()) == []  # checked without creating the folders


@pytest.mark.parametrize("make, where, problem", [
    (lambda t: (t / "afile.txt").write_text("x"), "afile.txt/s.pt", "afile.txt is a file, not a folder"),
    (lambda t: (t / "afile.txt").write_text("x"), "afile.txt/sub/s.pt", "afile.txt is a file, not a folder"),
    (lambda t: (t / "d.pt").mkdir(), "d.pt", "it is a folder; give a file path"),
])
def test_writable_file_refuses_naming_option_path_and_problem(tmp_path, make, where, problem):
    make(tmp_path)
    with pytest.raises(CacasError) as err:
        files.writable_file(tmp_path / where, "--model")
    msg = str(err.value)
    assert msg.startswith(f"--model {tmp_path / where}: cannot be written there: ") and problem in msg
    assert "\n" not in msg


def test_writable_file_refuses_a_folder_it_cannot_write_in(unwritable_folder):
    with pytest.raises(CacasError, match=r"--json .*locked/b\.json: cannot be written there: cannot create "
                                         r"files in .*locked \("):
        files.writable_file(unwritable_folder / "b.json", "--json")


def test_writable_file_without_creating_folders_wants_the_folder(tmp_path):
    with pytest.raises(CacasError, match="the folder .*absent does not exist"):
        files.writable_file(tmp_path / "absent" / "b.json", "--json", create_folders=False)
    (tmp_path / "notes").write_text("x")
    with pytest.raises(CacasError, match=f"^--json {re.escape(str(tmp_path / 'notes' / 'b.json'))}: cannot be written "
                                         f"there: {re.escape(str(tmp_path / 'notes'))} is a file, not a folder; "):
        files.writable_file(tmp_path / "notes" / "b.json", "--json", create_folders=False)
    assert files.writable_file(tmp_path / "b.json", "--json", create_folders=False) == tmp_path / "b.json"


def test_a_database_opened_through_a_link_keeps_its_files_beside_the_file(tmp_path):
    """Walkthrough: with CACAS_DB a symbolic link, policies were written beside the link, so an
    export of the real file (and a backup of its folder) missed them; the writer lock differed too."""
    real = tmp_path / "real" / "study.sqlite"
    real.parent.mkdir()
    link = tmp_path / "elsewhere" / "current.sqlite"
    link.parent.mkdir()
    link.symlink_to(real)
    with StudyStore(link) as s:
        s.add_participant("P01")
        s.open_day("P01")
        s.close_day("P01", 1)
        s.save_policy("P01", 1, "cacas", b"a policy")
        assert s.path == real and s.policy_dir == real.parent / "policies"
    assert list((real.parent / "policies").rglob("*.pt")) and not (link.parent / "policies").exists()
    with StudyStore(real, readonly=True) as s:
        assert s.load_policy("P01") == b"a policy"


def test_a_damaged_study_database_is_called_damaged(tmp_path):
    """Walkthrough: a truncated study database was refused as "is not a study database (database
    disk image is malformed)"; it is one, damaged. The file is left as it was."""
    intact = tmp_path / "intact.sqlite"
    with StudyStore(intact) as s:
        for i in range(300):  # pages beyond the header
            s.add_participant(f"P{i:03d}", notes="x" * 200)
    damaged = tmp_path / "study.sqlite"
    data = intact.read_bytes()
    damaged.write_bytes(data[:4096] + b"\0" * (len(data) - 4096))
    before = damaged.read_bytes()
    with pytest.raises(CacasError, match=r"study.sqlite: the database file is damaged \(.*malformed.*\); nothing "
                                         r"was changed\. Restore it from a backup or an export"):
        StudyStore(damaged)
    assert damaged.read_bytes() == before


@pytest.mark.parametrize("offset", [4096, 8192, 16384])
def test_damage_past_the_first_pages_is_found_on_opening(tmp_path, offset):
    """Data steward's audit: 2 KB overwritten at 4096 or 8192 opened, and then every page (the
    tablet too) showed "database disk image is malformed" as a traceback. quick_check on opening
    names it, and the file is left as it was."""
    intact = tmp_path / "intact.sqlite"
    with StudyStore(intact) as s:
        for i in range(300):
            s.add_participant(f"P{i:03d}", notes="x" * 200)
    damaged = tmp_path / "study.sqlite"
    data = bytearray(intact.read_bytes())
    data[offset:offset + 2048] = bytes(range(256)) * 8
    damaged.write_bytes(bytes(data))
    before = damaged.read_bytes()
    with pytest.raises(CacasError, match=r"study.sqlite: the database file is damaged \(.*malformed.*\); nothing "
                                         r"was changed\. Restore it from a backup or an export"):
        StudyStore(damaged)
    assert damaged.read_bytes() == before


def test_a_refused_save_keeps_the_file_another_database_names(tmp_path):
    """Review: a save refused after its file was written deleted it, though a database beside this
    one (a bundle imported twice) named the same file (the same bytes give the same name)."""
    a, b = StudyStore(tmp_path / "a.sqlite"), StudyStore(tmp_path / "b.sqlite")
    for s in (a, b):
        s.add_participant("P01")
        s.open_day("P01")
        s.close_day("P01", 1)
    b.save_adapted_policy("P01", 1, "nn", b"the same policy", {}, 1.0, {})
    a.save_adapted_policy("P01", 1, "nn", b"another policy", {}, 1.0, {})
    with pytest.raises(CacasError, match="adapted already"):
        a.save_adapted_policy("P01", 1, "nn", b"the same policy", {}, 1.0, {})
    assert b.load_policy("P01") == b"the same policy"
    a.close()
    b.close()


def test_a_policy_file_that_cannot_be_written_names_it_and_saves_nothing(tmp_path, monkeypatch):
    """Review: a full disk during an adaptation showed the raw "[Errno 28] No space left on
    device". The file is named, the cause said, and nothing is saved: no version, no run, no file."""
    store = StudyStore(tmp_path / "s.sqlite")
    store.add_participant("P01")
    store.open_day("P01")
    store.close_day("P01", 1)

    def disk_full(fd):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(files.os, "fsync", disk_full)
    with pytest.raises(CacasError, match=r"policies/P01/day1-nn-[0-9a-f]{8}\.pt: cannot be written \(No space left "
                                         r"on device\); nothing was saved\. Free some disk space"):
        store.save_adapted_policy("P01", 1, "nn", b"a policy", {}, 1.0, {})
    monkeypatch.undo()
    assert store.policy_versions("P01") == [] and store.adaptations_frame("P01").empty
    assert not [p for p in (tmp_path / "policies").rglob("*") if p.is_file()]  # no file, no temporary file
    assert store.save_adapted_policy("P01", 1, "nn", b"a policy", {}, 1.0, {}) == 1  # with space again: saved
    store.close()


def test_a_new_folder_is_put_in_place_whole_or_not_at_all(tmp_path, monkeypatch, fail_on_call):
    """A folder that does not exist is built beside it (hidden) and renamed into place: a disk that
    fills part-way, or Ctrl-C, leaves neither the folder nor the hidden one (it was made with the
    files it got so far, as an earlier run's mix would be)."""
    import os

    folder = tmp_path / "deep" / "out"
    contents = {"checksums.sha256": b"sums", "daily.csv": b"rows", "interactions.csv": b"more rows"}
    monkeypatch.setattr(os, "fsync", fail_on_call(os.fsync, 2))  # the second file's fsync: disk full
    with pytest.raises(CacasError, match=rf"^{folder / 'daily.csv'}: cannot be written \(No space left on device\); "
                                         rf"{folder} was not made$"):
        files.write_all(folder, contents)
    assert os.listdir(tmp_path / "deep") == []
    monkeypatch.setattr(os, "replace", fail_on_call(os.replace, 1, KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):
        files.write_all(folder, contents)
    assert os.listdir(tmp_path / "deep") == []
    monkeypatch.undo()
    assert files.write_all(folder, contents) == {n: folder / n for n in contents}
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == contents and os.listdir(tmp_path / "deep") == ["out"]


def test_a_folder_made_while_the_new_one_was_built_is_written_into_not_replaced(tmp_path, monkeypatch):
    """Someone makes the folder (and puts a file in it) while the files are written beside it: the
    rename would replace it (or fail); the files are written into it instead, the other file kept."""
    import os

    folder = tmp_path / "out"
    real = os.fsync

    def fsync(fd):  # the hidden folder's sync, after its files: the user's folder appears then
        if not folder.exists():
            folder.mkdir()
            (folder / "notes.txt").write_text("mine")
        return real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    files.write_all(folder, {"daily.csv": b"rows"})
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == {"daily.csv": b"rows", "notes.txt": b"mine"}
    assert sorted(os.listdir(tmp_path)) == ["out"]


def test_a_writable_folder_checked_without_creating_it_is_left_missing(tmp_path):
    folder = tmp_path / "a" / "b"
    assert files.writable_folder(folder, "--out a/b", create=False) == folder
    assert not folder.exists() and (tmp_path / "a").is_dir()  # the folders above it are made, as before
    with pytest.raises(CacasError, match="--out x: is a file"):
        (tmp_path / "x").write_text("")
        files.writable_folder(tmp_path / "x", "--out x", create=False)


def test_a_writable_folder_holding_a_folder_where_a_file_goes_is_refused(tmp_path):
    """CLI audit: write_all cannot replace a folder with a file, so a folder named like one of the
    files to write is refused when the output folder is checked (before the work, not after it);
    a file of that name, a folder of another name, or a missing output folder are fine."""
    (tmp_path / "out" / "daily.csv").mkdir(parents=True)
    (tmp_path / "out" / "figures").mkdir()
    (tmp_path / "out" / "interactions.csv").write_text("an earlier run's")
    with pytest.raises(CacasError, match=r"^--out out: holds a folder named daily.csv, where this run writes its "
                                         r"daily.csv; valid: a folder without it \(move or rename that folder\), "
                                         r"or another folder$"):
        files.writable_folder(tmp_path / "out", "--out out", names=["interactions.csv", "daily.csv"])
    assert files.writable_folder(tmp_path / "out", "--out out", names=["interactions.csv", "figures.csv"]) \
        == tmp_path / "out"
    assert files.writable_folder(tmp_path / "new", "--out new", create=False, names=["daily.csv"]) == tmp_path / "new"
    assert sorted(os.listdir(tmp_path)) == ["out"]
    with pytest.raises(CacasError, match="cannot be written"):  # why: no write_all gets past such a folder
        files.write_all(tmp_path / "out", {"daily.csv": b"rows"})


def test_what_a_write_killed_while_it_built_a_new_folder_left_is_removed_and_said(tmp_path):
    """A process killed before it renamed the new folder into place left ``.<name>.<pid>.new`` beside
    it: the next write into that folder says so and removes it; one holding a folder (not ours) or of a
    running process is kept."""
    import os

    folder = tmp_path / "out"
    dead = tmp_path / ".out.999999999.new"  # no process has this id
    dead.mkdir()
    (dead / "daily.csv").write_bytes(b"half")
    running = tmp_path / f".out.{os.getppid()}.new"
    running.mkdir()
    odd = tmp_path / ".out.999999998.new"
    (odd / "sub").mkdir(parents=True)
    assert files.remains(folder, ["daily.csv"]) == (
        f"{folder} was not written: an earlier run into it was stopped part-way (killed, or a power cut) while it "
        f"built it in .out.999999999.new beside it, which is removed now")
    files.write_all(folder, {"daily.csv": b"rows"})
    assert not dead.exists() and running.is_dir() and odd.is_dir()
    assert (folder / "daily.csv").read_bytes() == b"rows" and files.remains(folder, ["daily.csv"]) == ""


def test_write_all_takes_away_the_files_named_to_remove_in_the_same_change(tmp_path, monkeypatch, fail_on_call):
    """``remove``: an earlier run's file this write does not make (cacas simulate's fig3_methods.html)
    goes with the change, before checksums.sha256 is put in place; a failure puts it back too."""
    files.write_all(tmp_path, {"a.txt": b"a1", "old.html": b"earlier"}, checksums=True)
    monkeypatch.setattr(os, "replace", fail_on_call(os.replace, 2))  # a.txt's rename, after checksums.sha256's
    with pytest.raises(CacasError, match=r"a\.txt: cannot be written \(No space left on device\); the folder's files "
                                         r"are unchanged$"):
        files.write_all(tmp_path, {"a.txt": b"a2"}, checksums=True, remove=["old.html", "never.html"])
    monkeypatch.undo()
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.name != files.CHECKSUMS} == {
        "a.txt": b"a1", "old.html": b"earlier"}
    assert files.mismatched(tmp_path) == []
    files.write_all(tmp_path, {"a.txt": b"a2"}, checksums=True, remove=["old.html", "never.html"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", files.CHECKSUMS]
    assert files.mismatched(tmp_path) == []


def test_a_listed_file_is_checked_a_block_at_a_time_not_read_whole(tmp_path, monkeypatch):
    """Scale walk: cacas import checked a 0.8 GB study zip against checksums.sha256 by reading it into memory (the
    import's peak, 1.7 GB, was that and the policy files); now hashed from the file in blocks."""
    from pathlib import Path

    data = bytes(range(256)) * 5000  # over one block of hashlib.file_digest's
    files.write_all(tmp_path, {"big.zip": data, "small.csv": b"rows"}, checksums=True)
    real = Path.read_bytes
    monkeypatch.setattr(Path, "read_bytes", lambda p: (_ for _ in ()).throw(AssertionError(f"read whole: {p}"))
                        if p.suffix == ".zip" else real(p))
    assert files.mismatched(tmp_path) == [] and files.file_sha256(tmp_path / "big.zip") == files.sha256(data)
    (tmp_path / "big.zip").write_bytes(data[:-1] + b"x")
    assert files.mismatched(tmp_path) == ["big.zip"]
