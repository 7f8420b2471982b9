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
