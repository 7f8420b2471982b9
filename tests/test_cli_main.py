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


def _refused(argv, said: str, capsys) -> None:
    """``cacas argv`` exits 2 with one line on stderr: "cacas: error: " and ``said``."""
    import pytest

    from cacas.cli import main

    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err == f"cacas: error: {said}\n", err


def test_an_abbreviated_or_misspelt_option_is_refused_naming_the_full_one(capsys, tmp_path):
    """CLI audit: `--day 1` was taken as `--days 1` (argparse's abbreviations): a script would change its
    meaning once an option that the abbreviation also fits is added. Refused, one line, the nearest named."""
    personas = "study_data/personas/example.json"
    for argv, said in ((["simulate", "--personas", personas, "--out", str(tmp_path), "--day", "1"],
                        "unrecognized arguments: --day 1 (did you mean --days?)"),
                       (["simulate", "--personas", personas, "--out", str(tmp_path), "--day", "1", "--sed", "3"],
                        "unrecognized arguments: --day 1 --sed 3 (did you mean --days for --day, --seed for --sed?)"),
                       (["export", "--db", "x.sqlite", "--out", str(tmp_path), "--tables"],
                        "unrecognized arguments: --tables (did you mean --tables-only?)")):
        _refused(argv, said, capsys)
    assert not any(tmp_path.iterdir())  # nothing run


def test_an_option_of_another_command_is_refused_naming_this_commands_options(capsys, tmp_path):
    """`cacas sound generate --quiet` said "unrecognized arguments: --quiet (did you mean --quiet?)": the
    nearest option was looked for among every command's (`--quiet` is `sound train`'s), so an option of
    another command was offered as the one meant. Now the command run is searched, and where it has
    nothing near, the message names its options."""
    for argv, said in ((["sound", "generate", "--out", str(tmp_path), "--quiet"],
                        "unrecognized arguments: --quiet; cacas sound generate has no --quiet; valid: --clips, "
                        "--format, --out, --replace, --seconds, --seed"),
                       (["scene", "generate", "--out", str(tmp_path), "--clips", "3"],
                        "unrecognized arguments: --clips 3; cacas scene generate has no --clips; valid: "
                        "--images, --out, --replace, --seed, --size"),
                       (["export", "--db", "x.sqlite", "--out", str(tmp_path), "--seed", "3", "--tables"],
                        "unrecognized arguments: --seed 3 --tables (did you mean --tables-only?); cacas export has "
                        "no --seed; valid: --db, --out, --study, --tables-only")):
        _refused(argv, said, capsys)
    assert not any(tmp_path.iterdir())  # nothing run


def test_an_option_of_cacas_itself_after_a_command_is_refused_saying_where_it_goes(capsys, tmp_path):
    """Docs run: `cacas simulate --personas x --out y --version` said "(did you mean --personas?)", the nearest
    of simulate's options to "version" without its dashes; --version is cacas's own, given before a command."""
    for argv, said in ((["simulate", "--personas", "x.json", "--out", str(tmp_path), "--version"],
                        "unrecognized arguments: --version; --version is an option of cacas itself, given before a "
                        "command: cacas --version"),
                       (["sound", "generate", "--out", str(tmp_path), "--sed", "1", "--version"],
                        "unrecognized arguments: --sed 1 --version (did you mean --seed?); --version is an option of "
                        "cacas itself, given before a command: cacas --version")):
        _refused(argv, said, capsys)
    assert not any(tmp_path.iterdir())  # nothing run


def _help_pages():
    """(command words, parser) for ``cacas`` and every sub-command and action, at any depth."""
    import argparse

    from cacas.cli import build_parser

    pages = []

    def walk(words, parser):
        pages.append((words, parser))
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(words + [name], sub)
    walk(["cacas"], build_parser())
    return pages


def test_every_help_page_fits_80_columns_and_speaks_to_a_researcher(monkeypatch):
    """CLI audit: `cacas simulate --help` and `cacas bench --help` printed their module's
    docstring as written: lines of up to 104 columns, ``rst`` markup, "design.md's contract" (a
    file a researcher does not have) and "(issue 6)"."""
    monkeypatch.setenv("COLUMNS", "80")
    for words, parser in _help_pages():
        text = parser.format_help()
        wide = [line for line in text.splitlines() if len(line) > 80]
        assert not wide, (" ".join(words), wide)
        for internal in ("``", "design.md", "issue "):
            assert internal not in text, (" ".join(words), internal)


def _documented_commands():
    """Every `cacas ...` command the README and docs/ give (code blocks and inline code), with
    the file it is in; a line's comment left out."""
    import re
    from pathlib import Path

    root = Path(__file__).parents[1]
    found = []
    for doc in [root / "README.md", *sorted((root / "docs").glob("*.md"))]:
        text = doc.read_text()
        spans = re.findall(r"`(cacas [^`]+)`", text) + [line.strip() for line in text.splitlines()
                                                         if line.strip().startswith("cacas ")]
        for span in spans:
            if span.startswith("cacas simulate: note"):  # a message the command prints, not a command
                continue
            first, *rest = span.split("  #")[0].split(" ", 2)[1:] or [""]
            for sub in first.split("|"):  # "cacas sound|scene train": both
                found.append((doc.name, " ".join(["cacas", sub, *rest])))
    return found


def test_every_option_the_docs_give_is_one_the_command_has():
    """README and docs/ name each command's options as its --help does (an option renamed or
    misspelt in the docs is refused by the command: abbreviations are)."""
    import re

    pages = {" ".join(words): parser for words, parser in _help_pages()}
    checked = 0
    for doc, command in _documented_commands():
        words = command.split()
        path = "cacas"
        for word in words[1:]:  # the deepest sub-command named
            if f"{path} {word}" not in pages:
                break
            path = f"{path} {word}"
        assert path != "cacas" or words[1:2] in (["--version"], ["--help"]), (doc, command)
        options = {o for a in pages[path]._actions for o in a.option_strings}
        for option in re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", command):
            assert option in options, (doc, command, option, sorted(options))
            checked += 1
    assert checked > 30


def test_output_that_cannot_hold_a_character_escapes_it_instead_of_failing(tmp_path):
    """Output redirected on Windows is in the code page (cp1252, cp932), and PYTHONIOENCODING may name
    ASCII: `cacas --help` under a study data folder named in German and Japanese printed a traceback
    (exit 1), as `cacas simulate --out 結果` did after writing its files. Now the folder is escaped."""
    import os

    folder = tmp_path / "Studie Größe 結果"
    folder.mkdir()
    env = {**os.environ, "CACAS_STUDY_DATA": str(folder), "PYTHONIOENCODING": "ascii"}
    proc = subprocess.run([sys.executable, "-m", "cacas", "--help"], capture_output=True, text=True,
                          encoding="ascii", env=env)
    assert proc.returncode == 0 and proc.stderr == ""
    assert "Studie Gr\\xf6\\xdfe \\u7d50\\u679c" in proc.stdout.replace("\n", " ")


def test_a_file_name_s_undecodable_bytes_are_written_back_as_they_were(tmp_path):
    """In UTF-8 mode (LANG=C, C.UTF-8) stdout writes a file name's bytes that are not UTF-8 (a zip made on Windows:
    "K\\xfcche.png") back as they were, so that the printed name finds the file again; escaping what the output
    cannot hold must leave that be."""
    import os

    name = os.fsdecode(b"K\xfcche")
    env = {**os.environ, "LC_ALL": "C.UTF-8", "PYTHONUTF8": "1"}
    env.pop("PYTHONIOENCODING", None)
    child = f"import sys; sys.argv = ['cacas']; import cacas.cli as c; c._escape_what_the_output_cannot_hold(); print({name!r})"
    proc = subprocess.run([sys.executable, "-c", child], capture_output=True, env=env)
    assert proc.returncode == 0 and proc.stdout == b"K\xfcche\n", proc
