"""``streamlit run app.py`` with a probe inside the server process, for ``scripts/bench_long_run.py``.

    python3 scripts/long_run_server.py PROBE_DIR [--tracemalloc] -- <streamlit run's options>

Starts a daemon thread, then Streamlit's own command line (``streamlit run app.py <options>``) in this
process. The thread waits for ``PROBE_DIR/ask-N`` (written by the driver) and answers with
``PROBE_DIR/sample-N.json``: what the server process holds at that moment (:func:`sample`): its memory,
threads and open files, Streamlit's sessions (active and kept for a reconnection), their session state,
the entries of every ``st.cache_data`` / ``st.cache_resource`` function, the media files and deferred
downloads, the tablets' board, the background jobs, SQLite connections and torch tensors alive, and,
with ``--tracemalloc``, the lines of code that allocated what grew since the reference sample (the first, or
the last one asked for with ``reference`` in its ``ask-N`` file), and with ``holders`` there, what holds the
DataFrames alive (it gives every object its ``__dict__``, a few MB: not in a run whose memory is compared). Not a test,
and nothing of the app imports it.
"""

from __future__ import annotations

import collections
import gc
import json
import os
import sys
import threading
import time
import tracemalloc
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def _fds(db: str) -> dict[str, int]:
    """This process's open file descriptors by kind: the study database, its -wal, -shm and writer
    lock, policy files, sockets, pipes, other files."""
    kinds: collections.Counter = collections.Counter()
    for fd in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if db and target == db:
            kinds["db"] += 1
        elif db and target.startswith(db):
            kinds[target[len(db):].lstrip("-") or "db"] += 1  # wal, shm, writer.lock
        elif "/policies/" in target:
            kinds["policy files"] += 1
        elif target.startswith("socket:"):
            kinds["sockets"] += 1
        elif target.startswith("pipe:") or target.startswith("anon_inode:"):
            kinds["pipes/anon"] += 1
        else:
            kinds["other files"] += 1
    kinds["total"] = sum(kinds.values())
    return dict(kinds)


def _caches() -> dict[str, int]:
    """Entries per cached function (``st.cache_data`` and ``st.cache_resource``), by the function's name."""
    from streamlit.runtime.caching import cache_data_api, cache_resource_api

    out: dict[str, int] = {}
    for kind, caches in (("data", cache_data_api._data_caches), ("resource", cache_resource_api._resource_caches)):
        with caches._caches_lock:
            every = [c for by_key in caches._function_caches.values() for c in by_key.values()]
        for cache in every:
            name = f"{kind}:{getattr(cache, 'display_name', '?')}"
            held = getattr(cache, "_mem_cache", None)
            if held is None:  # st.cache_data's entries are in its storage (pickled bytes)
                held = getattr(getattr(cache, "storage", None), "_mem_cache", {})
            out[name] = out.get(name, 0) + len(held)
    return dict(sorted(out.items()))


def _streamlit() -> dict:
    from streamlit.runtime import Runtime

    rt = Runtime.instance()
    mgr = rt._session_mgr
    active = mgr.list_active_sessions()
    kept = mgr._session_storage.list()
    states = []
    for info in list(active) + list(kept):
        try:
            states.append(len(info.session.session_state.filtered_state) if hasattr(info.session.session_state, "filtered_state")
                          else len(list(info.session.session_state._state.keys())))
        except Exception:  # noqa: BLE001
            states.append(-1)
    media = rt.media_file_mgr
    storage = getattr(media, "_storage", None)
    files = getattr(storage, "_files_by_id", {})
    frames = getattr(rt, "dataframe_source_mgr", None)  # st.dataframe's rows served lazily, per session
    return {"sessions_active": len(active), "sessions_kept": len(kept),
            "dataframe_sources": frames.get_source_count() if frames is not None else None,
            "session_state_keys_max": max(states, default=0), "session_state_keys_total": sum(states),
            "connect_times": len(getattr(mgr, "_session_connect_times", {})),
            "media_files": len(files), "media_bytes": sum(len(f.content) for f in files.values()),
            "deferred_downloads": len(getattr(media, "_deferred_callables", {})),
            "media_sessions": len(getattr(media, "_files_by_session_and_coord", {}))}


def _objects(holders: bool = False) -> dict:
    """Objects alive, found by the garbage collector: SQLite connections (open or not), torch tensors and
    the bytes of their distinct storages, the app's long-lived holders (the tablets' board, the job runner,
    the stores), and Streamlit's sessions and script runners."""
    import sqlite3

    gc.collect()
    counts: collections.Counter = collections.Counter()
    tensors, storages = 0, {}
    boards, runners, stores, conns_open, pd_frames = [], [], [], 0, []
    torch = sys.modules.get("torch")
    tensor = getattr(torch, "Tensor", None)  # None while the app's preload is still importing torch
    for obj in gc.get_objects():
        t = type(obj)
        name = t.__name__
        if issubclass(t, sqlite3.Connection):  # type(), not isinstance(): a dead weak proxy raises
            counts["sqlite3.Connection"] += 1
            try:
                obj.total_changes  # raises on a closed connection
                conns_open += 1
            except sqlite3.ProgrammingError:
                pass
        elif tensor is not None and issubclass(t, tensor):
            tensors += 1
            try:  # by storage: a parameter and its views share one (counted by element, a policy was 3.8 MB, not 1.7)
                storage = obj.untyped_storage()
                storages[storage.data_ptr()] = storage.nbytes()
            except Exception:  # noqa: BLE001
                pass
        elif name == "DataFrame":
            counts[name] += 1
            pd_frames.append(obj)
        elif name in ("AppSession", "ScriptRunner", "Thread", "StudyStore", "Job",
                      "DiscreteSAC", "CacasPolicy", "MLPPolicy", "BanditPolicy", "Recognition"):
            counts[name] += 1
        if name == "TabletBoard":
            boards.append(obj)
        elif name == "JobRunner":
            runners.append(obj)
        elif name == "StudyStore":
            stores.append(obj)
    out = dict(counts)
    if holders:
        out["DataFrame held by"] = _holders(pd_frames)
    out["sqlite3.Connection open"] = conns_open
    out["torch tensors"] = tensors
    out["torch tensor MB"] = round(sum(storages.values()) / 2**20, 1)
    out["tablet board entries"] = sum(len(b._shown) + len(b._heard) + len(b._asked) for b in boards)
    out["jobs kept"] = sum(len(r._jobs) for r in runners)
    out["stores open"] = sum(1 for s in stores if _is_open(s))
    policies = sys.modules.get("cacas.store.policies")
    out["policy checks kept"] = len(getattr(policies, "_CHECKED", {}))
    return out


def _holders(frames: list) -> dict[str, int]:
    """What holds the DataFrames alive: the type of each object that refers to one (a dict by the class of
    the object whose ``__dict__`` it is, when it is one), counted; one pass over the collector's objects."""
    ids = {id(f) for f in frames}
    owners_of_dicts = {}
    held: collections.Counter = collections.Counter()
    for obj in gc.get_objects():  # an instance's __dict__ is made here if it was not yet (Python 3.11 keeps
        try:                       # attributes inline until asked), and found in the second pass
            d = None if issubclass(type(obj), type) else object.__getattribute__(obj, "__dict__")
        except Exception:  # noqa: BLE001  no __dict__, or a dead weak proxy
            continue
        if type(d) is dict:
            owners_of_dicts[id(d)] = type(obj).__name__
    every = gc.get_objects()
    for obj in every:
        if id(obj) in ids or obj is frames:
            continue
        for ref in gc.get_referents(obj):
            if id(ref) in ids:
                name = type(obj).__name__
                held[owners_of_dicts.get(id(obj), name) + ("'s __dict__" if id(obj) in owners_of_dicts else "")] += 1
    del every
    return dict(held.most_common(8))


def _is_open(store) -> bool:
    try:
        store._conn.total_changes
        return True
    except Exception:  # noqa: BLE001
        return False


def _threads() -> dict[str, int]:
    names: collections.Counter = collections.Counter()
    for t in threading.enumerate():
        names[t.name.split(":")[0].rstrip("0123456789-_ ")] += 1
    return dict(names)


def sample(db: str, first_snapshot, reference: bool = False, holders: bool = False) -> dict:
    t = time.perf_counter()
    out = {"time": time.time(), "rss_mb": round(_rss_mb(), 1), "threads": threading.active_count(),
           "os_threads": len(os.listdir("/proc/self/task")), "thread_names": _threads(), "fds": _fds(db)}
    try:
        out["streamlit"] = _streamlit()
    except Exception as exc:  # noqa: BLE001  the runtime not up yet
        out["streamlit"] = {"error": repr(exc)}
    try:
        out["caches"] = _caches()
    except Exception as exc:  # noqa: BLE001
        out["caches"] = {"error": repr(exc)}
    try:
        out["objects"] = _objects(holders)
    except Exception as exc:  # noqa: BLE001
        out["objects"] = {"error": repr(exc)}
    if tracemalloc.is_tracing():
        snap = tracemalloc.take_snapshot().filter_traces([tracemalloc.Filter(False, tracemalloc.__file__)])
        if first_snapshot[0] is None or reference:
            first_snapshot[0] = snap
        else:
            diff = snap.compare_to(first_snapshot[0], "lineno")
            out["tracemalloc_top"] = [f"{s.size_diff / 1024:+.0f} KiB {s.count_diff:+d} blocks "
                                      f"{s.traceback[0].filename}:{s.traceback[0].lineno}" for s in diff[:15]]
        out["tracemalloc_mb"] = round(tracemalloc.get_traced_memory()[0] / 2**20, 1)
    out["probe_s"] = round(time.perf_counter() - t, 2)
    return out


def serve(folder: Path, db: str) -> None:
    first = [None]
    n = 0
    while True:
        ask = folder / f"ask-{n}"
        if ask.exists():
            try:
                words = ask.read_text().split()
                result = sample(db, first, reference="reference" in words, holders="holders" in words)
            except Exception as exc:  # noqa: BLE001  the driver reads the error rather than waiting for ever
                result = {"error": repr(exc)}
            tmp = folder / f"sample-{n}.json.tmp"
            tmp.write_text(json.dumps(result))
            tmp.replace(folder / f"sample-{n}.json")
            n += 1
        else:
            time.sleep(0.1)


def main() -> None:
    args = sys.argv[1:]
    if "--" not in args:
        sys.exit("usage: long_run_server.py PROBE_DIR [--tracemalloc] -- <streamlit run's options>")
    split = args.index("--")
    ours, theirs = args[:split], args[split + 1:]
    folder = Path(ours[0])
    if "--tracemalloc" in ours:
        tracemalloc.start(1)
    db = os.path.realpath(os.environ.get("CACAS_DB", ""))
    threading.Thread(target=serve, args=(folder, db), name="long-run-probe", daemon=True).start()
    os.chdir(ROOT)
    sys.path.insert(0, str(ROOT))
    from streamlit.web import cli

    sys.argv = ["streamlit", "run", "app.py", *theirs]
    sys.exit(cli.main())


if __name__ == "__main__":
    main()
