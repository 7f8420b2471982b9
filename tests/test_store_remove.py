"""Removing a participant (withdrawal from the study, or a code added by mistake): everything
recorded about them goes, in one transaction; nothing of another participant is touched."""

import json
import os
import sqlite3

import pandas as pd
import pytest

from cacas.errors import CacasError
from cacas.store import StudyStore
from cacas.store.people import PARTICIPANT_TABLES
from cacas.store.schema import TABLES
from studies import policy_bytes

GOOD = dict(activity="cough", scene="bedroom", hour=7.5, interval_minutes=12, robot_action="pain check",
            response="accept")
NOTE = "prefers-mornings-7c1f"  # text only P01's rows hold, to look for in the file afterwards


def rows(path, code=None):
    """Every row of every table through a separate connection, sorted; with ``code``: that
    participant's rows only (events by their participant column). Compared whole, not counted: a
    removal that changed another participant's rows in place kept every count."""
    con = sqlite3.connect(path)
    try:
        def select(sql, *args):
            return sorted(con.execute(sql, args).fetchall(), key=repr)
        if code is None:
            return {t: select(f"SELECT * FROM {t}") for t in TABLES}
        pid = con.execute("SELECT id FROM participants WHERE code = ?", (code,)).fetchone()
        pid = None if pid is None else pid[0]
        out = {t: select(f"SELECT * FROM {t} WHERE participant_id = ?", pid) for t in PARTICIPANT_TABLES}
        out["participants"] = select("SELECT * FROM participants WHERE code = ?", code)
        out["events"] = select("SELECT * FROM events WHERE participant = ?", code)
        return out
    finally:
        con.close()


def fill(store, code, days=2, notes=""):
    """A participant with preferences (2 versions), days (the last one open), interactions, policy
    versions with files, adaptation runs and questionnaire answers."""
    store.add_participant(code, "25-34", notes)
    store.save_preferences(code, [{"activity": ["cough"], "action": "pain check", "description": notes}])
    store.save_preferences(code, [{"activity": ["cough", "sneeze"], "action": "pain check"}])
    store.save_policy(code, 0, "cacas", policy_bytes(f"initial {code}"))
    for _ in range(days):
        d = store.open_day(code)
        store.record_interaction(code, d, **GOOD)
        store.record_interaction(code, d, **{**GOOD, "response": "reject"})
        if d < days:
            store.close_day(code, d)
            v = store.save_policy(code, d, "cacas", policy_bytes(f"{code} day {d}"))
            store.record_adaptation(code, d, "cacas", {"beta": 0.5}, 1.0, {"preference_accuracy": 0.5},
                                    policy_version=v)
    store.record_questionnaire(code, 8, "fine")


@pytest.fixture
def store(tmp_path):
    s = StudyStore(tmp_path / "study.sqlite")
    fill(s, "P01", days=2, notes=NOTE)
    fill(s, "P02", days=3)
    yield s
    s.close()


def test_every_table_that_references_participants_is_emptied_of_them(store):
    """A new table about participants must be added to PARTICIPANT_TABLES (else its rows would
    outlive a withdrawal, or the delete would fail on its foreign key)."""
    con = sqlite3.connect(store.path)
    try:
        referencing = {t for t in TABLES
                       if any(fk[2] == "participants" for fk in con.execute(f"PRAGMA foreign_key_list({t})"))}
    finally:
        con.close()
    assert referencing == set(PARTICIPANT_TABLES)


def test_remove_deletes_every_row_of_that_participant_and_nothing_of_another(store):
    before, theirs, other = rows(store.path), rows(store.path, "P01"), rows(store.path, "P02")
    assert all(theirs[t] for t in theirs), theirs  # the test has something to remove in every table
    other_frames = (store.interactions_frame("P02", method=None, extra=True), store.policies_frame(),
                    store.preferences_frame(), store.days_frame(), store.questionnaire_frame(),
                    store.adaptations_frame("P02"), store.events("P02"))
    folder = store.policy_dir / "P01"
    assert folder.is_dir()
    footprint = store.participant_footprint("P01")
    assert (footprint.days, footprint.interactions, footprint.preference_versions, footprint.policy_versions,
            footprint.adaptation_runs, footprint.questionnaire_answers, footprint.policy_files) == (2, 4, 2, 2, 1, 1, 2)
    assert (footprint.open_day, footprint.open_day_interactions) == (2, 2)  # removed mid-day: allowed
    assert footprint.events == len(theirs["events"])

    removed = store.remove_participant("P01", confirm="P01")

    assert removed == footprint
    after = rows(store.path)
    for table in TABLES:  # exactly P01's rows went, every other row as it was (and one event came)
        kept = [row for row in before[table] if row not in theirs.get(table, [])]
        came = [row for row in after[table] if row not in kept]
        assert [row for row in after[table] if row in kept] == kept, table
        assert len(came) == (1 if table == "events" else 0), table
    assert all(not found for found in rows(store.path, "P01").values())
    assert rows(store.path, "P02") == other
    assert [p.code for p in store.list_participants()] == ["P02"]
    assert not folder.exists() and not list(store.policy_dir.glob(".removed-*"))
    assert (store.policy_dir / "P02").is_dir() and store.load_policy("P02") == policy_bytes("P02 day 2")
    p02 = store.policies_frame()
    assert p02["participant"].unique().tolist() == ["P02"]
    p02_now = (store.interactions_frame("P02", method=None, extra=True), store.policies_frame(),
               store.preferences_frame(), store.days_frame(), store.questionnaire_frame(),
               store.adaptations_frame("P02"), store.events("P02"))
    for old, new in zip(other_frames, p02_now):  # what the app shows of P02: as it was
        if "participant" in old.columns:
            old = old[old["participant"] == "P02"].reset_index(drop=True)
        pd.testing.assert_frame_equal(old, new.reset_index(drop=True), check_dtype=False)
    with pytest.raises(CacasError, match="unknown participant 'P01'"):
        store.get_participant("P01")
    with pytest.raises(CacasError, match="unknown participant 'P01'"):
        store.participant_footprint("P01")


def test_removed_data_are_not_left_in_the_database_file(store):
    store.remove_participant("P01", "P01")
    raw = store.path.read_bytes()
    wal = store.path.with_name(store.path.name + "-wal")
    if wal.exists():
        raw += wal.read_bytes()
    assert NOTE.encode() not in raw


def test_the_log_keeps_one_event_with_the_code_only(store):
    assert (store.events()["participant"] == "P01").any()
    store.remove_participant("P01", "P01")
    ev = store.events()
    assert not (ev["participant"] == "P01").any()
    assert not ev["details"].str.contains(NOTE).any()
    last = ev.iloc[-1]
    assert last["what"] == "remove_participant" and pd.isna(last["participant"])
    assert json.loads(last["details"]) == {"code": "P01", "study": "default"}
    # a new participant given the same code starts with an empty record, and no inherited event
    store.add_participant("P01")
    assert store.events("P01")["what"].tolist() == ["add_participant"]
    assert store.policy_versions("P01") == [] and store.days("P01") == []


@pytest.mark.parametrize("confirm", ["", "p01", "P01 ", "P02", None])
def test_a_wrong_confirmation_is_refused_and_writes_nothing(store, confirm):
    before = rows(store.path)
    with pytest.raises(CacasError, match="type its code P01 exactly to confirm.*nothing was removed"):
        store.remove_participant("P01", confirm)
    assert rows(store.path) == before
    assert (store.policy_dir / "P01").is_dir()


def test_an_unknown_participant_is_named_and_nothing_is_written(store):
    before = rows(store.path)
    with pytest.raises(CacasError, match="unknown participant 'P09'; known participants: P01, P02"):
        store.remove_participant("P09", "P09")
    assert rows(store.path) == before


def test_a_failure_part_way_removes_nothing_and_keeps_the_policy_files(store, monkeypatch):
    """The policy files are moved aside inside the transaction; a refused move (here the second
    file's; or a failed commit) leaves the database and the files as they were."""
    before = rows(store.path)
    files = sorted(p.name for p in (store.policy_dir / "P01").iterdir())
    assert len(files) == 2
    real_replace, calls = os.replace, []

    def refuse_the_second(src, dst):
        calls.append(src)
        if len(calls) == 2:
            raise OSError(13, "Permission denied")
        return real_replace(src, dst)
    monkeypatch.setattr(os, "replace", refuse_the_second)
    with pytest.raises(CacasError, match="policy file cannot be removed.*nothing was removed"):
        store.remove_participant("P01", "P01")
    monkeypatch.undo()
    assert rows(store.path) == before
    assert sorted(p.name for p in (store.policy_dir / "P01").iterdir()) == files
    assert store.load_policy("P01") == policy_bytes("P01 day 1")


def test_a_policy_saved_after_the_removal_leaves_no_file(store, monkeypatch):
    """An adaptation that finishes after its participant was removed: save_policy refuses, and
    its checkpoint file does not stay behind."""
    real_read = StudyStore._read
    calls = []

    def remove_after_check(self, fn):  # the participant goes between save_policy's check and its write
        out = real_read(self, fn)
        if not calls:
            calls.append(1)
            store.remove_participant("P01", "P01")
        return out
    monkeypatch.setattr(StudyStore, "_read", remove_after_check)
    with pytest.raises(CacasError, match="unknown participant"):
        store.save_policy("P01", 0, "cacas", policy_bytes("late policy"))
    monkeypatch.undo()
    assert not (store.policy_dir / "P01").exists()


def test_a_readonly_store_refuses(store):
    ro = StudyStore(store.path, readonly=True)
    try:
        with pytest.raises(CacasError, match="read-only"):
            ro.remove_participant("P01", "P01")
    finally:
        ro.close()
    assert rows(store.path, "P01")["participants"] != []


def _beside(store, name, code="P01"):
    """Another study database in the same folder, with a participant of the same code and a
    policy of its own (a pilot database beside the main one)."""
    other = StudyStore(store.path.parent / name)
    other.add_participant(code)
    other.save_policy(code, 0, "cacas", policy_bytes(f"{name}'s own {code}"))
    return other


def test_another_database_in_the_folder_keeps_its_policy_files(store):
    """policies/ is shared by the study databases beside each other: removing P01 from one
    deleted the other's P01 checkpoints with the folder (found by a data-analyst review)."""
    pilot = _beside(store, "pilot.sqlite")
    footprint = store.participant_footprint("P01")
    assert footprint.policy_files == 2  # its own two files, not the pilot's
    assert (footprint.kept_files, footprint.kept_because) == (  # named, so that a copy of the same person can go too
        1, "the study database pilot.sqlite beside this one names these files and holds a participant P01 of its "
           "own: if that is the same person (a copy imported there), remove them there too")
    store.remove_participant("P01", "P01")
    assert pilot.load_policy("P01") == policy_bytes("pilot.sqlite's own P01")
    assert [p.name for p in (store.policy_dir / "P01").iterdir()] == [pilot.active_policy("P01").path.name]
    pilot.remove_participant("P01", "P01")  # the last one takes the folder with it
    assert not (store.policy_dir / "P01").exists()
    pilot.close()


def test_a_bundle_imported_twice_into_one_folder_keeps_the_other_copy_working(store, tmp_path):
    """Two imports of one bundle name the same files: removing a participant from one database
    left the other unable to load (and export) its policies."""
    from cacas import export

    bundle = export.export_study(store, tmp_path / "out").bundle
    first, second = tmp_path / "moved" / "a.sqlite", tmp_path / "moved" / "b.sqlite"
    export.import_bundle(bundle, first)
    export.import_bundle(bundle, second)
    with StudyStore(second) as b:
        assert b.participant_footprint("P01").policy_files == 0  # every file is a.sqlite's too
        b.remove_participant("P01", "P01")
    with StudyStore(first) as a:
        assert a.load_policy("P01") == policy_bytes("P01 day 1")
        export.export_study(a, tmp_path / "again")  # every policy file is there


def test_an_unreadable_database_beside_keeps_every_file(store):
    """A study database in the folder that cannot be read might name any file: none is deleted."""
    other = store.path.parent / "other" / "intact.sqlite"  # a study database's header: not read from the open one
    StudyStore(other).close()
    (store.path.parent / "damaged.sqlite").write_bytes(other.read_bytes()[:100] + b"\0" * 4000)
    pilot = _beside(store, "pilot.sqlite")  # a readable neighbour naming one more P01 file
    pilot.close()
    files = sorted(p.name for p in (store.policy_dir / "P01").iterdir())
    before = store.participant_footprint("P01")
    assert before.policy_files == 0
    # ... and says so (walkthrough: "0 files" and nothing more, the files staying without a word),
    # naming for deletion only the files no readable database names (review: "delete policies/P01/"
    # would have taken the pilot's file too)
    assert before.kept_files == len(files) == 3
    ours = sorted(f"policies/P01/{p.path.name}" for p in store.policy_versions("P01"))
    assert before.kept_because == ("the study database damaged.sqlite beside this one cannot be read, and may name "
                                   f"these files: once you know it does not, delete {', '.join(ours)} by hand")
    removed = store.remove_participant("P01", "P01")
    assert (removed.kept_files, removed.kept_because) == (before.kept_files, before.kept_because)
    assert sorted(p.name for p in (store.policy_dir / "P01").iterdir()) == files


def test_files_beside_that_are_not_study_databases_do_not_keep_the_policy_files(store):
    """A CSV, a notes file or another application's SQLite file in the folder names no policy:
    the participant's files are deleted as if they were not there."""
    (store.path.parent / "participants.csv").write_text("participant,notes\nP01,x\n")
    con = sqlite3.connect(store.path.parent / "calendar.db")  # another application's database
    con.execute("CREATE TABLE policies (path TEXT)")
    con.execute("INSERT INTO policies VALUES ('P01/day1-cacas-00000000.pt')")
    con.commit()
    con.close()
    footprint = store.participant_footprint("P01")
    assert (footprint.policy_files, footprint.kept_files) == (2, 0)
    store.remove_participant("P01", "P01")
    assert not (store.policy_dir / "P01").exists()


def test_a_study_database_beside_whose_policies_cannot_be_read_keeps_every_file(store):
    """A neighbour recognised as a study database but whose policies table cannot be read (damaged,
    or an incomplete copy) may name any file: none is deleted, and the footprint says why."""
    broken = _beside(store, "broken.sqlite", code="P09")
    broken.close()
    con = sqlite3.connect(store.path.parent / "broken.sqlite")
    con.execute("DROP TABLE policies")
    con.commit()
    con.close()
    files = sorted(p.name for p in (store.policy_dir / "P01").iterdir())
    footprint = store.participant_footprint("P01")
    assert (footprint.policy_files, footprint.kept_files) == (0, 2)
    assert footprint.kept_because.startswith("the study database broken.sqlite beside this one cannot be read")
    store.remove_participant("P01", "P01")
    assert sorted(p.name for p in (store.policy_dir / "P01").iterdir()) == files


def test_policy_files_that_cannot_be_deleted_after_the_removal_are_named(store, monkeypatch):
    """The rows are gone (committed); the files moved aside could not be deleted (a permission
    changed meanwhile): the message says so and where they are, rather than nothing."""
    from cacas.store import people
    monkeypatch.setattr(people.shutil, "rmtree", lambda *a, **k: None)
    with pytest.raises(CacasError) as err:
        store.remove_participant("P01", "P01")
    monkeypatch.undo()
    (trash,) = store.policy_dir.glob(".removed-P01-*")
    assert str(err.value) == (f"participant P01 was removed from the study database, but their policy files in "
                              f"{trash} could not be deleted: delete that folder by hand")
    assert rows(store.path, "P01")["participants"] == []
    assert len([p for p in trash.rglob("*.pt")]) == 2


def test_a_removals_moves_are_synced_to_disk_before_it_commits(store, monkeypatch):
    """Safety audit L5: the removal moved the participant's policy files aside and committed
    without syncing the folders: after a power cut the files could be back in policies/P01/ with
    no row naming them. The participant's folder, the trash folder and the policies folder (the
    trash's name) are synced while the participant is still in the database (before the commit)."""
    real_fsync, real_replace = os.fsync, os.replace
    synced, trash = [], []

    def still_there() -> bool:
        con = sqlite3.connect(store.path)
        try:
            return con.execute("SELECT COUNT(*) FROM participants WHERE code = 'P01'").fetchone()[0] == 1
        finally:
            con.close()

    def fsync(fd):
        st = os.fstat(fd)
        if st.st_mode & 0o040000:  # a folder
            synced.append((st.st_ino, still_there()))
        real_fsync(fd)

    def replace(src, dst, *args, **kwargs):
        trash.append(os.stat(os.path.dirname(dst)).st_ino)
        real_replace(src, dst, *args, **kwargs)
    folder = store.policy_dir / "P01"
    wanted = {folder.stat().st_ino, store.policy_dir.stat().st_ino}
    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    store.remove_participant("P01", "P01")
    before_commit = {ino for ino, there in synced if there}
    assert wanted | {trash[0]} <= before_commit and not still_there()


def _withdrawn_files_back(store, code="P01"):
    """Remove ``code`` as a power cut that lost the removal's moves would leave it: the rows gone,
    the policy files back in policies/<code>/ as they were (their modification times too)."""
    kept = {p: (p.read_bytes(), p.stat().st_mtime_ns) for p in (store.policy_dir / code).rglob("*") if p.is_file()}
    store.remove_participant(code, code)
    for path, (data, mtime) in kept.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        os.utime(path, ns=(mtime, mtime))
    return sorted(kept)


def test_a_withdrawn_participants_files_brought_back_by_a_power_cut_are_deleted_at_the_next_opening(store):
    """Safety audit L5: files of a removed participant back in policies/P01/ (the removal's moves
    lost by a power cut) had no row and no marker, and stayed for good. The next opening for
    writing deletes them: older than the removal the database recorded, named by no database."""
    p02 = sorted(p.name for p in (store.policy_dir / "P02").iterdir())
    assert len(_withdrawn_files_back(store)) == 2
    store.close()
    with StudyStore(store.path) as s:
        assert not (s.policy_dir / "P01").exists()
        assert sorted(p.name for p in (s.policy_dir / "P02").iterdir()) == p02 and s.load_policy("P02")


def test_files_of_a_withdrawn_code_are_left_while_a_policy_file_is_being_written(store):
    """A writer holds the policies folder's lock (shared, as recovery.saving does while it writes):
    the opening leaves the withdrawn files for the next one, which deletes them."""
    import fcntl

    back = _withdrawn_files_back(store)
    store.close()
    fd = os.open(store.policy_dir, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH)
        StudyStore(store.path).close()
        assert all(p.is_file() for p in back)
    finally:
        os.close(fd)
    StudyStore(store.path).close()
    assert not any(p.exists() for p in back)


def test_files_of_a_withdrawn_code_another_database_holds_or_written_after_the_removal_are_kept(store):
    """policies/ is shared: a code removed here may be another study database's participant (a
    pilot's P01), or be written later (an import of another P01); such files are never deleted,
    nor anything while a database beside cannot be read (it may hold the code)."""
    back = _withdrawn_files_back(store)
    later = store.policy_dir / "P01" / "day1-cacas-0000abcd.pt"
    later.write_bytes(b"written after the removal, by a database moved away for now")
    after = pd.Timestamp(store.events(what="remove_participant")["at"].iloc[-1]).value + 10**9
    os.utime(later, ns=(after, after))  # a second after it (the log's clock may run ahead by a few ms)
    store.close()
    with StudyStore(store.path) as s:  # a newer file: kept; the older ones that were removed: deleted
        assert [p for p in (s.policy_dir / "P01").rglob("*") if p.is_file()] == [later]
    for path in back:  # brought back again, beside a database that holds a P01 of its own
        path.write_bytes(b"x")
        os.utime(path, ns=(1, 1))
    pilot = _beside(store, "pilot.sqlite", code="p01")  # in another letter case: one folder on macOS
    pilot.close()
    StudyStore(store.path).close()
    assert all(p.exists() for p in back)
    (store.path.parent / "pilot.sqlite").unlink()
    (store.path.parent / "damaged.sqlite").write_bytes(store.path.read_bytes()[:100] + b"\0" * 4000)
    StudyStore(store.path).close()
    assert all(p.exists() for p in back)  # a database beside that cannot be read may hold P01
    (store.path.parent / "damaged.sqlite").unlink()
    StudyStore(store.path).close()
    assert not any(p.exists() for p in back) and later.exists()


def test_removing_one_of_two_case_twins_keeps_the_others_files_where_they_share_a_folder(tmp_path, case_twin):
    """Safety audit L4: on a file system that does not tell letter case apart (macOS's default),
    P01 and p01 (of an imported study, or of two databases beside each other) share one folder,
    and removing p01 deleted P01's files with its own. A link stands in for such a file system here
    (policies/p01 is policies/P01), and the probe is told so; removing p01 keeps P01's files,
    whoever names them, and says why."""
    s = StudyStore(tmp_path / "study.sqlite")
    s.add_participant("P01")
    s.save_policy("P01", 0, "cacas", policy_bytes("P01's initial policy"))
    s.save_policy("P01", 0, "nn", policy_bytes("P01's other policy"))
    case_twin(s)
    s.save_policy("p01", 0, "cacas", policy_bytes("p01's initial policy"))
    pilot = _beside(s, "pilot.sqlite")  # names a P01 file of its own in the folder
    pilot.close()
    footprint = s.participant_footprint("p01")
    assert (footprint.policy_files, footprint.kept_files) == (1, 3)
    assert footprint.kept_because == ("participant P01 of this study database shares the folder policies/p01/ (the "
                                      "codes differ only in letter case, which this disk does not tell apart): their "
                                      "files are kept")
    s.remove_participant("p01", "p01")
    assert [s.load_policy("P01", version=v) for v in (1, 2)] == [policy_bytes("P01's initial policy"), policy_bytes("P01's other policy")]
    with StudyStore(tmp_path / "pilot.sqlite") as p:
        assert p.load_policy("P01") == policy_bytes("pilot.sqlite's own P01")
    assert len(list((s.policy_dir / "P01").iterdir())) == 3
    s.close()
