"""What a lab's Windows laptop does differently from Linux, run here: Windows' file rules
(:mod:`windows_rules`: no fcntl, an open file cannot be deleted or replaced, no folder opened as
a file, fsync only through a descriptor that may write)."""

import io
import os

import pytest

from cacas.store import StudyStore
from studies import policy_bytes
from windows_rules import windows_files  # noqa: F401


@pytest.fixture
def store(tmp_path, windows_files):
    s = StudyStore(tmp_path / "study.sqlite")
    s.add_participant("P01", "25-34")
    s.save_policy("P01", 0, "cacas", policy_bytes("initial P01"))
    s.add_participant("P02", "25-34")
    s.save_policy("P02", 0, "cacas", policy_bytes("initial P02"))
    yield s
    s.close()


def test_a_participants_removal_deletes_their_files_and_says_it_is_done(store):
    """The removal held its lock file (recovery.busy) open while it deleted the folder holding it: on
    Windows the lock file stayed, and every withdrawal with policy files ended with "could not be
    deleted: delete that folder by hand" (the rows were gone, the files too but the lock)."""
    store.remove_participant("P01", "P01")
    assert sorted(p.name for p in store.policy_dir.iterdir()) == ["P02"]
    assert store.list_participants()[0].code == "P02"


def test_a_removal_that_fails_puts_the_files_back_and_leaves_no_folder_aside(store, monkeypatch):
    """Rolled back (here the disk refused the sync after the moves), the files go home and the
    folder they were moved to goes: with its lock file still open, it stayed on Windows."""
    from cacas.errors import CacasError
    from cacas.store import people

    before = sorted(p.name for p in (store.policy_dir / "P01").iterdir())

    def disk_refuses(folder):
        raise OSError(5, "Input/output error")
    monkeypatch.setattr(people.files, "fsync_folder", disk_refuses)
    with pytest.raises((OSError, CacasError)):
        store.remove_participant("P01", "P01")
    monkeypatch.setattr(people.files, "fsync_folder", lambda folder: None)
    assert sorted(p.name for p in (store.policy_dir / "P01").iterdir()) == before
    assert sorted(p.name for p in store.policy_dir.iterdir()) == ["P01", "P02"]
    assert [p.code for p in store.list_participants()] == ["P01", "P02"]


def test_a_study_exports_and_imports(store, tmp_path):
    """The import deleted its lock file (recovery.import_lock) while it still held it open: on Windows
    that failed (a PermissionError, a traceback) after the new database was in place, so the import
    said it failed, and again it said "already exists"."""
    from cacas import export

    bundle = export.export_study(store, tmp_path / "out").bundle
    target = tmp_path / "copy" / "study.sqlite"
    restored = export.import_bundle(bundle, target)
    assert restored.interactions == 0
    assert sorted(p.name for p in target.parent.iterdir()) == ["policies", "study.sqlite"]
    with StudyStore(target) as copy:
        assert [p.code for p in copy.list_participants()] == ["P01", "P02"]
        assert copy.load_policy("P02") == policy_bytes("initial P02")


def test_an_import_refused_says_why_and_leaves_nothing(store, tmp_path):
    """A refusal part-way (a policy file of other content where the bundle's would go) is said as
    itself, with nothing of the import left: it was a PermissionError on its lock file on Windows."""
    from cacas import export
    from cacas.errors import CacasError

    bundle = export.export_study(store, tmp_path / "out").bundle
    rel = store.policies_frame()["path"].iloc[0]
    target = tmp_path / "copy" / "study.sqlite"
    (target.parent / "policies" / rel).parent.mkdir(parents=True)
    (target.parent / "policies" / rel).write_bytes(b"another policy")
    with pytest.raises(CacasError, match="exists with other content"):
        export.import_bundle(bundle, target)
    assert [p.relative_to(target.parent).as_posix() for p in sorted(target.parent.rglob("*"))] == \
        ["policies", "policies/" + rel.split("/")[0], "policies/" + rel]


def test_photos_are_added_to_the_library(windows_files, tmp_path):
    """The library's staging synced each new file through a descriptor opened read-only
    (files.fsync_file), which Windows' FlushFileBuffers refuses (EBADF): every photo or clip added
    on the Sounds and scenes page, and every `cacas sound generate` / `import`, failed there."""
    from cacas import lab
    from cacas.vision.library import image_paths
    from photos import photo

    png = io.BytesIO()
    photo().save(png, format="PNG")
    root = tmp_path / "scenes"
    added = lab.add_photos("kitchen", [("our stove.png", png.getvalue())], root)
    assert [p.relative_to(root).as_posix() for p in added] == ["kitchen/our_stove.png"]
    assert image_paths("kitchen", root) == added


def test_a_read_only_photo_is_added_as_a_file_the_lab_may_change(windows_files, tmp_path):
    """A copy kept its source's read-only mode (shutil.copy2): on Windows (the read-only attribute) its
    sync through a descriptor that may write was refused, and the library file could not be deleted."""
    from cacas.vision.library import import_folder
    from photos import photo

    source = tmp_path / "dvd" / "kitchen"
    source.mkdir(parents=True)
    photo().save(source / "stove.png")
    (source / "stove.png").chmod(0o444)
    (added,) = import_folder(source.parent, tmp_path / "scenes")
    assert added.stat().st_mode & 0o200


class FakeWinapi:
    """Windows' _winapi as :func:`cacas.store.files.process_running` uses it, over a table of
    process ids: running (exit code 259, STILL_ACTIVE), ended (another exit code, its handle still
    open somewhere), another user's (access denied) or none (WinError 87)."""

    def __init__(self, running=(), ended=(), denied=()):
        self.running, self.ended, self.denied, self.open = set(running), set(ended), set(denied), []

    def OpenProcess(self, access, inherit, pid):
        if pid in self.denied or pid not in self.running | self.ended:
            exc = OSError(13, "Access is denied") if pid in self.denied else OSError(22, "The parameter is incorrect")
            exc.winerror = 5 if pid in self.denied else 87  # (set by OSError itself on Windows alone)
            raise exc
        self.open.append(pid)
        return pid

    def GetExitCodeProcess(self, handle):
        return 259 if handle in self.running else 1

    def CloseHandle(self, handle):
        self.open.remove(handle)


def test_a_left_over_is_judged_without_signalling_its_process(tmp_path, monkeypatch):
    """os.kill(pid, 0) is no look-up on Windows (0 is CTRL_C_EVENT: a Ctrl-C sent to the console's
    processes), and a process that has ended raised WinError 87 out of the export. Hidden files a
    killed write left (its process gone, or ended) are removed; those of a running process, ours
    or another user's, stay."""
    import sys

    from cacas.store import files

    def no_signal(pid, sig):
        raise AssertionError(f"os.kill({pid}, {sig}) on Windows")
    winapi = FakeWinapi(running={4000}, ended={4001}, denied={4002})
    monkeypatch.setattr(files, "ON_WINDOWS", True, raising=False)
    monkeypatch.setitem(sys.modules, "_winapi", winapi)
    monkeypatch.setattr(os, "kill", no_signal)
    left = {pid: tmp_path / f".daily.csv.{pid}.tmp" for pid in (4000, 4001, 4002, 4003)}
    for path in left.values():
        path.write_text("rows of a run")
    files.write_all(tmp_path, {"daily.csv": b"rows"})
    assert sorted(p.name for p in tmp_path.iterdir()) == [".daily.csv.4000.tmp", ".daily.csv.4002.tmp", "daily.csv"]
    assert winapi.open == []  # every handle closed


def test_a_librarys_left_over_is_judged_without_signalling_its_process(tmp_path, monkeypatch):
    """The libraries' clean-up asked os.kill(pid, 0) too: on Windows a Ctrl-C to the console, and a
    killed generate's hidden copy stayed for good (the error taken for "running")."""
    import sys
    import time

    from cacas import media_library
    from cacas.store import files

    def no_signal(pid, sig):
        raise AssertionError(f"os.kill({pid}, {sig}) on Windows")
    monkeypatch.setattr(files, "ON_WINDOWS", True, raising=False)
    monkeypatch.setitem(sys.modules, "_winapi", FakeWinapi(running={4000}))
    monkeypatch.setattr(os, "kill", no_signal)
    (tmp_path / "cough").mkdir()
    old = time.time() - 2 * media_library.LEFTOVER_AGE
    for pid in (4000, 4001):
        (tmp_path / "cough" / f".take.wav.{pid}.tmp").write_bytes(b"RIFF")
        os.utime(tmp_path / "cough" / f".take.wav.{pid}.tmp", (old, old))
    assert media_library.remove_leftovers(tmp_path, (".wav",)) == [tmp_path / "cough" / ".take.wav.4001.tmp"]


@pytest.fixture
def no_hard_links(monkeypatch):
    """A file system without hard links (FAT32, exFAT: a USB stick or a disk a Mac and a Windows PC
    share): os.link fails as Linux's vfat fails it."""
    import errno

    def refused(src, dst, **kwargs):
        raise PermissionError(errno.EPERM, "Operation not permitted", os.fsdecode(src), None, os.fsdecode(dst))
    monkeypatch.setattr(os, "link", refused)


def test_a_second_export_into_a_folder_on_a_stick_replaces_the_first(no_hard_links, tmp_path, fail_on_call,
                                                                      monkeypatch):
    """write_all kept each replaced file under a second name (os.link) to put it back on a failure:
    without hard links the second `cacas export --out` / `simulate --out` into a folder said "cannot
    be written". A copy is kept there instead, and a failure still puts everything back."""
    from cacas.store import files

    files.write_all(tmp_path, {"daily.csv": b"first daily", "old.csv": b"first old"}, checksums=True)
    files.write_all(tmp_path, {"daily.csv": b"second daily"}, checksums=True, remove=["old.csv"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checksums.sha256", "daily.csv"]
    assert (tmp_path / "daily.csv").read_bytes() == b"second daily" and files.mismatched(tmp_path) == []
    monkeypatch.setattr(os, "replace", fail_on_call(os.replace, 2, PermissionError(13, "Permission denied")))
    with pytest.raises(files.CacasError, match="the folder's files are unchanged"):
        files.write_all(tmp_path, {"daily.csv": b"third daily"}, checksums=True)
    assert (tmp_path / "daily.csv").read_bytes() == b"second daily" and files.mismatched(tmp_path) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checksums.sha256", "daily.csv"]


def test_a_study_imports_onto_a_stick(no_hard_links, tmp_path):
    """The import linked its finished database into place (os.link, which never replaces a file):
    without hard links it failed ("Operation not permitted"), leaving nothing. Renamed there instead;
    an existing database is still refused."""
    from cacas import export
    from cacas.errors import CacasError

    with StudyStore(tmp_path / "a" / "study.sqlite") as s:
        s.add_participant("P01")
        s.save_policy("P01", 0, "cacas", policy_bytes("initial P01"))
        bundle = export.export_study(s, tmp_path / "out").bundle
    target = tmp_path / "stick" / "study.sqlite"
    export.import_bundle(bundle, target)
    assert sorted(p.name for p in target.parent.iterdir()) == ["policies", "study.sqlite"]
    with StudyStore(target) as copy:
        assert copy.load_policy("P01") == policy_bytes("initial P01")
    with pytest.raises(CacasError, match="already exists"):
        export.import_bundle(bundle, target)


def test_worker_processes_on_windows_are_as_many_as_its_memory_holds(monkeypatch):
    """The available memory was read from Linux's /proc alone: on Windows every worker process a
    core was started whatever the memory (16 of ~1 GB on a laptop of 16 logical cores and 16 GB,
    where Windows fails a process that finds no memory to commit). Asked of Windows now
    (GlobalMemoryStatusEx), it caps them as on Linux."""
    import ctypes

    from cacas import parallel
    from cacas.store import files

    class Kernel32:
        asked = []

        def GlobalMemoryStatusEx(self, status):
            status = status._obj  # the structure behind ctypes.byref
            self.asked.append(status.dwLength)
            status.ullAvailPhys = 5 * 2**30
            return 1

    kernel32 = Kernel32()
    monkeypatch.setattr(files, "ON_WINDOWS", True, raising=False)
    monkeypatch.setattr(ctypes, "windll", type("windll", (), {"kernel32": kernel32}), raising=False)
    monkeypatch.setattr(parallel, "cores", lambda: 16)
    assert parallel.available_memory() == 5 * 2**30
    assert kernel32.asked == [64]  # the size of MEMORYSTATUSEX, as Windows requires
    jobs, notes = parallel.plan_jobs(None, 24)
    assert jobs == 5 * 2**30 // parallel.WORKER_MEMORY == parallel.default_jobs()
    assert notes[0].startswith("one worker process per core: 16 worker processes need about 12.8 GB")


TEXT_ROUND = r"""
import json, sys, warnings
from pathlib import Path

warnings.simplefilter("always", EncodingWarning)
tmp = Path(sys.argv[1])
words = "Quand je tousse, apporte-moi de l'eau, été 中 咳"
with warnings.catch_warnings(record=True) as seen:
    warnings.simplefilter("always", EncodingWarning)
    from cacas import export, parallel, saved_runs
    from cacas.audio.model import SoundRecognizer
    from cacas.cli import main
    from cacas.d4a import load_d4a
    from cacas.preferences import load_personas, save_personas
    from cacas.previous_model import previous_metadata
    from cacas.store import StudyStore

    persona = {"participants": [{"id": "P01", "preferences": [
        {"activity": ["cough"], "action": "pain check", "description": words}]}]}
    (tmp / "p.json").write_bytes(json.dumps(persona, ensure_ascii=False).encode("utf-8"))
    people = load_personas(tmp / "p.json")
    save_personas(people, tmp / "again.json")
    with StudyStore(tmp / "a" / "study.sqlite") as s:
        s.import_personas(persona)
        bundle = export.export_study(s, tmp / "out").bundle
    export.import_bundle(bundle, tmp / "b" / "study.sqlite")
    assert main(["simulate", "--personas", str(tmp / "p.json"), "--days", "1", "--interactions", "2",
                 "--methods", "cacas", "--out", str(tmp / "sim"), "--jobs", "1"]) == 0
    run = saved_runs.save_run(tmp / "runs", "r", saved_runs.load_daily(tmp / "sim" / "daily.csv"),
                              saved_runs.load_run(tmp / "sim").interactions, {"personas": words})
    assert saved_runs.load_run(run).settings == {"personas": words}
    load_d4a()
    SoundRecognizer.load()
    previous_metadata(tmp / "sound_cnn.pt")
    parallel.default_jobs()
ours = sorted({f"{Path(w.filename).name}:{w.lineno}" for w in seen
               if issubclass(w.category, EncodingWarning) and "/cacas/" in w.filename.replace("\\", "/")})
print(json.dumps(ours))
"""


def test_every_text_file_is_read_and_written_as_utf_8(tmp_path):
    """Windows opens a text file without an encoding in the computer's code page (cp1252 in western
    Europe, cp932 in Japan), so a persona's own words with "é" or "中" would be written or read as
    other characters. Python warns of every such open (-X warn_default_encoding, PEP 597): a study's
    text round (persona files, a study database's export and import, cacas simulate --out, a saved
    run, the D4A table, the sound model and its kept predecessor, the memory the workers need) opens
    none in cacas."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).parents[1]
    (tmp_path / "round.py").write_text(TEXT_ROUND, encoding="utf-8")
    (tmp_path / "sound_cnn.previous.pt").write_bytes(b"weights")
    (tmp_path / "sound_cnn.previous.json").write_text('{"kind": "sound"}', encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-X", "warn_default_encoding", str(tmp_path / "round.py"), str(tmp_path)],
                          capture_output=True, text=True, encoding="utf-8", env=env, cwd=root, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == []


def test_a_table_open_in_another_program_is_named_as_the_reason(windows_files, tmp_path, monkeypatch):
    """Excel keeps a CSV it shows locked, and Windows replaces no file that is open: the second
    export into the folder said "Permission denied" alone. It says to close the file; the folder's
    files are as they were."""
    from cacas.store import files

    monkeypatch.setattr(files, "ON_WINDOWS", True, raising=False)
    files.write_all(tmp_path, {"daily.csv": b"first", "interactions.csv": b"first rows"}, checksums=True)
    shown = os.open(tmp_path / "daily.csv", os.O_RDONLY)  # as Excel holds it
    try:
        with pytest.raises(files.CacasError, match=r"daily\.csv: cannot be written \(.*\); the folder's files are "
                                                   r"unchanged; on Windows a file another program has open cannot "
                                                   r"be replaced: close it there \(Excel keeps a CSV it shows locked\)"):
            files.write_all(tmp_path, {"daily.csv": b"second", "interactions.csv": b"second rows"}, checksums=True)
    finally:
        os.close(shown)
    assert (tmp_path / "daily.csv").read_bytes() == b"first" and files.mismatched(tmp_path) == []


def test_tables_end_their_lines_alike_on_every_system(store, monkeypatch):
    """pandas' to_csv ends lines with os.linesep ("\r\n" on Windows) unless told otherwise: a study's
    tables (and their checksums) would differ byte for byte between a lab's Windows laptop and its
    Linux server. With Windows' line separator, an export's tables are those of Linux."""
    from cacas import export

    linux = export.export_contents(store)
    monkeypatch.setattr(os, "linesep", "\r\n")
    windows = export.export_contents(store)
    assert windows == linux
    assert not any(b"\r" in data for name, data in windows.items() if name.endswith(".csv"))


def _left_aside(store, code: str) -> tuple[list, object]:
    """A removal's folder of moved-aside files as a removal killed after its moves leaves it (its
    lock file there, held by nobody): the participant's files moved into it."""
    from cacas.store import recovery

    trash = store.policy_dir / f".removed-{code}-4242-123"
    trash.mkdir()
    (trash / recovery.REMOVAL_LOCK).touch()
    homes = sorted((store.policy_dir / code).iterdir())
    for f in homes:
        f.rename(trash / f.name)
    return homes, trash


def test_a_removal_killed_before_its_commit_gets_its_files_back_at_the_next_opening(store, tmp_path):
    """Windows has no flock, and the next opening put nothing right there: a removal killed between
    its moves and its commit (a laptop's battery, a closed console) left the participant in the study
    and their policy files in .removed-P01-..., and their next day could not start from their policy.
    Windows' own locks (msvcrt.locking) say now whether a removal still runs."""
    homes, trash = _left_aside(store, "P01")
    store.close()
    with StudyStore(tmp_path / "study.sqlite") as s:
        assert all(home.is_file() for home in homes) and not trash.exists()
        assert s.load_policy("P01") == policy_bytes("initial P01")


def test_a_removal_killed_after_its_commit_has_its_files_deleted_at_the_next_opening(store, tmp_path):
    """Killed after the commit, the withdrawn participant's files stayed for good on Windows, in a
    folder no page shows; they are deleted at the next opening, as the removal promised."""
    store.remove_participant("P01", "P01")
    (store.policy_dir / "P01").mkdir()
    (store.policy_dir / "P01" / "day0-cacas-left.pt").write_bytes(policy_bytes("initial P01"))
    homes, trash = _left_aside(store, "P01")
    store.close()
    StudyStore(tmp_path / "study.sqlite").close()
    assert not trash.exists() and not any(home.exists() for home in homes)


def test_a_removal_still_running_is_left_alone(store, tmp_path):
    from cacas.store import recovery

    homes, trash = _left_aside(store, "P01")
    with recovery.busy(trash / recovery.REMOVAL_LOCK):  # held, as the removal running in another process holds it
        StudyStore(tmp_path / "study.sqlite").close()
        assert (trash / homes[0].name).is_file() and not homes[0].exists()
    StudyStore(tmp_path / "study.sqlite").close()
    assert homes[0].is_file() and not trash.exists()


def test_the_hidden_database_of_an_import_killed_mid_way_is_deleted(windows_files, tmp_path):
    """Killed, an import left `.study.sqlite.importing-<pid>` (a full copy of the study's data), and
    on Windows no opening deleted it."""
    from cacas.store import recovery

    killed = tmp_path / ".study.sqlite.importing-4242"
    for f in (killed, recovery.import_lock(killed)):
        f.write_bytes(b"half an import")
    StudyStore(tmp_path / "study.sqlite").close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.sqlite"]
