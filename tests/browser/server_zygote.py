"""The browser tests' Streamlit servers, forked from one process that has imported Streamlit and the app's heavy
modules once (as Chromium forks its renderers from a zygote).

Each server the tests start (a module's app, every restart of test_browser_restart) imported torch, torchvision and
librosa again in its background preload (``app.PRELOADED``): ~10 s of CPU a server, ~25 servers a run, on a 2-core
machine that the browser tests keep busy (measured: the browser part ran 615 s with the preload, 540 s with none,
512-568 s with its servers forked from here). A server forked from here starts with those modules imported: it
answers in ~0.5 s (1.5 s), stops in ~0.3 s (2.2-2.7 s), and its preload has nothing left to import. Everything else
is the server's own, as with ``streamlit run app.py``: the command line, its environment, its working folder, its
log, its caches (nothing of the app, of ``pages`` or of a Streamlit session is imported here: only libraries and
``cacas``, which never imports streamlit).

Run as ``python -u tests/browser/server_zygote.py`` in the checkout; reads one JSON request a line on stdin
(``{"argv": [...], "env": {...}, "log": PATH}``), forks a server for it and answers ``{"pid": N}`` on stdout;
ends when stdin closes. Forking after these imports is what PyTorch's DataLoader workers and cacas.parallel's
fork server do: the native threads started by the imports (OpenBLAS's pool, jemalloc's) have fork handlers."""

from __future__ import annotations

import ast
import json
import os
import signal
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def preloaded() -> tuple[str, ...]:
    """``app.PRELOADED``, read from app.py's source: importing app.py here would run the app."""
    tree = ast.parse((ROOT / "app.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "PRELOADED" for t in node.targets):
            return tuple(ast.literal_eval(node.value))
    raise RuntimeError("app.py has no PRELOADED")


def serve(request: dict) -> int:
    """Fork a Streamlit server for ``request``; the parent gets its pid, the child never returns."""
    pid = os.fork()
    if pid:
        return pid
    code = 1
    try:
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)  # the server's own subprocesses are waited for as usual
        os.setsid()
        null = os.open(os.devnull, os.O_RDONLY)
        log = os.open(request["log"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(null, 0)
        os.dup2(log, 1)
        os.dup2(log, 2)
        os.environ.clear()
        os.environ.update(request["env"])
        os.chdir(ROOT)
        sys.argv = ["streamlit", *request["argv"]]
        from streamlit.web import cli

        cli.main(prog_name="streamlit")
        code = 0
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else 0
    except BaseException:  # noqa: BLE001  the server's log says what failed
        import traceback

        traceback.print_exc()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def main() -> None:
    sys.path[0] = str(ROOT)  # as `python -m streamlit run` from the checkout: its folder first
    import importlib

    import streamlit.web.cli  # noqa: F401
    for name in preloaded():
        importlib.import_module(name)
    signal.signal(signal.SIGCHLD, signal.SIG_IGN)  # ended servers are reaped by the system: no zombies to poll
    print(json.dumps({"ready": True}), flush=True)
    for line in sys.stdin:
        print(json.dumps({"pid": serve(json.loads(line))}), flush=True)


if __name__ == "__main__":
    main()
