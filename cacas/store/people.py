"""Studies, participants (pseudonymous codes) and their described preferences (versioned)."""

from __future__ import annotations

import json
from typing import Any, Iterable

import pandas as pd

from cacas import preferences as prefs
from cacas.errors import CacasError
from cacas.store import validate as v
from cacas.store.base import DEFAULT_STUDY, ParticipantInfo, Study


class PeopleMixin:
    """Method group of StudyStore: studies, participants, described preferences."""

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
            self._check_new_code(c, code)
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
        """Store a participant's described preferences as a new version; return the version
        (preferences equal to the latest version are not stored again: its number is returned).

        ``preferences``: a list of Preference objects or persona-format dicts, or a
        :class:`cacas.preferences.Participant`. Validated with
        :func:`cacas.preferences.parse_participant` (fields, names, conflicts); an invalid one
        raises CacasError naming the preference and field, and nothing is written.
        """
        code = str(code).strip()
        person = self._parse_preferences(code, preferences)
        prefs.check_private_words(person)  # on the way in only: versions saved before the check still read

        def fn(c):
            return self._save_version(c, self._pid(c, code), code, person)
        return self._write(fn)

    @staticmethod
    def _check_new_code(c, code: str) -> None:
        """A new code must differ from every code in use, also in letter case (P01 and p01 would
        be two participants a reader takes for one)."""
        row = c.execute("SELECT code FROM participants WHERE code = ? COLLATE NOCASE", (code,)).fetchone()
        if row is not None:
            same = "already exists" if row[0] == code else f"differs from participant {row[0]} only in letter case"
            raise CacasError(f"participant {code} {same}; codes must be unique")

    def _save_version(self, c, pid: int, code: str, person: prefs.Participant, **event: Any) -> int:
        """Write ``person``'s preferences as the participant's next version, unless they equal the
        latest one (then nothing is written); return the version now in force."""
        items = [p.to_dict() for p in person.preferences]
        latest = c.execute("SELECT version, preferences FROM preferences WHERE participant_id = ? "
                           "ORDER BY version DESC LIMIT 1", (pid,)).fetchone()
        if latest is not None and json.loads(latest[1]) == items:
            return latest[0]
        payload = json.dumps(items, ensure_ascii=False)
        version = 1 if latest is None else latest[0] + 1
        c.execute("INSERT INTO preferences (participant_id, version, preferences, created_at) "
                  "VALUES (?, ?, ?, ?)", (pid, version, payload, v.now()))
        self._event(c, "save_preferences", code, version=version, count=len(person.preferences), **event)
        return version

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
        missing (to ``study``) and save each one's preferences as a new version (unless they equal
        the latest). All or nothing: one invalid participant or preference, a participant of
        another study, or a code that differs from one in use only in letter case raises
        CacasError and nothing is written."""
        if isinstance(data, (str, bytes)):
            data = prefs.persona_json(data, source or "persona file")
        people = prefs.parse_personas(data, source)
        v.persona_codes(people, source)
        for person in people:
            prefs.check_private_words(person, source)
        study = v.study(study)

        def fn(c):
            sid = self._study_id(c, study)
            for p in people:  # check every code first: all or nothing (case twins within the file: parse_personas)
                row = c.execute("SELECT s.name FROM participants p JOIN studies s ON s.id = p.study_id "
                                "WHERE p.code = ?", (p.id,)).fetchone()
                if row is None:
                    self._check_new_code(c, p.id)  # a new participant: not a case twin of a code in use
                elif row[0] != study:
                    raise CacasError(f"{source or 'persona file'}: participant {p.id} belongs to study {row[0]!r}, "
                                     f"not {study!r}; nothing was imported. Import into study {row[0]!r}, or give "
                                     "the new participant a code not in use")
            for p in people:
                if c.execute("SELECT 1 FROM participants WHERE code = ?", (p.id,)).fetchone() is None:
                    at = v.now()
                    c.execute("INSERT INTO participants (study_id, code, created_at, updated_at) "
                              "VALUES (?, ?, ?, ?)", (sid, p.id, at, at))
                    self._event(c, "add_participant", p.id, study=study, source="personas")
                self._save_version(c, self._pid(c, p.id), p.id, p, source="personas")
        self._write(fn)
        return [p.id for p in people]

    def preferences_frame(self, study: str | None = None) -> pd.DataFrame:
        """preferences.csv: participant, version, preferences (persona-format JSON list), created_at."""
        sql = ("SELECT p.code AS participant, f.version, f.preferences, f.created_at FROM preferences f "
               "JOIN participants p ON p.id = f.participant_id JOIN studies s ON s.id = p.study_id")
        return self._frame(sql + (" WHERE s.name = ?" if study else "") + " ORDER BY p.code, f.version",
                           (study,) if study else ())
