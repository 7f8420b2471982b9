"""Simulated runs the Simulation lab keeps beside the study database, and the result tables a
researcher uploads to the Results page (the files ``cacas simulate --out`` writes: daily.csv,
interactions.csv, by_preference.csv; design.md's contract).

A run is a folder ``runs/<time>-seed<s>-<n>p-<d>d/`` beside the database with those tables and
its settings.json (:func:`save_run`, all or nothing); :func:`load_run` reads one back checked,
:func:`run_label` and :func:`run_caption` say it in words, :func:`run_simulation` makes one for a
background job. Uploaded tables are recognised by their columns and checked to belong to one run
(:func:`load_uploaded_tables`). No streamlit: the pages call these.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from cacas import plots, records
from cacas.app_support import percent
from cacas.errors import CacasError


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


#: Why a table does not match the checksums.sha256 written with it (an upload's, a run folder's).
STOPPED_PART_WAY = ("the run that wrote that folder was stopped part-way (killed, or a power cut) and left files of "
                    "two runs side by side, or the file was changed since")

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


def _shown(value) -> str:
    """A cell as a message shows it: text quoted, numbers plain."""
    return repr(value) if isinstance(value, str) else str(value)


def check_daily_values(df: pd.DataFrame, name: str) -> pd.DataFrame:
    """A daily.csv's days are whole numbers >= 1 and its rates are shares from 0 to 1 (or empty);
    else CacasError naming the file, the column and the first bad row (1-based, after the header)."""
    day = pd.to_numeric(df["day"], errors="coerce")
    bad = ~(day.notna() & (day >= 1) & (day == day.round()))
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise CacasError(f"{name}, row {row + 2}: day {_shown(df['day'].iloc[row])} is invalid; valid: a whole number >= 1")
    for col in [c for c in ("success_rate", "preference_accuracy", "success_ceiling") if c in df.columns]:
        value = pd.to_numeric(df[col], errors="coerce")
        bad = (value.isna() & df[col].notna()) | (value.notna() & ~value.between(0, 1))
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise CacasError(f"{name}, row {row + 2}: {col} {_shown(df[col].iloc[row])} is invalid; valid: a share "
                             "from 0 to 1, or empty")
    return df.assign(day=day.astype(int))


#: The tables a researcher can upload to the Results page, each recognised by its columns.
UPLOADABLE_TABLES = {
    "daily": list(records.DAILY_CONTRACT_COLUMNS),
    "by_preference": list(records.BY_PREFERENCE_COLUMNS),
    "interactions": list(records.INTERACTION_COLUMNS),
}
#: The Simulation lab's summary.csv (:func:`cacas.experiment.summary_table`: the means of daily.csv per method
#: and day; success_ceiling where the run has one), recognised by these columns and no participant column: it
#: uploads beside its daily.csv, checked against it (:func:`_check_summary`), and is not needed without one.
SUMMARY_COLUMNS = ["method", "day", "success_rate", "preference_accuracy", "cumulative_feedback"]
#: What an uploaded zip gives the Results page: the tables of :data:`UPLOADABLE_TABLES` and the checksums of
#: the folder its daily.csv is in (a run's zip, :func:`run_zip`; a study's, ``cacas export``'s bundle).
ZIP_MEMBERS = ("daily.csv", "by_preference.csv", "interactions.csv", "checksums.sha256")


def _missing_columns(columns) -> str:
    """What a CSV that is none of the ``UPLOADABLE_TABLES`` lacks to be the one it is nearest to (most of
    whose columns it has, at least half), as " (as a daily.csv it lacks the column day)"; "" if none is near
    (walkthrough: a daily.csv without its day column was told only every column a daily.csv needs)."""
    have = set(map(str, columns))
    share, kind = max((len(have & set(cols)) / len(cols), kind) for kind, cols in UPLOADABLE_TABLES.items())
    if share < 0.5:
        return ""
    lacks = [c for c in UPLOADABLE_TABLES[kind] if c not in have]
    return f" (as a {kind}.csv it lacks the column{'s' if len(lacks) > 1 else ''} {', '.join(lacks)})"


def unpacked_uploads(files: Sequence[tuple[str, bytes]]) -> list[tuple[str, bytes]]:
    """The uploaded files (name, content), each zip among them replaced by its daily.csv and the
    by_preference.csv, interactions.csv and checksums.sha256 in the same folder (:data:`ZIP_MEMBERS`,
    under their own names): the zip of a run (the Simulation lab's "Download the whole run",
    :func:`run_zip`) or of a study (``cacas export``, the Results page's "Download everything"). Its
    other files (settings.json, a study's other tables, policy files) are not read. A zip that is not
    readable, holds no daily.csv or more than one, or whose members are too large
    (:func:`cacas.export.check_sizes`) is a CacasError naming it and what is valid."""
    import zipfile
    import zlib
    from pathlib import PurePosixPath

    from cacas.export import check_sizes, read_member

    valid = ("valid: the zip of a run (the Simulation lab's 'Download the whole run') or of a study (cacas export, "
             "'Download everything')")
    out: list[tuple[str, bytes]] = []
    for name, data in files:
        if not str(name).lower().endswith(".zip"):
            out.append((name, data))
            continue
        try:
            with zipfile.ZipFile(io.BytesIO(data)) as zf:
                members = [i for i in zf.infolist() if not i.is_dir()]
                dailies = [i.filename for i in members if PurePosixPath(i.filename).name == "daily.csv"]
                if len(dailies) != 1:
                    raise CacasError(f"{name}: holds no daily.csv; {valid}" if not dailies else
                                     f"{name}: holds {len(dailies)} daily.csv files ({', '.join(dailies[:3])}"
                                     f"{', ...' if len(dailies) > 3 else ''}); upload the zip of one run or study")
                folder = PurePosixPath(dailies[0]).parent
                chosen = [i for i in members if PurePosixPath(i.filename).parent == folder
                          and PurePosixPath(i.filename).name in ZIP_MEMBERS]
                check_sizes(name, chosen, valid)
                out.extend((PurePosixPath(i.filename).name, read_member(name, zf, i.filename, valid)) for i in chosen)
        except (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError) as exc:
            raise CacasError(f"{name}: not a readable zip file ({exc}); {valid}") from None
    return out


def load_uploaded_tables(files: Sequence[tuple[str, bytes]]) -> dict[str, pd.DataFrame]:
    """Uploaded CSV files (name, content) as {"daily": ..., "by_preference": ..., "interactions":
    ..., "summary": ...}, each file recognised by its columns (``UPLOADABLE_TABLES``,
    ``SUMMARY_COLUMNS``). A daily.csv is required; the others are optional (a summary.csv is checked
    to be its means, :func:`_check_summary`). Raises CacasError naming the file at fault: one that
    is none of these tables, two of the same kind, or no daily.csv. Zips are read by
    :func:`unpacked_uploads` first.

    A ``checksums.sha256`` uploaded with them (:data:`cacas.store.files.CHECKSUMS`, written beside
    them by ``cacas export`` and ``cacas simulate --out``) is checked against each CSV: a file it lists
    with other bytes was left by a run stopped part-way (files of two runs side by side), or changed
    since, and is refused (safety audit L1)."""
    from cacas.store import files as store_files

    files = _checked_against_checksums(files, store_files)
    tables: dict[str, pd.DataFrame] = {}
    names: dict[str, str] = {}
    places: dict[str, int] = {}  # each kind's file's place among those uploaded (1, 2, ...)
    for place, (name, data) in enumerate(files, 1):
        try:
            df = records.read_csv(io.BytesIO(data))
        except (ValueError, pd.errors.ParserError, UnicodeDecodeError) as exc:
            raise CacasError(f"{name}: not a readable CSV file ({str(exc).splitlines()[0] if str(exc) else exc})")
        kind = next((k for k, cols in UPLOADABLE_TABLES.items() if set(cols) <= set(df.columns)), None)
        if kind is None and set(SUMMARY_COLUMNS) <= set(df.columns) and "participant" not in df.columns:
            kind = "summary"
        if kind is None:
            raise CacasError(f"{name}: not a daily.csv, by_preference.csv or interactions.csv"
                             f"{_missing_columns(df.columns)}; a daily.csv needs the columns "
                             f"{', '.join(UPLOADABLE_TABLES['daily'])}")
        if kind in tables:
            which = (f"two files named {name} (files {places[kind]} and {place} of those uploaded)"
                     if name == names[kind] else f"{name} and {names[kind]}")  # was "daily.csv and daily.csv"
            raise CacasError(f"{which} are both a {kind}.csv; upload one of each kind")
        tables[kind], names[kind], places[kind] = (check_daily_values(df, name) if kind == "daily" else df), name, place
    if "daily" not in tables:
        raise CacasError(f"{', '.join(names.values()) or 'nothing uploaded'}: upload a daily.csv as well "
                         "(the other tables are shown beside it)")
    if tables["daily"].empty:  # the page said "Run a day on the Study session page" (review)
        raise CacasError(f"{names['daily']}: has the daily.csv columns but no rows; valid: a daily.csv with at "
                         "least one participant-day")
    known = set(tables["daily"]["participant"].astype(str))
    for kind in ("by_preference", "interactions"):
        if kind in tables:
            strangers = records.by_code(set(tables[kind]["participant"].astype(str)) - known)
            if strangers:
                raise CacasError(f"{names[kind]}: participant(s) {', '.join(strangers[:5])} are not in "
                                 f"{names['daily']}; upload the tables of one study or run")
    _check_one_row_each(tables["daily"], names["daily"])
    if "interactions" in tables:
        _check_same_run(tables["daily"], tables["interactions"], names["daily"], names["interactions"])
    if "by_preference" in tables:
        _check_by_preference(tables["daily"], tables["by_preference"], names["daily"], names["by_preference"])
    if "summary" in tables:
        _check_summary(tables["daily"], tables["summary"], names["daily"], names["summary"])
    return {k: tables[k] for k in [*UPLOADABLE_TABLES, "summary"] if k in tables}


def _check_summary(daily: pd.DataFrame, summary: pd.DataFrame, daily_name: str, name: str) -> None:
    """A summary.csv belongs to the daily.csv beside it: each of its rows is the mean of daily.csv's
    rows of that method and day (:func:`cacas.experiment.summary_table`), within
    :data:`SHARE_TOLERANCE`, and it has a row for each method and day of daily.csv; else CacasError
    naming the method, day and column."""
    from cacas.experiment import summary_table

    made = summary_table(_keyed(daily, daily_name))
    said = summary.assign(method=summary["method"].astype(str), day=_whole_column(summary, "day", name, 1))
    columns = [c for c in made.columns if c in said.columns and c not in ("method", "day")]
    both = made.merge(said, on=["method", "day"], how="outer", suffixes=("", " said"), indicator=True)
    for _, row in both.iterrows():
        where = f"{name}: {row['method']} day {row['day']}"
        if row["_merge"] != "both":
            raise CacasError(f"{where} is {'not in' if row['_merge'] == 'left_only' else 'in it but not in'} "
                             f"{name if row['_merge'] == 'left_only' else daily_name}; upload the tables of one run")
        for col in columns:
            have, told = (pd.to_numeric(pd.Series([row[col], row[f"{col} said"]]), errors="coerce").astype(float))
            if np.isnan(have) != np.isnan(told) or abs(have - told) > SHARE_TOLERANCE:
                shown = (lambda x: "empty" if np.isnan(x) else f"{x:.6g}")
                raise CacasError(f"{where}: {col} {shown(told)}, the mean of {daily_name}'s rows is {shown(have)}; "
                                 "upload the tables of one run")


def _checked_against_checksums(uploaded: Sequence[tuple[str, bytes]], store_files) -> list[tuple[str, bytes]]:
    """The uploaded CSV files, once each matches the checksums file uploaded with them (if one was:
    a name ending in ``.sha256``); else CacasError naming the file and what to do."""
    sums = [(name, data) for name, data in uploaded if str(name).lower().endswith(".sha256")]
    rest = [(name, data) for name, data in uploaded if not str(name).lower().endswith(".sha256")]
    if len(sums) > 1:
        raise CacasError(f"{sums[0][0]} and {sums[1][0]}: two checksums files; upload the one of the folder the "
                         "tables are from")
    if not sums:
        return rest
    what, listed = sums[0][0], store_files.parse_checksums(sums[0][1])
    if listed is None:
        raise CacasError(f"{what}: not a checksums file; valid: the {store_files.CHECKSUMS} cacas export or cacas "
                         "simulate --out wrote beside the tables (a sha256 and a file name on each line)")
    for name, data in rest:
        digest = store_files.sha256(data)
        if listed.get(name, digest) != digest:
            raise CacasError(f"{name}: does not match its sha256 in {what}: {STOPPED_PART_WAY}; write the tables "
                             "again (cacas export, or cacas simulate --out) and upload them")
        if name not in listed and digest not in listed.values():
            raise CacasError(f"{name}: is not one of the files {what} lists ({', '.join(sorted(listed))}); upload the "
                             "tables and the checksums file of one folder")
    return rest


#: daily.csv's columns that follow from its interactions.csv (:func:`cacas.records.daily_table`), in
#: the order a mismatch is said: design.md's contract ones, and the others where the upload has them.
SAME_RUN_COLUMNS = ("interactions", "successes", "success_rate", "user_initiated", "feedback",
                    "cumulative_feedback", "unanswered")
#: How far a share in an uploaded daily.csv may be from the one its other tables give: the tables
#: write six decimals, and a spreadsheet may keep fewer; two runs' shares differ by at least 1/400
#: (Fig. 4's test states) or 1/interactions where their counts are the same.
SHARE_TOLERANCE = 5e-4
_KEY = ["participant", "method", "day"]


def _same_run(what: str, who, day, method) -> str:
    return f"{what}: {who} day {day} ({method})"


def _whole_column(df: pd.DataFrame, col: str, name: str, least: int) -> pd.Series:
    """``df[col]`` as whole numbers >= ``least``; else CacasError naming the file, column and row."""
    value = pd.to_numeric(df[col], errors="coerce")
    bad = ~(value.notna() & (value >= least) & (value == value.round()))
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise CacasError(f"{name}, row {row + 2}: {col} {_shown(df[col].iloc[row])} is invalid; valid: a whole "
                         f"number >= {least}")
    return value.astype("int64")


def _keyed(df: pd.DataFrame, name: str) -> pd.DataFrame:
    """``df`` with its participant and method as text and its day a whole number >= 1 (else
    CacasError naming the file and row): the keys by which two uploaded tables are matched."""
    return df.assign(participant=df["participant"].astype(str), method=df["method"].astype(str),
                     day=_whole_column(df, "day", name, 1))


def _daily_from(interactions: pd.DataFrame, daily: pd.DataFrame):
    """daily.csv as :func:`cacas.records.daily_table` makes it from ``interactions``, with the rows of
    the uploaded ``daily`` (its keys and preference accuracies), in each way a daily.csv of ours is
    written (made one by one, as asked for): a participant's interactions one stream (``cacas
    simulate``, the paper's protocol, and a study database's export), or every method a closed loop
    of its own (``cacas simulate --loop each``); and each also as tables written before commit 1c1999b
    counted them (a request made with no sound activity was recorded, two data points)."""
    accuracy = daily[_KEY + ["preference_accuracy"]]
    idle_request = (interactions["type"] == records.USER_INITIATED) & (interactions["activity"] == "do nothing")
    methods = list(dict.fromkeys([*daily["method"], *interactions["method"]]))
    variants = [interactions]
    if idle_request.any():  # (without one, the same tables as now)
        variants.append(interactions.assign(activity=interactions["activity"].where(~idle_request,
                                                                                  "(a request, doing nothing)")))
    for rows in variants:
        yield records.daily_table(rows, accuracy)
        if len(methods) > 1:
            yield pd.concat([records.daily_table(rows[rows["method"] == m], accuracy[accuracy["method"] == m])
                             for m in methods], ignore_index=True)


def _differences(daily: pd.DataFrame, made: pd.DataFrame) -> list[tuple]:
    """Where ``made`` (:func:`_daily_from`) differs from the uploaded ``daily``: (participant, method,
    day, column, made's value, daily's value), column None for a row daily.csv does not have; a row's
    first differing column only."""
    columns = [c for c in SAME_RUN_COLUMNS if c in daily.columns]
    both = made[_KEY + columns].merge(daily[_KEY + columns], on=_KEY, how="left", suffixes=("", " said"),
                                      indicator=True)
    lacking = (both["_merge"] == "left_only").to_numpy()
    first = np.full(len(both), -1)  # each row's first differing column (its place in ``columns``)
    for k, col in reversed(list(enumerate(columns))):
        have = pd.to_numeric(both[col], errors="coerce").astype(float).to_numpy()
        said = pd.to_numeric(both[f"{col} said"], errors="coerce").astype(float).to_numpy()
        tolerance = SHARE_TOLERANCE if col == "success_rate" else 0
        with np.errstate(invalid="ignore"):
            differ = (np.isnan(have) != np.isnan(said)) | (np.abs(have - said) > tolerance)
        first[differ] = k
    out = []
    for i in np.flatnonzero(lacking | (first >= 0)):
        where = (both["participant"].iat[i], both["method"].iat[i], int(both["day"].iat[i]))
        if lacking[i]:
            out.append((*where, None, None, None))
        else:
            col = columns[first[i]]
            out.append((*where, col, both[col].iat[i], both[f"{col} said"].iat[i]))
    return sorted(out, key=lambda d: d[3] is not None)  # a row daily.csv lacks is said first


def _check_same_run(daily: pd.DataFrame, interactions: pd.DataFrame, daily_name: str, inter_name: str) -> None:
    """An interactions.csv belongs to the daily.csv beside it: daily.csv is what
    :func:`cacas.records.daily_table` makes of it (:func:`_daily_from`), in one of the ways our
    daily.csv files are written. Every participant-method-day of its interactions is a row of
    daily.csv, and each row's counts of design.md's contract (interactions, cumulative_feedback) and
    success_rate, and the other counts the upload has (successes, user_initiated, feedback,
    unanswered), are its interactions': another run's file with the same participants, methods and
    days, a run of fewer days or participants with the same seed, or one of the two files cut short,
    is refused (with no checksums.sha256 uploaded, this is what shows them to be of one run)."""
    interactions = _keyed(interactions, inter_name)
    daily = _keyed(daily, daily_name)
    best = None
    for made in _daily_from(interactions, daily):
        found = _differences(daily, made)
        if not found:
            return
        if best is None or len(found) < len(best):
            best = found
    who, method, day, col, have, said = best[0]
    if col is None:
        raise CacasError(f"{_same_run(inter_name, who, day, method)} is not in {daily_name}; upload the tables of "
                         "one study or run")
    if col == "interactions":
        raise CacasError(f"{_same_run(inter_name, who, day, method)} has {int(have)} recorded interactions, "
                         f"{daily_name} says {said if pd.isna(said) else int(said)}; upload the tables of one "
                         "study or run")
    shown = (lambda x: "empty" if pd.isna(x) else f"{float(x):.6g}")
    raise CacasError(f"{_same_run(inter_name, who, day, method)}: its interactions give {col} {shown(have)}, "
                     f"{daily_name} says {shown(said)}; upload the tables of one study or run")


def _check_by_preference(daily: pd.DataFrame, by_preference: pd.DataFrame, daily_name: str, name: str) -> None:
    """A by_preference.csv belongs to the daily.csv beside it: each of its participant-method-days is a
    row of daily.csv, and that row's preference_accuracy (Fig. 4) is what its preferences' ``correct``
    of ``states`` give. Where no two of the participant's preferences share an activity they cover
    none of the same test states, and the accuracy is sum(correct) / sum(states) exactly; where some
    do, a state covered twice is counted twice, and the accuracy lies between
    max(correct) / (max(correct) + sum(wrong)) and sum(correct) / (sum(correct) + max(wrong)), wrong =
    states - correct (:func:`cacas.adaptation.accuracy_by_preference`,
    :func:`cacas.adaptation.preference_accuracy`)."""
    rows = _keyed(by_preference, name).assign(states=_whole_column(by_preference, "states", name, 0),
                                correct=_whole_column(by_preference, "correct", name, 0))
    over = rows["correct"] > rows["states"]
    if over.any():
        row = int(np.flatnonzero(over.to_numpy())[0])
        raise CacasError(f"{name}, row {row + 2}: correct {rows['correct'].iloc[row]} is more than states "
                         f"{rows['states'].iloc[row]}; valid: at most the test states the preference covers")
    accuracy = _keyed(daily, daily_name).drop_duplicates(_KEY).set_index(_KEY)["preference_accuracy"]
    groups = rows.assign(wrong=rows["states"] - rows["correct"]).groupby(_KEY, sort=False)
    for who, method, day in groups.groups:
        if (who, method, day) not in accuracy.index:
            raise CacasError(f"{_same_run(name, who, day, method)} is not in {daily_name}; upload the tables of one "
                             "study or run")

    def apart(activities) -> bool:  # no activity in two of these preferences
        sets = [{a.strip().lower() for a in str(acts).split("/")} for acts in activities]
        return sum(map(len, sets)) == len(set().union(*sets))

    g = groups.agg(states=("states", "sum"), correct=("correct", "sum"), most_correct=("correct", "max"),
                   wrong=("wrong", "sum"), most_wrong=("wrong", "max"), apart=("activity", apart))
    said = pd.to_numeric(accuracy.reindex(g.index), errors="coerce").astype(float).to_numpy()
    exact = g["correct"] / g["states"].where(g["states"] > 0)
    low = np.where(g["apart"], exact, g["most_correct"] / (g["most_correct"] + g["wrong"]).clip(lower=1))
    high = np.where(g["apart"], exact, g["correct"] / (g["correct"] + g["most_wrong"]).clip(lower=1))
    with np.errstate(invalid="ignore"):
        outside = ~np.isnan(said) & (g["states"].to_numpy() > 0) & \
            ((said < low - SHARE_TOLERANCE) | (said > high + SHARE_TOLERANCE))
    if outside.any():
        i = int(np.flatnonzero(outside)[0])
        who, method, day = g.index[i]
        gives = f"of {low[i]:.3f}" if g["apart"].iat[i] else \
            f"between {low[i]:.3f} and {high[i]:.3f} (preferences with activities in common)"
        raise CacasError(f"{_same_run(name, who, day, method)}: its preferences' correct of states give a preference "
                         f"accuracy {gives}, {daily_name} says {said[i]:.3f}; upload the tables of one study or run")


def _check_one_row_each(daily: pd.DataFrame, name: str) -> None:
    """daily.csv has one row per participant, method and day (design.md): two rows of one are two
    studies' or runs' tables put together, which every mean would count twice."""
    keys = _keyed(daily, name)[_KEY]
    twice = keys.duplicated(keep=False).to_numpy()
    if twice.any():
        rows = np.flatnonzero(twice)
        who, method, day = keys.iloc[rows[0]]
        same = [int(r) + 2 for r in rows if tuple(keys.iloc[r]) == (who, method, day)]
        times = "twice" if len(same) == 2 else f"{len(same)} times"
        raise CacasError(f"{name}: {who} day {day} ({method}) is listed {times} (rows {', '.join(map(str, same[:-1]))} "
                         f"and {same[-1]}); valid: one row per participant, method and day, as cacas "
                         "simulate and an export write it")


def upload_caption(kinds: Sequence[str], checksums: str | None) -> tuple[str, str | None]:
    """What the Results page says of uploaded tables (their kinds, as :func:`load_uploaded_tables`
    returns them) and of the checksums file uploaded with them (its name; None if none was): what
    was checked, and, without a checksums file, a note that the files' bytes were not (None with one)."""
    from cacas.store.files import CHECKSUMS

    names = ", ".join(f"{k}.csv" for k in kinds)
    together = " checked against each other (participants, methods, days and what they count)" \
        if len(kinds) > 1 else ""
    if checksums:
        return f"Uploaded: {names}, each matching its sha256 in {checksums}" + (f", and{together}" if together else "") \
            + ".", None
    return (f"Uploaded: {names}" + (f",{together}" if together else "") + ".",
            f"Checksums not checked: no {CHECKSUMS} was uploaded with {'them' if len(kinds) > 1 else 'it'}. Add the "
            "one beside the tables (cacas export and cacas simulate --out write it) to check that each file is whole "
            "and of that folder's run.")


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
             (", ".join(plots.METHOD_LABELS.get(m, m) for m in methods) if short else f"methods {', '.join(methods)}")
             if methods else "",
             f"seed {settings['seed']}" if settings.get("seed") is not None else "",
             f"asks after {percent(settings['ask_after_reject'])} of rejections"
             if settings.get("ask_after_reject") else "",
             ("each in its own loop" if short else "each method in its own closed loop")
             if settings.get("loop") == "each" else "",
             f"personas: {settings['personas']}" if settings.get("personas") and not short else ""]
    return [w for w in words if w]


def run_caption(settings: dict) -> str:
    """The Simulation lab's line under a run: every setting the run kept, e.g. "8 participants ·
    7 days · 15 interactions a day · methods cacas, nn · seed 0 · personas: ..."; a setting the
    run did not keep is left out."""
    return " · ".join(_settings_words(settings, short=False))


def run_label(root, name: str) -> str:
    """How the run pickers name a run: when it ran and what it compared, from its settings (two
    runs of one day differ in more than their time stamp), e.g. "26 Nov 2026 08:15:02 · 8
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
        when = datetime.strptime(name[:15], "%Y%m%d-%H%M%S").strftime("%d %b %Y %H:%M:%S")
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
