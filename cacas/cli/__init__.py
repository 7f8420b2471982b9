"""The ``cacas`` command: one argparse parser, a sub-command per module in :data:`COMMANDS`.

Each sub-command module exposes ``register(subparsers)``, which adds its parser and sets
``func`` (called with the parsed arguments, returning an exit code). Bad input raises
:class:`cacas.errors.CacasError`; it is printed as one line and the command exits with code 2,
never with a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from cacas.errors import CacasError

#: Sub-command modules under cacas.cli, in the order they appear in ``cacas --help``.
COMMANDS = ["simulate", "export", "sound", "scene", "bench"]


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse's own errors: one line, exit code 2
        self.exit(2, f"cacas: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="cacas", description="CACAS Studio command line")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMANDS:
        importlib.import_module(f"cacas.cli.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code = args.func(args)
    except CacasError as exc:
        print(f"cacas: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("cacas: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. `cacas sound eval | head`: the reader left; not an error of ours
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    return int(code or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
