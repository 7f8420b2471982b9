"""`cacas export --db PATH --out DIR` and `cacas import --bundle ZIP --db NEWPATH` (issue 4, items 4-5)."""

import hashlib
import sqlite3

import pytest

import cacas.cli as cli
from cacas import export
from cacas.store import StudyStore
from unwritable import unwritable_folder  # noqa: F401
from studies import policy_bytes


@pytest.fixture
def run(monkeypatch):
    """``cacas ...`` in process, with only this module's sub-commands registered (the other
    sub-commands are tested on their own)."""
    monkeypatch.setattr(cli, "COMMANDS", ["export"])
    return lambda *argv: cli.main([str(a) for a in argv])


def tree(folder):
    """Every file under ``folder`` with a hash of its bytes."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def study(tmp_path):
    path = tmp_path / "db" / "study.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P01")
        day = s.open_day("P01")
        s.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=0,
                             robot_action="pain check", response="accept")
        s.save_policy("P01", day, "cacas", policy_bytes("policy bytes"))
        s.record_questionnaire("P01", 8)
    return path


def test_export_and_import(run, study, tmp_path, capsys):
    before = tree(study.parent)
    assert run("export", "--db", study, "--out", tmp_path / "out") == 0
    assert tree(study.parent) == before  # exporting changes nothing beside the database
    out = capsys.readouterr().out
    assert "interactions.csv" in out and "cacas-study.zip" in out
    assert (tmp_path / "out" / "daily.csv").exists()
    new = tmp_path / "moved" / "study.sqlite"
    assert run("import", "--bundle", tmp_path / "out" / "cacas-study.zip", "--db", new) == 0
    assert "imported 1 participant and 1 interaction into" in capsys.readouterr().out
    with StudyStore(new) as s:
        assert s.resume("P01").total_interactions == 1
        assert s.load_policy("P01") == policy_bytes("policy bytes")


def _refused(run, capsys, tmp_path, db):
    before = tree(tmp_path)
    code = run("export", "--db", db, "--out", tmp_path / "out")
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("cacas: error: ") and str(db) in err
    assert tree(tmp_path) == before and not (tmp_path / "out").exists()  # nothing changed or created
    return err


@pytest.mark.parametrize("name", ["daily.csv", "cacas-study.zip", "checksums.sha256"])
def test_a_folder_where_the_export_writes_a_file_is_refused_before_the_tables_are_read(run, study, tmp_path,
                                                                                         capsys, monkeypatch, name):
    """CLI audit: the export read every table and zipped every policy file (2.7 s for a study of 30),
    then was refused by its folder; a folder named daily.csv was said as 'a simulation's tables'."""
    import cacas.export

    def never(*a, **k):
        raise AssertionError("the tables were read before the folder was checked")

    monkeypatch.setattr(cacas.export, "export_contents", never)
    (tmp_path / "out" / name).mkdir(parents=True)
    assert run("export", "--db", study, "--out", tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert err == (f"cacas: error: {tmp_path / 'out'}: holds a folder named {name}, where this run writes its {name}; "
                   "valid: a folder without it (move or rename that folder), or another folder\n")
    assert [p.name for p in (tmp_path / "out").iterdir()] == [name]


def test_an_export_leaves_the_researchers_own_files_in_its_folder_as_its_help_says(run, study, tmp_path, capsys):
    """CLI audit: --help said DIR 'may be new, empty or an earlier export's', yet a folder holding
    other files was taken (and they were kept): the help now says so, and this holds it to that."""
    sub = next(a for a in cli.build_parser()._actions if a.dest == "command").choices["export"]
    assert "other files there are left as they are" in " ".join(sub.description.split())
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "notes.txt").write_text("mine")
    assert run("export", "--db", study, "--out", tmp_path / "out") == 0
    assert (tmp_path / "out" / "notes.txt").read_text() == "mine" and (tmp_path / "out" / "daily.csv").is_file()


def test_an_export_refused_by_its_database_leaves_no_folder_made_for_its_out(run, capsys, tmp_path):
    """The output folder is checked first now; the folders above it that the check made go again when
    the database is then refused."""
    assert run("export", "--db", tmp_path / "nope.sqlite", "--out", tmp_path / "a" / "b" / "out") == 2
    assert "no such study database" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_export_of_a_missing_file_exits_2_and_creates_nothing(run, capsys, tmp_path):
    err = _refused(run, capsys, tmp_path, tmp_path / "nope.sqlite")
    assert "no such study database" in err
    assert not (tmp_path / "nope.sqlite").exists()


def test_export_of_a_text_file_exits_2(run, capsys, tmp_path):
    (tmp_path / "notes.txt").write_text("not a database")
    assert "not a study database" in _refused(run, capsys, tmp_path, tmp_path / "notes.txt")


def test_export_of_an_empty_file_exits_2(run, capsys, tmp_path):
    (tmp_path / "empty.sqlite").write_bytes(b"")
    assert "not a study database" in _refused(run, capsys, tmp_path, tmp_path / "empty.sqlite")


def test_export_of_another_sqlite_database_exits_2(run, capsys, tmp_path):
    con = sqlite3.connect(tmp_path / "other.db")
    con.execute("CREATE TABLE things (x)")
    con.commit()
    con.close()
    assert "another application" in _refused(run, capsys, tmp_path, tmp_path / "other.db")


def test_export_of_a_folder_exits_2(run, capsys, tmp_path):
    (tmp_path / "folder").mkdir()
    assert "is not a file" in _refused(run, capsys, tmp_path, tmp_path / "folder")


def test_import_refuses_an_existing_database(run, study, tmp_path, capsys):
    assert run("export", "--db", study, "--out", tmp_path / "out") == 0
    capsys.readouterr()
    before = tree(study.parent)
    code = run("import", "--bundle", tmp_path / "out" / "cacas-study.zip", "--db", study)
    err = capsys.readouterr().err
    assert code == 2 and "already exists" in err and err.count("\n") == 1
    assert tree(study.parent) == before


def test_import_of_a_missing_bundle_exits_2(run, tmp_path, capsys):
    code = run("import", "--bundle", tmp_path / "none.zip", "--db", tmp_path / "new.sqlite")
    assert code == 2 and "no such bundle" in capsys.readouterr().err
    assert not (tmp_path / "new.sqlite").exists()


def test_import_of_a_folder_says_it_is_a_folder_and_which_file_is_meant(run, study, tmp_path, capsys):
    """Review: --bundle <the export's folder> said "no such bundle", as if it were not there."""
    empty = tmp_path / "empty"
    empty.mkdir()
    code = run("import", "--bundle", empty, "--db", tmp_path / "new.sqlite")
    assert code == 2 and capsys.readouterr().err == (f"cacas: error: {empty}: is a folder; valid: the cacas-study.zip "
                                                     "file written by cacas export\n")
    assert run("export", "--db", study, "--out", tmp_path / "out") == 0
    capsys.readouterr()
    code = run("import", "--bundle", tmp_path / "out", "--db", tmp_path / "new.sqlite")
    assert code == 2 and capsys.readouterr().err == (
        f"cacas: error: {tmp_path / 'out'}: is a folder; valid: the cacas-study.zip file written by cacas export, "
        f"such as {tmp_path / 'out' / 'cacas-study.zip'} in this folder\n")
    assert not (tmp_path / "new.sqlite").exists()


def test_export_is_a_registered_sub_command():
    assert "export" in cli.COMMANDS


def test_export_of_an_unknown_study_exits_2_and_keeps_an_earlier_export(run, study, tmp_path, capsys):
    out = tmp_path / "out"
    assert run("export", "--db", study, "--out", out) == 0
    before = tree(out)
    assert run("export", "--db", study, "--out", out, "--study", "defualt") == 2
    err = capsys.readouterr().err
    assert "unknown study 'defualt'; known studies: default" in err and len(err.strip().splitlines()) == 1
    assert tree(out) == before


def test_export_of_a_study_named_in_another_letter_case_suggests_the_study(run, study, tmp_path, capsys):
    assert run("export", "--db", study, "--out", tmp_path / "out", "--study", "Default") == 2
    err = capsys.readouterr().err
    assert "unknown study 'Default'; did you mean 'default'? known studies: default" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "out").exists()


def test_export_of_a_database_with_a_damaged_table_exits_2(run, study, tmp_path, capsys):
    """A damaged page inside a table (the file still opens as a study database): one line."""
    with sqlite3.connect(study) as c:
        c.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        root = c.execute("SELECT rootpage FROM sqlite_master WHERE name = 'interactions'").fetchone()[0]
        page = c.execute("PRAGMA page_size").fetchone()[0]
    c.close()
    with open(study, "r+b") as fh:
        fh.seek((root - 1) * page)
        fh.write(b"\xab" * page)
    code = run("export", "--db", study, "--out", tmp_path / "out")
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "cannot be read" in err


def test_export_into_a_folder_that_cannot_be_written_exits_2(run, study, tmp_path, capsys):
    (tmp_path / "a_file").write_text("x")
    assert run("export", "--db", study, "--out", tmp_path / "a_file" / "out") == 2
    err = capsys.readouterr().err
    assert "cannot write in this folder" in err and len(err.strip().splitlines()) == 1


@pytest.fixture
def read_only(study):
    """``study``'s folder made read-only once the database is closed (no -shm beside it), as on a
    write-protected USB stick: chattr +i for root (who ignores permission bits), else chmod 555."""
    import os
    import subprocess

    folder = study.parent
    assert not (folder / "study.sqlite-shm").exists()
    if os.geteuid() == 0:
        if subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode != 0:
            pytest.skip("cannot make a folder unwritable for root here (no chattr +i)")
        yield folder
        subprocess.run(["chattr", "-i", str(folder)], check=True)
    else:
        folder.chmod(0o555)
        yield folder
        folder.chmod(0o755)


def test_an_export_from_read_only_media_says_to_copy_the_folder_somewhere_writable(run, study, read_only, tmp_path,
                                                                                  capsys):
    """Safety audit L8: a study database (WAL mode) on read-only media cannot be read without the
    -shm file SQLite writes beside it, and ``cacas export`` said only "cannot be read (unable to
    open database file)". It now says why and what to do; nothing is created."""
    before = tree(read_only)
    assert run("export", "--db", study, "--out", tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert err == (f"cacas: error: {study}: cannot be read (unable to open database file); SQLite writes a -shm file "
                   "beside a study database to read it, and this folder cannot be written (read-only media such as a "
                   "write-protected USB stick or a DVD, a read-only network share, or no permission); copy the folder "
                   "(the database with the policies folder beside it) to a writable place and use the copy\n")
    assert tree(read_only) == before and not (tmp_path / "out").exists()


def test_a_missing_policy_file_stops_the_zip_not_the_tables(run, study, tmp_path, capsys):
    """The zip must hold every checkpoint to be imported; the message says how to get the
    tables out all the same, and --tables-only does."""
    with StudyStore(study) as s:
        s.active_policy("P01").path.unlink()
    assert run("export", "--db", study, "--out", tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert "policy version 1 of participant P01 is missing" in err and "--tables-only" in err
    assert not (tmp_path / "out" / "interactions.csv").exists()
    assert run("export", "--db", study, "--out", tmp_path / "out", "--tables-only") == 0
    out = tmp_path / "out"
    assert (out / "interactions.csv").read_text().count("\n") == 2 and not (out / "cacas-study.zip").exists()


def test_import_into_a_folder_that_cannot_be_written_names_the_given_path(run, study, tmp_path, unwritable_folder,
                                                                         capsys):
    assert run("export", "--db", study, "--out", tmp_path / "out") == 0
    capsys.readouterr()
    target = unwritable_folder / "x.sqlite"
    assert run("import", "--bundle", tmp_path / "out" / "cacas-study.zip", "--db", target) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"cacas: error: --db {target}: cannot be written there: ")
    assert "importing" not in err


def test_an_export_into_a_simulations_folder_is_refused(run, study, tmp_path, capsys):
    """The two share daily.csv, interactions.csv and by_preference.csv: an export into a
    simulation's --out folder replaced its tables silently (data-analyst review)."""
    sim = tmp_path / "sim"
    sim.mkdir()
    for name in ("daily.csv", "interactions.csv", "by_preference.csv"):
        (sim / name).write_text(f"a simulation's {name}")
    before = tree(sim)
    assert run("export", "--db", study, "--out", sim) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds daily.csv, interactions.csv, by_preference.csv but no participants.csv" \
        in err and "valid: an empty folder, a new one, or an earlier export's" in err
    assert tree(sim) == before
    assert run("export", "--db", study, "--out", tmp_path / "out") == 0  # an earlier export's folder is fine
    assert run("export", "--db", study, "--out", tmp_path / "out") == 0


def test_an_export_into_a_folder_of_a_simulations_figures_is_refused(run, study, tmp_path, capsys):
    """CLI audit: `cacas simulate --plot figs` (figures apart from their tables), then `cacas export
    --out figs`: the study's daily.csv sat beside a simulated study's Fig. 3 and Fig. 4, which read
    as its own (and a later --plot there is refused, as the folder then holds an export). A folder
    holding such a folder is fine: the export writes only its own files, the figures stay apart."""
    figs = tmp_path / "figs"
    figs.mkdir()
    for name in ("fig3_success.html", "fig4_methods.html", "fig4_by_preference.html", "plotly.min.js"):
        (figs / name).write_text(f"a simulation's {name}")
    before = tree(figs)
    assert run("export", "--db", study, "--out", figs) == 2
    err = capsys.readouterr().err
    assert err == (f"cacas: error: {figs}: holds a simulation's figures (fig3_success.html, fig4_methods.html, "
                   "fig4_by_preference.html; cacas simulate --plot): this export's tables would sit beside figures "
                   "that do not show them; valid: an empty folder, a new one, or an earlier export's\n")
    assert tree(figs) == before
    assert run("export", "--db", study, "--out", tmp_path) == 0  # figs/ inside the export's folder: kept as it was
    assert tree(figs) == before and (tmp_path / "daily.csv").is_file() and (tmp_path / "cacas-study.zip").is_file()


def test_tables_only_removes_an_earlier_exports_zip(run, study, tmp_path, capsys):
    """A zip left beside newer tables holds older data (one questionnaire answer fewer, say)."""
    assert run("export", "--db", study, "--out", tmp_path / "out") == 0
    with StudyStore(study) as s:
        s.record_questionnaire("P01", 9)
    capsys.readouterr()
    assert run("export", "--db", study, "--out", tmp_path / "out", "--tables-only") == 0
    assert not (tmp_path / "out" / "cacas-study.zip").exists()
    assert f"removed an earlier export's {tmp_path / 'out' / 'cacas-study.zip'} (it no longer matches these tables)\n" \
        in capsys.readouterr().out
    assert (tmp_path / "out" / "questionnaire.csv").read_text().count("\n") == 3  # header and both answers



def test_tables_only_keeps_an_earlier_exports_zip_that_holds_the_same_tables(run, study, tmp_path, capsys):
    """CLI audit: --tables-only said the earlier zip "no longer matches these tables" (and removed
    it) when nothing had changed. A zip holding these same tables is kept (it holds the policy files
    they name: --tables-only is what to run when one is missing now) and listed in checksums.sha256;
    one that does not is removed, saying why, only then that it no longer matches."""
    from cacas.store import files

    out = tmp_path / "out"
    zipped = out / "cacas-study.zip"
    assert run("export", "--db", study, "--out", out) == 0
    before = zipped.read_bytes()
    with StudyStore(study) as s:
        s.active_policy("P01").path.unlink()  # the zip cannot be made again now; the tables can
    capsys.readouterr()
    assert run("export", "--db", study, "--out", out, "--tables-only") == 0
    said = capsys.readouterr().out
    assert "no longer matches" not in said and "removed" not in said
    assert f"kept an earlier export's {zipped}: it holds these same tables and the policy files they name\n" in said
    assert zipped.read_bytes() == before and files.mismatched(out) == []
    assert export.import_bundle(zipped, tmp_path / "back" / "study.sqlite").interactions == 1
    zipped.write_bytes(before[: len(before) // 2])  # cut short: not a whole zip
    assert run("export", "--db", study, "--out", out, "--tables-only") == 0
    assert f"removed an earlier export's {zipped} (it cannot be read as an export's zip (damaged, or not one))\n" in \
        capsys.readouterr().out
    assert not zipped.exists() and files.mismatched(out) == []

def test_import_of_a_study_with_a_code_like_a_date_restores_it_and_prints_a_note(run, tmp_path, capsys, monkeypatch):
    """A code added before such codes were refused for new participants is the study's own: its
    backup imports (it was refused, exit 2), with a note on stderr naming the table, row and column."""
    from cacas.store import validate

    path = tmp_path / "db" / "study.sqlite"
    with monkeypatch.context() as m:
        m.setattr(validate, "contact_details", lambda value: None)  # as before the check
        with StudyStore(path) as s:
            s.add_participant("20261121")
    assert run("export", "--db", path, "--out", tmp_path / "out") == 0
    capsys.readouterr()
    bundle = tmp_path / "out" / "cacas-study.zip"
    assert run("import", "--bundle", bundle, "--db", tmp_path / "moved" / "study.sqlite") == 0
    captured = capsys.readouterr()
    assert "imported 1 participant and 0 interactions into" in captured.out
    assert captured.err == (f"cacas import: note: {bundle}: participants.csv, row 2, column participant: '20261121' "
                            "looks like a phone number or a date; imported as it was, "
                            "as the study held it (the forms refuse it in new data)\n")
    with StudyStore(tmp_path / "moved" / "study.sqlite") as s:
        assert [p.code for p in s.list_participants()] == ["20261121"]


def _damaged(bundle, member, out):
    """A copy of ``bundle`` with bytes inverted in the middle third of ``member``'s compressed data."""
    import zipfile

    data = bytearray(bundle.read_bytes())
    with zipfile.ZipFile(bundle) as zf:
        info = zf.getinfo(member)
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)  # after the local header
    for k in range(info.compress_size // 3, 2 * info.compress_size // 3):
        data[start + k] ^= 0xFF
    out.write_bytes(bytes(data))
    return out


@pytest.mark.parametrize("member", ["interactions.csv", "policies/P01/"])
def test_import_of_a_bundle_damaged_inside_a_member_exits_2_naming_it(run, study, tmp_path, capsys, member):
    """Bytes changed inside a compressed member ended the import with zlib.error, a traceback and
    exit 1; a truncated zip or a bad CRC were already one line and exit 2."""
    import zipfile

    assert run("export", "--db", study, "--out", tmp_path / "out") == 0
    capsys.readouterr()
    bundle = tmp_path / "out" / "cacas-study.zip"
    with zipfile.ZipFile(bundle) as zf:
        member = next(n for n in zf.namelist() if n.startswith(member))
    bad = _damaged(bundle, member, tmp_path / "bad.zip")
    target = tmp_path / "new" / "study.sqlite"
    code = run("import", "--bundle", bad, "--db", target)
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"cacas: error: {bad}: {member} in the bundle is damaged (")
    assert not target.parent.exists()


def test_import_of_a_bundle_with_a_bad_number_names_bundle_file_row_and_column(run, study, tmp_path, capsys):
    """Review: 'x' in a numeric column said "days.csv, row 2: 'x' is not a whole number": neither
    the bundle nor the column, nor what is valid."""
    import io
    import zipfile

    import pandas as pd

    assert run("export", "--db", study, "--out", tmp_path / "out") == 0
    capsys.readouterr()
    bad = tmp_path / "bad.zip"
    with zipfile.ZipFile(tmp_path / "out" / "cacas-study.zip") as zin, zipfile.ZipFile(bad, "w") as zout:
        for name in zin.namelist():
            data = zin.read(name)
            if name == "interactions.csv":
                df = pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False).assign(hour="x")
                data = df.to_csv(index=False).encode()
            zout.writestr(name, data)
    target = tmp_path / "new" / "study.sqlite"
    assert run("import", "--bundle", bad, "--db", target) == 2
    assert capsys.readouterr().err == (f"cacas: error: {bad}: interactions.csv, row 2, column hour: 'x' is not a "
                                       "number; valid: a number, or empty\n")
    assert not target.parent.exists()
