"""Load exported tables back into an empty study database (the import half of issue 4's bundle).

:func:`restore` takes the tables of a bundle as read from CSV (all cells text, "" for empty) and
the policy checkpoint files, checks every name through :mod:`cacas.spaces` and every checkpoint
against its sha256, and inserts everything in one transaction: a bad bundle raises CacasError
naming the table, row and column, and nothing is written.

A restore gives back the study a bundle holds, as it was: what the forms refuse only in new data
(a participant code that looks like a phone number or a date, or that differs from another's
only in letter case, free text holding what looks like contact details, a study's name that
differs from another's only in letter case, an age range above 120, a time not written as the app
writes times; a study may hold them from before the check) is imported, with a note naming the
table, row and column (:class:`Restored`), not refused.
"""

from __future__ import annotations

import json
import sqlite3
from dataclasses import dataclass
from collections.abc import Mapping
from typing import Any, Callable

import pandas as pd

from cacas import preferences as prefs
from cacas import spaces
from cacas.errors import CacasError, DamagedFile
from cacas.privacy import contact_details
from cacas.store import files, schema
from cacas.store import validate as v

#: Tables a bundle must have to be restored, with the columns read from each.
RESTORE_COLUMNS: dict[str, list[str]] = {
    "studies": ["name", "description", "created_at"],
    "participants": ["participant", "study", "age_range", "notes", "active_policy", "created_at", "updated_at"],
    "preferences": ["participant", "version", "preferences", "created_at"],
    "days": ["participant", "day", "opened_at", "closed_at"],
    "policies": ["participant", "version", "day", "method", "path", "sha256", "size", "created_at"],
    "interactions": ["participant", "method", "day", "index", "time", "activity", "scene", "time_slot",
                     "interval", "task", "previous_action", "previous_response", "type", "robot_action",
                     "response", "user_action", "hour", "interval_minutes", "recognised_activity",
                     "recognised_scene", "sound_model", "scene_model", "probabilities", "policy_version",
                     "created_at"],
    "adaptations": ["participant", "day", "method", "parameters", "duration_s", "metrics", "policy_version",
                    "created_at"],
    "questionnaire": ["participant", "satisfaction", "comments", "created_at"],
    "events": ["at", "what", "participant", "details"],
}

#: Columns a bundle written before they existed may lack: read as empty.
OPTIONAL_COLUMNS: dict[str, list[str]] = {"interactions": ["sound_model", "scene_model"]}  # schema version 2

#: Columns cacas export writes that an import does not read: each is worked out again from the
#: others (an interaction's study from its participant, a participant's preference version from
#: preferences.csv, an answer's day from days.csv, a run's preference accuracy from its metrics, a
#: policy's being in force from participants.csv).
DERIVED_COLUMNS: dict[str, list[str]] = {
    "interactions": ["study"],
    "participants": ["preference_version"],
    "questionnaire": ["day"],
    "adaptations": ["preference_accuracy"],
    "policies": ["active"],
}


def known_columns(name: str) -> list[str]:
    """Every column of table ``name`` a bundle may have (those :data:`RESTORE_COLUMNS` reads, then
    :data:`DERIVED_COLUMNS`): what cacas export writes, now and in every earlier version."""
    return RESTORE_COLUMNS[name] + DERIVED_COLUMNS.get(name, [])


def check_columns(tables: dict[str, pd.DataFrame]) -> None:
    """Refuse (CacasError) a table holding a column this CACAS Studio does not know (one a newer
    version writes, or an edited file's): an import would drop it without a word. Names the file,
    its unknown columns and the columns that are valid."""
    for name in RESTORE_COLUMNS:
        df = tables.get(name)
        if df is None:
            continue
        known = known_columns(name)
        unknown = [str(c) for c in df.columns if c not in known]
        if unknown:
            raise CacasError(f"{name}.csv has {'a column' if len(unknown) == 1 else 'columns'} this CACAS Studio "
                             f"does not know ({', '.join(map(repr, unknown))}), which an import would lose; "
                             f"valid: the columns cacas export writes ({', '.join(known)}). A bundle written by a "
                             "newer CACAS Studio needs that version to import it")


#: The largest whole number a study database column holds (SQLite's 64-bit INTEGER).
_MAX_INT = 2**63 - 1


class _CellError(CacasError):
    """What is wrong with one cell: :func:`_rows` names its file, row and column, as a note does
    (``interactions.csv, row 2, column hour: 'x' is not a number; valid: ...``)."""

    def __init__(self, column: str, problem: str):
        super().__init__(problem)
        self.column = column


def _int(r: dict, column: str, low: int = 0, high: int = _MAX_INT) -> int:
    """The whole number in ``r[column]``, from ``low`` to ``high``."""
    cell = r[column]
    try:
        value = int(cell)
    except ValueError:
        raise _CellError(column, f"{cell!r} is not a whole number; valid: {_whole(low, high)}") from None
    if not low <= value <= high:
        raise _CellError(column, f"{cell!r} is too {'small' if value < low else 'large'}; valid: {_whole(low, high)}")
    return value


def _whole(low: int, high: int) -> str:
    return f"a whole number >= {low}" if high == _MAX_INT else f"a whole number {low}..{high}"


def _opt_int(r: dict, column: str) -> int | None:
    """The whole number (from 1) in ``r[column]``, or None for an empty cell."""
    if r[column] == "":
        return None
    try:
        return _int(r, column, 1)
    except _CellError as exc:
        raise _CellError(column, f"{exc}, or empty") from None


def _opt_float(r: dict, column: str) -> float | None:
    """The number in ``r[column]``, or None for an empty cell."""
    cell = r[column]
    if cell == "":
        return None
    try:
        return float(cell)
    except ValueError:
        raise _CellError(column, f"{cell!r} is not a number; valid: a number, or empty") from None


def _opt(cell: str) -> str | None:
    return None if cell == "" else cell


def _json_text(r: dict, column: str, empty: str | None = None) -> str:
    """The JSON text in ``r[column]`` (``empty`` for an empty cell, if given), checked."""
    cell = r[column] if r[column] != "" or empty is None else empty
    try:
        json.loads(cell)
    except json.JSONDecodeError as exc:
        raise _CellError(column, f"not valid JSON ({exc.msg})") from None
    return cell


@dataclass(frozen=True)
class Restored:
    """What :func:`restore` did: the number of interactions restored, and one note per cell it
    kept as it was although the forms refuse it in new data (each names the table, row and column)."""

    interactions: int
    notes: tuple[str, ...] = ()


class _Notes(list):
    """The notes of one restore; :func:`_rows` sets ``where`` (table and row) before each row."""

    where = ""

    def kept(self, column: str, problem: str, why: str) -> None:
        """Note that the cell of ``column`` in this row has ``problem`` and was imported as it was."""
        self.append(f"{self.where}, column {column}: {problem}; imported as it was, as the study held it ({why})")

    def private(self, value: str, column: str) -> str:
        """``value``, noted if it holds what looks like contact details (:func:`contact_details`:
        an e-mail address, a phone number; a participant code that is a date), which the forms
        refuse in new data but a study may hold from before the check."""
        found = contact_details(value)
        if found:
            what = ("a phone number or a date" if column == "participant" else
                    "contact details (a phone number or an e-mail address)")
            self.kept(column, f"{found!r} looks like {what}", "the forms refuse it in new data")
        return value

    def age(self, cell: str) -> str:
        """An age range, checked as the forms check one (:func:`validate.age_range`); one naming an
        age above ``validate.AGE_MAX``, which the forms took before they refused it, is noted."""
        try:
            return v.age_range(cell)
        except CacasError:
            text = v.age_range(cell, bounded=False)  # what the forms never took is refused
            self.kept("age_range", f"age range {cell!r} names an age above {v.AGE_MAX}",
                      "the forms took such ages before they refused them")
            return text

    def time(self, cell: str, column: str = "time") -> str:
        """A time of ``column``, checked as ``record_interaction`` checks an interaction's ``time``
        (:func:`validate.timestamp`: ISO 8601 with a time zone) and kept as it was. A time not
        written as the app writes times (:func:`validate.now`: UTC, milliseconds, "Z"), but one
        :func:`validate.iso_time` reads (with an offset, without a zone, a date alone), is noted:
        ``record_interaction`` stored such an interaction ``time`` as given before it converted
        times to UTC, and an import took any text in the other time columns (``created_at``,
        ``opened_at``, an event's ``at``, ...) before it checked them. Anything else is refused."""
        before = ("record_interaction stored such times before it {}" if column == "time" else
                  "an import took such times before it checked them")
        try:
            utc = v.timestamp(cell, column)
        except CacasError as exc:
            problem = str(exc).removeprefix(f"{column} ")  # the column is named before it: "column at: 'x' is ..."
            try:
                v.iso_time(cell)
            except ValueError:
                raise _CellError(column, problem) from None
            self.kept(column, problem.partition("; valid:")[0], before.format("refused them"))
            return cell
        if utc != cell:
            in_utc = v.iso_time(cell).utcoffset().total_seconds() == 0
            self.kept(column, f"{cell!r} is " + ("in UTC, but not written as the app writes times" if in_utc
                                                 else "not in UTC as the app writes times") + f" ({utc!r})",
                      before.format("converted them to UTC"))
        return cell


def _rows(tables: dict[str, pd.DataFrame], name: str, convert: Callable[[dict], tuple],
          notes: _Notes | None = None) -> list[tuple]:
    df = tables.get(name)
    if df is None:
        raise CacasError(f"{name}.csv is missing from the bundle")
    optional = OPTIONAL_COLUMNS.get(name, [])
    df = df.assign(**{c: "" for c in optional if c not in df.columns})
    missing = [c for c in RESTORE_COLUMNS[name] if c not in df.columns]
    if missing:
        raise CacasError(f"{name}.csv has no column {missing[0]!r}; expected {', '.join(RESTORE_COLUMNS[name])}")
    out = []
    for i, row in enumerate(df[RESTORE_COLUMNS[name]].to_dict("records")):
        if notes is not None:
            notes.where = f"{name}.csv, row {i + 2}"
        try:
            out.append(convert(row))
        except _CellError as exc:
            raise CacasError(f"{name}.csv, row {i + 2}, column {exc.column}: {exc}") from None
        except DamagedFile:  # a policy file's bytes, named as they are
            raise
        except CacasError as exc:
            raise CacasError(f"{name}.csv, row {i + 2}: {exc}") from None
    return out


def _interaction(r: dict[str, Any], noted: _Notes) -> tuple:
    slot, iv = _int(r, "time_slot", 0, spaces.N_SLOTS - 1), _int(r, "interval")
    if iv not in spaces.INTERVAL_BINS:
        raise CacasError(f"interval {iv} is not an S4 bin value; valid: {list(spaces.INTERVAL_BINS)}")
    iv = spaces.INTERVAL_BINS.index(iv)
    hour, minutes = _opt_float(r, "hour"), _opt_float(r, "interval_minutes")
    v.time_slot(hour, slot)
    v.interval(minutes, iv)
    kind = v.conversation_type(r["type"])
    user = v.user_action(kind, r["user_action"], v.name("response", r["response"], "response"),
                         v.name("action", r["robot_action"], "robot_action"))  # the rule record_interaction keeps
    probs = _opt(r["probabilities"])
    if probs is not None:
        v.probabilities(json.loads(_json_text(r, "probabilities")))
    return (r["participant"], _int(r, "day", 1), _int(r, "index", 1), noted.time(r["time"]), v.method(r["method"]),
            v.name("activity", r["activity"], "activity"), v.name("scene", r["scene"], "scene"), hour, slot,
            minutes, iv, v.name("action", r["task"], "task"),
            v.name("action", r["previous_action"], "previous_action"),
            v.name("response", r["previous_response"], "previous_response"),
            None if r["recognised_activity"] == "" else v.name("activity", r["recognised_activity"],
                                                                 "recognised_activity"),
            None if r["recognised_scene"] == "" else v.name("scene", r["recognised_scene"], "recognised_scene"),
            v.model_id(r["sound_model"], "sound_model"), v.model_id(r["scene_model"], "scene_model"),
            kind, v.name("action", r["robot_action"], "robot_action"), probs,
            v.name("response", r["response"], "response"),
            user, _opt_int(r, "policy_version"), noted.time(r["created_at"], "created_at"))


def _check_days(days: list[tuple]) -> None:
    """Each participant's days as ``open_day`` and ``close_day`` leave them: numbered 1, 2, 3, ...
    (no gap, none twice), and every one closed but the latest (at most one open day, the latest).
    ``days`` are days.csv's rows in order (participant, day, opened_at, closed_at)."""
    by_participant: dict[str, list[tuple[int, int, str | None]]] = {}
    for i, (code, day, _opened, closed) in enumerate(days):
        by_participant.setdefault(code, []).append((day, i + 2, closed))
    for code, rows in by_participant.items():
        rows.sort()
        for n, (day, row, closed) in enumerate(rows, start=1):
            if day != n:
                what = f"is listed twice (rows {rows[n - 2][1]} and {row})" if day == n - 1 else \
                    f"follows day {n - 1}" if n > 1 else "is their first"
                raise CacasError(f"days.csv, row {row}: day {day} of participant {code} {what}; valid: days "
                                 "numbered 1, 2, 3, ... as the app opens them")
            if closed is None and n < len(rows):
                raise CacasError(f"days.csv, row {row}: day {day} of participant {code} is open (closed_at is "
                                 f"empty) but day {day + 1} follows it; valid: a closed_at time on every day "
                                 "but a participant's latest (the app opens a day after closing the one before)")


def _check_unique(name: str, rows: list[tuple], columns: list[str]) -> None:
    """No two rows of ``name`` share the values of ``columns`` (the first ones of each row), which
    the schema holds unique: the second is named with the row it repeats (the database said only
    "UNIQUE constraint failed", naming the table)."""
    seen: dict[tuple, int] = {}
    for i, row in enumerate(rows):
        key = tuple(row[:len(columns)])
        if key in seen:
            said = ", ".join(f"{c} {k}" for c, k in zip(columns, key))
            raise CacasError(f"{name}.csv, row {i + 2}: {said} is listed twice (rows {seen[key]} and {i + 2}); "
                             f"valid: one row for each {' and '.join(columns)}")
        seen[key] = i + 2


def _check_days_named(name: str, rows: list[tuple], at: int, days: list[tuple]) -> None:
    """Each row of ``name`` (policies or adaptations: the participant first, the day at ``at``)
    names day 0 (the initial policy) or one of the participant's days in days.csv, as
    ``save_policy`` and ``record_adaptation`` refuse a day the participant does not have (the
    schema's foreign keys do not cover it)."""
    have: dict[str, set[int]] = {}
    for code, day, *_ in days:
        have.setdefault(code, set()).add(day)
    for i, row in enumerate(rows):
        code, day = row[0], row[at]
        if day and day not in have.get(code, set()):
            last = max(have.get(code, {0}))
            theirs = f"1..{last}" if last else "none yet"
            raise CacasError(f"{name}.csv, row {i + 2}: participant {code} has no day {day} in days.csv (their days: "
                             f"{theirs}); valid: 0 (the initial policy) or one of their days")


#: The CSV file of a study database's table, where its name differs.
_CSV_NAMES = {"questionnaires": "questionnaire"}


def _check_foreign_keys(c: sqlite3.Connection, before: dict[str, int]) -> None:
    """Refuse (CacasError) the first row ``PRAGMA foreign_key_check`` finds naming a row its parent
    table lacks (an interaction's day or policy version, an adaptation's policy version), naming
    the CSV file, its row, the columns and values. Each table's rows were inserted in the file's
    order after the ids ``before`` holds, so a row's id gives its line in the file."""
    bad = c.execute("PRAGMA foreign_key_check").fetchone()
    if bad is None:
        return
    table, rowid, parent, fk = bad
    columns = [r[3] for r in c.execute(f"PRAGMA foreign_key_list({table})") if r[0] == fk]
    row = c.execute(f"SELECT {', '.join(columns)} FROM {table} WHERE id = ?", (rowid,)).fetchone()
    values = dict(zip(columns, row))
    code = c.execute("SELECT code FROM participants WHERE id = ?", (values.pop("participant_id", None),)).fetchone()
    name, parent_name = (f"{_CSV_NAMES.get(t, t)}.csv" for t in (table, parent))
    who = f" of participant {code[0]}" if code else ""
    what = ", ".join(f"{column} {value}" for column, value in values.items())
    raise CacasError(f"{name}, row {rowid - before[table] + 1}: {what}{who} is not in {parent_name}; valid: one that "
                     f"{parent_name} lists{' for them' if code else ''}")


def restore(store, tables: dict[str, pd.DataFrame], policy_files: Mapping[str, bytes]) -> Restored:
    """Insert the bundle's tables into ``store`` (which must hold no participant yet); return the
    number of interactions restored and the notes on what was kept as it was. ``policy_files``
    maps each policies.csv path to its bytes. A column it does not know is refused before any row
    is read (:func:`check_columns`)."""
    from cacas.policy import policy_checkpoint  # torch: only when an import runs

    check_columns(tables)
    # codes and free text as the study held them: what looks like contact details is noted, not refused
    noted = _Notes()
    names = [s.name for s in store.studies()]  # the new database's "default", then the bundle's

    def study_row(r):
        name = noted.private(v.study(r["name"], check_contacts=False), "name")
        twin = next((n for n in names if n.lower() == name.lower()), name)
        if twin != name and name not in names:  # a new study beside a case twin, which create_study refuses
            noted.kept("name", f"{name!r} differs from study {twin!r} only in letter case",
                       "the forms refuse it in new data")
        names.append(name)
        return (name, noted.private(v.text(r["description"], "description", check_contacts=False), "description"),
                noted.time(r["created_at"], "created_at"))

    studies = _rows(tables, "studies", study_row, noted)
    codes: dict[str, str] = {}  # lower case -> the first code of the bundle written so

    def person_row(r):
        code = noted.private(v.code(r["participant"]), "participant")
        twin = codes.setdefault(code.lower(), code)
        if twin != code:  # a case twin, which add_participant refuses (codes are unique across studies)
            noted.kept("participant", f"{code!r} differs from participant {twin!r} only in letter case",
                       "the forms refuse it in new data")
        if files.windows_device_name(code):  # policies/CON/ cannot be made on Windows (v.new_code refuses it)
            noted.kept("participant", f"{code!r} {v.DEVICE_NAME_PROBLEM}", "the forms refuse it in new data")
        return (code, r["study"], noted.age(r["age_range"]),
                noted.private(v.text(r["notes"], "notes", check_contacts=False), "notes"),
                _opt_int(r, "active_policy"), noted.time(r["created_at"], "created_at"),
                noted.time(r["updated_at"], "updated_at"))

    people = _rows(tables, "participants", person_row, noted)

    def pref_row(r):
        items = json.loads(_json_text(r, "preferences"))
        person = prefs.parse_participant({"id": r["participant"], "preferences": items})
        for k, pref in enumerate(person.preferences):
            noted.private(pref.description, f"preferences (preference {k + 1}'s description)")
        return r["participant"], _int(r, "version", 1), r["preferences"], noted.time(r["created_at"], "created_at")

    preferences = _rows(tables, "preferences", pref_row, noted)
    days = _rows(tables, "days", lambda r: (
        r["participant"], _int(r, "day", 1), noted.time(r["opened_at"], "opened_at"),
        None if r["closed_at"] == "" else noted.time(r["closed_at"], "closed_at")), noted)
    _check_days(days)

    def policy_row(r):
        if not r["path"].startswith(f"{r['participant']}/"):  # a participant's removal deletes their folder's files
            raise _CellError("path", f"{r['path']!r} is not in participant {r['participant']}'s folder; valid: a path "
                                     f"beginning {r['participant']}/ (cacas export keeps each policy file in its "
                                     "participant's folder)")
        data = policy_files.get(r["path"])
        if data is None:
            raise CacasError(f"policy file {r['path']!r} is missing from the bundle")
        if files.sha256(data) != r["sha256"]:
            raise CacasError(f"policy file {r['path']!r} does not match its sha256")
        try:  # the bytes are read as the tablet will read them (weights only: nothing in them runs)
            policy_checkpoint(data)
        except CacasError as exc:  # sha256 and size edited to match other bytes (safety)
            raise CacasError(f"policy file {r['path']!r} is {exc}; valid: a policy file as `cacas export` "
                             "wrote it") from None
        return (r["participant"], _int(r, "version", 1), _int(r, "day"), v.method(r["method"]), r["path"],
                r["sha256"], len(data), noted.time(r["created_at"], "created_at"))

    policies = _rows(tables, "policies", policy_row, noted)
    interactions = _rows(tables, "interactions", lambda r: _interaction(r, noted), noted)
    adaptations = _rows(tables, "adaptations", lambda r: (
        r["participant"], _int(r, "day"), v.method(r["method"]), _json_text(r, "parameters"),
        v.number(_opt_float(r, "duration_s") or 0.0, "duration_s", 0), _json_text(r, "metrics"),
        _opt_int(r, "policy_version"), noted.time(r["created_at"], "created_at")), noted)
    answers = _rows(tables, "questionnaire", lambda r: (
        r["participant"], v.satisfaction(_int(r, "satisfaction", 1, 10)),
        noted.private(v.text(r["comments"], "comments", check_contacts=False), "comments"),
        noted.time(r["created_at"], "created_at")), noted)
    events = _rows(tables, "events", lambda r: (noted.time(r["at"], "at"), r["what"], _opt(r["participant"]),
                                                _json_text(r, "details", empty="{}")), noted)
    _check_unique("participants", people, ["participant"])
    _check_unique("preferences", preferences, ["participant", "version"])
    _check_unique("policies", policies, ["participant", "version"])
    _check_unique("interactions", interactions, ["participant", "day", "index"])

    def fn(c):
        try:
            return insert(c)
        except sqlite3.IntegrityError as exc:
            raise CacasError(f"the bundle's tables do not fit together ({exc})") from None

    def insert(c):
        if c.execute("SELECT COUNT(*) FROM participants").fetchone()[0]:
            raise CacasError(f"{store.path}: already holds participants; import into a new database")
        # a row naming a missing one (a day, a policy version) is found once all are in, and named
        # below; checked at each INSERT, the first such row failed there, with no table or row named
        c.execute("PRAGMA defer_foreign_keys = ON")  # until this transaction ends
        before = {t: c.execute(f"SELECT COALESCE(MAX(id), 0) FROM {t}").fetchone()[0] for t in schema.TABLES}
        for name, desc, at in studies:
            c.execute("INSERT INTO studies (name, description, created_at) VALUES (?, ?, ?) ON CONFLICT(name) "
                      "DO UPDATE SET description = excluded.description, created_at = excluded.created_at",
                      (name, desc, at))
        sid = {n: i for i, n in c.execute("SELECT id, name FROM studies")}
        for row, (code, study, age, notes, _active, at, upd) in enumerate(people, start=2):
            if study not in sid:
                raise CacasError(f"participants.csv, row {row}: participant {code} is in study {study!r}, "
                                 f"which studies.csv does not have; valid: a study studies.csv lists")
            c.execute("INSERT INTO participants (study_id, code, age_range, notes, created_at, updated_at) "
                      "VALUES (?, ?, ?, ?, ?, ?)", (sid[study], code, age, notes, at, upd))
        pid = {code: i for i, code in c.execute("SELECT id, code FROM participants")}

        def p(code, table):
            if code not in pid:
                raise CacasError(f"{table}.csv names participant {code!r}, which participants.csv does not have")
            return pid[code]

        c.executemany("INSERT INTO preferences (participant_id, version, preferences, created_at) "
                      "VALUES (?, ?, ?, ?)", [(p(r[0], "preferences"), *r[1:]) for r in preferences])
        c.executemany("INSERT INTO days (participant_id, day, opened_at, closed_at) VALUES (?, ?, ?, ?)",
                      [(p(r[0], "days"), *r[1:]) for r in days])
        c.executemany("INSERT INTO policies (participant_id, version, day, method, path, sha256, size, "
                      "created_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)", [(p(r[0], "policies"), *r[1:]) for r in policies])
        saved = {(r[0], r[1]) for r in policies}
        for row, (code, _s, _a, _n, active, _c, _u) in enumerate(people, start=2):
            if active is not None and (code, active) not in saved:  # the column has no foreign key
                raise CacasError(f"participants.csv, row {row}: participant {code}'s policy in force is version "
                                 f"{active}, which policies.csv does not have; valid: one of their versions in "
                                 "policies.csv, or empty")
            c.execute("UPDATE participants SET active_policy = ? WHERE id = ?", (active, pid[code]))
        c.executemany(
            "INSERT INTO interactions (participant_id, day, idx, time, method, activity, scene, hour, time_slot, "
            "interval_minutes, interval_bin, task, previous_action, previous_response, recognised_activity, "
            "recognised_scene, sound_model, scene_model, type, robot_action, probabilities, response, "
            "user_action, policy_version, created_at) VALUES (" + ", ".join("?" * 25) + ")",
            [(p(r[0], "interactions"), *r[1:]) for r in interactions])
        c.executemany("INSERT INTO adaptations (participant_id, day, method, parameters, duration_s, metrics, "
                      "policy_version, created_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                      [(p(r[0], "adaptations"), *r[1:]) for r in adaptations])
        c.executemany("INSERT INTO questionnaires (participant_id, satisfaction, comments, created_at) "
                      "VALUES (?, ?, ?, ?)", [(p(r[0], "questionnaire"), *r[1:]) for r in answers])
        c.executemany("INSERT INTO events (at, what, participant, details) VALUES (?, ?, ?, ?)", events)
        _check_days_named("policies", policies, 2, days)  # each table's participants are known by now
        _check_days_named("adaptations", adaptations, 1, days)
        _check_foreign_keys(c, before)
        store._event(c, "import_bundle", None, participants=len(people), interactions=len(interactions),
                     notes=len(noted))
        return Restored(len(interactions), tuple(noted))

    return store._write(fn)
