"""Simulated runs the Simulation lab keeps beside the study database (the files ``cacas simulate
--out`` writes: daily.csv, interactions.csv, by_preference.csv; design.md's contract).

A run is a folder ``runs/<time>-seed<s>-<n>p-<d>d/`` beside the database with those tables and
its settings.json (:func:`save_run`, all or nothing); :func:`load_run` reads one back checked,
:func:`run_label` and :func:`run_caption` say it in words, :func:`run_simulation` makes one for a
background job (the Results page's uploads: :mod:`cacas.uploaded_run`). No streamlit: the pages
call these.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from cacas import plots, records
from cacas.app_support import percent
from cacas.errors import CacasError
from cacas.uploaded_run import STOPPED_PART_WAY, check_daily_values


def runs_dir(db_path) -> Path:
    """Where the Simulation lab keeps its runs: ``runs/`` beside the study database."""
    return Path(db_path).parent / "runs"


def save_run(root, name: str, daily: pd.DataFrame, interactions: pd.DataFrame, settings: dict,
             by_preference: pd.DataFrame | None = None) -> Path:
    """Write a simulated run as ``cacas simulate`` does (daily.csv, interactions.csv and, when
    given, by_preference.csv, with their checksums.sha256) plus settings.json, into ``root/name``,
    all or nothing (:func:`cacas.store.files.write_all`): a failure part-way leaves an earlier run
    of that name as it was, and a kill between two renames leaves files that do not match the
    checksums (:func:`load_run` refuses them). daily.csv, by which :func:`list_runs` knows a run,
    is put in place last. An earlier run's by_preference.csv that this run has none of is taken
    away in the same change."""
    from cacas.store import files

    folder = files.writable_folder(Path(root) / name, f"run folder {Path(root) / name}")
    contents = {"interactions.csv": records.csv_bytes(interactions)}
    if by_preference is not None:
        contents["by_preference.csv"] = records.csv_bytes(by_preference)
    contents["settings.json"] = json.dumps(settings, indent=2, default=str).encode("utf-8")
    contents["daily.csv"] = records.csv_bytes(daily)
    files.write_all(folder, contents, checksums=True, remove=() if by_preference is not None else ("by_preference.csv",))
    return folder


#: A run folder's files, as :func:`save_run` and ``cacas simulate --out`` write them (those it has).
RUN_FILES = ("daily.csv", "interactions.csv", "by_preference.csv", "settings.json", "checksums.sha256")


def run_zip(folder) -> bytes:
    """A run folder's files (:data:`RUN_FILES`, those it has) in one zip, under the folder's name:
    the Simulation lab's download of a whole run, to keep or to upload on Results (its
    checksums.sha256 with it). Checked first (:func:`load_run`): a run killed part-way is refused
    by name, as when it is opened."""
    import zipfile

    from cacas.export import zip_entry

    folder = Path(folder)
    load_run(folder)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name in RUN_FILES:
            if (folder / name).is_file():
                zip_entry(zf, f"{folder.name}/{name}", (folder / name).read_bytes())
    return buf.getvalue()


def list_runs(root) -> list[str]:
    """Names of the saved runs, newest first."""
    root = Path(root)
    if not root.is_dir():
        return []
    runs = [p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".") and (p / "daily.csv").exists()]
    return [p.name for p in sorted(runs, key=lambda p: p.stat().st_mtime, reverse=True)]


def load_daily(path) -> pd.DataFrame:
    """A daily.csv (of a run, or uploaded): checked for design.md's columns."""
    df = records.read_csv(path)
    name = getattr(path, "name", path)
    missing = [c for c in records.DAILY_CONTRACT_COLUMNS if c not in df.columns]
    if missing:
        raise CacasError(f"{name}: not a daily.csv; missing columns: {', '.join(missing)}")
    return records.whole_counts(check_daily_values(df, str(name)))


def load_by_preference(folder) -> pd.DataFrame | None:
    """A run's by_preference.csv (Fig. 4 by described preference), or None for a run saved
    before the Simulation lab wrote it."""
    path = Path(folder) / "by_preference.csv"
    return records.read_csv(path) if path.exists() else None


@dataclass(frozen=True)
class Run:
    """A saved simulated run: its tables and the settings it was run with ({} if none saved)."""

    name: str
    daily: pd.DataFrame
    interactions: pd.DataFrame
    by_preference: pd.DataFrame | None
    settings: dict

    @property
    def tables(self) -> dict[str, pd.DataFrame]:
        """daily, interactions and (when saved) by_preference, as the Results page lists them."""
        out = {"daily": self.daily, "interactions": self.interactions}
        if self.by_preference is not None:
            out["by_preference"] = self.by_preference
        return out


def load_run(folder) -> Run:
    """A run folder of :func:`save_run` (or ``cacas simulate --out``): daily.csv (checked,
    :func:`load_daily`), interactions.csv, by_preference.csv when there is one and settings.json
    when there is one. A missing folder or table, unreadable settings, or a file that does not
    match the folder's checksums.sha256 (a run killed between its renames left files of two runs
    side by side, or a file was changed since) is a CacasError naming it."""
    from cacas.store import files

    folder = Path(folder)
    if not folder.is_dir():
        raise CacasError(f"{folder}: no such run folder")
    for table in ("daily.csv", "interactions.csv"):
        if not (folder / table).is_file():
            raise CacasError(f"{folder}: no {table}; not a complete run (valid: a folder the Simulation lab "
                             "or `cacas simulate --out` wrote)")
    bad = files.mismatched(folder, set(RUN_FILES) - {files.CHECKSUMS})
    if bad:
        raise CacasError(f"{folder}: {', '.join(bad)} {'does' if len(bad) == 1 else 'do'} not match "
                         f"{files.CHECKSUMS}: {STOPPED_PART_WAY}; run it again")
    return Run(name=folder.name, daily=load_daily(folder / "daily.csv"),
               interactions=records.read_csv(folder / "interactions.csv"),
               by_preference=load_by_preference(folder), settings=run_settings(folder))


def run_settings(folder) -> dict:
    """A run's settings.json ({} when it has none, as ``cacas simulate --out`` writes none); one
    that is not a readable JSON object is a CacasError naming it."""
    path = Path(folder) / "settings.json"
    if not path.exists():
        return {}
    try:
        settings = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise CacasError(f"{path}: not readable JSON ({exc})") from None
    if not isinstance(settings, dict):
        raise CacasError(f"{path}: not a JSON object of settings")
    return settings


def run_days(days) -> str:
    """A run's length as its caption says it: "1 day", "7 days" ("? days" when not known)."""
    return "? days" if days is None else f"{days} day{'s' if days != 1 else ''}"


def _settings_words(settings: dict, short: bool) -> list[str]:
    """A run's settings in words, each it kept (a settings.json written by hand, or by an older
    version, lacks some): in full for the line under the run, ``short`` for the run picker."""
    n = len(settings.get("participants", []))
    methods = settings.get("methods") or []
    words = [f"{n} participant{'s' if n != 1 else ''}" + (_personas_short(settings.get("personas")) if short else ""),
             run_days(settings["days"]) if settings.get("days") is not None else "",
             (f"{settings['interactions']} a day" if short else f"{settings['interactions']} interactions a day")
             if settings.get("interactions") is not None else "",
             (plots.method_names(methods) if short else f"methods {plots.method_names(methods)}") if methods else "",
             f"seed {settings['seed']}" if settings.get("seed") is not None else "",
             f"asks after {percent(settings['ask_after_reject'])} of rejections"
             if settings.get("ask_after_reject") else "",
             ("each in its own loop" if short else "each method in its own closed loop")
             if settings.get("loop") == "each" else "",
             f"personas: {settings['personas']}" if settings.get("personas") and not short else ""]
    return [w for w in words if w]


def run_caption(settings: dict) -> str:
    """The Simulation lab's line under a run: every setting the run kept, e.g. "8 participants ·
    7 days · 15 interactions a day · methods CACAS, NN · seed 0 · personas: ..." (the methods named as the
    figures name them); a setting the run did not keep is left out."""
    return " · ".join(_settings_words(settings, short=False))


def run_label(root, name: str) -> str:
    """How the run pickers name a run: when it ran and what it compared, from its settings (two
    runs of one day differ in more than their time stamp; the folder's time is UTC, :func:`_stamp`, and
    said so: a lab in Berlin read its run of 09:15 as "08:15:02"), e.g. "26 Nov 2026 08:15:02 UTC · 8
    participants (example.json) · 7 days · 15 a day · CACAS, NN · seed 0". A run without readable
    settings (one copied in from ``cacas simulate --out``) is its folder name."""
    from datetime import datetime

    try:
        settings = run_settings(Path(root) / name)
    except CacasError:
        settings = {}
    if not settings:
        return name
    try:
        when = datetime.strptime(name[:15], "%Y%m%d-%H%M%S").strftime("%d %b %Y %H:%M:%S UTC")  # as the app's times
    except ValueError:
        when = name
    return " · ".join([when, *_settings_words(settings, short=True)])


def _personas_short(source) -> str:
    """Where a run's personas came from, briefly, for its label: " (example.json)", " (study
    pilot)", or "" when the run did not keep it (:func:`persona_source` has the long form)."""
    import re

    if not source:
        return ""
    source = str(source)
    found = (re.fullmatch(r"study_data/personas/(.+)", source) or re.fullmatch(r"uploaded file (.+) \(sha256 \w+\)", source)
             or re.fullmatch(r"the described preferences of the participants of study '(.+)'", source))
    if found and source.startswith("the described"):
        return f" (study {found.group(1)})"
    return f" ({found.group(1) if found else source})"


def uploaded_personas(name: str, data: bytes) -> list:
    """The participants of a persona file uploaded to the Simulation lab, checked as an import
    into the study database is: the persona format (design.md), no contact details in the
    participants' words, and pseudonymous codes (a run's tables carry them)."""
    from cacas.preferences import check_private_words, parse_personas, persona_json
    from cacas.store import validate

    people = parse_personas(persona_json(data, name), name)
    validate.persona_codes(people, name)
    for person in people:
        check_private_words(person, name)
    return people


def persona_source(choice: str, file_name: str | None = None, data: bytes | None = None,
                   study: str | None = None) -> str:
    """Where a simulated run's personas came from, for its settings.json: a shipped file, an
    upload (its name and the first 12 hex digits of its SHA-256, to tell two uploads apart) or a
    study's participants (their saved preferences at the time of the run)."""
    import hashlib

    if data is not None:
        return f"uploaded file {file_name} (sha256 {hashlib.sha256(data).hexdigest()[:12]})"
    if study is not None:
        return f"the described preferences of the participants of study {study!r}"
    return f"study_data/personas/{file_name}" if file_name else choice


#: The Simulation lab's labels of a study's sizes, for the messages of its checks.
SIMULATION_FIELDS = {"days": "Days", "interactions": "Interactions a day", "seed": "Seed",
                     "no_response_rate": "No-response rate", "ask_after_reject": "Ask after a rejection"}


def check_simulation(participants, methods, days: int = 7, interactions: int = 15, seed: int = 0,
                     no_response_rate: float = 0.1, ask_after_reject: float = 0.0) -> tuple[str, ...]:
    """The Simulation lab's choice, checked before a run starts: at least one participant, known
    methods (:func:`cacas.experiment.check_methods`) and the study's sizes
    (:func:`cacas.experiment.study_argument_problems`, named by the lab's labels); returns the
    methods. One CacasError names every problem, one a line (the form is filled in at once, so
    it is corrected at once, not one refusal at a time)."""
    from cacas.experiment import check_methods, study_argument_problems

    problems = [] if participants else ["choose at least one simulated participant"]
    try:
        methods = check_methods(methods)
    except CacasError as exc:
        problems.append(str(exc))
    problems += study_argument_problems(days, interactions, no_response_rate, ask_after_reject, seed,
                                        names=SIMULATION_FIELDS)
    if problems:
        raise CacasError("\n".join(problems))
    return methods


def run_simulation(participants, out_root, days: int = 7, interactions: int = 15, methods=("cacas",),
                   seed: int = 0, no_response_rate: float = 0.1, progress=None,
                   ask_after_reject: float = 0.0, loop: str = "first", jobs: int | None = None,
                   personas: str | None = None, places=None) -> Path:
    """A simulated study (:func:`cacas.experiment.simulate_study`) saved as a run under
    ``out_root`` (see :func:`save_run`); returns the run's folder. For a background job.
    ``personas`` says where the participants came from (:func:`persona_source`), kept in the
    run's settings; ``places``, the participants' places in it (their random streams:
    :func:`cacas.experiment.simulate_study`), so that a run of some of a file's participants
    gives each the rows ``cacas simulate`` gives them from the whole file.
    Participants run side by side in ``jobs`` worker processes (default: one per core, as
    ``cacas simulate``); the tables are the same whatever ``jobs``."""
    from cacas.experiment import default_jobs, simulate_study

    methods = check_simulation(participants, methods, days, interactions, seed, no_response_rate, ask_after_reject)
    result = simulate_study(list(participants), days=days, interactions=interactions, methods=tuple(methods),
                            seed=seed, no_response_rate=no_response_rate, progress=progress,
                            ask_after_reject=ask_after_reject, loop=loop,
                            jobs=default_jobs() if jobs is None else jobs, places=places)
    name = new_run_name(out_root, f"{_stamp()}-seed{seed}-{len(participants)}p-{days}d")
    settings = {"participants": [p.id for p in participants], "days": days, "interactions": interactions,
                "methods": list(methods), "seed": seed, "no_response_rate": no_response_rate,
                "ask_after_reject": ask_after_reject, "loop": loop, "personas": personas}
    try:
        return save_run(out_root, name, result.daily, result.interactions, settings, result.by_preference)
    except BaseException:  # the folder claimed for it is left empty: not a run
        from cacas.store import files

        files.remove_empty([Path(out_root) / name])
        raise


def _stamp() -> str:
    """A run's time in its folder name (UTC, to the second)."""
    from datetime import datetime, timezone

    return datetime.now(timezone.utc).strftime("%Y%m%d-%H%M%S")


def new_run_name(root, base: str) -> str:
    """``base``, or ``base-2``, ``base-3``, ... the first name no run under ``root`` has, claimed by
    making its (empty) folder: two runs of the same seed and size that finished in the same second
    (two tabs, two researchers, two servers on one study) got one name, and the second run's
    tables replaced the first's."""
    from cacas.store import files

    root = files.writable_folder(root, f"runs folder {root}")
    for k in range(1, 10_000):
        name = base if k == 1 else f"{base}-{k}"
        try:
            (root / name).mkdir()
        except FileExistsError:
            continue
        except OSError as exc:
            raise CacasError(f"{root / name}: cannot be made ({exc.strerror or exc}); the run was not saved") from None
        return name
    raise CacasError(f"{root}: holds runs {base} to {base}-9999; remove some")
