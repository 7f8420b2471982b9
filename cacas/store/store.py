"""StudyStore: the durable record of a human-subject study (issue 4; paper Section V-B).

One object per database file; every method is one job. Writes are validated first (bad input:
one CacasError, nothing written), then run in one short ``BEGIN IMMEDIATE`` transaction that
also appends an event to the event log, and are committed before the method returns. Several
processes may use the same file at once (WAL, busy_timeout, retry on SQLITE_BUSY); within one
process a StudyStore may be shared between threads (a lock serialises its one connection).

Conventions:

* participants are named by their pseudonymous code everywhere (``"P01"``);
* study days are numbered 1..n per participant; "day 0" in adaptation runs and policy
  checkpoints means before the first day (the initial policy, CACAA step 1);
* an adaptation run or checkpoint of day ``d`` was adapted from days 1..d and is meant to be in
  force on day d + 1 (Section V-B.1: "After each interaction day, we utilize the proposed CACAS to
  adapt the policy");
* policy versions are numbered 1..n per participant; ``None`` is the initial policy.
"""

from __future__ import annotations

import json
import os
import sqlite3
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence, TypeVar

import pandas as pd

from cacas import preferences as prefs
from cacas import spaces
from cacas.errors import CacasError
from cacas.paths import study_data_dir
from cacas.records import INTERACTION_COLUMNS, ROBOT_INITIATED, USER_INITIATED
from cacas.store import db, files
from cacas.store import validate as v

T = TypeVar("T")

#: The study every database has, so the app works out of the box.
DEFAULT_STUDY = "default"
#: Environment variable that overrides the default database path.
DB_ENV = "CACAS_DB"


def default_db_path() -> Path:
    """``$CACAS_DB`` if set, else ``study_data/cacas.sqlite`` (see :func:`cacas.paths.study_data_dir`)."""
    env = os.environ.get(DB_ENV)
    return Path(env) if env else study_data_dir() / "cacas.sqlite"


@dataclass(frozen=True)
class Study:
    name: str
    description: str
    created_at: str


@dataclass(frozen=True)
class ParticipantInfo:
    """A participant: pseudonymous code, study, age range, notes, the policy version in force."""

    code: str
    study: str
    age_range: str
    notes: str
    active_policy: int | None
    created_at: str
    updated_at: str


@dataclass(frozen=True)
class DayInfo:
    day: int
    opened_at: str
    closed_at: str | None

    @property
    def is_open(self) -> bool:
        return self.closed_at is None


@dataclass(frozen=True)
class PolicyVersion:
    """A policy checkpoint: adapted with ``method`` from days 1..``day`` (0: the initial policy)."""

    version: int
    day: int
    method: str
    path: Path
    sha256: str
    size: int
    created_at: str
    active: bool


@dataclass(frozen=True)
class ResumeInfo:
    """Where a participant's study stands, from the database alone.

    ``day``: the latest study day (0 before the first); ``day_open``: whether it is still open;
    ``interactions_today``: interactions recorded on ``day``; ``total_interactions``: all days;
    ``policy_version``: the policy in force (None: the initial policy).
    """

    day: int
    day_open: bool
    interactions_today: int
    total_interactions: int
    policy_version: int | None


_INTERACTION_SELECT = """
    SELECT p.code AS participant, i.method, i.day, i.idx AS "index", i.time, i.activity, i.scene,
           i.time_slot, i.interval_bin AS interval, i.task, i.previous_action, i.previous_response,
           i.type, i.robot_action, i.response, COALESCE(i.user_action, '') AS user_action,
           i.hour, i.interval_minutes, COALESCE(i.recognised_activity, '') AS recognised_activity,
           COALESCE(i.recognised_scene, '') AS recognised_scene,
           COALESCE(i.probabilities, '') AS probabilities, i.policy_version, s.name AS study,
           i.created_at
    FROM interactions i JOIN participants p ON p.id = i.participant_id
    JOIN studies s ON s.id = p.study_id
"""
#: Columns of the interactions export after the INTERACTION_COLUMNS contract.
INTERACTION_EXTRA_COLUMNS = ["hour", "interval_minutes", "recognised_activity", "recognised_scene",
                             "probabilities", "policy_version", "study", "created_at"]


class StudyStore:
    """The study database (SQLite, WAL, foreign keys on, schema version + migrations).

    ``StudyStore(path=None)`` opens ``path`` (default :func:`default_db_path`), creating the file
    and schema if missing. An existing file that is not a study database raises CacasError naming
    it. ``readonly=True`` opens an existing study database without creating or changing anything
    (writes then raise CacasError). Use as a context manager or call :meth:`close`.
    """

    def __init__(self, path: str | Path | None = None, readonly: bool = False):
        self.path = Path(path) if path is not None else default_db_path()
        self.readonly = readonly
        self._lock = threading.RLock()
        self._conn = db.connect(self.path, readonly=readonly)
        self._queue = None if readonly else db.WriterQueue(self.path)

    # --- plumbing ------------------------------------------------------------------------------
    @property
    def policy_dir(self) -> Path:
        """Folder of the policy checkpoints, beside the database file."""
        return self.path.parent / "policies"

    def close(self) -> None:
        with self._lock:
            self._conn.close()
            if self._queue is not None:
                self._queue.close()

    def __del__(self):  # a store dropped without close(): release the connection and lock file
        try:
            self.close()
        except Exception:
            pass

    def __enter__(self) -> "StudyStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _write(self, fn: Callable[[sqlite3.Connection], T]) -> T:
        if self.readonly:
            raise CacasError(f"{self.path}: opened read-only; nothing was written")
        with self._lock:
            return db.transact(self._conn, fn, self._queue)

    def _read(self, fn: Callable[[sqlite3.Connection], T]) -> T:
        with self._lock:
            return db.read(self._conn, fn)

    def _frame(self, sql: str, params: Sequence = ()) -> pd.DataFrame:
        with self._lock:
            cur = self._conn.execute(sql, params)
            cols = [d[0] for d in cur.description]
            return pd.DataFrame(cur.fetchall(), columns=cols)

    @staticmethod
    def _event(c: sqlite3.Connection, what: str, participant: str | None = None, **details: Any) -> None:
        c.execute("INSERT INTO events (at, what, participant, details) VALUES (?, ?, ?, ?)",
                  (v.now(), what, participant, json.dumps(details, sort_keys=True, default=str)))

    @staticmethod
    def _pid(c: sqlite3.Connection, code: Any) -> int:
        row = c.execute("SELECT id FROM participants WHERE code = ?", (str(code).strip(),)).fetchone()
        if row is None:
            known = [r[0] for r in c.execute("SELECT code FROM participants ORDER BY code LIMIT 21")]
            more = ", ..." if len(known) > 20 else ""
            listed = ", ".join(known[:20]) + more if known else "none yet; add one first"
            raise CacasError(f"unknown participant {code!r}; known participants: {listed}")
        return row[0]

    @staticmethod
    def _study_id(c: sqlite3.Connection, name: str) -> int:
        row = c.execute("SELECT id FROM studies WHERE name = ?", (name,)).fetchone()
        if row is None:
            known = ", ".join(r[0] for r in c.execute("SELECT name FROM studies ORDER BY name"))
            raise CacasError(f"unknown study {name!r}; known studies: {known}")
        return row[0]

    @staticmethod
    def _day_row(c: sqlite3.Connection, pid: int, code: str, day: Any):
        day = v.integer(day, "day", 1)
        row = c.execute("SELECT day, closed_at FROM days WHERE participant_id = ? AND day = ?",
                        (pid, day)).fetchone()
        if row is None:
            last = c.execute("SELECT MAX(day) FROM days WHERE participant_id = ?", (pid,)).fetchone()[0]
            have = f"days 1..{last}" if last else "no day yet; open day 1 first"
            raise CacasError(f"participant {code} has no day {day}; they have {have}")
        return row

    @staticmethod
    def _check_version(c: sqlite3.Connection, pid: int, code: str, version: Any) -> int | None:
        if version is None:
            return None
        version = v.integer(version, "policy version", 1)
        if c.execute("SELECT 1 FROM policies WHERE participant_id = ? AND version = ?",
                     (pid, version)).fetchone() is None:
            have = [r[0] for r in c.execute("SELECT version FROM policies WHERE participant_id = ? "
                                            "ORDER BY version", (pid,))]
            raise CacasError(f"participant {code} has no policy version {version}; saved versions: "
                             f"{', '.join(map(str, have)) or 'none (the initial policy is in force)'}")
        return version

    # --- studies -------------------------------------------------------------------------------
    def create_study(self, name: str, description: str = "") -> Study:
        """Add a study (a name unique in this database)."""
        name = v.study(name)
        description = v.text(description, "study description")
        at = v.now()

        def fn(c):
            if c.execute("SELECT 1 FROM studies WHERE name = ?", (name,)).fetchone():
                raise CacasError(f"study {name!r} already exists")
            c.execute("INSERT INTO studies (name, description, created_at) VALUES (?, ?, ?)",
                      (name, description, at))
            self._event(c, "create_study", None, study=name)
        self._write(fn)
        return Study(name, description, at)

    def studies(self) -> list[Study]:
        """All studies, by name ("default" always exists)."""
        with self._lock:
            rows = self._conn.execute("SELECT name, description, created_at FROM studies ORDER BY name")
            return [Study(*r) for r in rows]

    # --- participants --------------------------------------------------------------------------
    _PARTICIPANT_SQL = ("SELECT p.code, s.name, p.age_range, p.notes, p.active_policy, p.created_at, "
                        "p.updated_at FROM participants p JOIN studies s ON s.id = p.study_id")

    def add_participant(self, code: str, age_range: str = "", notes: str = "",
                        study: str = DEFAULT_STUDY) -> ParticipantInfo:
        """Add a participant under a pseudonymous ``code`` (1-16 letters, digits, "-", "_"; no
        names). ``age_range`` like "25-34" or "65+"; a code already in use raises CacasError."""
        code, age_range = v.code(code), v.age_range(age_range)
        notes, study = v.text(notes, "notes"), v.study(study)

        def fn(c):
            sid = self._study_id(c, study)
            if c.execute("SELECT 1 FROM participants WHERE code = ?", (code,)).fetchone():
                raise CacasError(f"participant {code} already exists; codes must be unique")
            at = v.now()
            c.execute("INSERT INTO participants (study_id, code, age_range, notes, created_at, updated_at) "
                      "VALUES (?, ?, ?, ?, ?, ?)", (sid, code, age_range, notes, at, at))
            self._event(c, "add_participant", code, study=study, age_range=age_range)
        self._write(fn)
        return self.get_participant(code)

    def update_participant(self, code: str, age_range: str | None = None,
                           notes: str | None = None) -> ParticipantInfo:
        """Change a participant's age range and/or notes (None: unchanged)."""
        age = None if age_range is None else v.age_range(age_range)
        notes = None if notes is None else v.text(notes, "notes")

        def fn(c):
            pid = self._pid(c, code)
            row = c.execute("SELECT age_range, notes FROM participants WHERE id = ?", (pid,)).fetchone()
            new = (row[0] if age is None else age, row[1] if notes is None else notes)
            c.execute("UPDATE participants SET age_range = ?, notes = ?, updated_at = ? WHERE id = ?",
                      (*new, v.now(), pid))
            self._event(c, "update_participant", str(code).strip(), age_range=new[0],
                        notes_changed=notes is not None)
        self._write(fn)
        return self.get_participant(code)

    def get_participant(self, code: str) -> ParticipantInfo:
        """One participant; an unknown code raises CacasError listing the known ones."""
        def fn(c):
            self._pid(c, code)
            row = c.execute(self._PARTICIPANT_SQL + " WHERE p.code = ?", (str(code).strip(),)).fetchone()
            return ParticipantInfo(*row)
        return self._read(fn)

    def list_participants(self, study: str | None = None) -> list[ParticipantInfo]:
        """Participants (of one study, or all), by code."""
        with self._lock:
            if study is None:
                rows = self._conn.execute(self._PARTICIPANT_SQL + " ORDER BY p.code")
            else:
                rows = self._conn.execute(self._PARTICIPANT_SQL + " WHERE s.name = ? ORDER BY p.code", (study,))
            return [ParticipantInfo(*r) for r in rows]

    def participants_frame(self, study: str | None = None) -> pd.DataFrame:
        """participants.csv: participant, study, age_range, notes, active_policy, created_at,
        updated_at, preference_version (latest saved, empty if none)."""
        sql = ("SELECT p.code AS participant, s.name AS study, p.age_range, p.notes, p.active_policy, "
               "p.created_at, p.updated_at, (SELECT MAX(version) FROM preferences f "
               "WHERE f.participant_id = p.id) AS preference_version "
               "FROM participants p JOIN studies s ON s.id = p.study_id")
        df = self._frame(sql + (" WHERE s.name = ?" if study else "") + " ORDER BY p.code",
                         (study,) if study else ())
        for col in ("active_policy", "preference_version"):
            df[col] = df[col].astype("Int64")
        return df

    # --- described preferences (persona format, design.md) ------------------------------------
    @staticmethod
    def _parse_preferences(code: str, preferences: Any) -> prefs.Participant:
        if isinstance(preferences, prefs.Participant):
            items = [p.to_dict() for p in preferences.preferences]
        else:
            items = [p.to_dict() if isinstance(p, prefs.Preference) else p for p in (preferences or [])]
        return prefs.parse_participant({"id": code, "preferences": items})

    def save_preferences(self, code: str, preferences: Any) -> int:
        """Store a participant's described preferences as a new version; return the version.

        ``preferences``: a list of Preference objects or persona-format dicts, or a
        :class:`cacas.preferences.Participant`. Validated with
        :func:`cacas.preferences.parse_participant` (fields, names, conflicts); an invalid one
        raises CacasError naming the preference and field, and nothing is written.
        """
        code = str(code).strip()
        person = self._parse_preferences(code, preferences)
        payload = json.dumps([p.to_dict() for p in person.preferences], ensure_ascii=False)

        def fn(c):
            pid = self._pid(c, code)
            version = c.execute("SELECT COALESCE(MAX(version), 0) + 1 FROM preferences WHERE participant_id = ?",
                                (pid,)).fetchone()[0]
            c.execute("INSERT INTO preferences (participant_id, version, preferences, created_at) "
                      "VALUES (?, ?, ?, ?)", (pid, version, payload, v.now()))
            self._event(c, "save_preferences", code, version=version, count=len(person.preferences))
            return version
        return self._write(fn)

    def get_preferences(self, code: str, version: int | None = None) -> prefs.Participant | None:
        """The participant's described preferences (latest version, or ``version``); None if none saved."""
        def fn(c):
            pid = self._pid(c, code)
            if version is None:
                row = c.execute("SELECT preferences FROM preferences WHERE participant_id = ? "
                                "ORDER BY version DESC LIMIT 1", (pid,)).fetchone()
            else:
                row = c.execute("SELECT preferences FROM preferences WHERE participant_id = ? AND version = ?",
                                (pid, v.integer(version, "preference version", 1))).fetchone()
                if row is None:
                    raise CacasError(f"participant {code} has no preference version {version}")
            return row
        row = self._read(fn)
        return None if row is None else self._parse_preferences(str(code).strip(), json.loads(row[0]))

    def preference_versions(self, code: str) -> list[dict]:
        """Saved versions: [{"version", "created_at", "count"}], oldest first."""
        def fn(c):
            pid = self._pid(c, code)
            return c.execute("SELECT version, created_at, preferences FROM preferences "
                             "WHERE participant_id = ? ORDER BY version", (pid,)).fetchall()
        return [{"version": r[0], "created_at": r[1], "count": len(json.loads(r[2]))} for r in self._read(fn)]

    def export_personas(self, codes: Iterable[str] | None = None, study: str | None = None) -> str:
        """The persona file text (design.md) of the latest preferences of these participants
        (default: all, or all of ``study``); participants with no preferences are left out."""
        wanted = [p.code for p in self.list_participants(study)] if codes is None else list(codes)
        people = [p for p in (self.get_preferences(c) for c in wanted) if p is not None]
        return prefs.dumps_personas(people)

    def import_personas(self, data: Any, study: str = DEFAULT_STUDY, source: str | None = None) -> list[str]:
        """Import a persona document (JSON text or parsed JSON): add participants that are
        missing (to ``study``) and save each one's preferences as a new version. All or nothing:
        one invalid participant or preference raises CacasError and nothing is written."""
        if isinstance(data, (str, bytes)):
            try:
                data = json.loads(data)
            except json.JSONDecodeError as exc:
                raise CacasError(f"{source or 'persona file'}: not valid JSON (line {exc.lineno}, "
                                 f"column {exc.colno}: {exc.msg})") from None
        people = prefs.parse_personas(data, source)
        for p in people:
            v.code(p.id)
        study = v.study(study)

        def fn(c):
            sid = self._study_id(c, study)
            for p in people:
                at = v.now()
                row = c.execute("SELECT id FROM participants WHERE code = ?", (p.id,)).fetchone()
                if row is None:
                    c.execute("INSERT INTO participants (study_id, code, created_at, updated_at) "
                              "VALUES (?, ?, ?, ?)", (sid, p.id, at, at))
                    self._event(c, "add_participant", p.id, study=study, source="personas")
                pid = self._pid(c, p.id)
                version = c.execute("SELECT COALESCE(MAX(version), 0) + 1 FROM preferences "
                                    "WHERE participant_id = ?", (pid,)).fetchone()[0]
                payload = json.dumps([x.to_dict() for x in p.preferences], ensure_ascii=False)
                c.execute("INSERT INTO preferences (participant_id, version, preferences, created_at) "
                          "VALUES (?, ?, ?, ?)", (pid, version, payload, at))
                self._event(c, "save_preferences", p.id, version=version, count=len(p.preferences),
                            source="personas")
        self._write(fn)
        return [p.id for p in people]

    def preferences_frame(self, study: str | None = None) -> pd.DataFrame:
        """preferences.csv: participant, version, preferences (persona-format JSON list), created_at."""
        sql = ("SELECT p.code AS participant, f.version, f.preferences, f.created_at FROM preferences f "
               "JOIN participants p ON p.id = f.participant_id JOIN studies s ON s.id = p.study_id")
        return self._frame(sql + (" WHERE s.name = ?" if study else "") + " ORDER BY p.code, f.version",
                           (study,) if study else ())

    # --- study days ----------------------------------------------------------------------------
    def open_day(self, participant: str) -> int:
        """Open the participant's next study day and return its number (1..n).

        If the latest day is still open, it is returned as is (a page reload opens nothing new).
        """
        def fn(c):
            pid = self._pid(c, participant)
            row = c.execute("SELECT day, closed_at FROM days WHERE participant_id = ? ORDER BY day DESC LIMIT 1",
                            (pid,)).fetchone()
            if row is not None and row[1] is None:
                return row[0]
            day = 1 if row is None else row[0] + 1
            c.execute("INSERT INTO days (participant_id, day, opened_at) VALUES (?, ?, ?)", (pid, day, v.now()))
            self._event(c, "open_day", str(participant).strip(), day=day)
            return day
        return self._write(fn)

    def close_day(self, participant: str, day: int) -> None:
        """Close a study day (then adapt the policy). Closing a closed day changes nothing;
        a day that does not exist raises CacasError."""
        def fn(c):
            pid = self._pid(c, participant)
            row = self._day_row(c, pid, participant, day)
            if row[1] is not None:
                return
            n = c.execute("SELECT COUNT(*) FROM interactions WHERE participant_id = ? AND day = ?",
                          (pid, day)).fetchone()[0]
            c.execute("UPDATE days SET closed_at = ? WHERE participant_id = ? AND day = ?", (v.now(), pid, day))
            self._event(c, "close_day", str(participant).strip(), day=day, interactions=n)
        self._write(fn)

    def current_day(self, participant: str) -> int | None:
        """The participant's latest study day (open or closed); None before the first."""
        def fn(c):
            pid = self._pid(c, participant)
            return c.execute("SELECT MAX(day) FROM days WHERE participant_id = ?", (pid,)).fetchone()[0]
        return self._read(fn)

    def days(self, participant: str) -> list[DayInfo]:
        """All study days of a participant, in order."""
        def fn(c):
            pid = self._pid(c, participant)
            return c.execute("SELECT day, opened_at, closed_at FROM days WHERE participant_id = ? ORDER BY day",
                             (pid,)).fetchall()
        return [DayInfo(*r) for r in self._read(fn)]

    def days_frame(self, study: str | None = None) -> pd.DataFrame:
        """days.csv: participant, day, opened_at, closed_at (empty while open)."""
        sql = ("SELECT p.code AS participant, d.day, d.opened_at, COALESCE(d.closed_at, '') AS closed_at "
               "FROM days d JOIN participants p ON p.id = d.participant_id JOIN studies s ON s.id = p.study_id")
        return self._frame(sql + (" WHERE s.name = ?" if study else "") + " ORDER BY p.code, d.day",
                           (study,) if study else ())

    # --- interactions --------------------------------------------------------------------------
    def record_interaction(self, participant: str, day: int, *, activity: str, scene: str,
                           robot_action: str, response: str, type: str = ROBOT_INITIATED,
                           hour: float | None = None, time_slot: int | None = None,
                           interval_minutes: float | None = None, interval_bin: int | None = None,
                           task: str = "do nothing", previous_action: str = "do nothing",
                           previous_response: str = "others", user_action: str | None = None,
                           probabilities: Sequence[float] | None = None,
                           recognised_activity: str | None = None, recognised_scene: str | None = None,
                           policy_version: int | None = None, method: str | None = None,
                           time: Any = None) -> int:
        """Record one interaction of an open study day; return its row id once committed.

        The context as set (Table I): ``activity`` S1, ``scene`` S2, ``hour`` (0 <= h < 24) or
        ``time_slot`` (0..11) S3, ``interval_minutes`` (>= 0) or ``interval_bin`` (0..11) S4,
        ``task`` S5; ``previous_action`` / ``previous_response`` are S6 / S7 of the policy state.
        ``recognised_activity`` / ``recognised_scene``: what the recognisers reported.
        ``type``: "type_1" (robot-initiated) or "type_2" (user-initiated, Table II; then
        ``user_action`` is the requested action, not "do nothing"). ``robot_action`` with the
        policy's 14 ``probabilities`` (Eq. 4; a list in Table I's order or a dict by action name),
        ``response`` accept / reject / others. ``policy_version``: default the participant's
        active policy; ``method``: default the method of that policy, else "cacas". ``time``:
        when it happened (default now). Any bad name or value raises CacasError and nothing is
        written; so does a participant or day that does not exist, or a closed day.
        """
        values = dict(
            activity=v.name("activity", activity, "activity"),
            scene=v.name("scene", scene, "scene"),
            task=v.name("action", task, "task"),
            previous_action=v.name("action", previous_action, "previous_action"),
            previous_response=v.name("response", previous_response, "previous_response"),
            robot_action=v.name("action", robot_action, "robot_action"),
            response=v.name("response", response, "response"),
            type=v.conversation_type(type),
            recognised_activity=None if recognised_activity is None else
            v.name("activity", recognised_activity, "recognised_activity"),
            recognised_scene=None if recognised_scene is None else
            v.name("scene", recognised_scene, "recognised_scene"),
            probabilities=v.probabilities(probabilities),
            time=v.timestamp(time),
        )
        values["hour"], values["time_slot"] = v.time_slot(hour, time_slot)
        values["interval_minutes"], values["interval_bin"] = v.interval(interval_minutes, interval_bin)
        if values["type"] == USER_INITIATED:
            if user_action is None:
                raise CacasError("user_action is missing: a user-initiated (type_2) interaction names the "
                                 "action the participant asked for")
            values["user_action"] = v.name("action", user_action, "user_action")
            if values["user_action"] == "do nothing":
                raise CacasError("user_action 'do nothing' is not a request; valid: one of the 13 other actions")
        else:
            if user_action not in (None, ""):
                raise CacasError(f"user_action {user_action!r} given for a robot-initiated (type_1) "
                                 f"interaction; only type_2 interactions have one")
            values["user_action"] = None
        if method is not None:
            method = v.method(method)
        code, day = str(participant).strip(), v.integer(day, "day", 1)

        def fn(c):
            pid = self._pid(c, participant)
            row = self._day_row(c, pid, code, day)
            if row[1] is not None:
                raise CacasError(f"day {day} of participant {code} is closed; open the next day to record more")
            version = self._check_version(c, pid, code, policy_version)
            if version is None and policy_version is None:
                version = c.execute("SELECT active_policy FROM participants WHERE id = ?", (pid,)).fetchone()[0]
            m = method
            if m is None and version is not None:
                m = c.execute("SELECT method FROM policies WHERE participant_id = ? AND version = ?",
                              (pid, version)).fetchone()[0]
            m = m or "cacas"
            idx = c.execute("SELECT COALESCE(MAX(idx), 0) + 1 FROM interactions WHERE participant_id = ? AND day = ?",
                            (pid, day)).fetchone()[0]
            cols = ["participant_id", "day", "idx", "method", "policy_version", "created_at", *values]
            vals = [pid, day, idx, m, version, v.now(), *values.values()]
            cur = c.execute(f"INSERT INTO interactions ({', '.join(cols)}) VALUES ({', '.join('?' * len(cols))})",
                            vals)
            self._event(c, "record_interaction", code, day=day, index=idx, id=cur.lastrowid,
                        type=values["type"], robot_action=values["robot_action"], response=values["response"])
            return cur.lastrowid
        return self._write(fn)

    def interactions_frame(self, participant: str | None = None, method: str | None = "cacas",
                           study: str | None = None, extra: bool = False) -> pd.DataFrame:
        """The user data: one row per interaction with exactly
        :data:`cacas.records.INTERACTION_COLUMNS` (``extra=True`` appends
        :data:`INTERACTION_EXTRA_COLUMNS`: hour, interval_minutes, recognised activity and scene,
        the policy's probabilities as JSON, policy version, study, created_at).

        As ``cacas simulate`` writes them: ``time_slot`` is the S3 index (0..11), ``interval``
        the S4 bin's value in minutes (one of :data:`cacas.spaces.INTERVAL_BINS`, e.g. 10 for 12
        minutes), ``user_action`` "" for type_1; ``time`` is the wall-clock timestamp (UTC,
        ISO 8601) at which it was recorded. Filters: one participant (unknown -> CacasError), one
        ``method`` (None: all), one ``study``. Sorted by participant, day, index.
        """
        where, params = [], []
        if participant is not None:
            self._read(lambda c: self._pid(c, participant))
            where.append("p.code = ?")
            params.append(str(participant).strip())
        if method is not None:
            where.append("i.method = ?")
            params.append(method)
        if study is not None:
            where.append("s.name = ?")
            params.append(study)
        sql = _INTERACTION_SELECT + (" WHERE " + " AND ".join(where) if where else "")
        df = self._frame(sql + " ORDER BY p.code, i.day, i.idx", params)
        df["interval"] = [spaces.INTERVAL_BINS[int(b)] for b in df["interval"]]  # S4 bin -> its minutes
        df["policy_version"] = df["policy_version"].astype("Int64")
        for col in ("day", "index", "time_slot", "interval"):
            df[col] = df[col].astype("int64")
        for col in ("hour", "interval_minutes"):
            df[col] = df[col].astype("float64")
        cols = INTERACTION_COLUMNS + (INTERACTION_EXTRA_COLUMNS if extra else [])
        return df[cols].reset_index(drop=True)

    # --- adaptation runs and policy checkpoints (CACAA, Table III) -----------------------------
    def record_adaptation(self, participant: str, day: int, method: str, parameters: dict,
                          duration_s: float, metrics: dict, policy_version: int | None = None) -> int:
        """Record an adaptation run that used days 1..``day`` (0: the initial policy) with
        ``method``; ``parameters`` and ``metrics`` are JSON-able dicts (metrics key
        "preference_accuracy" feeds daily.csv), ``policy_version`` the checkpoint it produced.
        Returns the run's id."""
        method = v.method(method)
        day = v.integer(day, "day", 0)  # 0: the initial policy
        params_json, metrics_json = v.json_dict(parameters, "parameters"), v.json_dict(metrics, "metrics")
        duration = v.number(duration_s, "duration_s", 0)
        code = str(participant).strip()

        def fn(c):
            pid = self._pid(c, participant)
            if day:
                self._day_row(c, pid, code, day)
            version = self._check_version(c, pid, code, policy_version)
            cur = c.execute("INSERT INTO adaptations (participant_id, day, method, parameters, duration_s, "
                            "metrics, policy_version, created_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                            (pid, day, method, params_json, duration, metrics_json, version, v.now()))
            self._event(c, "record_adaptation", code, day=day, method=method, id=cur.lastrowid,
                        duration_s=duration, policy_version=version)
            return cur.lastrowid
        return self._write(fn)

    def adaptations_frame(self, participant: str | None = None, study: str | None = None) -> pd.DataFrame:
        """adaptations.csv: participant, day, method, parameters (JSON), duration_s, metrics
        (JSON), policy_version, created_at, preference_accuracy (from metrics; NaN if absent)."""
        sql = ("SELECT p.code AS participant, a.day, a.method, a.parameters, a.duration_s, a.metrics, "
               "a.policy_version, a.created_at FROM adaptations a JOIN participants p ON p.id = a.participant_id "
               "JOIN studies s ON s.id = p.study_id")
        where, params = [], []
        if participant is not None:
            where.append("p.code = ?")
            params.append(str(participant).strip())
        if study is not None:
            where.append("s.name = ?")
            params.append(study)
        df = self._frame(sql + (" WHERE " + " AND ".join(where) if where else "") + " ORDER BY a.id", params)
        df["policy_version"] = df["policy_version"].astype("Int64")
        df["duration_s"] = df["duration_s"].astype("float64")
        df["preference_accuracy"] = [pd.to_numeric(json.loads(m).get("preference_accuracy"), errors="coerce")
                                     for m in df["metrics"]]
        df["preference_accuracy"] = df["preference_accuracy"].astype("float64")
        return df

    def save_policy(self, participant: str, day: int, method: str, data: bytes, activate: bool = True) -> int:
        """Store a policy checkpoint adapted from days 1..``day`` (0: the initial policy).

        The bytes go to ``policies/<participant>/day<d>-<method>-<sha8>.pt`` beside the database,
        written atomically (tmp + fsync + rename); the row records its sha256. Returns the new
        version number (1..n per participant); with ``activate`` it becomes the policy in force.
        """
        method, day = v.method(method), v.integer(day, "day", 0)
        if not isinstance(data, (bytes, bytearray)) or not data:
            raise CacasError("policy data must be non-empty bytes (ReshapedPolicy.to_bytes())")
        code = v.code(participant)
        digest = files.sha256(bytes(data))
        rel = f"{code}/day{day}-{method}-{digest[:8]}.pt"

        def check(c):
            pid = self._pid(c, code)
            if day:
                self._day_row(c, pid, code, day)
        self._read(check)  # refuse before writing a file
        if self.readonly:
            raise CacasError(f"{self.path}: opened read-only; nothing was written")
        files.atomic_write(self.policy_dir / rel, bytes(data))

        def fn(c):
            pid = self._pid(c, code)
            version = c.execute("SELECT COALESCE(MAX(version), 0) + 1 FROM policies WHERE participant_id = ?",
                                (pid,)).fetchone()[0]
            c.execute("INSERT INTO policies (participant_id, version, day, method, path, sha256, size, created_at) "
                      "VALUES (?, ?, ?, ?, ?, ?, ?, ?)", (pid, version, day, method, rel, digest, len(data), v.now()))
            if activate:
                c.execute("UPDATE participants SET active_policy = ?, updated_at = ? WHERE id = ?",
                          (version, v.now(), pid))
            self._event(c, "save_policy", code, version=version, day=day, method=method, sha256=digest,
                        active=activate)
            return version
        return self._write(fn)

    def _policy_rows(self, c, pid: int, where: str = "", params: Sequence = ()) -> list[PolicyVersion]:
        active = c.execute("SELECT active_policy FROM participants WHERE id = ?", (pid,)).fetchone()[0]
        rows = c.execute("SELECT version, day, method, path, sha256, size, created_at FROM policies "
                         f"WHERE participant_id = ? {where} ORDER BY version", (pid, *params)).fetchall()
        return [PolicyVersion(r[0], r[1], r[2], self.policy_dir / r[3], r[4], r[5], r[6], r[0] == active)
                for r in rows]

    def policy_versions(self, participant: str) -> list[PolicyVersion]:
        """All policy checkpoints of a participant, oldest first (``active`` marks the one in force)."""
        return self._read(lambda c: self._policy_rows(c, self._pid(c, participant)))

    def active_policy(self, participant: str) -> PolicyVersion | None:
        """The checkpoint in force; None: the initial policy."""
        return next((p for p in self.policy_versions(participant) if p.active), None)

    def set_active_policy(self, participant: str, version: int | None) -> None:
        """Put a saved version in force (roll back or forward); None: back to the initial policy."""
        code = str(participant).strip()

        def fn(c):
            pid = self._pid(c, participant)
            ver = self._check_version(c, pid, code, version)
            c.execute("UPDATE participants SET active_policy = ?, updated_at = ? WHERE id = ?", (ver, v.now(), pid))
            self._event(c, "set_active_policy", code, version=ver)
        self._write(fn)

    def load_policy(self, participant: str, day: int | None = None, method: str = "cacas",
                    version: int | None = None) -> bytes:
        """The bytes of a checkpoint, after checking its sha256 (a mismatch or a missing file
        raises CacasError). Which one: ``version`` if given; else the latest of ``method`` saved
        for ``day``; else the active policy, or failing that the latest of ``method``."""
        code = str(participant).strip()

        def fn(c):
            pid = self._pid(c, participant)
            if version is not None:
                rows = self._policy_rows(c, pid, "AND version = ?", (v.integer(version, "policy version", 1),))
                what = f"version {version}"
            elif day is not None:
                rows = self._policy_rows(c, pid, "AND day = ? AND method = ?", (day, method))
                what = f"day {day} and method {method!r}"
            else:
                rows = [p for p in self._policy_rows(c, pid) if p.active] or \
                       self._policy_rows(c, pid, "AND method = ?", (method,))
                what = f"method {method!r}"
            if not rows:
                raise CacasError(f"participant {code} has no saved policy for {what}")
            return rows[-1]
        pv = self._read(fn)
        try:
            data = pv.path.read_bytes()
        except OSError:
            raise CacasError(f"{pv.path}: policy version {pv.version} of participant {code} is missing") from None
        if files.sha256(data) != pv.sha256:
            raise CacasError(f"{pv.path}: policy version {pv.version} of participant {code} does not match "
                             f"its recorded sha256 (the file was changed or damaged)")
        return data

    def policies_frame(self, study: str | None = None) -> pd.DataFrame:
        """policies.csv: participant, version, day, method, path (relative to the policies
        folder), sha256, size, created_at, active."""
        sql = ("SELECT p.code AS participant, o.version, o.day, o.method, o.path, o.sha256, o.size, o.created_at, "
               "CAST(o.version = p.active_policy AS INTEGER) AS active FROM policies o "
               "JOIN participants p ON p.id = o.participant_id JOIN studies s ON s.id = p.study_id")
        return self._frame(sql + (" WHERE s.name = ?" if study else "") + " ORDER BY p.code, o.version",
                           (study,) if study else ())

    # --- questionnaire (Section V-B.1) ---------------------------------------------------------
    def record_questionnaire(self, participant: str, satisfaction: int, comments: str = "") -> int:
        """The post-test question "What is your satisfaction level regarding the robot's ability to
        adapt to your preferences?": ``satisfaction`` 1 (very dissatisfied) .. 10 (very
        satisfied), with free-text ``comments``. Returns the row id."""
        score, comments = v.satisfaction(satisfaction), v.text(comments, "comments")
        code = str(participant).strip()

        def fn(c):
            pid = self._pid(c, participant)
            cur = c.execute("INSERT INTO questionnaires (participant_id, satisfaction, comments, created_at) "
                            "VALUES (?, ?, ?, ?)", (pid, score, comments, v.now()))
            self._event(c, "record_questionnaire", code, satisfaction=score, id=cur.lastrowid)
            return cur.lastrowid
        return self._write(fn)

    def questionnaire_frame(self, study: str | None = None) -> pd.DataFrame:
        """questionnaire.csv: participant, satisfaction, comments, created_at (every answer)."""
        sql = ("SELECT p.code AS participant, q.satisfaction, q.comments, q.created_at FROM questionnaires q "
               "JOIN participants p ON p.id = q.participant_id JOIN studies s ON s.id = p.study_id")
        return self._frame(sql + (" WHERE s.name = ?" if study else "") + " ORDER BY q.id",
                           (study,) if study else ())

    # --- event log and resume ------------------------------------------------------------------
    def events(self, participant: str | None = None, what: str | None = None,
               limit: int | None = None) -> pd.DataFrame:
        """The event log (newest last): id, at, what, participant, details (JSON); optionally of
        one participant or kind, the last ``limit`` only."""
        where, params = [], []
        if participant is not None:
            where.append("participant = ?")
            params.append(str(participant).strip())
        if what is not None:
            where.append("what = ?")
            params.append(what)
        sql = "SELECT id, at, what, participant, details FROM events" + \
              (" WHERE " + " AND ".join(where) if where else "") + " ORDER BY id DESC"
        if limit is not None:
            sql += f" LIMIT {v.integer(limit, 'limit', 0)}"
        return self._frame(sql, params).iloc[::-1].reset_index(drop=True)

    def resume(self, participant: str) -> ResumeInfo:
        """Where the participant's study stands: latest day, open or not, interactions on it and
        in all, the policy version in force (all read in one snapshot)."""
        def fn(c):
            pid = self._pid(c, participant)
            row = c.execute("SELECT day, closed_at FROM days WHERE participant_id = ? ORDER BY day DESC LIMIT 1",
                            (pid,)).fetchone()
            day, is_open = (0, False) if row is None else (row[0], row[1] is None)
            today = c.execute("SELECT COUNT(*) FROM interactions WHERE participant_id = ? AND day = ?",
                              (pid, day)).fetchone()[0]
            total = c.execute("SELECT COUNT(*) FROM interactions WHERE participant_id = ?", (pid,)).fetchone()[0]
            active = c.execute("SELECT active_policy FROM participants WHERE id = ?", (pid,)).fetchone()[0]
            return ResumeInfo(day, is_open, today, total, active)
        return self._read(fn)
