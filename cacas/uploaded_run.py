"""The result tables a researcher uploads to the Results page (the files ``cacas simulate --out``,
the Simulation lab and ``cacas export`` write: daily.csv, by_preference.csv, interactions.csv, the
lab's summary.csv, the checksums.sha256 beside them, or the zip of a run or a study), each recognised
by its columns and checked to belong to one run (:func:`load_uploaded_tables`, after
:func:`unpacked_uploads`), and what the page says of them (:func:`upload_caption`). No streamlit.
"""

from __future__ import annotations

import io
from typing import Sequence

import numpy as np
import pandas as pd

from cacas import records
from cacas.errors import CacasError, not_utf8
from cacas.store.files import CHECKSUMS

#: Why a table does not match the checksums.sha256 written with it (an upload's, a run folder's).
STOPPED_PART_WAY = ("the run that wrote that folder was stopped part-way (killed, or a power cut) and left files of "
                    "two runs side by side, or the file was changed since")


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
ZIP_MEMBERS = (*(f"{kind}.csv" for kind in UPLOADABLE_TABLES), CHECKSUMS)


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

    from cacas.export import check_sizes, read_member, unreadable_zip

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
                check_sizes(name, chosen, valid, what="zip")
                out.extend((PurePosixPath(i.filename).name, read_member(name, zf, i.filename, valid, what="zip"))
                           for i in chosen)
        except (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError) as exc:
            raise unreadable_zip(name, data[:4], exc, valid) from None
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
        except UnicodeDecodeError:
            raise CacasError(f"{name}: cannot be read as UTF-8 text ({not_utf8(data)}); valid: {AS_WRITTEN}") from None
        except (ValueError, pd.errors.ParserError) as exc:
            raise CacasError(f"{name}: not a readable CSV file ({str(exc).splitlines()[0] if str(exc) else exc})")
        kind = next((k for k, cols in UPLOADABLE_TABLES.items() if set(cols) <= set(df.columns)), None)
        if kind is None and _summary_columns(df.columns):
            kind = "summary"
        if kind is None and _semicolons(data):
            raise CacasError(f"{name}: its columns are separated by ';', not ',', as a spreadsheet saves a CSV where "
                             f"the decimal mark is a comma (German, French, Turkish, ...); valid: {AS_WRITTEN}")
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


#: What an upload that a spreadsheet saved again should be instead (its separator, encoding, codes and times changed).
AS_WRITTEN = ("the file as cacas wrote it (comma-separated UTF-8; docs/tables.md): upload it from the export or the "
              "run's folder, not a copy a spreadsheet saved")


def _semicolons(data: bytes) -> bool:
    """Whether a CSV's header is one of the tables' separated by ";" (a spreadsheet in a language whose decimal mark
    is a comma saves CSV so, "0,5" in its cells): it was said to be none of the tables, naming columns it has."""
    header = data.decode("utf-8", errors="replace").removeprefix("\ufeff").partition("\n")[0].strip()
    names = {n.strip().strip('"') for n in header.split(";")}
    return "," not in header and any(set(cols) <= names for cols in (*UPLOADABLE_TABLES.values(), SUMMARY_COLUMNS))


def _summary_columns(columns) -> bool:
    """Whether ``columns`` are the lab's summary.csv's: :data:`SUMMARY_COLUMNS` and no participant column."""
    return set(SUMMARY_COLUMNS) <= set(columns) and "participant" not in set(columns)


def _is_summary(data: bytes) -> bool:
    """Whether a CSV's header is the lab's summary.csv's (:func:`_summary_columns`): it is not in the run's
    folder, so no checksums file lists it; it is checked against daily.csv instead (:func:`_check_summary`)."""
    try:
        return _summary_columns(records.read_csv(io.BytesIO(data), nrows=0).columns)
    except (ValueError, pd.errors.ParserError, UnicodeDecodeError):
        return False


def _checked_against_checksums(uploaded: Sequence[tuple[str, bytes]], store_files) -> list[tuple[str, bytes]]:
    """The uploaded CSV files, once each matches the checksums file uploaded with them (if one was:
    a name ending in ``.sha256``) and is one it lists (by name or by its bytes; a summary.csv,
    :func:`_is_summary`, need not be); else CacasError naming the file and what to do."""
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
            # most often a table picked from another run's folder (walk3: the message spoke of killed runs only)
            raise CacasError(f"{name}: does not match its sha256 in {what}, so it is not the {name} written with it: "
                             f"one from another folder (upload the tables of one folder with that folder's {what}), "
                             f"or {STOPPED_PART_WAY}; then write the tables again (cacas export, or cacas simulate "
                             "--out) and upload them")
        if name not in listed and digest not in listed.values() and not _is_summary(data):
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


def upload_caption(kinds: Sequence[str], checksums: str | None, zips: Sequence[str] = ()) -> tuple[str, str | None]:
    """What the Results page says of uploaded tables (their kinds, as :func:`load_uploaded_tables`
    returns them; read from the ``zips`` named, if any) and of the checksums file uploaded with them (its
    name; None if none was): what was checked, and, without a checksums file, a note that the files'
    bytes were not (None with one). A summary.csv (the lab's) is said apart: no checksums file lists it,
    and it is checked to be daily.csv's means (walkthrough: beside a run's zip it was said to be from the
    zip and to match its sha256)."""
    from cacas.store.files import CHECKSUMS

    summary = "summary" in kinds  # the lab's summary.csv: in no run folder, so in no checksums file
    kinds = [k for k in kinds if k != "summary"]
    names = ", ".join(f"{k}.csv" for k in kinds)
    uploaded = f"Uploaded from {', '.join(zips)}" if zips else "Uploaded"
    together = " checked against each other (participants, methods, days and what they count)" \
        if len(kinds) > 1 else ""
    means = (f" The summary.csv uploaded with {'them' if len(kinds) > 1 else 'it'} is checked to be daily.csv's "
             "means per method and day.") if summary else ""
    if checksums:
        return f"{uploaded}: {names}, each matching its sha256 in {checksums}" + (f", and{together}" if together else "") \
            + "." + means, None
    return (f"{uploaded}: {names}" + (f",{together}" if together else "") + "." + means,
            f"Checksums not checked: no {CHECKSUMS} was uploaded with {'them' if len(kinds) > 1 else 'it'}. Add the "
            "one beside the tables (cacas export and cacas simulate --out write it) to check that each file is whole "
            "and of that folder's run.")
