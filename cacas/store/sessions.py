"""Study days and interactions (the user data of Table II), and resuming a participant."""

from __future__ import annotations

from typing import Any, Sequence

import pandas as pd

from cacas import spaces
from cacas.errors import AlreadyRecorded, CacasError
from cacas.records import INTERACTION_COLUMNS, ROBOT_INITIATED
from cacas.store import validate as v
from cacas.store.base import DayInfo, ResumeInfo

_INTERACTION_SELECT = """
    SELECT p.code AS participant, i.method, i.day, i.idx AS "index", i.time, i.activity, i.scene,
           i.time_slot, i.interval_bin AS interval, i.task, i.previous_action, i.previous_response,
           i.type, i.robot_action, i.response, COALESCE(i.user_action, '') AS user_action,
           i.hour, i.interval_minutes, COALESCE(i.recognised_activity, '') AS recognised_activity,
           COALESCE(i.recognised_scene, '') AS recognised_scene,
           COALESCE(i.sound_model, '') AS sound_model, COALESCE(i.scene_model, '') AS scene_model,
           COALESCE(i.probabilities, '') AS probabilities, i.policy_version, s.name AS study,
           i.created_at
    FROM interactions i JOIN participants p ON p.id = i.participant_id
    JOIN studies s ON s.id = p.study_id
"""
#: Columns of the interactions export after the INTERACTION_COLUMNS contract.
INTERACTION_EXTRA_COLUMNS = ["hour", "interval_minutes", "recognised_activity", "recognised_scene",
                             "sound_model", "scene_model", "probabilities", "policy_version", "study",
                             "created_at"]


class SessionsMixin:
    """Method group of StudyStore: study days, interactions, resume."""

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
        a day that does not exist raises CacasError. ``day`` may be any integer, e.g. numpy's
        from a frame (given to SQLite as it was, it matched no row: the day stayed open)."""
        day = v.integer(day, "day", 1)

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
        return self._frame(sql + (" WHERE s.name = ?" if study is not None else "") + " ORDER BY p.code, d.day",
                           (study,) if study is not None else ())

    # --- interactions --------------------------------------------------------------------------
    def record_interaction(self, participant: str, day: int, *, activity: str, scene: str,
                           robot_action: str, response: str, type: str = ROBOT_INITIATED,
                           hour: float | None = None, time_slot: int | None = None,
                           interval_minutes: float | None = None, interval_bin: int | None = None,
                           task: str = "do nothing", previous_action: str = "do nothing",
                           previous_response: str = "others", user_action: str | None = None,
                           probabilities: Sequence[float] | None = None,
                           recognised_activity: str | None = None, recognised_scene: str | None = None,
                           sound_model: str | None = None, scene_model: str | None = None,
                           policy_version: int | None = None, method: str | None = None,
                           time: Any = None, index: int | None = None) -> int:
        """Record one interaction of an open study day; return its row id once committed.

        The context as set (Table I): ``activity`` S1, ``scene`` S2, ``hour`` (0 <= h < 24) or
        ``time_slot`` (0..11) S3, ``interval_minutes`` (>= 0) or ``interval_bin`` (0..11) S4,
        ``task`` S5; ``previous_action`` / ``previous_response`` are S6 / S7 of the policy state.
        ``recognised_activity`` / ``recognised_scene``: what the recognisers reported;
        ``sound_model`` / ``scene_model``: which saved models did (:func:`cacas.recognition.model_id`).
        ``type``: "type_1" (robot-initiated) or "type_2" (user-initiated, Table II; then
        ``user_action`` is the requested action, not "do nothing"). ``robot_action`` with the
        policy's 14 ``probabilities`` (Eq. 4; a list in Table I's order or a dict by action name),
        ``response`` accept / reject / others. ``policy_version``: default the participant's
        active policy; ``method``: default the method of that policy, else "cacas". ``time``:
        when it happened (default now), an aware datetime or an ISO 8601 text with a time zone,
        stored in UTC as the app's own times (:func:`validate.timestamp`; a time without a zone,
        or a date alone, is refused). Any bad name or value raises CacasError and nothing is
        written; so does a participant or day that does not exist, or a closed day. ``index``:
        the day's interaction number (1..) this answer is for; if it is taken already (a second
        click, another tab), nothing is written and :class:`~cacas.errors.AlreadyRecorded` is
        raised (checked in the same transaction as the write).
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
            sound_model=v.model_id(sound_model, "sound_model"),
            scene_model=v.model_id(scene_model, "scene_model"),
            probabilities=v.probabilities(probabilities),
            time=v.timestamp(time),
        )
        values["hour"], values["time_slot"] = v.time_slot(hour, time_slot)
        values["interval_minutes"], values["interval_bin"] = v.interval(interval_minutes, interval_bin)
        values["user_action"] = v.user_action(values["type"], user_action, values["response"], values["robot_action"])
        if method is not None:
            method = v.method(method)
        code, day = str(participant).strip(), v.integer(day, "day", 1)
        expected = None if index is None else v.integer(index, "index", 1)

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
            if expected is not None and expected != idx:
                raise AlreadyRecorded(f"interaction {expected} of day {day} of participant {code} is recorded "
                                      f"already; the next one is {idx}")
            cols = ["participant_id", "day", "idx", "method", "policy_version", "created_at", *values]
            vals = [pid, day, idx, m, version, v.now(), *values.values()]
            cur = c.execute(f"INSERT INTO interactions ({', '.join(cols)}) VALUES ({', '.join('?' * len(cols))})",
                            vals)
            self._event(c, "record_interaction", code, day=day, index=idx, id=cur.lastrowid,
                        type=values["type"], robot_action=values["robot_action"], response=values["response"],
                        user_action=values.get("user_action") or None)
            return cur.lastrowid
        return self._write(fn)

    def interactions_frame(self, participant: str | None = None, method: str | None = None,
                           study: str | None = None, extra: bool = False, day: int | None = None) -> pd.DataFrame:
        """The user data: one row per interaction with exactly
        :data:`cacas.records.INTERACTION_COLUMNS` (``extra=True`` appends
        :data:`INTERACTION_EXTRA_COLUMNS`: hour, interval_minutes, recognised activity and scene,
        the ids of the sound and scene models that recognised them, the policy's probabilities as
        JSON, policy version, study, created_at).

        As ``cacas simulate`` writes them: ``time_slot`` is the S3 index (0..11), ``interval``
        the S4 bin's value in minutes (one of :data:`cacas.spaces.INTERVAL_BINS`, e.g. 10 for 12
        minutes), ``user_action`` "" for type_1; ``time`` is the wall-clock timestamp (UTC,
        ISO 8601) at which it was recorded. Filters: one participant (unknown -> CacasError), one
        ``method`` (the method of the policy in force; default None: all, the participant's one
        stream of user data, whichever policy was in force), one ``study``, one ``day``. Sorted by
        participant, day, index.
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
        if day is not None:
            where.append("i.day = ?")
            params.append(v.integer(day, "day", 1))
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

    # --- resume ------------------------------------------------------------------------------------
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
