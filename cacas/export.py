"""Tidy CSV tables of a study database, one zip bundle of them, and the import of a bundle.

The tables (long format; issue 4, item 4):

* ``interactions.csv``: :data:`cacas.records.INTERACTION_COLUMNS` first (the same as
  ``cacas simulate`` writes), then :data:`cacas.store.INTERACTION_EXTRA_COLUMNS`;
* ``daily.csv``: :func:`cacas.records.daily_table`, the columns of ``cacas simulate``'s
  ``daily.csv`` (Fig. 3 success rate and cumulative feedback; Fig. 4 preference accuracy, see
  :func:`accuracy_frame`), so one set of plots serves human and simulated studies, and a last
  column, ``preferences_version`` (:func:`with_preferences_version`);
* ``by_preference.csv``: :func:`by_preference_frame`, Fig. 4 by described preference (the
  columns ``cacas simulate`` writes);
* ``participants.csv``, ``questionnaire.csv``, ``adaptations.csv``;
* and, so that a study can move between machines, ``studies.csv``, ``preferences.csv``,
  ``days.csv``, ``policies.csv`` (+ the checkpoint files under ``policies/`` in the zip) and
  ``events.csv``.

The zip also holds ``manifest.json``: the bundle format and its version (:data:`BUNDLE_VERSION`),
which an import checks (a newer one is refused; a bundle without it, written before it, is read
as version 1).

:func:`export_study` writes them and ``cacas-study.zip``; :func:`import_bundle` loads such a zip
into a new database (export, import, export gives the same tables; the event log gains one
"import_bundle" event). CSV is written with :func:`cacas.records.csv_bytes` and the zip with
fixed timestamps, so the same database gives the same bytes; the CSVs and the zip replace an
earlier export's as one change (:func:`cacas.store.files.write_all`).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import sqlite3
import zipfile
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from cacas.errors import CacasError, DamagedFile, did_you_mean
from cacas import records
from cacas.records import BY_PREFERENCE_COLUMNS, INTERACTION_COLUMNS, csv_bytes, daily_table
from cacas.store import StudyStore, files, recovery
from cacas.store.db import WriteRefused, refused
from cacas.store.restore import RESTORE_COLUMNS, Restored, check_columns, restore
from cacas.study_day import STUDY_DAYS

#: Name of the zip of all tables inside the output folder.
BUNDLE_NAME = "cacas-study.zip"
#: The member of a bundle that says its format and the format's version (bundles written before
#: it have none, and are read as version 1).
MANIFEST_NAME = "manifest.json"
#: What a bundle's manifest says it is.
BUNDLE_FORMAT = "cacas-study-bundle"
#: The version of the bundle format this CACAS Studio writes, and the newest it imports. A change
#: an older import would get wrong (a new column, table or file it would leave out without a word)
#: takes the next number.
BUNDLE_VERSION = 1
#: The tables of a bundle, in the order they are written.
TABLES = ("interactions", "daily", "by_preference", "participants", "questionnaire", "adaptations", "preferences",
          "days", "policies", "studies", "events")
#: The most a bundle's member may hold uncompressed (its ZipInfo.file_size), checked before it is
#: read: a study's largest table is a few MB, and a policy file smaller still.
MAX_MEMBER_BYTES = 256 * 2**20
#: The most all the members an import reads may hold together, uncompressed, unless they come to at most
#: :data:`BUNDLE_EXPANSION` times the zip's own size (:func:`check_sizes`).
MAX_BUNDLE_BYTES = 1024 * 2**20
#: How many times its own size a zip's members may hold together, uncompressed, past :data:`MAX_BUNDLE_BYTES`:
#: a large study's zip is mostly policy files stored as they are (1.0; its tables deflate ~13 to 1, and an older
#: bundle's deflated policy files ~1.1), a zip bomb's hundreds of times. Without it the import refused the zip
#: cacas export wrote of a study of more than ~1,700 policy versions (82 participants x 21 days: 1,052 MiB).
BUNDLE_EXPANSION = 2
#: The most a member of more than :data:`RATIO_FROM_BYTES` may be compressed (uncompressed size /
#: compressed size): a study's tables come to 5-30, a policy file to about 1; a zip bomb to ~1000.
MAX_COMPRESSION_RATIO = 200
RATIO_FROM_BYTES = 2**20
_POLICY_PATH = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,15}/day\d+-[a-z0-9][a-z0-9_.-]*-[0-9a-f]{8}\.pt$")
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


@dataclass(frozen=True)
class ExportResult:
    """What :func:`export_study` wrote: one CSV per table and the zip of them all."""

    tables: dict[str, Path]
    bundle: Path | None  # None: tables only
    removed: tuple[Path, ...] = ()  # an earlier export's zip beside tables-only tables it does not hold
    remains: str = ""  # what an earlier export stopped part-way left in the folder (files.remains), replaced
    removed_why: str = ""  # why ``removed`` was: "it no longer matches these tables", or it cannot be read
    kept: Path | None = None  # an earlier export's zip a tables-only export kept: it holds these same tables


def runs_in_force(interactions: pd.DataFrame, adaptations: pd.DataFrame, days: pd.DataFrame) -> pd.DataFrame:
    """participant, method, day, run: for every day a participant has, the adaptation run (its
    position in ``adaptations``) whose policy each method had in force that day.

    A run recorded for day d (adapted from days 1..d; day 0: the initial policy) is in force on
    day d + 1 (the latest such run of its method). Where a day's interactions name the policy
    version in force and a run produced that version, that run is used instead (this follows a
    roll-back); a day with a roll-back in the middle is the version most of its interactions were
    recorded with (the later one on a tie). Days not started yet are not listed
    (:func:`next_day_accuracy` scores them).
    """
    cols = ["participant", "method", "day", "run"]
    if not len(adaptations):
        return pd.DataFrame(columns=cols)
    runs = adaptations.reset_index(drop=True)
    keyed = pd.DataFrame({"participant": runs["participant"], "method": runs["method"],
                          "day": runs["day"].astype(int) + 1, "run": runs.index})
    run = keyed.drop_duplicates(["participant", "method", "day"], keep="last").set_index(
        ["participant", "method", "day"])["run"]
    linked = runs.dropna(subset=["policy_version"])
    if len(interactions):
        keys = ["participant", "method", "day"]
        tally = (interactions[keys].assign(version=interactions["policy_version"].fillna(-1).astype("int64"),
                                           at=np.arange(len(interactions)))
                 .groupby(keys + ["version"]).agg(n=("at", "size"), last=("at", "max")).reset_index())
        most = tally.sort_values(["n", "last"], kind="stable").drop_duplicates(keys, keep="last")
        # the latest run of each policy version, and of each method's initial policy (day 0): looked up,
        # not searched for per participant-day (that scan was most of the Results page's time)
        by_version = {(who, int(v)): i for who, v, i in zip(linked["participant"], linked["policy_version"], linked.index)}
        first = runs[runs["day"].astype(int) == 0]
        initial = {(who, m): i for who, m, i in zip(first["participant"], first["method"], first.index)}
        used = {}
        for who, method, day, version in zip(most["participant"], most["method"], most["day"], most["version"]):
            hit = initial.get((who, method)) if version == -1 else by_version.get((who, int(version)))
            if hit is not None:
                used[(who, method, int(day))] = hit
        if used:
            run = pd.concat([run[~run.index.isin(list(used))],
                             pd.Series(used, name="run").rename_axis(["participant", "method", "day"])])
    run = run.reset_index()
    have = set(zip(days["participant"], days["day"].astype(int)))
    keep = [(p, int(d)) in have for p, d in zip(run["participant"], run["day"])]
    run = run[keep].astype({"day": "int64", "run": "int64"})
    return records.sort_by_method(run, ["participant", "method", "day"]).reset_index(drop=True)[cols]


def accuracy_frame(interactions: pd.DataFrame, adaptations: pd.DataFrame, days: pd.DataFrame,
                   found: pd.DataFrame | None = None) -> pd.DataFrame:
    """participant, method, day, preference_accuracy, preferences_version: Fig. 4's metric of the
    policy in force (the run of :func:`runs_in_force`, or ``found``, its answer if the caller has
    it): its ``metrics["preference_accuracy"]``, NaN if absent, and the described preferences'
    version it was scored against (:func:`cacas.study_day.scored_version`; empty for a run not
    scored, or recorded before runs named it). Only days the participant has are listed."""
    from cacas.study_day import scored_version

    cols = ["participant", "method", "day", "preference_accuracy", "preferences_version"]
    found = runs_in_force(interactions, adaptations, days) if found is None else found
    if not len(found):
        return pd.DataFrame(columns=cols)
    run = found["run"].to_numpy()
    value = adaptations["preference_accuracy"].astype(float).to_numpy()[run]
    version = pd.array([scored_version(m) for m in adaptations["metrics"].to_numpy()[run]], dtype="Int64")
    return found.assign(preference_accuracy=value, preferences_version=version)[cols]


def with_preferences_version(daily: pd.DataFrame, accuracy: pd.DataFrame) -> pd.DataFrame:
    """A human study's daily.csv with a last column, ``preferences_version``: the described
    preferences' version each row's ``preference_accuracy`` was scored against (from
    :func:`accuracy_frame`). Preferences edited mid-study leave earlier days scored on theirs, so
    a participant's days may be scored on two versions; empty where nothing was scored."""
    keys = ["participant", "method", "day"]
    version = accuracy[keys + ["preferences_version"]].astype({"day": "int64"}) if len(accuracy) else \
        pd.DataFrame(columns=keys + ["preferences_version"])
    out = daily.merge(version, on=keys, how="left")
    out["preferences_version"] = pd.array(pd.to_numeric(out["preferences_version"]), dtype="Int64")
    return out


def by_preference_frame(interactions: pd.DataFrame, adaptations: pd.DataFrame, days: pd.DataFrame,
                        found: pd.DataFrame | None = None) -> pd.DataFrame:
    """by_preference.csv of a human study (:data:`cacas.records.BY_PREFERENCE_COLUMNS`, as
    ``cacas simulate`` writes it): Fig. 4 by described preference for the policy in force each
    day (the run of :func:`runs_in_force`, or ``found``), from its
    ``metrics["by_preference"]``; runs recorded without it (or for participants without
    described preferences) give no rows."""
    found = runs_in_force(interactions, adaptations, days) if found is None else found
    metrics = adaptations["metrics"].to_numpy()
    rows = []
    for who, method, day, run in found.itertuples(index=False):
        m = metrics[run]
        for pref in (json.loads(m) if isinstance(m, str) else m or {}).get("by_preference", []):
            rows.append({"participant": who, "method": method, "day": int(day), **pref})
    df = pd.DataFrame(rows, columns=BY_PREFERENCE_COLUMNS)
    states = df["states"].astype(float)
    df["accuracy"] = (df["correct"].astype(float) / states).where(states > 0)
    return df.astype({"day": "int64", "preference": "int64", "states": "int64", "correct": "int64",
                      "accuracy": "float64"})


def next_day_accuracy(tables: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """participant, day, method, preference_accuracy, in_force: Fig. 4's metric of the policies
    adapted for a participant's next study day, which has not started (their latest day is closed
    and not the study's last, :data:`cacas.study_day.STUDY_DAYS`), from
    a human study's tables (:func:`export_tables`). Each method's latest run adapted after that
    day; for the policy the participant has in force (after a roll-back an earlier version, or
    the initial policy: the day-0 run), the run that produced it, marked ``in_force``.

    Fig. 4 and daily.csv list a day once it has begun (:func:`accuracy_frame`); this is what the
    robot will do on the day ahead, right after an adaptation (and a comparison of methods)."""
    cols = ["participant", "day", "method", "preference_accuracy", "in_force"]
    runs, days, policies = tables["adaptations"].reset_index(drop=True), tables["days"], tables["policies"]
    if not len(runs) or not len(days):
        return pd.DataFrame(columns=cols)
    latest = days.assign(day=days["day"].astype(int)).sort_values("day").drop_duplicates("participant", keep="last")
    rows = []
    for who, day, closed in zip(latest["participant"], latest["day"], latest["closed_at"]):
        if not (isinstance(closed, str) and closed) or day >= STUDY_DAYS:
            continue  # the day is open (nothing is ahead of it yet), or the study's last
        mine = runs[runs["participant"] == who]
        chosen = {m: group.index[-1] for m, group in mine[mine["day"].astype(int) == day].groupby("method", sort=False)}
        in_force = None
        saved = policies[policies["participant"] == who]
        if len(saved):  # the participant's policy in force: the active version, or the initial policy
            active = saved[saved["active"].eq(1)]  # NULL when the initial policy is in force
            if len(active):
                hit = mine[mine["policy_version"] == active["version"].iloc[-1]]
            else:
                method = saved["method"].iloc[-1]
                hit = mine[(mine["day"].astype(int) == 0) & (mine["method"] == method)]
            if len(hit):
                in_force = hit["method"].iloc[-1]
                chosen[in_force] = hit.index[-1]
        for method, run in chosen.items():
            rows.append({"participant": who, "day": day + 1, "method": method,
                         "preference_accuracy": float(runs.at[run, "preference_accuracy"]),
                         "in_force": method == in_force})
    return pd.DataFrame(rows, columns=cols).astype({"day": "int64", "preference_accuracy": "float64",
                                                     "in_force": "bool"})


def described_preferences(preferences: pd.DataFrame) -> dict:
    """Participant code -> the versions of their described preferences' preferred-action table,
    ``[(saved_at, table), ...]`` oldest first, from preferences.csv's frame (the store's
    ``preferences_frame``), for daily.csv's success ceiling (evaluation only): each interaction is
    scored against the version of its time, so preferences edited mid-study leave the closed days'
    ceilings as they were (they moved with every edit). Participants without any are left out."""
    from cacas.preferences import parse_participant

    out = {}
    for code, rows in preferences.sort_values(["participant", "version"]).groupby("participant", sort=False):
        tables = [(saved, parse_participant({"id": code, "preferences": items}).preferred_action_table())
                  for saved, items in zip(rows["created_at"], map(json.loads, rows["preferences"])) if items]
        if tables:
            out[str(code)] = tables
    return out


def export_tables(store: StudyStore, study: str | None = None) -> dict[str, pd.DataFrame]:
    """All tables of :data:`TABLES` as DataFrames (of one study, or all)."""
    participants = store.participants_frame(study)
    events = store.events(study=study)  # a study's: its creation, its participants' and their removals
    studies = pd.DataFrame([s.__dict__ for s in store.studies()], columns=["name", "description", "created_at"])
    if study is not None:
        studies = studies[studies["name"] == study]
    interactions = store.interactions_frame(method=None, study=study, extra=True)
    adaptations, days = store.adaptations_frame(study=study), store.days_frame(study)
    preferences = store.preferences_frame(study)
    found = runs_in_force(interactions, adaptations, days)  # once, for daily.csv and by_preference.csv
    accuracy = accuracy_frame(interactions, adaptations, days, found)
    return {
        "interactions": interactions,
        "daily": with_preferences_version(daily_table(interactions[INTERACTION_COLUMNS], accuracy,
                                                      described_preferences(preferences)), accuracy),
        "by_preference": by_preference_frame(interactions, adaptations, days, found),
        "participants": participants,
        "questionnaire": store.questionnaire_frame(study),
        "adaptations": adaptations,
        "preferences": preferences,
        "days": days,
        "policies": store.policies_frame(study),
        "studies": studies.reset_index(drop=True),
        "events": events.drop(columns=["id"]).reset_index(drop=True),
    }


#: The tables ``cacas simulate --out`` writes too (same names and columns).
SIMULATION_TABLES = ("daily.csv", "interactions.csv", "by_preference.csv")
#: What only a study export writes.
EXPORT_ONLY = tuple(f"{t}.csv" for t in TABLES if f"{t}.csv" not in SIMULATION_TABLES) + (BUNDLE_NAME,)
#: The figures ``cacas simulate --plot`` writes (fig3_methods.html only with --loop each and
#: several methods), beside the plotly.min.js they load.
SIMULATION_FIGURES = ("fig3_success.html", "fig4_methods.html", "fig4_by_preference.html", "fig3_methods.html")


def check_output_folder(folder: str | Path, writing: str, what: str) -> None:
    """Refuse (CacasError naming ``what``, the folder as the user gave it) to write a study export
    (``writing="export"``) or a simulation's tables (``"simulation"``) into a folder that holds the
    other's: the three tables they share would be replaced and the rest left beside them, one
    folder mixing two studies. An empty folder, a missing one, or one of the same kind is fine.
    A simulation's figures (``"figures"``: ``cacas simulate --plot`` into a folder other than its
    ``--out``) go into no folder holding tables, a study's export or another run's: they would sit
    beside results they do not show (and a later export into that folder would keep them). Nor does
    an export go into a folder holding such figures: its tables would sit beside figures of a
    simulated study, which read as theirs (nothing is lost: an export writes and removes only its
    own files, and a sub-folder of figures, ``DIR/figures/``, is left as it is and kept apart)."""
    folder = Path(folder)
    if not folder.is_dir():
        return
    present = {p.name for p in folder.iterdir() if p.is_file()}  # a folder named daily.csv is no table (CLI audit)
    if writing == "figures":
        found = [n for n in EXPORT_ONLY if n in present]
        tables = [n for n in SIMULATION_TABLES if n in present]
        if found or tables:
            held = (f"an export of a study database ({', '.join(found[:3])}{', ...' if len(found) > 3 else ''})"
                    if found else f"another simulation's tables ({', '.join(tables)})")
            raise CacasError(f"{what}: holds {held}; this run's figures would sit beside results they do not show; "
                             "valid: the --out folder, an empty folder, a new one, or one holding figures only")
        return
    if writing == "simulation":
        found = [n for n in EXPORT_ONLY if n in present]
        if found:
            raise CacasError(f"{what}: holds an export of a study database ({', '.join(found[:3])}"
                             f"{', ...' if len(found) > 3 else ''}); a simulation's {', '.join(SIMULATION_TABLES)} "
                             "would replace the study's and leave its other tables beside them; valid: an empty "
                             "folder, a new one, or an earlier simulation's")
    elif writing == "export":
        shared = [n for n in SIMULATION_TABLES if n in present]
        if shared and "participants.csv" not in present:
            raise CacasError(f"{what}: holds {', '.join(shared)} but no participants.csv: a simulation's tables "
                             "(cacas simulate --out), which this export would replace; valid: an empty folder, "
                             "a new one, or an earlier export's")
        figures = [n for n in SIMULATION_FIGURES if n in present]
        if figures:  # (--plot refuses an export's folder: no export of ours holds them)
            raise CacasError(f"{what}: holds a simulation's figures ({', '.join(figures)}; cacas simulate --plot): "
                             "this export's tables would sit beside figures that do not show them; valid: an empty "
                             "folder, a new one, or an earlier export's")
    else:
        raise ValueError(f"writing={writing!r}")


def manifest_bytes() -> bytes:
    """The bytes of a bundle's ``manifest.json``: the format and its version (the same every time,
    so the same database gives the same zip)."""
    return (json.dumps({"format": BUNDLE_FORMAT, "version": BUNDLE_VERSION}, indent=2, sort_keys=True)
            + "\n").encode()


def _check_manifest(path: Path, data: bytes) -> None:
    """Refuse (CacasError naming the bundle) a manifest this CACAS Studio cannot read, or one of a
    bundle format newer than :data:`BUNDLE_VERSION`: its import would lose what that version added."""
    valid = (f'valid: {{"format": "{BUNDLE_FORMAT}", "version": N}} with N from 1 to {BUNDLE_VERSION}, as '
             "cacas export writes it")
    try:
        manifest = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CacasError(f"{path}: {MANIFEST_NAME} in the bundle is not valid JSON ({exc}); {valid}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != BUNDLE_FORMAT:
        said = manifest.get("format") if isinstance(manifest, dict) else manifest
        raise CacasError(f"{path}: {MANIFEST_NAME} in the bundle does not name a study bundle (format {said!r}); "
                         f"{valid}")
    version = manifest.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise CacasError(f"{path}: {MANIFEST_NAME} in the bundle gives the version {version!r}; {valid}")
    if version > BUNDLE_VERSION:
        raise CacasError(f"{path}: was written by a newer CACAS Studio (bundle format version {version}); this one "
                         f"imports versions 1 to {BUNDLE_VERSION} and would lose what is new in it; update CACAS "
                         "Studio, then import it; nothing was imported")


def zip_entry(zf: zipfile.ZipFile, name: str, data: bytes, compress: bool = True) -> None:
    """Put ``data`` in ``zf`` as ``name`` with a fixed time stamp and mode: the same files give the
    same zip (an export's bundle, a simulated run's zip). Deflated, unless not ``compress``: a
    policy file is a zip of its own (torch.save's) of weights that deflate takes to 0.90 of their
    size, at 17 ms a 640-KB file: for 60 participants x 21 days, 21 of the bundle's 36 s for a
    tenth of its size (scripts/bench_export.py)."""
    info = zipfile.ZipInfo(name, date_time=_ZIP_TIME)
    info.compress_type = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    info.external_attr = 0o644 << 16
    zf.writestr(info, data)


#: Reads of the tables an export makes when its policy files change under it (a participant removed
#: between the tables' snapshot and the files' reads); the last failure is said as it is.
_EXPORT_ATTEMPTS = 3


def export_study(db: StudyStore | str | Path, out_dir: str | Path, study: str | None = None,
                 bundle: bool = True) -> ExportResult:
    """Write every table as ``<out_dir>/<table>.csv`` and all of them (with the policy
    checkpoints) as ``<out_dir>/cacas-study.zip``; with ``bundle=False`` the tables only (they
    need no checkpoint file, so a missing or damaged one does not stop them), and an earlier
    export's zip there is kept if it holds these same tables (:func:`earlier_zip_differs`: it
    holds every checkpoint they name, maybe one missing now), else removed.

    ``db`` is an open StudyStore or the path of a study database; a path is checked and opened
    read-only *before* anything is created, so a missing file or one that is not a study
    database raises CacasError and changes and creates nothing.
    """
    # the folder checked before the tables are read and the policy files zipped (CLI audit: refused after them,
    # 2.7 s for a study of 30); a new folder is put in place whole, and the folders above it made for the check are
    # taken away again if the database is refused
    made = files.missing_folders(out_dir)
    check_output_folder(out_dir, "export", str(out_dir))
    out = files.writable_folder(out_dir, str(out_dir), create=False,
                                names=[*(f"{t}.csv" for t in TABLES), BUNDLE_NAME, files.CHECKSUMS])
    try:
        contents = export_contents(db, study, bundle)
    except BaseException:
        files.remove_empty(made)
        raise
    remains = files.remains(out, [*contents, BUNDLE_NAME])
    stale = out / BUNDLE_NAME
    earlier, why = None, ""
    if not bundle and stale.is_file():  # an earlier export's zip: kept only if it holds these very tables
        try:
            earlier = stale.read_bytes()
        except OSError:
            earlier = None
        why = earlier_zip_differs(earlier, contents)
        if not why:  # a whole bundle of this study as it is (with the policy files these tables need): kept,
            contents = {**contents, BUNDLE_NAME: earlier}  # listed in checksums.sha256 (rewritten as it is)
    paths = files.write_all(out, contents, checksums=True)
    removed: tuple[Path, ...] = ()
    if why:  # beside these tables it would hold other data
        stale.unlink()
        removed = (stale,)
    return ExportResult({name: paths[f"{name}.csv"] for name in TABLES}, paths.get(BUNDLE_NAME) if bundle else None,
                        removed, remains, why, stale if earlier is not None and not why else None)


def earlier_zip_differs(data: bytes | None, contents: dict[str, bytes]) -> str:
    """Why an earlier export's zip (its bytes; None: it cannot be read) does not go with the
    tables of ``contents`` (:func:`export_contents`, name -> bytes), in words for "removed ... (it
    ...)"; "" when it does: a whole zip (every member's CRC checked) of this bundle format whose
    tables are, byte for byte, these (so its policy files are those these tables name)."""
    unreadable = "it cannot be read as an export's zip (damaged, or not one)"
    if data is None:
        return unreadable
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            if zf.testzip() is not None or zf.read(MANIFEST_NAME) != manifest_bytes():
                return unreadable
            same = all(zf.read(f"{name}.csv") == contents[f"{name}.csv"] for name in TABLES)
    except (zipfile.BadZipFile, zlib.error, KeyError, OSError, EOFError, NotImplementedError, ValueError):
        return unreadable
    return "" if same else "it no longer matches these tables"


def bundle_bytes(db: StudyStore | str | Path, study: str | None = None) -> bytes:
    """The bytes of the ``cacas-study.zip`` :func:`export_study` writes (the Results page's
    "Download everything"), made in memory: no copy of the study is written to disk (a temporary
    folder of the tables, left behind when the server is killed during the download, would hold
    a withdrawn participant's data; a full temporary disk failed the download)."""
    return export_contents(db, study)[BUNDLE_NAME]


def export_contents(db: StudyStore | str | Path, study: str | None = None, bundle: bool = True) -> dict[str, bytes]:
    """File name -> bytes of what :func:`export_study` writes: every table's CSV and, with
    ``bundle``, the zip of them all with the policy checkpoints (a missing or damaged checkpoint
    raises CacasError naming it). ``db``: as for :func:`export_study`."""
    # a path is opened here; anything else is an open store (also one of a class reloaded since,
    # as Streamlit does when the code changes under a running app)
    store = StudyStore(db, readonly=True) if isinstance(db, (str, os.PathLike)) else db
    try:
        known = [s.name for s in store.studies()]
        if study is not None and study not in known:
            raise CacasError(f"unknown study {study!r}; {did_you_mean(study, known)}"
                             f"known studies: {', '.join(known) or 'none'}")
        for attempt in range(_EXPORT_ATTEMPTS):
            with store.snapshot():  # one consistent view, even while the app keeps writing
                tables = export_tables(store, study)
            contents = {f"{name}.csv": csv_bytes(tables[name]) for name in TABLES}
            if not bundle:
                break
            try:
                contents[BUNDLE_NAME] = _bundle_zip(store, contents, tables["policies"])
                break
            except CacasError as exc:  # the zip must hold every checkpoint to be imported; the tables do not
                if attempt + 1 < _EXPORT_ATTEMPTS and not store.policies_frame(study).equals(tables["policies"]):
                    continue  # a participant removed (or a policy saved) after the tables were read: read again
                raise CacasError(f"{exc}; the zip needs every policy file (restore it from a backup), and "
                                 f"`cacas export --tables-only` writes the CSV tables without it") from None
    finally:
        if store is not db:
            store.close()
    return contents


def _bundle_zip(store: StudyStore, contents: dict[str, bytes], policies: pd.DataFrame) -> bytes:
    """The bundle's bytes: the manifest, the tables (``contents``, name -> CSV bytes) and every policy file
    ``policies`` (policies.csv's rows) names, each put in the zip as it is read (checked against its sha256:
    :meth:`StudyStore.load_policy`), stored as it is (:func:`zip_entry`). All the files were read first and then
    zipped: for 60 participants x 21 days, 790 MB of policy files beside the 700-MB zip (1.8 GB at its peak)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        zip_entry(zf, MANIFEST_NAME, manifest_bytes())
        for name, data in contents.items():
            zip_entry(zf, name, data)
        for rel, who, ver in sorted(zip(policies["path"], policies["participant"], policies["version"])):
            zip_entry(zf, f"policies/{rel}", store.load_policy(who, version=int(ver)), compress=False)
    return buf.getvalue()


def _size(n: int) -> str:
    return f"{n} bytes ({n / 2**20:.1f} MiB)" if n >= 2**20 else f"{n} bytes"


def check_sizes(path: Path, members: list[zipfile.ZipInfo], valid: str | None = None, what: str = "bundle",
                zip_size: int = 0) -> None:
    """Refuse (CacasError naming the bundle, the member and the limit, then ``valid``) before anything
    is read: a member larger than :data:`MAX_MEMBER_BYTES` uncompressed, or compressed more than
    :data:`MAX_COMPRESSION_RATIO` to 1 (a zip bomb), or members larger together than
    :data:`MAX_BUNDLE_BYTES` and than :data:`BUNDLE_EXPANSION` times ``zip_size``, the zip's own size
    in bytes (0: not known). The sizes are the zip's own word; zipfile never reads more than the
    size a member's header gives (it stops there, and a CRC that does not match is a damage).
    ``what`` names the zip in the messages: "bundle" (cacas import's), "zip" (a run's, uploaded)."""
    valid = valid or f"valid: the {BUNDLE_NAME} cacas export wrote; nothing was imported"
    limit = max(MAX_BUNDLE_BYTES, BUNDLE_EXPANSION * zip_size)
    total = 0
    for info in members:
        if info.file_size > MAX_MEMBER_BYTES:
            raise CacasError(f"{path}: {info.filename} in the {what} is {_size(info.file_size)} uncompressed, over "
                             f"the limit of {_size(MAX_MEMBER_BYTES)} for one file of a {what}; {valid}")
        ratio = info.file_size / max(info.compress_size, 1)
        if info.file_size > RATIO_FROM_BYTES and ratio > MAX_COMPRESSION_RATIO:
            raise CacasError(f"{path}: {info.filename} in the {what} is compressed {ratio:.0f} to 1 "
                             f"({_size(info.file_size)} from {_size(info.compress_size)}), over the limit of "
                             f"{MAX_COMPRESSION_RATIO} to 1 (a study's tables come to about 30 at most); {valid}")
        total += info.file_size
        if total > limit:
            contents = "the bundle's tables and policy files" if what == "bundle" else f"the {what}'s files"
            times = f" ({BUNDLE_EXPANSION} times the {what}'s own size)" if limit > MAX_BUNDLE_BYTES else ""
            raise CacasError(f"{path}: {contents} are {_size(total)} uncompressed "
                             f"by {info.filename}, over the limit of {_size(limit)}{times} for a whole {what}; "
                             f"{valid}")


def read_member(path: Path, zf: zipfile.ZipFile, name: str, valid: str | None = None, what: str = "bundle") -> bytes:
    """The bytes of the bundle's member ``name`` (its size checked by :func:`check_sizes` first); a
    damaged one (bytes changed in its compressed data: zlib.error; a bad CRC; cut short: EOFError)
    is a :class:`~cacas.errors.DamagedFile` naming the bundle (``what``: "bundle", or "zip" for a run's) and
    it, then ``valid``."""
    try:
        return zf.read(name)
    except (zipfile.BadZipFile, zlib.error, EOFError) as exc:
        raise DamagedFile(f"{path}: {name} in the {what} is damaged ({exc}); " + (valid or f"valid: "
                         f"the {BUNDLE_NAME} as cacas export wrote it (export again, or use another copy)")) from None


#: How a zip file begins: the header of its first member. A file that begins so but that zipfile
#: cannot open lacks the zip's end, the list of its files (:func:`unreadable_zip`).
_ZIP_START = b"PK\x03\x04"


def unreadable_zip(name, head: bytes, exc: Exception, valid: str) -> CacasError:
    """The message for a file zipfile cannot open (``exc``), given its first bytes ``head``: one that
    begins as a zip was cut short (a download or a copy that did not finish; it was called "not a zip
    file", which sends one to look for another file); any other is not a zip. Then ``valid``."""
    if head.startswith(_ZIP_START):
        return CacasError(f"{name}: is cut short: it begins as a zip, but the zip's end (the list of its files) is "
                          f"missing, as when a download or a copy did not finish; {valid}")
    return CacasError(f"{name}: not a readable zip file ({exc}); {valid}")


def _read_table(path: Path, zf: zipfile.ZipFile, member: str) -> pd.DataFrame:
    """A bundle's CSV table (every cell as text), or a CacasError naming the bundle and the member
    when it cannot be read as one (empty, not text, not CSV)."""
    data = read_member(path, zf, member)
    try:
        return pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False).map(records.unescape_formula)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        said = ("is empty" if not data.strip() else "is not text (UTF-8)" if isinstance(exc, UnicodeDecodeError)
                else "is not a CSV table")
        raise CacasError(f"{path}: {member} in the bundle {said} ({exc.__class__.__name__}: {exc}); valid: a CSV "
                         "table as cacas export wrote it (export again, or use another copy); nothing was "
                         "imported") from None


class BundlePolicies(Mapping):
    """The policy files of a bundle zip, policies.csv's path -> bytes, each read from the open zip
    when asked for (and its CRC checked then): an import checks and writes one at a time rather than
    holding all of them (60 participants x 21 days: 1,260 files, 0.8 GB). Close it (or use it in a
    ``with``) when done; its members were sized before any was read (:func:`check_sizes`)."""

    def __init__(self, path: Path, zf: zipfile.ZipFile, members: dict[str, str]):
        self._path, self._zf, self._members = path, zf, members

    def __getitem__(self, rel: str) -> bytes:
        return read_member(self._path, self._zf, self._members[rel])

    def __iter__(self):
        return iter(self._members)

    def __len__(self) -> int:
        return len(self._members)

    def close(self) -> None:
        self._zf.close()

    def __enter__(self) -> BundlePolicies:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_bundle(path: str | Path) -> tuple[dict[str, pd.DataFrame], BundlePolicies]:
    """The tables (every cell as text, "" for empty) and policy files (a :class:`BundlePolicies`,
    read when asked for from the zip kept open: close it) of a bundle zip, after its
    ``manifest.json`` (if it has one: older bundles do not) is checked: a bundle of a newer format
    version than :data:`BUNDLE_VERSION` is refused, as is a table with a column this CACAS Studio
    does not know (:func:`cacas.store.restore.check_columns`)."""
    path = Path(path)
    if path.is_dir():  # an export's folder, say: "no such bundle" read as if it were not there
        inside = path / BUNDLE_NAME
        hint = f", such as {inside} in this folder" if inside.is_file() else ""
        raise CacasError(f"{path}: is a folder; valid: the {BUNDLE_NAME} file written by cacas export{hint}")
    if not path.is_file():
        raise CacasError(f"{path}: no such bundle (expected the {BUNDLE_NAME} written by cacas export)")
    try:
        zf = zipfile.ZipFile(path)
    except zipfile.BadZipFile as exc:
        with open(path, "rb") as fh:
            head = fh.read(len(_ZIP_START))
        if not head.startswith(_ZIP_START):
            raise CacasError(f"{path}: is not a study bundle ({exc.__class__.__name__}: {exc})") from None
        raise unreadable_zip(path, head, exc, f"valid: the whole {BUNDLE_NAME} as cacas export wrote it (export "
                             "again, or use another copy); nothing was imported") from None
    try:
        tables, policies = _read_bundle(path, zf)
    except BaseException:
        zf.close()
        raise
    return tables, policies


def _read_bundle(path: Path, zf: zipfile.ZipFile) -> tuple[dict[str, pd.DataFrame], BundlePolicies]:
    """:func:`read_bundle`'s reading of the open zip ``zf``: its tables read, its policy files listed."""
    names = set(zf.namelist())
    # every member read below, sized before any is read (others are never read)
    check_sizes(path, [i for i in zf.infolist() if i.filename == MANIFEST_NAME
                       or i.filename in {f"{t}.csv" for t in RESTORE_COLUMNS}
                       or (i.filename.startswith("policies/") and not i.filename.endswith("/"))],
                zip_size=path.stat().st_size)
    if MANIFEST_NAME in names:  # none in bundles written before it: version 1
        _check_manifest(path, read_member(path, zf, MANIFEST_NAME))
    tables = {}
    for name in RESTORE_COLUMNS:
        if f"{name}.csv" not in names:
            raise CacasError(f"{path}: {name}.csv is missing; expected a bundle written by cacas export")
        tables[name] = _read_table(path, zf, f"{name}.csv")
    members = {}
    for name in sorted(names):
        if name.startswith("policies/") and not name.endswith("/"):
            rel = name[len("policies/"):]
            if not _POLICY_PATH.match(rel):
                raise CacasError(f"{path}: unexpected file {name!r} in the bundle")
            members[rel] = name
    try:
        check_columns(tables)
    except CacasError as exc:
        raise CacasError(f"{path}: {exc}") from None
    listed = list(tables["policies"].get("path", []))
    for rel in listed:
        if not _POLICY_PATH.match(rel):
            raise CacasError(f"{path}: policies.csv names an unexpected policy path {rel!r}")
    unlisted = sorted(set(members) - set(listed))
    if unlisted:
        raise CacasError(f"{path}: policies/{unlisted[0]} is in the bundle but not in policies.csv; "
                         "valid: only the checkpoints policies.csv lists")
    return tables, BundlePolicies(path, zf, members)


#: How on from a zip an export stopped part-way left (:func:`_check_whole_export`).
_EXPORT_AGAIN = ("run cacas export again and import the new zip (to import this one all the same, copy it out of "
                 "this folder first); nothing was imported")


def _check_whole_export(bundle: Path) -> None:
    """Refuse (CacasError) a zip that :data:`cacas.store.files.CHECKSUMS` beside it lists with
    other bytes: the export that wrote its folder was stopped part-way (killed, a power cut) before
    it replaced the zip, so the zip is an earlier export's (or it was changed since). Imported, it
    would silently bring back the study as it was then (safety audit L1). So is the export's zip
    when that file does not list it: a ``--tables-only`` export killed before it removed an
    earlier export's zip that no longer goes with its tables."""
    try:
        listed = files.parse_checksums((bundle.parent / files.CHECKSUMS).read_bytes())
    except OSError:
        listed = None
    if listed is not None and bundle.name == BUNDLE_NAME and bundle.name not in listed:
        # `cacas export --tables-only` lists no zip: one there is an earlier export's it was killed before removing
        raise CacasError(f"{bundle}: {files.CHECKSUMS} beside it does not list it: the export that wrote this folder "
                         "wrote its tables only (--tables-only) and was stopped (killed, or a power cut) before it "
                         f"removed this zip, which is an earlier export's; {_EXPORT_AGAIN}")
    bad = files.mismatched(bundle.parent, {bundle.name})
    if bad:
        raise CacasError(f"{bundle}: does not match its sha256 in {files.CHECKSUMS} beside it: the export that wrote "
                         "this folder was stopped part-way (killed, or a power cut) before it replaced this zip, "
                         f"which is an earlier export's (or it was changed since); {_EXPORT_AGAIN}")


def import_bundle(bundle: str | Path, db_path: str | Path) -> Restored:
    """Load a bundle written by :func:`export_study` into a NEW database at ``db_path``; returns a
    :class:`~cacas.store.restore.Restored`: the number of interactions imported, and notes on what
    was kept as the study held it although the forms refuse it in new data
    (:func:`cacas.store.restore.restore`).

    Refuses (CacasError, nothing changed) if ``db_path`` exists. The database is built under a
    temporary name beside it and linked into place only when complete, so a bad bundle leaves
    nothing behind; policy checkpoints go to the ``policies/`` folder beside it.
    """
    db_path = Path(db_path)
    if db_path.exists() or Path(f"{db_path}-wal").exists():
        raise CacasError(f"{db_path}: already exists; import only into a new database file")
    tables, policies = read_bundle(bundle)
    with policies:
        _check_whole_export(Path(bundle))
        made = files.missing_folders(db_path.parent)  # removed again, with those under it, if the import fails
        db_path.parent.mkdir(parents=True, exist_ok=True)
        tmp = db_path.with_name(f".{db_path.name}.importing-{os.getpid()}")
        lock = recovery.import_lock(tmp)
        try:
            try:
                with recovery.busy(lock):  # a killed import's files are deleted at next opening
                    return _import_into(tmp, db_path, tables, policies, made, Path(bundle))
            finally:  # once released: Windows deletes no file that is open (the import failed there after its link)
                lock.unlink(missing_ok=True)
        except BaseException:
            files.remove_empty(made)
            raise


def _check_case_twins(store: StudyStore, tables: dict, bundle: Path, db_path: Path) -> None:
    """Refuse (CacasError) a bundle whose participant codes differ only in letter case from each
    other (possible only in an imported study: the forms refuse them) or from a participant of a
    study database beside ``db_path``, when the file system there does not tell letter case apart
    (macOS's and Windows' default): the two would share one folder of policy files,
    ``policies/P01/``, and removing one would delete the other's (safety audit L4)."""
    codes = [str(c) for c in tables["participants"]["participant"]] if "participants" in tables else []
    seen: dict[str, str] = {}
    twins = None
    for code in codes:
        first = seen.setdefault(code.casefold(), code)
        if first != code:
            twins = f"participants.csv holds participants {first} and {code}, whose codes differ only in letter case"
            break
    beside = ""
    hit = store._case_twin_beside(codes) if twins is None else None
    if hit is not None:
        code, twin, name = hit
        twins = f"participant {code} differs only in letter case from participant {twin} of the study database {name} " \
                f"beside {db_path.name}"
        beside = "another folder for the new database, or "
    if twins is None or not files.ignores_letter_case(store.policy_dir):
        return
    raise CacasError(f"{bundle}: {twins}; the file system of {db_path.parent} does not tell letter case apart (as "
                     "macOS's and Windows' do by default), so they would share one folder of policy files, and "
                     f"removing one would delete the other's; valid: {beside}a disk that tells letter case apart "
                     "(on macOS, a case-sensitive APFS volume); nothing was imported")


def _link_new(tmp: Path, db_path: Path) -> None:
    """``tmp`` under the new name ``db_path`` too, which must not exist (FileExistsError): a hard
    link, which never replaces a file. A file system without hard links (FAT32, exFAT: a USB stick, a
    disk a Mac and a Windows PC share) refuses ``os.link``, and an import there failed; ``tmp`` is
    renamed instead, after a look for ``db_path`` (Windows' rename never replaces a file; elsewhere a
    file made in between the look and the rename would be, a moment no import of ours leaves)."""
    try:
        os.link(tmp, db_path)
    except FileExistsError:
        raise
    except OSError:
        if os.path.lexists(db_path):
            raise FileExistsError(db_path) from None
        os.rename(tmp, db_path)


def _import_into(tmp: Path, db_path: Path, tables: dict, policies: dict, made: list[Path], bundle: Path) -> Restored:
    """:func:`import_bundle`'s work: the database built as ``tmp``, then linked as ``db_path``;
    the folders it creates for policy files are added to ``made``. A table :func:`restore`
    refuses is named with the ``bundle`` it is in, as :func:`read_bundle` names its refusals."""
    created: list[Path] = []
    try:
        try:
            store = StudyStore(tmp)
        except WriteRefused as exc:  # a full disk, a folder that cannot be written: the new database's doing
            raise CacasError(f"{db_path}: {exc}") from None
        policy_dir = store.policy_dir
        try:
            _check_case_twins(store, tables, bundle, db_path)
            try:
                restored = restore(store, tables, policies)
                store._conn.execute("PRAGMA journal_mode = DELETE")  # everything into the main file
            except WriteRefused as exc:  # not the bundle's fault (it was named as if it were)
                raise CacasError(f"{db_path}: {exc}") from None
            except sqlite3.OperationalError as exc:  # a read, or the fold of the log into the file, the disk refused
                raise CacasError(f"{db_path}: {refused(exc)}") from None
            except DamagedFile:  # a policy file of the bundle, read as its row was restored: named already
                raise
            except CacasError as exc:
                raise CacasError(f"{bundle}: {exc}") from None
        finally:
            store.close()
        if policies:
            made.extend(files.missing_folders(policy_dir))
        # killed before the link, the files no database names are deleted at the next opening (markers)
        with recovery.saving(policy_dir) if policies else contextlib.nullcontext(lambda path: None) as mark:
            try:
                listed = dict(zip(tables["policies"]["path"], tables["policies"]["sha256"])) if policies else {}
                for rel in sorted(policies):
                    data = policies[rel]  # one at a time from the zip, checked by restore when it was read before
                    if files.sha256(data) != listed.get(rel):  # the zip changed on disk since (read again here)
                        raise CacasError(f"{bundle}: policy file {rel!r} changed while it was imported; import again")
                    target = policy_dir / rel
                    if target.exists():
                        if files.sha256(target.read_bytes()) != files.sha256(data):
                            raise CacasError(f"{target}: exists with other content; move it away and import again")
                        continue
                    made.extend(files.missing_folders(target.parent))
                    mark(target)
                    files.atomic_write(target, data)
                    created.append(target)
                try:
                    _link_new(tmp, db_path)
                except FileExistsError:
                    raise CacasError(f"{db_path}: already exists; import only into a new database file") from None
                files.fsync_folder(db_path.parent)  # the new name on disk before "imported" is said
                created.clear()
                return restored
            except BaseException:
                for p in created:
                    p.unlink(missing_ok=True)
                raise
    finally:
        for p in (tmp, Path(f"{tmp}-wal"), Path(f"{tmp}-shm"), Path(f"{tmp}-journal"), Path(f"{tmp}-writer.lock")):
            p.unlink(missing_ok=True)  # (the lock file, held meanwhile, by import_bundle once released)


__all__ = ["BUNDLE_NAME", "BUNDLE_VERSION", "MANIFEST_NAME", "TABLES", "ExportResult", "Restored", "accuracy_frame", "bundle_bytes", "by_preference_frame",
           "next_day_accuracy", "runs_in_force", "export_contents", "export_tables", "export_study", "read_bundle",
           "import_bundle"]
