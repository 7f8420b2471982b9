"""The study database (issue 4): what it keeps, bad input refused with nothing written, resume."""

import json
import re
import sqlite3

import numpy as np
import pandas as pd
import pytest

from cacas import spaces
from cacas.errors import CacasError
from cacas.records import INTERACTION_COLUMNS, USER_INITIATED
from cacas.store import SCHEMA_VERSION, PersonasImport, StudyStore, default_db_path
from cacas.store.schema import APPLICATION_ID, TABLES

STOVE = {"description": "When I use the stove in the kitchen, remind me to turn it off.",
         "activity": ["use stove", "fry food"], "scene": ["kitchen"], "hours": [[6, 10], [16, 20]],
         "interval": [0, 30], "action": "remind to turn off"}
COUGH = {"activity": ["cough"], "action": "pain check"}


def probs(action="pain check"):
    p = np.full(spaces.N_ACTIONS, 0.01)
    p[spaces.action_index(action)] = 1 - 0.01 * (spaces.N_ACTIONS - 1)
    return p


GOOD = dict(activity="cough", scene="bedroom", hour=7.5, interval_minutes=12, robot_action="pain check",
            response="accept")


@pytest.fixture
def store(tmp_path):
    s = StudyStore(tmp_path / "study.sqlite")
    s.add_participant("P01", "25-34", "familiar with robots")
    yield s
    s.close()


def snapshot(path):
    """Every row of every table (including the event log), sorted, read through a separate
    connection: "nothing written" means no row added, removed or changed (row counts alone
    missed a change in place)."""
    con = sqlite3.connect(path)
    try:
        return {t: sorted(con.execute(f"SELECT * FROM {t}").fetchall(), key=repr) for t in TABLES}
    finally:
        con.close()


# --- the file -------------------------------------------------------------------------------------

def test_new_database_has_schema_wal_foreign_keys_and_default_study(tmp_path):
    path = tmp_path / "sub" / "new.sqlite"
    with StudyStore(path) as s:
        assert [st.name for st in s.studies()] == ["default"]
        assert s._conn.execute("PRAGMA foreign_keys").fetchone()[0] == 1
        assert s._conn.execute("PRAGMA busy_timeout").fetchone()[0] > 0
    con = sqlite3.connect(path)
    assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert con.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    assert con.execute("PRAGMA application_id").fetchone()[0] == APPLICATION_ID
    con.close()
    with StudyStore(path) as s:  # reopening creates nothing twice
        assert [st.name for st in s.studies()] == ["default"]


def test_default_path_follows_env(monkeypatch, tmp_path):
    monkeypatch.setenv("CACAS_DB", str(tmp_path / "env.sqlite"))
    assert default_db_path() == tmp_path / "env.sqlite"
    with StudyStore() as s:
        assert s.path == tmp_path / "env.sqlite"
    assert (tmp_path / "env.sqlite").exists()
    monkeypatch.delenv("CACAS_DB")
    monkeypatch.setenv("CACAS_STUDY_DATA", str(tmp_path / "sd"))
    assert default_db_path() == tmp_path / "sd" / "cacas.sqlite"


def test_text_file_is_not_a_study_database(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("participant list\n" * 20)
    with pytest.raises(CacasError, match="notes.txt: is not a study database"):
        StudyStore(path)
    assert path.read_text() == "participant list\n" * 20


def test_other_sqlite_file_is_not_a_study_database(tmp_path):
    path = tmp_path / "other.db"
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE t (x)")
    con.commit()
    con.close()
    before = path.read_bytes()
    with pytest.raises(CacasError, match="other.db: is not a study database"):
        StudyStore(path)
    with pytest.raises(CacasError, match="other.db: is not a study database"):
        StudyStore(path, readonly=True)
    assert path.read_bytes() == before


def test_newer_schema_is_refused(tmp_path):
    path = tmp_path / "s.sqlite"
    StudyStore(path).close()
    con = sqlite3.connect(path)
    con.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    con.close()
    with pytest.raises(CacasError, match="newer"):
        StudyStore(path)


@pytest.mark.parametrize("change, remedy", [
    (f"PRAGMA user_version = {SCHEMA_VERSION + 1}", "it was written by a newer CACAS Studio: update this one"),
    ("DROP TABLE questionnaires", "it is incomplete"),
])
def test_a_study_database_that_cannot_be_read_here_is_refused_read_only(tmp_path, change, remedy):
    """``cacas export`` of a database a newer CACAS Studio wrote (or one missing a table): the
    message says which versions this one reads and what to do; the file is left as it was."""
    path = tmp_path / "s.sqlite"
    StudyStore(path).close()
    con = sqlite3.connect(path, isolation_level=None)
    con.execute(change)
    con.close()
    before = path.read_bytes()
    version = SCHEMA_VERSION + 1 if "user_version" in change else SCHEMA_VERSION
    with pytest.raises(CacasError, match=re.escape(
            f"s.sqlite: study database schema version {version} cannot be read here (this CACAS Studio reads "
            f"versions 1 to {SCHEMA_VERSION}; {remedy})")):
        StudyStore(path, readonly=True)
    assert path.read_bytes() == before


def test_a_study_database_on_a_full_disk_is_not_called_another_applications_file(tmp_path):
    """Safety audit: a study database (WAL mode) opened when its disk was full (SQLite cannot
    size the -shm file it needs: "disk I/O error") was refused as "is not a study database": a
    researcher told that moves or replaces a healthy file. The message says the disk may be full
    and what to do; the file is left as it was. (A file size limit stands in for the full disk.)"""
    import subprocess
    import sys

    path = tmp_path / "s.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P01")
    assert not (tmp_path / "s.sqlite-shm").exists()  # the last connection closed: SQLite needs a new one
    before = path.read_bytes()
    script = ("import resource, signal, sys\n"
              "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
              "resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))  # no file grows past 4 kB: a full disk\n"
              "from cacas.errors import CacasError\n"
              "from cacas.store import StudyStore\n"
              "for readonly in (False, True):  # the app; cacas export\n"
              "    try:\n"
              "        StudyStore(sys.argv[1], readonly=readonly)\n"
              "    except CacasError as exc:\n"
              "        print(exc)\n")
    said = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True, check=True,
                          cwd=str(__import__("pathlib").Path(__file__).resolve().parents[1])).stdout.strip()
    assert said.splitlines() == [
        f"{path}: the study database cannot be opened now (disk I/O error); nothing was changed. The disk may be "
        "full, or the file or its folder cannot be written: free some disk space (or check the permissions) and open "
        "it again; the file is not damaged by this, do not replace it",
        f"{path}: cannot be read (disk I/O error); the disk may be full, or the file or its folder cannot be written "
        "(SQLite writes its -shm file beside the database to read it): free some disk space (or check the "
        "permissions) and try again"]
    assert path.read_bytes() == before
    with StudyStore(path) as s:  # room again: the study is there
        assert [p.code for p in s.list_participants()] == ["P01"]


@pytest.mark.parametrize("held", ["written", "read", "read at the WAL switch"])
def test_a_study_database_held_locked_while_it_opens_is_busy_not_another_file(tmp_path, monkeypatch, held):
    """Safety audit L2: a "database is locked" met while opening (quick_check, or the switch to WAL)
    said "is not a study database (database is locked)": a researcher told that moves or replaces a
    healthy file. Another connection holds it: one writing (quick_check cannot read) or one reading
    (the schema's check cannot commit, nor the switch to WAL take the file); the file is left as it
    was, and opens once it is let go."""
    from cacas.store import db

    path = tmp_path / "s.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P01")
    other = sqlite3.connect(path, isolation_level=None)
    other.execute("PRAGMA journal_mode = DELETE")  # as an import leaves it; a lock then keeps others out
    before = path.read_bytes()
    if held == "written":
        other.execute("BEGIN EXCLUSIVE")
    else:
        other.execute("BEGIN")
        other.execute("SELECT COUNT(*) FROM participants").fetchone()
    monkeypatch.setattr(db, "BUSY_TIMEOUT_MS", 50)  # not the 10 s a study waits
    if held == "read at the WAL switch":  # the reader came after the schema's check: the switch meets it
        monkeypatch.setattr(db, "_init_schema", lambda conn, path: None)
    try:
        modes = (False, True) if held == "written" else (False,)  # a reader does not keep cacas export out
        for readonly in modes:  # the app; cacas export
            with pytest.raises(CacasError) as refused:
                StudyStore(path, readonly=readonly)
            assert str(refused.value) == (
                f"{path}: the study database is busy (database is locked): another program held it for more than "
                "0.05 s while it was being opened; nothing was changed, and the file is fine. Try again in a moment, "
                "once that program is done with it")
    finally:
        other.execute("ROLLBACK")
        other.close()
    assert path.read_bytes() == before
    with StudyStore(path) as s:  # let go: the study is there
        assert [p.code for p in s.list_participants()] == ["P01"]


def test_a_folder_or_a_file_sqlite_keeps_beside_is_not_opened(tmp_path):
    (tmp_path / "folder.sqlite").mkdir()
    with pytest.raises(CacasError, match=r"folder.sqlite: is not a file; expected a CACAS study database \(.sqlite\)"):
        StudyStore(tmp_path / "folder.sqlite")
    (tmp_path / "afile").write_text("notes")
    with pytest.raises(CacasError, match=r"afile/s.sqlite: cannot create its folder \("):
        StudyStore(tmp_path / "afile" / "s.sqlite")
    StudyStore(tmp_path / "s.sqlite").close()
    (tmp_path / "s.sqlite-wal").write_bytes(b"")
    with pytest.raises(CacasError, match="s.sqlite-wal: is a file SQLite keeps beside a database, not a study database"):
        StudyStore(tmp_path / "s.sqlite-wal", readonly=True)
    assert (tmp_path / "afile").read_text() == "notes" and sorted(p.name for p in tmp_path.iterdir()) == [
        "afile", "folder.sqlite", "s.sqlite", "s.sqlite-wal", "s.sqlite-writer.lock"]


def test_readonly_store_creates_nothing_and_refuses_writes(tmp_path):
    path = tmp_path / "missing.sqlite"
    with pytest.raises(CacasError, match="no such study database"):
        StudyStore(path, readonly=True)
    assert list(tmp_path.iterdir()) == []
    StudyStore(path).close()
    with StudyStore(path, readonly=True) as s:
        with pytest.raises(CacasError, match="read-only"):
            s.add_participant("P02")
    assert snapshot(path)["participants"] == []


# --- participants and preferences -----------------------------------------------------------------

def test_participants_add_update_list(store):
    store.add_participant("P02", study="default")
    store.update_participant("P01", notes="new notes")
    p = store.get_participant("P01")
    assert (p.code, p.age_range, p.notes, p.study) == ("P01", "25-34", "new notes", "default")
    assert [x.code for x in store.list_participants()] == ["P01", "P02"]
    store.create_study("pilot", "a pilot")
    store.add_participant("Q1", study="pilot")
    assert [x.code for x in store.list_participants("pilot")] == ["Q1"]
    assert list(store.participants_frame()["participant"]) == ["P01", "P02", "Q1"]


def test_participants_are_listed_by_code_whatever_its_letter_case(store, tmp_path):
    """Walkthrough: the sidebar listed "P01, R01, p02, r03" (sorted as stored, capitals first). A person reads
    codes case-blind: "P01, p02, R01, r03"; codes that differ only in letter case (a restored backup keeps
    them) by the exact code, so the order is total. The exports keep the exact code's order."""
    for code in ("r03", "R01", "p02"):
        store.add_participant(code)
    assert [p.code for p in store.list_participants()] == ["P01", "p02", "R01", "r03"]
    assert [p.code for p in store.list_participants("default")] == ["P01", "p02", "R01", "r03"]
    with sqlite3.connect(store.path) as c:  # as a restored backup holds them
        c.execute("INSERT INTO participants (study_id, code, created_at, updated_at) VALUES (1, 'r01', 'x', 'x')")
    assert [p.code for p in store.list_participants()] == ["P01", "p02", "R01", "r01", "r03"]
    with pytest.raises(CacasError, match=r"known participants: P01, p02, R01, r01, r03$"):
        store.get_participant("X9")
    # what is exported is as it was: participants.csv and the persona file by the exact code
    assert list(store.participants_frame()["participant"]) == ["P01", "R01", "p02", "r01", "r03"]
    for code in ("R01", "p02"):
        store.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
    assert [p["id"] for p in json.loads(store.export_personas())["participants"]] == ["R01", "p02"]


def test_participants_are_listed_in_natural_order(store):
    """As a researcher reads codes (records.code_order): "P2" before "P10" (as text, "P10, P2"), and "P_1"
    and "P-3" before "P01" and "PA" (ignoring case, "-" came before the digits and "_" between them and
    letters: "P-3, P01, P10, P2, P_1, PA"); the message naming the known participants lists them so too; the exports by the exact code."""
    for code in ("P10", "P2", "PA", "P_1", "P-3"):
        store.add_participant(code)
    natural = ["P_1", "P-3", "P01", "P2", "P10", "PA"]
    assert [p.code for p in store.list_participants()] == natural
    with pytest.raises(CacasError, match=r"known participants: " + ", ".join(natural) + "$"):
        store.get_participant("X9")
    assert list(store.participants_frame()["participant"]) == sorted(natural)


@pytest.mark.parametrize("code", ["", "   ", "Jane Doe", "P" * 17, "a/b", "-x", None, 7])
def test_bad_participant_code_is_refused(store, code):
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="participant code"):
        store.add_participant(code)
    assert snapshot(store.path) == before


@pytest.mark.parametrize("notes, found", [("Call John at 555-1234", "555-1234"), ("mail: jo.doe@uni.edu", "jo.doe@uni.edu"),
                                          ("+44 20 7946 0958 (home)", "+44 20 7946 0958"),
                                          ("office (405) 744-5000", "(405) 744-5000"),
                                          ("her daughter: 06 12 34 56 78", "06 12 34 56 78"),
                                          # data steward's audit: forms the check missed
                                          ("mobile +33 6 12 34 56 78", "+33 6 12 34 56 78"),
                                          ("Tel.: 0 30 / 12 34 56 78", "0 30 / 12 34 56 78"),
                                          ("anna\uff20example.com", "anna@example.com"),  # full-width @
                                          ("john\u200b@example.com", "john@example.com")])  # zero-width space
def test_contact_details_in_free_text_are_refused(store, notes, found):
    before = snapshot(store.path)
    with pytest.raises(CacasError, match=f"notes contain what looks like contact details \\({re.escape(repr(found))}\\)"):
        store.add_participant("P03", notes=notes)
    with pytest.raises(CacasError, match="comments contain what looks like contact details"):
        store.record_questionnaire("P01", 8, notes)
    described = [{"description": f"when I fall, {notes}", "activity": ["fall down"], "action": "call someone for help"}]
    with pytest.raises(CacasError, match="field 'description': holds what looks like contact details"):
        store.save_preferences("P01", described)  # the Participants form
    with pytest.raises(CacasError, match="field 'description': holds what looks like contact details"):
        store.import_personas({"participants": [{"id": "P09", "preferences": described}]})
    assert snapshot(store.path) == before


def test_preferences_saved_before_the_contact_details_check_still_read(store):
    """The check is on the way in: a version an older CACAS Studio saved with a phone number in
    its words is read (evaluated, exported) as it is."""
    import json as _json
    store.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
    old = [{"description": "call 555-1234", "activity": ["cough"], "action": "pain check"}]
    with store._lock:
        store._conn.execute("UPDATE preferences SET preferences = ? WHERE version = 1", (_json.dumps(old),))
        store._conn.commit()
    assert store.get_preferences("P01").preferences[0].description == "call 555-1234"
    assert "555-1234" in store.export_personas()


@pytest.mark.parametrize("notes", ["visit 2026/11/21 at 10:00", "slots 0-2 2-4 4-6 6-8 8-10", "pain 0/10 3/10 4/10",
                                   "0.25 0.5 0.75 1.0", "accuracy 0.91/0.85/0.73", "0 1 2 3 4 5 6 7 8",
                                   "06/08 08/10 10/12", "01/02/03/04/05"])
def test_dates_hours_scores_and_lists_are_not_phone_numbers(store, notes):
    """Review: the check's forms for '+33 6 12 34 56 78' and slashes refused these ordinary notes."""
    assert store.add_participant("P03", notes=notes).notes == notes


def test_dates_times_and_counts_in_free_text_are_not_contact_details(store):
    notes = ("first session 2026-11-21 10:00-12:00, again on 21.11.2026; 3 kids, rated 8 9 10; age 65+; "
             "awake 6-10 16-20 daily; ratings 8 9 10 8 7 9 10")  # runs of small numbers were taken for phones
    assert store.add_participant("P03", notes=notes).notes == notes


def test_a_study_name_with_a_phone_number_is_refused(store):
    """A study's name is in every export (data steward's audit: 'pilot 0151 12345678' was taken)."""
    before = snapshot(store.path)
    with pytest.raises(CacasError, match=r"study name 'pilot 0151 12345678' holds what looks like a phone number "
                                         r"\('0151 12345678'\)"):
        store.create_study("pilot 0151 12345678")
    assert snapshot(store.path) == before
    assert store.create_study("pilot 2026-11 wave 2") is not None  # dates and numbers of waves are names


def test_a_study_name_that_differs_from_one_only_in_letter_case_is_refused(store):
    """Walkthrough: "Default" was created beside "default"; the sidebar listed both, and
    participants were added to the one not meant. Codes refuse their case twins the same way."""
    store.create_study("pilot walk")
    before = snapshot(store.path)
    for name, existing in (("Default", "default"), ("DEFAULT ", "default"), ("Pilot Walk", "pilot walk")):
        with pytest.raises(CacasError, match=f"^study {name.strip()!r} differs from study {existing!r} only in "
                                             "letter case; study names must be unique, also in letter case$"):
            store.create_study(name)
    with pytest.raises(CacasError, match="^study 'pilot walk' already exists; study names must be unique"):
        store.create_study("pilot walk")
    assert snapshot(store.path) == before
    assert [s.name for s in store.studies()] == ["default", "pilot walk"]


def test_a_lookup_that_differs_from_a_code_or_study_only_in_letter_case_suggests_it(store):
    """`--participant p01` said "unknown participant 'p01'; known participants: P01". Codes and
    study names cannot differ only in letter case, so the message names the one meant; the lookup
    stays exact (nothing is matched, changed or written)."""
    store.add_participant("P02")
    store.create_study("Pilot Walk")
    before = snapshot(store.path)
    with pytest.raises(CacasError, match=r"^unknown participant 'p01'; did you mean 'P01'\? known participants: "
                                         r"P01, P02$"):
        store.get_participant("p01")
    with pytest.raises(CacasError, match=r"^unknown participant ' p02 '; did you mean 'P02'\? known"):
        store.update_participant(" p02 ", notes="x")
    with pytest.raises(CacasError, match=r"^unknown study 'pilot walk'; did you mean 'Pilot Walk'\? known studies: "
                                         r"Pilot Walk, default$"):
        store.add_participant("P03", study="pilot walk")
    # no case twin: the message as before
    with pytest.raises(CacasError, match=r"^unknown participant 'P09'; known participants: P01, P02$"):
        store.get_participant("P09")
    with pytest.raises(CacasError, match=r"^unknown study 'nope'; known studies: Pilot Walk, default$"):
        store.add_participant("P03", study="nope")
    assert snapshot(store.path) == before
    assert [p.code for p in store.list_participants()] == ["P01", "P02"]


def test_no_suggestion_when_a_restored_study_keeps_two_codes_that_differ_only_in_letter_case(store):
    """A restored backup may keep case twins (restore notes them); then "which one" is not ours to guess."""
    with sqlite3.connect(store.path) as c:  # as a restored backup holds them
        c.executemany("INSERT INTO participants (study_id, code, created_at, updated_at) VALUES (1, ?, 'x', 'x')",
                      [("Ab",), ("aB",)])
    with pytest.raises(CacasError, match=r"^unknown participant 'ab'; known participants: Ab, aB, P01$"):
        store.get_participant("ab")
    assert store.get_participant("aB").code == "aB"


@pytest.mark.parametrize("code", ["0612345678", "20261121", "06-12-34-56-78"])
def test_a_new_participant_code_that_looks_like_a_phone_number_or_a_date_is_refused(store, code):
    """A code is in every export: one that is a phone number or a birth date is not pseudonymous.
    Refused where a participant is added (form, persona import); codes of the example kind pass."""
    before = snapshot(store.path)
    message = rf"participant code '{code}' looks like a phone number or a date, which could identify the participant"
    with pytest.raises(CacasError, match=message):
        store.add_participant(code)
    with pytest.raises(CacasError, match=rf"^persona file: {message}"):
        store.import_personas({"participants": [{"id": code, "preferences": [COUGH]}]})
    assert snapshot(store.path) == before
    for fine in ("P09", "S20261121", "PILOT-0001", "T1234567"):
        assert store.add_participant(fine).code == fine


@pytest.mark.parametrize("code", ["CON", "nul", "Aux", "PRN", "COM1", "lpt9"])
def test_a_new_participant_code_that_windows_keeps_for_a_device_is_refused(store, code):
    """A participant's policy files go in policies/<code>/, and Windows makes no folder named CON,
    NUL, AUX, PRN, COM1-9 or LPT1-9 (in any letter case): a study begun on Linux or a Mac and moved
    to a Windows laptop could not save that participant's adapted policy at the end of a day.
    Refused where a participant is added, on every system; codes that merely hold such a name pass."""
    before = snapshot(store.path)
    message = rf"^participant code '{code}' is a name Windows keeps for a device: .*policies/<code>/.*other than CON"
    with pytest.raises(CacasError, match=message):
        store.add_participant(code)
    with pytest.raises(CacasError, match=rf"^persona file: participant code '{code}' is a name Windows keeps"):
        store.import_personas({"participants": [{"id": code, "preferences": [COUGH]}]})
    assert snapshot(store.path) == before
    for fine in ("CON1", "CONTROL-01", "COM10", "NUL_2", "LPT0"):
        assert store.add_participant(fine).code == fine


def test_line_breaks_in_free_text_are_kept_as_line_feeds_and_text_that_is_not_unicode_is_refused(store):
    """A lone carriage return broke the exported CSV's rows; a lone surrogate raised
    UnicodeEncodeError from SQLite instead of one clear message."""
    assert store.add_participant("P02", notes="first\rsecond\r\nthird").notes == "first\nsecond\nthird"
    before = snapshot(store.path)
    with pytest.raises(CacasError, match=r"^notes holds a character that is not valid Unicode text \(at position 3\)"):
        store.update_participant("P01", notes="abc\ud800")
    with pytest.raises(CacasError, match="comments holds a character that is not valid Unicode"):
        store.record_questionnaire("P01", 7, "\udfff")
    with pytest.raises(CacasError, match=r"^method 'cacas\\n' is invalid"):  # was taken, and named a policy file
        store.save_policy("P01", 0, "cacas\n", b"policy")
    assert snapshot(store.path) == before


def test_notes_that_are_too_long_or_not_text_are_refused(store):
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="^notes is 2001 characters long; valid: at most 2000$"):
        store.add_participant("P03", notes="x" * 2001)
    with pytest.raises(CacasError, match="^notes must be text, got int$"):
        store.update_participant("P01", notes=5)
    with pytest.raises(CacasError, match=r"^study name ' ' is invalid; valid: 1-64 letters A-Z \(no accents\), digits, spaces"):
        store.create_study(" ")
    # review: "letters" read as any letter, and "Pilot Ü" or "Zoë1" was refused as a bug would be
    with pytest.raises(CacasError, match=r"^study name 'Pilot Ü' is invalid; valid: 1-64 letters A-Z \(no accents\)"):
        store.create_study("Pilot Ü")
    with pytest.raises(CacasError, match=r"letters A-Z \(no accents\), digits"):
        store.add_participant("Zoë1")
    assert snapshot(store.path) == before
    assert store.add_participant("P03", notes="x" * 2000).notes == "x" * 2000



def test_a_case_twin_of_a_participant_in_a_database_beside_is_refused_where_letter_case_is_not_told_apart(
        store, tmp_path, monkeypatch):
    """Safety audit L4 follow-up: the forms looked at their own database only, so a pilot's p01 was
    added beside the main study's P01, and on a file system that does not tell letter case apart
    (macOS's default) the two share policies/P01/. Adding it (by the form, or from a persona file)
    is refused there with one message, as an import is, and nothing is written; the same code (a
    copy of the same person, whose files a removal keeps) and a case twin where the file system
    tells letter case apart are added. The probe is told the disk is case-blind, as in the L4 tests."""
    from cacas.store import files

    pilot = StudyStore(tmp_path / "pilot.sqlite")
    before = snapshot(pilot.path)
    monkeypatch.setattr(files, "ignores_letter_case", lambda folder: True)
    said = (f"participant p01 differs only in letter case from participant P01 of the study database study.sqlite "
            f"beside this one; the file system of {tmp_path} does not tell letter case apart (as macOS's and "
            "Windows' do by default), so they would share one folder of policy files, and removing one would delete "
            "the other's; valid: a code that differs from P01 in more than letter case; ")
    with pytest.raises(CacasError) as err:
        pilot.add_participant("p01")
    assert str(err.value) == said + "nothing was added"
    with pytest.raises(CacasError) as err:
        pilot.import_personas({"participants": [{"id": "P02", "preferences": [COUGH]},
                                                {"id": "p01", "preferences": [COUGH]}]}, source="personas.json")
    assert str(err.value) == "personas.json: " + said + "nothing was imported"
    assert snapshot(pilot.path) == before
    with StudyStore(tmp_path / "copy.sqlite") as copy:
        assert copy.add_participant("P01").code == "P01"
    monkeypatch.undo()
    if files.ignores_letter_case(tmp_path):  # pragma: no cover - this machine's disk does not tell letter case apart
        return
    assert pilot.add_participant("p01").code == "p01"
    pilot.close()


def test_an_age_range_typed_with_other_digits_is_saved_with_0_to_9(store):
    """A Japanese keyboard types full-width digits, an Arabic one Arabic-Indic digits: "２５-３４" and "٢٥-٣٤" were
    taken and kept as typed, so participants.csv held three spellings of one range (a group-by counts three)."""
    # and a dash as a word processor writes it between two numbers (an en dash: macOS, Word; i18n's left-alone item)
    for typed, saved in (("２５-３４", "25-34"), ("٢٥-٣٤", "25-34"), ("６５＋", "65+"), ("٣٠", "30"), ("३०", "30"),
                         ("25–34", "25-34"), ("25 — 34", "25-34"), ("25−34", "25-34")):
        store.add_participant("P07", age_range=typed)
        assert store.get_participant("P07").age_range == saved, typed
        assert store.update_participant("P07", age_range=typed).age_range == saved, typed
        store.remove_participant("P07", confirm="P07")
    with pytest.raises(CacasError, match=r"^age range '２５０' is invalid; valid: .*ages up to 120$"):
        store.add_participant("P07", age_range="２５０")


def test_a_code_typed_in_full_width_says_how_to_type_it(store):
    """'ｐ０１' from a Japanese or Chinese keyboard was refused with the generic message, the researcher left to
    see why it is not p01 (i18n's left-alone item). It is still refused (a code is an identity across files,
    never changed without a word), naming the half-width code; other codes get the message as before."""
    with pytest.raises(CacasError, match=r"^participant code 'ｐ０１' is invalid; it is written in full-width letters "
                                         r"or digits: type it as 'p01' \(half-width\); valid: a pseudonymous code"):
        store.add_participant("ｐ０１")
    with pytest.raises(CacasError, match=r"^participant code 'Ü01' is invalid; valid: a pseudonymous code"):
        store.add_participant("Ü01")
    assert [p.code for p in store.list_participants()] == ["P01"]


def test_duplicate_code_and_bad_age_range_and_unknown_study(store):
    before = snapshot(store.path)
    with pytest.raises(CacasError, match=r"^participant P01 already exists \(in study 'default'\); codes must be "
                                         "unique across all studies$"):
        store.add_participant("P01")
    with pytest.raises(CacasError, match=r"^participant p01 differs from participant P01 \(in study 'default'\) "
                                         "only in letter case; codes must be unique across all studies$"):
        store.add_participant("p01")
    with pytest.raises(CacasError, match="age range"):
        store.add_participant("P03", age_range="old")
    with pytest.raises(CacasError, match="age range"):
        store.add_participant("P03", age_range="35-25")
    for age in ("200", "65-200", "121+"):  # walkthrough: "200" was taken
        with pytest.raises(CacasError, match=rf"^age range '{re.escape(age)}' is invalid; valid: e\.g\. \"25-34\", "
                                             r'"65\+" or empty, ages up to 120$'):
            store.add_participant("P03", age_range=age)
    with pytest.raises(CacasError, match="^age range '130' is invalid"):
        store.update_participant("P01", age_range="130")
    with pytest.raises(CacasError, match="unknown study 'nope'"):
        store.add_participant("P03", study="nope")
    with pytest.raises(CacasError, match="unknown participant 'P09'"):
        store.update_participant("P09", notes="x")
    assert snapshot(store.path) == before
    # walkthrough: P01 added in study "Pilot" said "already exists" beside "0 participant(s) in study 'Pilot'"
    store.create_study("Pilot")
    with pytest.raises(CacasError, match=r"^participant P01 already exists \(in study 'default'\)"):
        store.add_participant("P01", study="Pilot")


def test_preferences_may_be_given_as_the_participants_persona_object(store):
    """design.md's participant object was refused with a message about preference 1's fields."""
    from cacas.preferences import parse_participant

    assert store.save_preferences("P01", {"id": "P01", "preferences": [COUGH]}) == 1
    assert store.save_preferences("P01", {"preferences": [COUGH]}) == 1  # the same: not saved again
    assert store.save_preferences("P01", parse_participant({"id": "P01", "preferences": [COUGH]})) == 1
    for other in ({"id": "P02", "preferences": [COUGH]}, parse_participant({"id": "P02", "preferences": [COUGH]})):
        with pytest.raises(CacasError, match="participant P01: these preferences are participant P02's"):
            store.save_preferences("P01", other)
    assert store.get_preferences("P01").preferences[0].action == "pain check"
    with pytest.raises(CacasError, match="no preference version 2"):  # nothing else was saved
        store.get_preferences("P01", version=2)


def test_preferences_are_versioned_and_validated(store):
    assert store.get_preferences("P01") is None
    assert store.save_preferences("P01", [STOVE]) == 1
    assert store.save_preferences("P01", [STOVE, COUGH]) == 2
    assert len(store.get_preferences("P01").preferences) == 2
    assert len(store.get_preferences("P01", version=1).preferences) == 1
    assert [v["count"] for v in store.preference_versions("P01")] == [1, 2]
    assert store.save_preferences("P01", [dict(STOVE), dict(COUGH)]) == 2  # unchanged: no new version
    assert len(store.preference_versions("P01")) == 2
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="activity"):
        store.save_preferences("P01", [{"activity": ["juggle"], "action": "chitchat"}])
    with pytest.raises(CacasError, match="preferences 1 and 2"):
        store.save_preferences("P01", [COUGH, {"activity": ["cough"], "action": "chitchat"}])
    with pytest.raises(CacasError, match="unknown participant"):
        store.save_preferences("P77", [COUGH])
    assert snapshot(store.path) == before


def test_persona_json_round_trip(store, tmp_path):
    store.save_preferences("P01", [STOVE, COUGH])
    text = store.export_personas()
    assert json.loads(text)["participants"][0]["id"] == "P01"
    other = StudyStore(tmp_path / "other.sqlite")
    assert other.import_personas(text).added == ("P01",)
    assert other.get_preferences("P01") == store.get_preferences("P01")
    before = snapshot(other.path)
    bad = {"participants": [{"id": "P05", "preferences": [COUGH]},
                            {"id": "P06", "preferences": [{"activity": ["juggle"], "action": "chitchat"}]}]}
    with pytest.raises(CacasError, match="participant P06"):
        other.import_personas(bad)
    with pytest.raises(CacasError, match="participant code"):
        other.import_personas({"participants": [{"id": "Jane Doe", "preferences": [COUGH]}]})
    assert snapshot(other.path) == before
    again = other.import_personas(text)  # the same file again: no new version
    assert (again.codes, again.added, again.unchanged) == (("P01",), (), ("P01",))
    assert len(other.preference_versions("P01")) == 1
    other.close()


def test_an_import_does_not_replace_the_preferences_of_a_participant_under_way(store):
    """Walkthrough: importing the example personas (P01-P08) into a study under way gave its P01
    and P02 the examples' preferences, silently, mid-study (P02's accuracy fell to 0 %), and added
    P03-P08. Refused, naming them and their day, unless the researcher chooses to replace them; the
    same preferences, or a participant without any, import as before."""
    store.save_preferences("P01", [COUGH])
    store.add_participant("P02")
    store.save_preferences("P02", [STOVE])
    store.open_day("P02")
    store.add_participant("P03")  # no preferences yet: nothing to lose
    before = snapshot(store.path)
    example = {"participants": [{"id": "P01", "preferences": [STOVE]}, {"id": "P02", "preferences": [COUGH]},
                                {"id": "P03", "preferences": [COUGH]}, {"id": "P04", "preferences": [COUGH]}]}
    with pytest.raises(CacasError, match=r"^example.json: P01, P02 \(day 1\) are in study 'default' already, with "
                                         r"other preferences; nothing was imported\."):
        store.import_personas(example, source="example.json")
    assert snapshot(store.path) == before  # P04 not added either
    same = {"participants": [{"id": "P01", "preferences": [COUGH]}, {"id": "P03", "preferences": [COUGH]}]}
    done = store.import_personas(same)
    assert (done.codes, done.unchanged, done.first) == (("P01", "P03"), ("P01",), ("P03",))
    assert [len(store.preference_versions(c)) for c in ("P01", "P03")] == [1, 1]
    done = store.import_personas(example, replace=True)  # what happened to each, for the page to say
    assert done == PersonasImport(codes=("P01", "P02", "P03", "P04"), added=("P04",), replaced=("P01", "P02"),
                                  unchanged=("P03",))
    assert store.get_preferences("P02").preferences[0].action == COUGH["action"]
    assert [len(store.preference_versions(c)) for c in ("P01", "P02", "P03", "P04")] == [2, 2, 1, 1]


def test_import_never_touches_another_studys_participants(store):
    store.create_study("pilot")
    store.import_personas({"participants": [{"id": "P10", "preferences": [COUGH]}]}, study="pilot")
    before = snapshot(store.path)
    clash = {"participants": [{"id": "P11", "preferences": [COUGH]}, {"id": "P10", "preferences": [STOVE]}]}
    with pytest.raises(CacasError, match="new.json: participant P10 belongs to study 'pilot', not 'default'; "
                                         "nothing was imported"):
        store.import_personas(clash, source="new.json")
    with pytest.raises(CacasError, match=r"participant p10 differs from participant P10 \(in study 'pilot'\) only "
                                         "in letter case"):
        store.import_personas({"participants": [{"id": "p10", "preferences": [STOVE]}]}, study="pilot")
    with pytest.raises(CacasError, match="new.json, participant p13, field .id.: differs from participant P13 "
                                         "only in letter case"):
        store.import_personas({"participants": [{"id": "P13", "preferences": [STOVE]},
                                                {"id": "p13", "preferences": [STOVE]}]}, source="new.json")
    assert snapshot(store.path) == before  # all or nothing: P11 was not added either
    with pytest.raises(CacasError, match="persona file: P10 is in study 'pilot' already, with other preferences; "
                                         "nothing was imported. To save the file's as their new version, choose "
                                         "to replace them"):
        store.import_personas(clash, study="pilot")
    assert snapshot(store.path) == before
    assert store.import_personas(clash, study="pilot", replace=True).codes == ("P11", "P10")  # into its own study
    assert store.get_preferences("P10").preferences[0].action == "remind to turn off"
    # a database from before the case check may hold both P12 and p12: each imports as itself
    with sqlite3.connect(store.path) as con:
        sid = con.execute("SELECT id FROM studies WHERE name = 'default'").fetchone()[0]
        for code in ("P12", "p12"):
            con.execute("INSERT INTO participants (study_id, code, created_at, updated_at) VALUES (?, ?, '', '')",
                        (sid, code))
    assert store.import_personas({"participants": [{"id": "p12", "preferences": [COUGH]}]}).codes == ("p12",)
    assert store.get_preferences("P12") is None and store.get_preferences("p12") is not None


# --- days and interactions ------------------------------------------------------------------------

def test_days_open_close_and_current(store):
    assert store.current_day("P01") is None
    assert store.open_day("P01") == 1
    assert store.open_day("P01") == 1  # still open: a reload opens nothing new
    store.close_day("P01", 1)
    store.close_day("P01", 1)  # closing twice changes nothing
    assert store.open_day("P01") == 2
    assert store.current_day("P01") == 2
    assert [(d.day, d.is_open) for d in store.days("P01")] == [(1, False), (2, True)]
    with pytest.raises(CacasError, match="no day 5"):
        store.close_day("P01", 5)


def test_a_day_given_as_a_numpy_integer_is_closed(store):
    """A day number read from a frame is numpy's: close_day closed nothing with it (SQLite stored no
    match) yet logged the day closed, and an adapted day stayed open for more interactions."""
    store.open_day("P01")
    store.close_day("P01", np.int64(1))
    assert [(d.day, d.is_open) for d in store.days("P01")] == [(1, False)]
    with pytest.raises(CacasError, match="day 1 of participant P01 is closed"):
        store.record_interaction("P01", 1, **GOOD)
    with pytest.raises(CacasError, match=r"^day 1\.5 is invalid; valid: a whole number >= 1$"):
        store.close_day("P01", 1.5)


def test_record_interaction_all_fields(store):
    day = store.open_day("P01")
    i1 = store.record_interaction("P01", day, **GOOD, probabilities=probs(), recognised_activity="sneeze",
                                  recognised_scene="bedroom", task="chitchat", time="2026-11-21T10:00:00Z")
    i2 = store.record_interaction("P01", day, activity="Use Stove", scene="kitchen", time_slot=3,
                                  interval_bin=0, robot_action="do nothing", response="accept",
                                  type=USER_INITIATED, user_action="remind to turn off",
                                  previous_action="pain check", previous_response="accept")
    assert i2 > i1
    df = store.interactions_frame("P01")
    assert list(df.columns) == INTERACTION_COLUMNS
    assert list(df["index"]) == [1, 2]
    first, second = df.iloc[0], df.iloc[1]
    assert (first.activity, first.time_slot, first.interval, first.task, first.method) == \
        ("cough", 3, 10, "chitchat", "cacas")  # S4: 12 minutes is in the bin of 10
    assert first.user_action == "" and first.time == "2026-11-21T10:00:00.000Z"
    assert (second.activity, second.type, second.user_action, second.previous_action) == \
        ("use stove", "type_2", "remind to turn off", "pain check")
    extra = store.interactions_frame("P01", extra=True)
    assert list(extra.columns[:len(INTERACTION_COLUMNS)]) == INTERACTION_COLUMNS
    assert extra.iloc[0]["recognised_activity"] == "sneeze"
    assert np.allclose(json.loads(extra.iloc[0]["probabilities"]), probs())
    assert extra.iloc[0]["hour"] == 7.5 and np.isnan(extra.iloc[1]["hour"])
    assert store.events(participant="P01", what="record_interaction").shape[0] == 2


BAD_INTERACTIONS = [
    (dict(response="maybe"), "unknown response 'maybe'"),
    (dict(activity="juggle"), "unknown activity 'juggle'"),
    (dict(scene="garage"), "unknown scene 'garage'"),
    (dict(robot_action="dance"), "unknown action 'dance'"),
    (dict(task="dance"), "task: unknown action"),
    (dict(previous_response="yes"), "previous_response: unknown response 'yes'; valid: accept, reject, others"),
    (dict(recognised_activity="juggle"), "recognised_activity: unknown activity 'juggle'; valid: cough, "),
    (dict(type="type_3"), "interaction type"),
    (dict(type="type_2"), "user_action is missing"),
    (dict(type="type_2", user_action="do nothing"), "not a request"),
    (dict(type="type_2", user_action="chitchat", response="reject"),
     r"response 'reject' given for a user-initiated \(type_2\) interaction; valid: 'accept'"),
    (dict(type="type_2", user_action="pain check", robot_action="pain check", response="accept"),
     r"user_action 'pain check' is the robot's own proposal \(robot_action\); valid: a request for another "
     r"action, or the proposal's accept as a robot-initiated \(type_1\) interaction"),
    (dict(user_action="chitchat"), r"user_action 'chitchat' given for a robot-initiated \(type_1\) interaction; "
                                   "only type_2 interactions have one"),
    (dict(hour=24), "hour 24 is invalid; valid: a number with 0 <= hour < 24"),
    (dict(hour=None), "time of day is missing"),
    (dict(hour=7.5, time_slot=5), "time slot"),
    (dict(interval_minutes=-1), "interval_minutes"),
    (dict(probabilities=[0.5] * 14), "sum to 1"),
    (dict(probabilities=[1.0]), "14 numbers"),
    (dict(time="yesterday"), "time 'yesterday'"),
    (dict(method="Bad Method"), "method 'Bad Method' is invalid; valid: a short lower-case name"),
    (dict(policy_version=3), "no policy version 3"),
    (dict(interval_minutes=None), r"repeat interval is missing; give interval_minutes \(>= 0\) or interval_bin"),
    (dict(interval_bin=5), "interval 12 minutes is in bin 4, not 5; give one of them"),
    (dict(probabilities={"pain check": 0.9, "dance": 0.1}), "probabilities: unknown action 'dance'"),
    (dict(probabilities=["high"] * 14), "probabilities must be 14 numbers, one per action"),
    (dict(time=1763718454), "time 1763718454 is invalid; valid: a datetime with a time zone"),
    # a time without a zone was stored as given, and compared as text with the app's UTC times
    (dict(time="2026-11-21T10:00:00"), r"time '2026-11-21T10:00:00' has no time zone, so which moment it names "
                                       r"is not known; valid: an ISO 8601 time with a time zone, such as "
                                       r'"2026-11-21T10:00:00Z" \(UTC\)'),
    (dict(time="2026-11-21"), r"time '2026-11-21' is a date alone; valid: an ISO 8601 time with a time zone"),
    (dict(time=pd.NaT), r"^time NaT is missing; valid: an ISO 8601 time"),  # a frame's missing time (ValueError)
]


@pytest.mark.parametrize("change,message", BAD_INTERACTIONS)
def test_bad_interaction_is_refused_with_nothing_written(store, change, message):
    day = store.open_day("P01")
    store.record_interaction("P01", day, **GOOD)
    before = snapshot(store.path)
    with pytest.raises(CacasError, match=message):
        store.record_interaction("P01", day, **{**GOOD, **change})
    assert snapshot(store.path) == before


def test_probabilities_by_action_name_are_kept_in_table_one_order(store):
    """A dict by action name (record_interaction's docstring) is stored as the 14 numbers in Table
    I's order, an action it leaves out at 0."""
    day = store.open_day("P01")
    store.record_interaction("P01", day, **GOOD, probabilities={"chitchat": 0.25, "pain check": 0.75})
    stored = json.loads(store.interactions_frame("P01", extra=True).iloc[0]["probabilities"])
    expected = [0.0] * spaces.N_ACTIONS
    expected[spaces.action_index("chitchat")], expected[spaces.action_index("pain check")] = 0.25, 0.75
    assert stored == expected


def test_an_interaction_time_is_stored_in_utc_as_the_app_writes_it(store):
    """A time with a zone, as a datetime or as text, is stored in UTC with milliseconds and "Z", as
    the app's own times (the docs promise UTC, ISO 8601): text was stored as given (with its
    offset), a datetime or text without a zone as given, and a date alone was taken."""
    from datetime import datetime, timedelta, timezone
    day = store.open_day("P01")
    plus_one = timezone(timedelta(hours=1))
    for time in (datetime(2026, 11, 21, 10, 0, 5, 123456, tzinfo=plus_one), "2026-11-21T10:00:05.123456+01:00",
                 "2026-11-21T09:00:05.123Z", " 2026-11-21T09:00:05.123+00:00 "):
        store.record_interaction("P01", day, **GOOD, time=time)
    store.record_interaction("P01", day, **GOOD, time="2026-11-21T09:00:05Z")
    assert list(store.interactions_frame("P01")["time"]) == ["2026-11-21T09:00:05.123Z"] * 4 + [
        "2026-11-21T09:00:05.000Z"]
    before = snapshot(store.path)
    for naive in (datetime(2026, 11, 21, 10, 0, 5), "2026-11-21T10:00:00.000", "2026-11-21"):
        with pytest.raises(CacasError, match=r'valid: an ISO 8601 time with a time zone, such as "2026-11-21T10:0'):
            store.record_interaction("P01", day, **GOOD, time=naive)
    assert snapshot(store.path) == before


def test_interaction_for_missing_participant_or_day_or_closed_day(store):
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="unknown participant 'P99'"):
        store.record_interaction("P99", 1, **GOOD)
    with pytest.raises(CacasError, match="P01 has no day 1; they have no day yet"):
        store.record_interaction("P01", 1, **GOOD)
    assert snapshot(store.path) == before
    store.open_day("P01")
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="has no day 2; they have days 1..1"):
        store.record_interaction("P01", 2, **GOOD)
    with pytest.raises(CacasError, match="day 0"):
        store.record_interaction("P01", 0, **GOOD)
    assert snapshot(store.path) == before
    store.close_day("P01", 1)
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="day 1 of participant P01 is closed"):
        store.record_interaction("P01", 1, **GOOD)
    assert snapshot(store.path) == before


# --- policies, adaptations, questionnaire ---------------------------------------------------------

def test_policy_versions_atomic_files_hash_and_rollback(store):
    store.open_day("P01")
    assert store.active_policy("P01") is None
    v1 = store.save_policy("P01", 0, "cacas", b"initial policy")
    v2 = store.save_policy("P01", 1, "cacas", b"day one policy")
    assert (v1, v2) == (1, 2)
    active = store.active_policy("P01")
    assert active.version == 2 and active.path.name.startswith("day1-cacas-") and active.path.exists()
    assert not list(active.path.parent.glob(".*.tmp"))
    assert store.load_policy("P01") == b"day one policy"
    assert store.load_policy("P01", day=0) == b"initial policy"
    store.set_active_policy("P01", 1)
    assert store.load_policy("P01") == b"initial policy"
    assert store.resume("P01").policy_version == 1
    # the interaction records the version in force
    store.record_interaction("P01", 1, **GOOD)
    assert store.interactions_frame("P01", extra=True)["policy_version"].tolist() == [1]
    # a damaged file is detected
    active.path.write_bytes(b"tampered")
    with pytest.raises(CacasError, match="does not match its recorded sha256"):
        store.load_policy("P01", version=2)
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="no policy version 9"):
        store.set_active_policy("P01", 9)
    with pytest.raises(CacasError, match="no day 4"):
        store.save_policy("P01", 4, "cacas", b"x")
    with pytest.raises(CacasError, match="no saved policy"):
        store.load_policy("P01", day=1, method="orl")
    assert snapshot(store.path) == before
    assert [p.version for p in store.policy_versions("P01")] == [1, 2]


def test_a_policy_saved_without_activating_it_leaves_the_one_in_force(store):
    store.open_day("P01")
    store.save_policy("P01", 0, "cacas", b"initial policy")
    v2 = store.save_policy("P01", 1, "nn", b"a comparison policy", activate=False)
    assert store.active_policy("P01").version == 1 and store.load_policy("P01") == b"initial policy"
    assert [(p.version, p.active) for p in store.policy_versions("P01")] == [(1, True), (v2, False)]
    assert store.load_policy("P01", version=v2) == b"a comparison policy"
    saved = store.events(participant="P01", what="save_policy")["details"].map(json.loads).tolist()
    assert [(d["version"], d["active"]) for d in saved] == [(1, True), (2, False)]


def test_a_policy_that_is_not_bytes_or_a_read_only_store_writes_no_file(store):
    store.open_day("P01")
    before = snapshot(store.path)
    for data in (b"", "a policy as text", None):
        with pytest.raises(CacasError, match=r"^policy data must be non-empty bytes \(ReshapedPolicy.to_bytes\(\)\)$"):
            store.save_policy("P01", 1, "cacas", data)
    with StudyStore(store.path, readonly=True) as ro:
        with pytest.raises(CacasError, match=f"^{re.escape(str(store.path))}: opened read-only; nothing was written$"):
            ro.save_policy("P01", 1, "cacas", b"a policy")
    assert snapshot(store.path) == before and not store.policy_dir.exists()


def _clock(monkeypatch, offset_ns: int) -> None:
    """The damaged-file check's clock moved ``offset_ns`` on (the code before it had none)."""
    import time
    from types import SimpleNamespace

    from cacas.store import policies
    monkeypatch.setattr(policies, "time", SimpleNamespace(time_ns=lambda: time.time_ns() + offset_ns), raising=False)


def test_a_same_size_rewrite_keeping_the_modification_time_is_seen_as_damage(store, monkeypatch):
    """Safety audit L10: the damaged-file check remembered each file's answer by its size and
    modification time, so a rewrite of the same size within the time granularity (here: the
    modification time set back, as ``touch -d`` or ``cp -p`` do) was not seen; the Results page
    offered the zip, and its download failed with the browser's bare "Failed to generate file".
    The status change time (ctime), which no program sets back, is part of the key now."""
    import os

    store.open_day("P01")
    store.save_policy("P01", 1, "cacas", b"the adapted policy")
    path = store.active_policy("P01").path
    _clock(monkeypatch, 10**12)  # the file's last change long past: its answer is remembered
    assert store.damaged_policy_files() == []
    st = path.stat()
    path.write_bytes(b"the adapted POLICY")  # same size
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert path.stat().st_size == st.st_size and path.stat().st_mtime_ns == st.st_mtime_ns
    assert store.damaged_policy_files() == [f"P01/{path.name}"]


def test_a_policy_file_changed_just_now_is_read_at_every_check(store, monkeypatch):
    """A file whose last change is under 2 s old is not remembered (on FAT, HFS+ or a network share
    a rewrite within the same second or two keeps every time stamp); once settled, it is read once."""
    from cacas.store import files, policies

    store.open_day("P01")
    store.save_policy("P01", 1, "cacas", b"the adapted policy")
    reads = []
    real = files.sha256
    monkeypatch.setattr(files, "sha256", lambda data: reads.append(1) or real(data))
    _clock(monkeypatch, 0)
    policies._CHECKED.clear()
    assert store.damaged_policy_files() == [] and store.damaged_policy_files() == [] and len(reads) == 2
    _clock(monkeypatch, policies._SETTLED_NS)
    assert store.damaged_policy_files() == [] and store.damaged_policy_files() == [] and len(reads) == 3


def test_adaptation_runs(store):
    store.open_day("P01")
    v = store.save_policy("P01", 1, "cacas", b"p")
    run = store.record_adaptation("P01", 1, "cacas", {"epochs": np.int64(3), "beta": 0.5}, 12.5,
                                  {"preference_accuracy": np.float32(0.75)}, policy_version=v)
    df = store.adaptations_frame("P01")
    assert run == 1 and df.iloc[0]["preference_accuracy"] == 0.75
    assert json.loads(df.iloc[0]["parameters"]) == {"beta": 0.5, "epochs": 3}
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="no day 3"):
        store.record_adaptation("P01", 3, "cacas", {}, 1.0, {})
    with pytest.raises(CacasError, match="duration_s"):
        store.record_adaptation("P01", 1, "cacas", {}, -1.0, {})
    with pytest.raises(CacasError, match="parameters must be a dict"):
        store.record_adaptation("P01", 1, "cacas", [1], 1.0, {})
    with pytest.raises(CacasError, match=r"^metrics cannot be stored as JSON \(set\)$"):
        store.record_adaptation("P01", 1, "cacas", {}, 1.0, {"by_preference": {1, 2}})
    assert snapshot(store.path) == before
    store.record_adaptation("P01", 1, "nn", None, 1.0, {"curve": np.array([0.5, 0.75])})  # arrays as lists
    assert json.loads(store.adaptations_frame("P01").iloc[1]["parameters"]) == {}
    assert json.loads(store.adaptations_frame("P01").iloc[1]["metrics"]) == {"curve": [0.5, 0.75]}


@pytest.mark.parametrize("score", [11, 0, -3, 7.5, "8", True, None])
def test_bad_satisfaction_is_refused(store, score):
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="satisfaction"):
        store.record_questionnaire("P01", score, "too good")
    assert snapshot(store.path) == before


def test_questionnaire(store):
    before = snapshot(store.path)
    with pytest.raises(CacasError, match="participant P01 has had no study day yet"):
        store.record_questionnaire("P01", 10)
    assert snapshot(store.path) == before
    store.open_day("P01")
    store.record_questionnaire("P01", 10, "it learned my stove habit")
    store.record_questionnaire("P01", 1)
    df = store.questionnaire_frame()
    assert df["satisfaction"].tolist() == [10, 1] and df["comments"].iloc[0] == "it learned my stove habit"
    assert list(df.columns) == ["participant", "day", "satisfaction", "comments", "created_at"]
    assert df["day"].tolist() == [1, 1]
    store.close_day("P01", 1)
    store.open_day("P01")
    store.record_questionnaire("P01", 6)
    assert store.questionnaire_frame()["day"].tolist() == [1, 1, 2]  # each answer keeps the day it was given on
    with pytest.raises(CacasError, match="unknown participant"):
        store.record_questionnaire("P02", 5)


def test_a_questionnaire_answer_saved_by_mistake_is_removed_with_the_code_typed(store):
    """Walkthrough: an answer saved for the wrong participant (the form starts at the sidebar's) could not be
    removed, and one for a participant who never answered stayed counted. The participant's latest answer is
    removed once their code is typed; the event log keeps what was removed; bad input removes nothing."""
    from cacas.recent_activity import recent_events

    store.add_participant("P02")
    store.open_day("P01")
    store.record_questionnaire("P01", 9, "mine")
    store.record_questionnaire("P01", 3, "saved for P01 by mistake")
    before = snapshot(store.path)
    for who, typed, message in (
            ("P01", "", r"^to remove P01's latest questionnaire answer, type the code P01 to confirm \(typed: nothing\); "
                        r"nothing was removed$"),
            ("P01", "P02", r"type the code P01 to confirm \(typed: 'P02'\); nothing was removed$"),
            ("P02", "P02", r"^participant P02 has no questionnaire answer to remove$"),
            ("P09", "P09", r"^unknown participant 'P09'")):
        with pytest.raises(CacasError, match=message):
            store.remove_questionnaire_answer(who, typed)
        assert snapshot(store.path) == before
    assert store.remove_questionnaire_answer("P01", "P01") == 3
    df = store.questionnaire_frame()
    assert df["satisfaction"].tolist() == [9] and df["comments"].tolist() == ["mine"]
    event = store.events(limit=1).iloc[0]
    assert (event["what"], event["participant"]) == ("remove_questionnaire", "P01")
    assert json.loads(event["details"])["satisfaction"] == 3
    assert recent_events(store, limit=1)["what"].iloc[0].startswith("questionnaire answer removed (satisfaction 3, "
                                                                     "saved ")


def test_every_write_appends_an_event(store):
    n = len(store.events())
    store.save_preferences("P01", [COUGH])
    d = store.open_day("P01")
    store.record_interaction("P01", d, **GOOD)
    store.close_day("P01", d)
    v = store.save_policy("P01", d, "cacas", b"x")
    store.record_adaptation("P01", d, "cacas", {}, 1.0, {}, policy_version=v)
    store.set_active_policy("P01", None)
    store.record_questionnaire("P01", 8)
    ev = store.events()
    assert ev["what"].tolist()[n:] == ["save_preferences", "open_day", "record_interaction", "close_day",
                                      "save_policy", "record_adaptation", "set_active_policy",
                                      "record_questionnaire"]
    assert (ev["participant"].iloc[n:] == "P01").all()
    assert json.loads(ev["details"].iloc[-1])["satisfaction"] == 8
    assert store.events(limit=2)["what"].tolist() == ["set_active_policy", "record_questionnaire"]


# --- resume ---------------------------------------------------------------------------------------

def test_resume_after_restart_continues_where_it_stopped(tmp_path):
    path = tmp_path / "study.sqlite"
    s = StudyStore(path)
    s.add_participant("P01")
    fresh = s.resume("P01")
    assert (fresh.day, fresh.day_open, fresh.interactions_today, fresh.total_interactions,
            fresh.policy_version) == (0, False, 0, 0, None)
    d1 = s.open_day("P01")
    for _ in range(3):
        s.record_interaction("P01", d1, **GOOD)
    s.close_day("P01", d1)
    v = s.save_policy("P01", d1, "cacas", b"after day 1")
    d2 = s.open_day("P01")
    s.record_interaction("P01", d2, **GOOD)
    s.record_interaction("P01", d2, **GOOD)
    del s  # the app stops (no close: like a killed process)
    s = StudyStore(path)
    info = s.resume("P01")
    assert (info.day, info.day_open, info.interactions_today, info.total_interactions, info.policy_version) == \
        (2, True, 2, 5, v)
    assert s.open_day("P01") == 2  # the open day continues
    s.record_interaction("P01", info.day, **GOOD)
    assert s.interactions_frame("P01")["index"].tolist() == [1, 2, 3, 1, 2, 3]
    assert s.load_policy("P01") == b"after day 1"
    s.close()


def test_interactions_frame_filters(store):
    store.add_participant("P02")
    for who in ("P01", "P02"):
        d = store.open_day(who)
        store.record_interaction(who, d, **GOOD)
    store.record_interaction("P02", 1, **GOOD, method="orl")
    # by default every interaction, whichever method's policy was in force (the participant's one stream of
    # user data); the default was "cacas" and left out the ones recorded under a baseline put in force
    assert store.interactions_frame()["participant"].tolist() == ["P01", "P02", "P02"]
    assert store.interactions_frame("P02")["method"].tolist() == ["cacas", "orl"]
    assert store.interactions_frame(method="cacas")["participant"].tolist() == ["P01", "P02"]
    assert store.interactions_frame("P02", method="orl")["method"].tolist() == ["orl"]
    with pytest.raises(CacasError, match="unknown participant"):
        store.interactions_frame("P03")
    empty = StudyStore(store.path.parent / "empty.sqlite").interactions_frame()
    assert list(empty.columns) == INTERACTION_COLUMNS and len(empty) == 0
    assert isinstance(empty, pd.DataFrame)


def test_frame_gives_back_the_recorded_policy_states(store):
    """The user data the adaptation reads (records.policy_states) is the state that was recorded."""
    from cacas.records import policy_states

    day = store.open_day("P01")
    recorded = []
    for i, (minutes, hour) in enumerate([(0, 0.5), (1.5, 7), (12, 13.9), (59, 22), (250, 23.99)]):
        state = spaces.State.from_names(spaces.ACTIVITIES[i * 5], spaces.SCENES[i], hour, minutes,
                                        task=spaces.ACTIONS[i], action=spaces.ACTIONS[i + 1],
                                        response=spaces.RESPONSES[i % 3])
        store.record_interaction("P01", day, activity=spaces.ACTIVITIES[i * 5], scene=spaces.SCENES[i], hour=hour,
                                 interval_minutes=minutes, task=spaces.ACTIONS[i],
                                 previous_action=spaces.ACTIONS[i + 1], previous_response=spaces.RESPONSES[i % 3],
                                 robot_action="chitchat", response="accept")
        recorded.append(state.as_tuple())
    assert policy_states(store.interactions_frame("P01")).tolist() == [list(s) for s in recorded]


def test_an_older_schema_is_migrated_on_open(tmp_path, monkeypatch):
    from cacas.store import db, schema
    path = tmp_path / "old.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P01")
    v2 = schema.MIGRATIONS + [(SCHEMA_VERSION + 1, ["ALTER TABLE participants ADD COLUMN site TEXT DEFAULT ''"])]
    monkeypatch.setattr(schema, "MIGRATIONS", v2)
    monkeypatch.setattr(db, "SCHEMA_VERSION", SCHEMA_VERSION + 1)
    with StudyStore(path) as s:
        assert s.get_participant("P01").code == "P01"
        assert s._conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION + 1
        assert s._conn.execute("SELECT site FROM participants").fetchone() == ("",)


def _version_1_file(path):
    """A study database as CACAS Studio wrote it before schema version 2 (no model ids), with
    one interaction recorded."""
    with StudyStore(path) as s:
        s.add_participant("P01")
        s.record_interaction("P01", s.open_day("P01"), recognised_activity="cough", **GOOD)
    con = sqlite3.connect(path, isolation_level=None)
    con.execute("ALTER TABLE interactions DROP COLUMN sound_model")
    con.execute("ALTER TABLE interactions DROP COLUMN scene_model")
    con.execute("PRAGMA user_version = 1")
    con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    con.close()
    return path


def test_a_version_1_database_gains_the_model_ids_on_open(tmp_path):
    path = _version_1_file(tmp_path / "v1.sqlite")
    with StudyStore(path) as s:
        assert s._conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION == 2
        old = s.interactions_frame("P01", extra=True).iloc[0]
        assert (old["recognised_activity"], old["sound_model"], old["scene_model"]) == ("cough", "", "")
        s.record_interaction("P01", 1, sound_model="0123456789ab", scene_model="ba9876543210", **GOOD)
        new = s.interactions_frame("P01", extra=True).iloc[1]
        assert (new["sound_model"], new["scene_model"]) == ("0123456789ab", "ba9876543210")


def test_a_version_1_database_is_read_without_being_changed(tmp_path):
    """``cacas export`` of a database the app has not opened since the update: read through a
    migrated copy in memory; the file stays version 1, byte for byte."""
    path = _version_1_file(tmp_path / "v1.sqlite")
    before = path.read_bytes()
    with StudyStore(path, readonly=True) as s:
        frame = s.interactions_frame("P01", extra=True)
        assert list(frame["sound_model"]) == [""] and list(frame["activity"]) == ["cough"]
        with pytest.raises(CacasError, match="read-only"):
            s.add_participant("P02")
    assert path.read_bytes() == before
    con = sqlite3.connect(path)
    assert con.execute("PRAGMA user_version").fetchone()[0] == 1
    con.close()


@pytest.mark.parametrize("field", ["sound_model", "scene_model"])
@pytest.mark.parametrize("bad", ["xyz", "0123456789AB", "0123456789abc", 12])
def test_a_bad_model_id_names_the_field_and_writes_nothing(store, field, bad):
    day = store.open_day("P01")
    with pytest.raises(CacasError, match=rf"{field}: .* is not a model id; valid: 12 hex digits"):
        store.record_interaction("P01", day, **{field: bad}, **GOOD)
    assert store.interactions_frame("P01").empty


def test_empty_file_becomes_a_study_database(tmp_path):
    path = tmp_path / "new.sqlite"
    path.write_bytes(b"")
    with StudyStore(path) as s:
        s.add_participant("P01")
    with StudyStore(path, readonly=True) as s:
        assert [p.code for p in s.list_participants()] == ["P01"]


def test_snapshot_reads_one_consistent_view(store):
    day = store.open_day("P01")
    other = StudyStore(store.path)  # e.g. the tablet, writing while the researcher exports
    with store.snapshot():
        other.record_interaction("P01", day, **GOOD)
        assert len(store.interactions_frame("P01")) == 0 and store.resume("P01").total_interactions == 0
        with pytest.raises(RuntimeError, match="for reads"):
            store.record_questionnaire("P01", 5)
    assert len(store.interactions_frame("P01")) == 1
    assert store.questionnaire_frame().empty
    other.close()


def test_a_write_the_database_refuses_is_one_message_and_writes_nothing(store):
    """A read-only (or full) database: a CacasError that says so, nothing half-written."""
    day = store.open_day("P01")
    store._conn.execute("PRAGMA query_only = 1")  # every write now fails as on a read-only file
    with pytest.raises(CacasError, match=r"the study database cannot be written \(attempt to write a readonly "
                                         r"database\); nothing was saved"):
        store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=0,
                                 robot_action="pain check", response="accept")
    store._conn.execute("PRAGMA query_only = 0")
    assert len(store.interactions_frame("P01")) == 0


@pytest.mark.parametrize("data, message", [
    (b"\x89PNG\r\n\x1a\n\x00", r"photo.json: cannot be read as UTF-8 text"),
    ("[" * 100_000 + "]" * 100_000, r"photo.json: nested too deeply"),
    ('{"participants": [{"id": "P 01", "preferences": [{"activity": ["cough"], "action": "pain check"}]}]}',
     r"photo.json: participant code 'P 01' is invalid"),
])
def test_import_of_a_file_that_is_not_personas_names_it_and_writes_nothing(store, data, message):
    before = snapshot(store.path)
    with pytest.raises(CacasError, match=message):
        store.import_personas(data, source="photo.json")
    assert snapshot(store.path) == before


def test_interactions_of_one_day(store):
    day = store.open_day("P01")
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
    assert len(store.interactions_frame("P01", method=None, day=day)) == 1
    assert len(store.interactions_frame("P01", method=None, day=day + 1)) == 0
    with pytest.raises(CacasError, match=r"^day 0 is invalid; valid: a whole number >= 1$"):
        store.interactions_frame("P01", method=None, day=0)


def test_details_edited_from_what_a_form_was_drawn_with_keep_another_tabs_change(store):
    """Safety audit: ``update_participant(drawn=...)``, the details form's save. A field left as the
    form was drawn keeps what is saved now; a field changed here and by another tab since is
    refused, nothing written; without ``drawn`` a call sets what it names, as before."""
    from cacas.store.people import DetailsChanged

    store.add_participant("P09", age_range="25-34", notes="likes tea")
    drawn = ("25-34", "likes tea")
    store.update_participant("P09", notes="likes tea; hard of hearing")  # another tab
    info = store.update_participant("P09", age_range="35-44", notes="likes tea", drawn=drawn)
    assert (info.age_range, info.notes) == ("35-44", "likes tea; hard of hearing")
    events = len(store.events("P09"))
    with pytest.raises(DetailsChanged, match=r"^P09's age range and notes were saved \(in another tab\) while this "
                                             r"form was changed; nothing was saved, as saving would undo that change$"):
        store.update_participant("P09", age_range="45-54", notes="likes coffee", drawn=drawn)
    assert (store.get_participant("P09").age_range, len(store.events("P09"))) == ("35-44", events)
    # the same change made in both: nothing to undo
    info = store.update_participant("P09", age_range="35-44", notes="likes coffee",
                                    drawn=("25-34", "likes tea; hard of hearing"))
    assert (info.age_range, info.notes) == ("35-44", "likes coffee")
    assert store.update_participant("P09", notes="walks daily").notes == "walks daily"


def test_the_store_refuses_preferences_edited_from_an_older_version(store):
    from cacas.store.people import PreferencesChanged

    store.add_participant("P09")
    assert store.save_preferences("P09", [{"activity": ["cough"], "action": "pain check"}], edited_version=0) == 1
    with pytest.raises(PreferencesChanged, match="version 1 of P09's preferences was saved"):
        store.save_preferences("P09", [{"activity": ["cough"], "action": "chitchat"}], edited_version=0)
    assert store.save_preferences("P09", [{"activity": ["cough"], "action": "chitchat"}], edited_version=1) == 2
    with pytest.raises(PreferencesChanged, match=r"P09's preferences are not the ones this form was drawn from "
                                                 r"\(version 5; the latest is version 2 now\); nothing was saved"):
        store.save_preferences("P09", [{"activity": ["cough"], "action": "pain check"}], edited_version=5)


def test_an_age_range_the_store_took_before_its_bound_stays_when_the_details_are_saved(store):
    """Ages above 120 were taken before they were refused: a participant holding one keeps it when the
    Participants page saves their details (it sends the age range with the notes); a new one is checked."""
    import sqlite3

    with sqlite3.connect(store.path) as c:  # as the store took it before
        c.execute("UPDATE participants SET age_range = '200' WHERE code = 'P01'")
    c.close()
    assert store.update_participant("P01", age_range="200", notes="new notes").age_range == "200"
    with pytest.raises(CacasError, match="^age range '201' is invalid"):
        store.update_participant("P01", age_range="201")
    assert store.update_participant("P01", age_range="65+").age_range == "65+"
    assert store.add_participant("P09", age_range="120").age_range == "120"


@pytest.mark.parametrize("call", [
    lambda s: s.close_day("P01", 2**63),
    lambda s: s.interactions_frame(day=2**63),
    lambda s: s.get_preferences("P01", 2**63),
    lambda s: s.set_active_policy("P01", 2**63),
    lambda s: s.load_policy("P01", version=2**63),
    lambda s: s.record_adaptation("P01", 2**63, "cacas", {}, 0.0, {}),
    lambda s: s.save_policy("P01", 2**63, "cacas", b"x"),
    lambda s: s.events(limit=2**63),
    lambda s: s.record_interaction("P01", 2**63, activity="cough", scene="bedroom", time_slot=1, interval_bin=1,
                                   robot_action="pain check", response="accept"),
    lambda s: s.record_interaction("P01", 1, activity="cough", scene="bedroom", time_slot=1, interval_bin=1,
                                   robot_action="pain check", response="accept", policy_version=2**63),
])
def test_a_number_too_large_for_the_database_is_refused_naming_it(tmp_path, call):
    """A day, version or limit above SQLite's 64-bit INTEGER passed the checks and reached SQLite,
    which raised OverflowError (or "datatype mismatch"), not one CacasError."""
    with StudyStore(tmp_path / "db.sqlite") as s:
        s.add_participant("P01")
        s.open_day("P01")
        with pytest.raises(CacasError, match=r"9223372036854775808 is too large; valid: a whole number >= \d+ "
                                             r"\(at most 9223372036854775807\)$"):
            call(s)


def test_minutes_too_many_for_six_decimals_are_kept_not_a_traceback(tmp_path):
    """interval_minutes 1e308 is a finite number the check took; cutting it to 6 decimals overflowed
    (OverflowError: cannot convert float infinity to integer)."""
    with StudyStore(tmp_path / "db.sqlite") as s:
        s.add_participant("P01")
        day = s.open_day("P01")
        s.record_interaction("P01", day, activity="cough", scene="bedroom", time_slot=1, interval_minutes=1e308,
                             robot_action="pain check", response="accept")
        row = s.interactions_frame(extra=True).iloc[0]
        assert row["interval_minutes"] == 1e308 and row["interval"] == 200


def test_an_empty_study_name_filters_every_table_alike(store):
    """Review: study "" gave every study's rows from five frames (they tested ``if study``) and none
    from the others (``is not None``); a filter is a filter: "" names no study, None means all."""
    store.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
    day = store.open_day("P01")
    store.record_interaction("P01", day, **GOOD)
    store.record_questionnaire("P01", 8)
    store.record_adaptation("P01", 1, "cacas", {}, 1.0, {})
    store.save_policy("P01", 1, "cacas", b"weights")
    frames = {"participants": store.participants_frame, "days": store.days_frame,
              "preferences": store.preferences_frame, "questionnaire": store.questionnaire_frame,
              "policies": store.policies_frame, "adaptations": lambda study: store.adaptations_frame(study=study),
              "interactions": lambda study: store.interactions_frame(study=study),
              "events": lambda study: store.events(study=study),
              "list_participants": lambda study: pd.DataFrame(store.list_participants(study))}
    for name, frame in frames.items():
        assert len(frame(None)) and len(frame("default")), name
        assert frame("").empty and frame("default ").empty, name


def test_every_wrong_field_of_a_participant_is_said_at_once(store):
    """Walkthrough: a form with a wrong age range and contact details in the notes was told one per save."""
    before = store.list_participants()
    with pytest.raises(CacasError) as err:
        store.add_participant("P 01", age_range="old", notes="mail me at a@b.org")
    said = str(err.value)
    assert said.count("; and ") == 2 and "'P 01'" in said and "age range 'old' is invalid" in said \
        and "notes contain what looks like contact details ('a@b.org')" in said
    assert store.list_participants() == before
    store.add_participant("P09", age_range="25-34")
    with pytest.raises(CacasError, match=r"age range 'old' is invalid.*; and notes contain what looks like contact"):
        store.update_participant("P09", age_range="old", notes="call 555-1234")
    assert (store.get_participant("P09").age_range, store.get_participant("P09").notes) == ("25-34", "")


def test_the_data_stamp_changes_with_every_write_of_any_connection_and_not_with_reads(tmp_path):
    """The app caches what it reads from the study database under this stamp (``ui.study_tables``): a
    write by the app's own connection, or by another one (a ``cacas import``, a worker process), must
    change it, or a page shows tables of before the write."""
    path = tmp_path / "study.sqlite"
    with StudyStore(path) as app, StudyStore(path) as other:
        start = app.data_stamp()
        app.participants_frame(None), app.interactions_frame(method=None), other.studies()  # reads only
        assert app.data_stamp() == start
        app.add_participant("P01")  # the app's own write
        own = app.data_stamp()
        assert own != start
        other.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])  # another connection's
        theirs = app.data_stamp()
        assert theirs != own
        other.add_participant("P02")
        assert app.data_stamp() not in (start, own, theirs)
        assert app.data_stamp() == app.data_stamp()


def test_a_removed_questionnaire_answers_words_are_not_left_in_the_database_file(store):
    """The comments are the participant's own words: a removed answer's were left in the file's free pages (and
    its write-ahead log) until SQLite happened to reuse them; a participant's removal overwrote them already."""
    words = "I told the robot about my neighbour Ms Quarrington-Feltham"
    store.open_day("P01")
    store.record_questionnaire("P01", 4, words)
    store.remove_questionnaire_answer("P01", "P01")
    raw = store.path.read_bytes()
    wal = store.path.with_name(store.path.name + "-wal")
    raw += wal.read_bytes() if wal.exists() else b""
    assert words.encode() not in raw and b"Quarrington" not in raw
    assert store.questionnaire_frame().empty


def test_notes_edited_to_take_words_out_leave_none_of_them_in_the_file(store):
    """A researcher who takes a participant's identifying words out of the notes expects them gone: the old
    notes stayed in the write-ahead log's copy of the page until a checkpoint."""
    store.update_participant("P01", notes="Lives with daughter Quarrington in Hove")
    store.update_participant("P01", notes="uses a walking frame")
    raw = store.path.read_bytes()
    wal = store.path.with_name(store.path.name + "-wal")
    raw += wal.read_bytes() if wal.exists() else b""
    assert b"Quarrington" not in raw and store.get_participant("P01").notes == "uses a walking frame"
