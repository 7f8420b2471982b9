import subprocess
import sys

CHILD = r'''
import argparse, sys
import cacas.cli as cli

def build_parser():
    p = argparse.ArgumentParser()
    p.set_defaults(func=lambda args: [print("line", i) for i in range(200000)] and 0)
    return p

cli.build_parser = build_parser
sys.exit(cli.main([]))
'''


def test_a_reader_that_leaves_early_is_not_an_error():
    """`cacas ... | head`: no BrokenPipeError traceback, exit code 0."""
    proc = subprocess.run(f'"{sys.executable}" -c \'{CHILD}\' | head -n 1; exit ${{PIPESTATUS[0]}}',
                          shell=True, executable="/bin/bash", capture_output=True, text=True)
    assert proc.stdout == "line 0\n"
    assert "Traceback" not in proc.stderr and "BrokenPipe" not in proc.stderr
    assert proc.returncode == 0


def test_unknown_command_is_one_line_and_exit_2():
    proc = subprocess.run([sys.executable, "-m", "cacas", "frobnicate"], capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "invalid choice" in proc.stderr


def test_a_file_that_cannot_be_written_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    """The last resort for any sub-command: an OSError names the path, no traceback."""
    import argparse

    import cacas.cli as cli

    def build_parser():
        p = argparse.ArgumentParser()
        p.set_defaults(func=lambda args: (tmp_path / "a_file" / "x.csv").write_text("x"))
        return p

    (tmp_path / "a_file").write_text("not a folder")
    monkeypatch.setattr(cli, "build_parser", build_parser)
    assert cli.main([]) == 2
    err = capsys.readouterr().err
    assert err == f"cacas: error: {tmp_path / 'a_file' / 'x.csv'}: Not a directory\n"


def test_version_prints_the_package_version_and_exits_0():
    import importlib.metadata
    import tomllib
    from pathlib import Path

    proc = subprocess.run([sys.executable, "-m", "cacas", "--version"], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stderr == ""
    try:
        expected = importlib.metadata.version("cacas")
    except importlib.metadata.PackageNotFoundError:
        expected = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"]["version"]
    assert proc.stdout == f"cacas {expected}\n"


def test_version_falls_back_to_pyproject_when_not_installed(monkeypatch):
    import importlib.metadata
    import tomllib
    from pathlib import Path

    import cacas.cli as cli

    def not_installed(name):
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "version", not_installed)
    expected = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"]["version"]
    assert cli.package_version() == expected


def test_a_missing_command_or_action_is_one_line_naming_the_valid_ones(capsys):
    """CLI audit: `cacas` and `cacas sound` said 'the following arguments are required: COMMAND'
    (ACTION) and no more: the one-line error leaves out argparse's usage, so nothing named the
    commands (actions) there are."""
    import pytest

    from cacas.cli import main

    for argv, valid in ([[], "simulate, export, import, sound, scene, bench"],
                        [["sound"], "generate, import, train, eval, recognize, put-back"],
                        [["scene"], "generate, import, train, eval, recognize, put-back"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2 and err.count("\n") == 1, err
        assert "the following arguments are required" in err and f"; valid: {valid}" in err, err


def test_an_abbreviated_or_misspelt_option_is_refused_naming_the_full_one(capsys, tmp_path):
    """CLI audit: `--day 1` was taken as `--days 1` (argparse's abbreviations): a script would change its
    meaning once an option that the abbreviation also fits is added. Refused, one line, the nearest named."""
    import pytest

    from cacas.cli import main

    personas = "study_data/personas/example.json"
    for argv, said in ((["simulate", "--personas", personas, "--out", str(tmp_path), "--day", "1"],
                        "unrecognized arguments: --day 1 (did you mean --days?)"),
                       (["simulate", "--personas", personas, "--out", str(tmp_path), "--day", "1", "--sed", "3"],
                        "unrecognized arguments: --day 1 --sed 3 (did you mean --days for --day, --seed for --sed?)"),
                       (["export", "--db", "x.sqlite", "--out", str(tmp_path), "--tables"],
                        "unrecognized arguments: --tables (did you mean --tables-only?)")):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2 and err == f"cacas: error: {said}\n", err
    assert not any(tmp_path.iterdir())  # nothing run
