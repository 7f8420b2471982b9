"""The ``cacas`` command: one argparse parser, a sub-command per module in :data:`COMMANDS`.

Each sub-command module exposes ``register(subparsers)``, which adds its parser and sets
``func`` (called with the parsed arguments, returning an exit code). Bad input raises
:class:`cacas.errors.CacasError`; it is printed as one line and the command exits with code 2,
never with a traceback. So is, as a last resort, a file the command cannot read or write
(OSError) and a study database found damaged while reading it.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sqlite3
import sys

from cacas.errors import CacasError

#: Sub-command modules under cacas.cli, in the order they appear in ``cacas --help``.
COMMANDS = ["simulate", "export", "sound", "scene", "bench"]


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors, and options only as spelt in full: an abbreviation ("--day" for
    "--days") is refused, so that a script written today keeps its meaning when an option is added
    that the abbreviation would also fit (CLI audit)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):  # argparse's own errors: one line, exit code 2
        if message.startswith("the following arguments are required: "):  # a missing COMMAND / ACTION: which there are
            missing = message.split(": ", 1)[1].split(", ")
            for action in self._actions:
                if isinstance(action, argparse._SubParsersAction) and action.metavar in missing:
                    message += f"; valid: {', '.join(action.choices)}"
        elif message.startswith("unrecognized arguments: "):  # an option misspelt or abbreviated: the nearest
            import difflib

            # the command run's own options (every command's, an option of another command was offered as the
            # one meant: "--quiet (did you mean --quiet?)"), compared without their dashes ("--out" for "--quiet")
            command = self._command_run()
            options = sorted(command._own_options() if command is not self else self._option_strings())
            words = [word for word in message.split(": ", 1)[1].split() if word.startswith("--")]
            # an option of cacas itself after a command ("cacas simulate ... --version" offered --personas)
            own = [word for word in words if command is not self and word in self._own_options()]
            near = {word: difflib.get_close_matches(word[2:], [o[2:] for o in options], n=1, cutoff=0.6)
                    for word in words if word not in own}
            said = {word: f"--{found[0]}" for word, found in near.items() if found}
            if len(said) == 1:
                message += f" (did you mean {next(iter(said.values()))}?)"
            elif said:
                message += f" (did you mean {', '.join(f'{full} for {word}' for word, full in said.items())}?)"
            unknown = [word for word, found in near.items() if not found]
            if unknown and command is not self:
                message += f"; {command.prog} has no {', '.join(unknown)}; valid: {', '.join(options)}"
            if own:
                message += (f"; {', '.join(own)} {'is an option' if len(own) == 1 else 'are options'} of {self.prog} "
                            f"itself, given before a command: {self.prog} {' '.join(own)}")
        self.exit(2, f"cacas: error: {message}\n")

    def parse_args(self, args=None, namespace=None):
        self._argv = list(sys.argv[1:] if args is None else args)  # for error(): which command was run
        return super().parse_args(args, namespace)

    def _command_run(self) -> "_Parser":
        """The deepest sub-command the arguments parsed last name (``cacas sound generate``'s parser), else this one."""
        parser = self
        for word in getattr(self, "_argv", []):
            subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
            if subs and word in subs[0].choices:
                parser = subs[0].choices[word]
            elif not word.startswith("-"):
                break
        return parser

    def _own_options(self) -> set[str]:
        """This parser's long options but --help."""
        return {o for a in self._actions for o in a.option_strings if o.startswith("--") and o != "--help"}

    def _option_strings(self) -> set[str]:
        """Every option of this parser and of its sub-commands, at any depth."""
        found = set()
        for action in self._actions:
            found.update(o for o in action.option_strings if o.startswith("--"))
            if isinstance(action, argparse._SubParsersAction):
                for sub in action.choices.values():
                    found |= sub._option_strings()
        return found


def package_version() -> str:
    """The installed package's version (importlib.metadata), else the checkout's pyproject.toml's."""
    import importlib.metadata
    from pathlib import Path

    try:
        return importlib.metadata.version("cacas")
    except importlib.metadata.PackageNotFoundError:
        pass
    import tomllib

    pyproject = Path(__file__).resolve().parents[2] / "pyproject.toml"
    try:
        return str(tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]["version"])
    except (OSError, ValueError, KeyError):  # no pyproject beside the package, or not one of ours
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    from cacas.paths import STUDY_DATA_ENV, study_data_dir

    parser = _Parser(prog="cacas", description="CACAS Studio command line: simulated studies, study exports, "
                                               "sound and scene recognition models, benchmarks.",
                     epilog="Run 'cacas COMMAND --help' for a command's options. A default under study_data/ is in "
                            f"the study data folder, now {study_data_dir()} (${STUDY_DATA_ENV} moves it); other "
                            "relative paths are from the current folder. More: README.md and docs/ in the project "
                            "folder.")
    parser.add_argument("--version", action="version", version=f"cacas {package_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMANDS:
        importlib.import_module(f"cacas.cli.{name}").register(sub)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM (``kill``, a job scheduler's stop) while a command runs: handled as Ctrl-C is, so an
    output folder the command created is not left behind, and nothing is half-written."""


#: Set once SIGTERM arrived: an error raised after it (a worker's manager process, ended by the
#: same signal sent to the process group, resets its connection) is part of the termination.
_SIGNALLED = {"term": False}


def _terminate(signum, frame):
    _SIGNALLED["term"] = True
    raise Terminated()


def _escape_what_the_output_cannot_hold() -> None:
    """stdout and stderr write a character their encoding lacks as an escape (``Gr\\xf6\\xdfe``)
    instead of failing: with output redirected on Windows (the code page, e.g. cp1252) or
    PYTHONIOENCODING=ascii, a folder named in Japanese or a description with an emoji in what a
    command prints ended it with a traceback and exit code 1 after its files were written
    (``wrote 結果/daily.csv``), and ``cacas --help`` under a study data folder with an umlaut
    printed nothing. A UTF-8 terminal is unchanged, and so is a stream that already deals with such characters
    otherwise (stderr escapes them; in UTF-8 mode stdout writes a file name's undecodable bytes back as they were)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream.errors == "strict":
                stream.reconfigure(errors="backslashreplace")
        except (AttributeError, ValueError):  # replaced by a stream without it (a test's StringIO), or closed
            pass


def main(argv: list[str] | None = None) -> int:
    import signal
    import threading

    _escape_what_the_output_cannot_hold()
    parser = build_parser()
    args = parser.parse_args(argv)
    on_main_thread = threading.current_thread() is threading.main_thread()
    earlier = signal.signal(signal.SIGTERM, _terminate) if on_main_thread else None
    _SIGNALLED["term"] = False
    try:
        return _run(args)
    finally:
        if on_main_thread:
            signal.signal(signal.SIGTERM, earlier)


@contextlib.contextmanager
def signals_held():
    """Ctrl-C (SIGINT) and SIGTERM held while the block runs and delivered when it ends: a command
    puts its results in place (several files, an earlier run's removed) as one change, not stopped
    half-way through it. The block is short (files written from bytes already made). Off the main
    thread (where no signal handler runs) it holds nothing."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    arrived: list[int] = []
    earlier = {s: signal.signal(s, lambda signum, frame: arrived.append(signum))
               for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in earlier.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        for s in dict.fromkeys(arrived):  # its own handler now: "cacas: interrupted" / "terminated"
            signal.raise_signal(s)


def _terminated() -> int:
    print("cacas: terminated", file=sys.stderr)
    return 143  # 128 + SIGTERM, as the shell reports a process it ended


def _failed(message: str) -> int:
    """Exit code 2 with one line; or, once SIGTERM has arrived, the termination said instead (the
    error was its doing)."""
    if _SIGNALLED["term"]:
        return _terminated()
    print(f"cacas: error: {message}", file=sys.stderr)
    return 2


def _run(args) -> int:
    try:
        code = args.func(args)
    except CacasError as exc:
        return _failed(str(exc))
    except BrokenPipeError:  # e.g. `cacas sound eval | head`: the reader left; not an error of ours
        if _SIGNALLED["term"]:  # or the workers' manager, ended by SIGTERM: that run exited 0, saying nothing
            return _terminated()
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # a file or folder the command could not read or write
        where = f"{exc.filename}: " if exc.filename else ""
        return _failed(f"{where}{exc.strerror or exc}")
    except EOFError:  # a pipe to a worker's manager closed under us: after SIGTERM, its doing (a traceback, exit 1)
        if _SIGNALLED["term"]:
            return _terminated()
        raise
    except sqlite3.DatabaseError as exc:  # e.g. a damaged page found while reading the tables
        return _failed(f"the study database cannot be read ({exc}); restore it from a backup or an export")
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM (Terminated)
        if _SIGNALLED["term"]:
            return _terminated()
        print("cacas: interrupted", file=sys.stderr)
        return 130
    return int(code or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
