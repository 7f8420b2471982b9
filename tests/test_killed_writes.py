"""A real ``kill -9`` between the renames of ``files.write_all`` (``cacas export --out``, ``cacas
simulate --out``), at each one (safety audit L1): the folder may then hold files of two runs side
by side, and ``checksums.sha256``, put in place before the files it lists, tells which. ``cacas
import`` refuses a zip that an export killed before it could replace it left (an earlier export's),
the Results page's upload refuses tables of two runs, and the next run says what it found and puts
the folder right. The bytes of each file are compared with both runs' to know what the folder
holds, independently of the checks under test."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from cacas import export, uploaded_run
from cacas.errors import CacasError
from cacas.store import StudyStore, files
from studies import policy_bytes

ROOT = Path(__file__).resolve().parents[1]
#: Runs ``cacas ARGS...`` and kills itself (SIGKILL) before, or after, its N-th os.replace.
KILLER = """
import os, signal, sys
n, when, args = int(sys.argv[1]), sys.argv[2], sys.argv[3:]
calls, real = [0], os.replace
def replace(*a, **k):
    calls[0] += 1
    if calls[0] == n and when == "before":
        os.kill(os.getpid(), signal.SIGKILL)
    real(*a, **k)
    if calls[0] == n and when == "after":
        os.kill(os.getpid(), signal.SIGKILL)
os.replace = replace
from cacas.cli import main
sys.exit(main(args))
"""


def killed(n: int, when: str, *args) -> None:
    done = subprocess.run([sys.executable, "-c", KILLER, str(n), when, *map(str, args)], cwd=ROOT,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True)
    assert done.returncode == -9, done.stderr  # killed, not finished nor failed


def hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


#: The end of both refusals of a zip an export stopped part-way left (spelt out: the test checks the words).
EXPORT_AGAIN = ("run cacas export again and import the new zip (to import this one all the same, copy it out of this "
                "folder first); nothing was imported")


def import_refused(zip_path: Path, target: Path) -> str:
    """cacas import's refusal of ``zip_path`` (its message), with nothing made at ``target``."""
    with pytest.raises(CacasError) as err:
        export.import_bundle(zip_path, target)
    assert not target.parent.exists()
    return str(err.value)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A study database and its export's files (name -> bytes) before and after a change that
    changes most tables."""
    db = tmp_path_factory.mktemp("db") / "study.sqlite"
    with StudyStore(db) as s:
        s.add_participant("P01")
        day = s.open_day("P01")
        s.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=0,
                             robot_action="pain check", response="accept")
        s.save_policy("P01", day, "cacas", policy_bytes("policy bytes"))
        first = export.export_contents(s)
        s.add_participant("P02")
        day = s.open_day("P02")
        s.record_interaction("P02", day, activity="cough", scene="bedroom", hour=9, interval_minutes=0,
                             robot_action="pain check", response="reject")
        s.save_policy("P02", day, "cacas", policy_bytes("P02's policy"))
        s.record_questionnaire("P01", 8)
        second = export.export_contents(s)
    return db, first, second


@pytest.mark.parametrize("n,when", [(n, "before") for n in range(1, 14)] + [(13, "after")])
def test_an_export_killed_at_each_rename_is_found_by_import_upload_and_the_next_export(runs, tmp_path, n, when,
                                                                                       capsys):
    from cacas.cli import main

    db, first, second = runs
    assert len(second) + 1 == 13  # the renames: checksums.sha256, then the 11 tables and the zip
    out = tmp_path / "out"
    files.write_all(out, first, checksums=True)  # the earlier export
    killed(n, when, "export", "--db", db, "--out", out)

    def runs_of(name):  # which exports' bytes the file holds: {1}, {2}, or {1, 2} (the same in both)
        data = (out / name).read_bytes()
        return {k for k, v in ((1, first), (2, second))
                if (files.checksums_bytes(v) if name == files.CHECKSUMS else v[name]) == data}

    def one_run(names):  # the files are of one export
        return bool(set.intersection(*(runs_of(name) for name in names)))
    mixed = not one_run([files.CHECKSUMS, *second])
    assert mixed == (when == "before" and 1 < n <= 13)  # killed between the first rename and the last
    assert hidden(out)  # a killed write leaves its hidden copies

    # cacas import: a zip the killed export did not replace is refused; a whole one is imported
    zip_path = out / export.BUNDLE_NAME
    target = tmp_path / "moved" / "study.sqlite"
    if one_run([export.BUNDLE_NAME, files.CHECKSUMS]):
        export.import_bundle(zip_path, target)
        with StudyStore(target, readonly=True) as s:
            assert len(s.list_participants()) == (2 if runs_of(export.BUNDLE_NAME) == {2} else 1)
    else:
        assert import_refused(zip_path, target) == (
            f"{zip_path}: does not match its sha256 in checksums.sha256 beside it: the export that wrote this folder "
            "was stopped part-way (killed, or a power cut) before it replaced this zip, which is an earlier export's "
            "(or it was changed since); " + EXPORT_AGAIN)

    # the Results page's upload: the three tables it shows, with the checksums file beside them
    shown = ["daily.csv", "interactions.csv", "by_preference.csv"]
    uploaded = [(name, (out / name).read_bytes()) for name in [*shown, files.CHECKSUMS]]
    if not one_run([*shown, files.CHECKSUMS]):
        with pytest.raises(CacasError, match=r"does not match its sha256 in checksums\.sha256, so it is not the .*"
                                             r"or the run that wrote that folder was stopped part-way"):
            uploaded_run.load_uploaded_tables(uploaded)
    else:
        assert "daily" in uploaded_run.load_uploaded_tables(uploaded)

    # the next export says what it found, and leaves the folder whole
    left = len(hidden(out))
    capsys.readouterr()
    assert main(["export", "--db", str(db), "--out", str(out)]) == 0
    note = capsys.readouterr().err
    if mixed:
        assert note.startswith(f"cacas export: note: {out} held what an earlier run stopped part-way (killed, or a "
                               "power cut) left: ") and note.count("\n") == 1
        assert note.endswith(f" did not match checksums.sha256 (files of two runs side by side), and {left} hidden "
                             "temporary file(s); all are replaced now\n")
    else:
        assert note == (f"cacas export: note: {out} held {left} hidden temporary file(s) "
                        "an earlier run stopped part-way (killed, or a power cut) left; its files were still those "
                        "of the run before it, and are replaced now\n")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == {**second, files.CHECKSUMS: files.checksums_bytes(second)}
    assert files.mismatched(out) == []


def test_a_tables_only_export_killed_before_it_removed_an_earlier_zip_is_found_by_import(runs, tmp_path):
    """cacas export --tables-only removes an earlier export's zip that no longer goes with its tables
    after it has written them: killed in between, the zip stayed beside a checksums.sha256 that does
    not list it, and cacas import took it, bringing back the study as it was then."""
    from cacas.cli import main

    db, first, second = runs
    out = tmp_path / "out"
    files.write_all(out, first, checksums=True)  # the earlier export, with its zip
    killed(12, "after", "export", "--db", db, "--out", out, "--tables-only")  # its last rename: the 11 tables
    assert (out / export.BUNDLE_NAME).read_bytes() == first[export.BUNDLE_NAME]
    assert files.mismatched(out) == []  # what checksums.sha256 lists is whole: the tables of the second export
    target = tmp_path / "moved" / "study.sqlite"
    assert import_refused(out / export.BUNDLE_NAME, target) == (
        f"{out / export.BUNDLE_NAME}: checksums.sha256 beside it does not list it: the export that wrote this folder "
        "wrote its tables only (--tables-only) and was stopped (killed, or a power cut) before it removed this zip, "
        "which is an earlier export's; " + EXPORT_AGAIN)
    assert main(["export", "--db", str(db), "--out", str(out), "--tables-only"]) == 0  # the next one removes it
    assert not (out / export.BUNDLE_NAME).exists()


def test_a_simulation_killed_between_its_renames_is_found_by_the_upload_and_the_next_run(tmp_path, capsys):
    from cacas.cli import main

    personas = tmp_path / "personas.json"
    personas.write_text('{"participants": [{"id": "S01", "preferences": [{"activity": ["cough"], '
                        '"action": "pain check"}]}]}')
    out = tmp_path / "out"
    args = ["simulate", "--personas", personas, "--days", "1", "--interactions", "2", "--methods", "nn", "--jobs",
            "1", "--quiet", "--out", out]
    assert main([str(a) for a in args + ["--seed", "1"]]) == 0
    earlier = {p.name: p.read_bytes() for p in out.iterdir()}
    killed(3, "before", *args, "--seed", "2")  # checksums.sha256 and daily.csv replaced, not the other two
    assert (out / "daily.csv").read_bytes() != earlier["daily.csv"]
    assert (out / "interactions.csv").read_bytes() == earlier["interactions.csv"]
    uploaded = [(name, (out / name).read_bytes()) for name in ("daily.csv", "interactions.csv", files.CHECKSUMS)]
    with pytest.raises(CacasError) as err:
        uploaded_run.load_uploaded_tables(uploaded)
    assert str(err.value) == (
        "interactions.csv: does not match its sha256 in checksums.sha256, so it is not the interactions.csv written "
        "with it: one from another folder (upload the tables of one folder with that folder's checksums.sha256), or "
        "the run that wrote that folder was stopped part-way (killed, or a power cut) and left files of two runs side "
        "by side, or the file was changed since; then write the tables again (cacas export, or cacas simulate --out) "
        "and upload them")
    capsys.readouterr()
    assert main([str(a) for a in args + ["--seed", "2"]]) == 0
    assert capsys.readouterr().err == (
        f"cacas simulate: note: {out} held what an earlier run stopped part-way (killed, or a power cut) left: "
        "by_preference.csv, interactions.csv did not match checksums.sha256 (files of two runs side by side), and 6 "
        "hidden temporary file(s); all are replaced now\n")
    assert files.mismatched(out) == [] and not hidden(out)


@pytest.mark.parametrize("when", ["before", "after"])
def test_an_export_into_a_new_folder_killed_leaves_it_whole_or_not_there(runs, tmp_path, capsys, when):
    """L1, for a folder that does not exist yet: the export is built in a hidden folder beside it and
    renamed into place (one rename), so a kill leaves no folder at all, or the whole export: never
    a part of one (before, a kill part-way left the tables written so far, and no zip)."""
    from cacas.cli import main

    db, _, second = runs
    out = tmp_path / "new" / "out"
    killed(1, when, "export", "--db", db, "--out", out)
    whole = {**second, files.CHECKSUMS: files.checksums_bytes(second)}
    if when == "before":
        assert not out.exists()
        staged = [p.name for p in out.parent.iterdir()]
        assert len(staged) == 1 and staged[0].startswith(".out.") and staged[0].endswith(".new")
    else:
        assert {p.name: p.read_bytes() for p in out.iterdir()} == whole and os.listdir(out.parent) == ["out"]
    capsys.readouterr()
    assert main(["export", "--db", str(db), "--out", str(out)]) == 0
    note = capsys.readouterr().err
    assert note == ("" if when == "after" else
                    f"cacas export: note: {out} was not written: an earlier run into it was stopped part-way (killed, "
                    f"or a power cut) while it built it in {staged[0]} beside it, which is removed now\n")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == whole and os.listdir(out.parent) == ["out"]


def test_figures_killed_between_their_renames_in_a_folder_of_their_own_are_found(tmp_path, capsys):
    """--plot DIR into a folder of figures only writes checksums.sha256 there too, so figures of two
    runs side by side (a run killed between their renames) are found, and said by the next run."""
    from cacas.cli import main

    personas = tmp_path / "personas.json"
    personas.write_text('{"participants": [{"id": "S01", "preferences": [{"activity": ["cough"], '
                        '"action": "pain check"}]}]}')
    out, plots = tmp_path / "out", tmp_path / "plots"
    args = ["simulate", "--personas", personas, "--days", "1", "--interactions", "2", "--methods", "nn", "--jobs",
            "1", "--quiet", "--out", out, "--plot", plots]
    assert main([str(a) for a in args + ["--seed", "1"]]) == 0
    assert files.mismatched(plots) == [] and files.CHECKSUMS in os.listdir(plots)
    earlier = {p.name: p.read_bytes() for p in plots.iterdir()}
    # the renames: the tables' four, then the figures' checksums.sha256 and fig3_success.html; not the others
    killed(6, "after", *args, "--seed", "2")
    assert (plots / "fig3_success.html").read_bytes() != earlier["fig3_success.html"]
    assert (plots / "fig4_methods.html").read_bytes() == earlier["fig4_methods.html"]
    assert files.mismatched(plots) == ["fig4_by_preference.html", "fig4_methods.html"]
    left = len(hidden(plots))  # the killed write's temporary files and kept copies
    capsys.readouterr()
    assert main([str(a) for a in args + ["--seed", "2"]]) == 0
    assert capsys.readouterr().err == (
        f"cacas simulate: note: {plots} held what an earlier run stopped part-way (killed, or a power cut) left: "
        "fig4_by_preference.html, fig4_methods.html did not match checksums.sha256 (files of two runs side by side), "
        f"and {left} hidden temporary file(s); all are replaced now\n")
    assert files.mismatched(plots) == [] and not hidden(plots) and files.mismatched(out) == []


@pytest.mark.parametrize("when", ["before", "after"])
def test_an_earlier_runs_figure_is_not_left_unlisted_beside_a_killed_runs(tmp_path, capsys, when):
    """Safety round: a --loop each run's fig3_methods.html was removed after the new figures were
    in place, so a run without it killed in between left it beside them, listed by no
    checksums.sha256: nothing found it. It is taken away before the new checksums.sha256 is put in
    place: killed before that rename the earlier checksums still list it (missing: found), after it
    it is gone. The next run says what it found and leaves no hidden copy."""
    from cacas.cli import main

    personas = tmp_path / "personas.json"
    personas.write_text('{"participants": [{"id": "S01", "preferences": [{"activity": ["cough"], '
                        '"action": "pain check"}]}]}')
    out, plots = tmp_path / "out", tmp_path / "plots"
    args = ["simulate", "--personas", personas, "--days", "1", "--interactions", "2", "--methods", "nn,bandit",
            "--jobs", "1", "--quiet", "--out", out, "--plot", plots, "--seed", "1"]
    assert main([str(a) for a in args + ["--loop", "each"]]) == 0
    assert (plots / "fig3_methods.html").is_file()
    killed(5, when, *args)  # the tables' four renames, then the figures' checksums.sha256
    assert not (plots / "fig3_methods.html").exists()
    bad = files.mismatched(plots)
    assert ("fig3_methods.html" in bad) == (when == "before")  # listed by the earlier checksums: missing
    assert set(files.parse_checksums((plots / files.CHECKSUMS).read_bytes())) == (
        {"fig3_success.html", "fig4_methods.html", "fig4_by_preference.html", "fig3_methods.html", "plotly.min.js"}
        if when == "before" else {"fig3_success.html", "fig4_methods.html", "fig4_by_preference.html", "plotly.min.js"})
    capsys.readouterr()
    assert main([str(a) for a in args]) == 0
    assert "did not match checksums.sha256" in capsys.readouterr().err
    assert files.mismatched(plots) == [] and not hidden(plots) and not (plots / "fig3_methods.html").exists()
