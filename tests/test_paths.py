"""The study data folder and what it needs of the shipped files."""

from cacas.paths import PROJECT_ROOT, SHIPPED, missing_shipped, study_data_dir, study_data_problem


def test_the_shipped_folder_has_everything(monkeypatch):
    monkeypatch.delenv("CACAS_STUDY_DATA", raising=False)
    assert study_data_dir() == PROJECT_ROOT / "study_data"
    assert missing_shipped() == [] and study_data_problem() is None


def test_an_empty_folder_is_named_with_what_it_lacks_and_how_to_set_it_up(tmp_path, monkeypatch):
    monkeypatch.setenv("CACAS_STUDY_DATA", str(tmp_path))
    assert missing_shipped() == list(SHIPPED)
    problem = study_data_problem()
    assert problem.startswith(f"the study data folder {tmp_path} lacks the shipped d4a.csv, personas, sounds, "
                              "scenes, models: without d4a.csv the robot cannot get ready")
    assert f"valid: a copy of the shipped folder (cp -r {PROJECT_ROOT / 'study_data'}/. {tmp_path})" in problem
    assert "$CACAS_DB" in problem


def test_a_folder_with_the_d4a_pairs_is_told_only_what_else_it_lacks(tmp_path):
    (tmp_path / "d4a.csv").write_text("x")
    for name in ("personas", "scenes", "models"):
        (tmp_path / name).mkdir()
    assert missing_shipped(tmp_path) == ["sounds"]
    problem = study_data_problem(tmp_path)
    assert problem.startswith(f"the study data folder {tmp_path} lacks the shipped sounds; valid:")
    assert "cannot get ready" not in problem
