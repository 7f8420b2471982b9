"""The study data folder and what it needs of the shipped files."""

import shlex
import subprocess

from cacas.paths import PROJECT_ROOT, REQUIRED, SHIPPED, missing_shipped, study_data_blocked, study_data_dir, \
    study_data_problem


def test_the_shipped_folder_has_everything(monkeypatch):
    monkeypatch.delenv("CACAS_STUDY_DATA", raising=False)
    assert study_data_dir() == PROJECT_ROOT / "study_data"
    assert missing_shipped() == [] and study_data_problem() is None and not study_data_blocked()


def test_an_empty_folder_is_named_with_what_it_lacks_and_how_to_set_it_up(tmp_path, monkeypatch):
    monkeypatch.setenv("CACAS_STUDY_DATA", str(tmp_path))
    assert missing_shipped() == list(SHIPPED) and study_data_blocked()
    problem = study_data_problem()
    assert problem.startswith(f"the study data folder {tmp_path} lacks the shipped d4a.csv, personas, sounds, "
                              "scenes, models (without d4a.csv, the robot cannot get ready")
    shipped = PROJECT_ROOT / "study_data"
    assert (f"valid: copy them from the shipped folder (cp -rn {shipped}/d4a.csv {shipped}/personas "
            f"{shipped}/sounds {shipped}/scenes {shipped}/models {tmp_path}/)") in problem
    assert "$CACAS_DB" in problem


def test_a_folder_with_the_d4a_pairs_is_told_only_what_else_it_lacks(tmp_path):
    (tmp_path / REQUIRED).write_text("x")
    for name in ("personas", "scenes", "models"):
        (tmp_path / name).mkdir()
    assert missing_shipped(tmp_path) == ["sounds"] and not study_data_blocked(tmp_path)
    problem = study_data_problem(tmp_path)
    assert problem.startswith(f"the study data folder {tmp_path} lacks the shipped sounds (without sounds, the tablet "
                              "plays no activity sound and no sound model can be trained); valid: copy it from")
    assert "cannot get ready" not in problem


def test_the_advice_copies_what_is_missing_and_leaves_the_study_database_as_it_is(tmp_path):
    """The folder may already hold a study database (the app makes its default one there): the
    advised command copies the missing entries alone and overwrites nothing (it copied the whole
    shipped folder, with the study database kept there by default)."""
    folder = tmp_path / "data"
    folder.mkdir()
    (folder / "cacas.sqlite").write_bytes(b"the study's own database")
    for name in ("personas", "sounds", "scenes", "models"):  # present, so that the copy stays small
        (folder / name).mkdir()
    problem = study_data_problem(folder)
    command = problem[problem.index("(cp -rn ") + 1:problem.index(f" {folder}/)") + len(f" {folder}/")]
    assert ".sqlite" not in command and "policies" not in command
    subprocess.run(shlex.split(command), check=True)
    assert missing_shipped(folder) == [] and study_data_problem(folder) is None
    assert (folder / "cacas.sqlite").read_bytes() == b"the study's own database"
    assert (folder / "d4a.csv").read_bytes() == (PROJECT_ROOT / "study_data" / "d4a.csv").read_bytes()


def test_the_advised_command_runs_as_pasted_where_a_folder_name_holds_a_space_or_a_quote(tmp_path):
    """The `cp -rn` the pages give is pasted into a shell: a folder named "Jane's study data" (or a project
    under "/Users/Jane Doe/") was written bare, and the shell split it ("cp: target 'data/': No such file or
    directory"). Now each path is quoted as the shell reads it."""
    folder = tmp_path / "Jane's study data"
    folder.mkdir()
    for name in ("personas", "sounds", "scenes", "models"):
        (folder / name).mkdir()
    problem = study_data_problem(folder)
    command = problem[problem.index("(cp -rn ") + 1:problem.index("), or $CACAS_STUDY_DATA")]
    subprocess.run(["bash", "-c", command], check=True, capture_output=True)
    assert missing_shipped(folder) == [] and study_data_problem(folder) is None
