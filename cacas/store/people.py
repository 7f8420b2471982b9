"""Studies, participants (pseudonymous codes) and their described preferences (versioned)."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import time
from dataclasses import dataclass
from typing import Any, Iterable

import pandas as pd

from cacas import preferences as prefs
from cacas import records
from cacas.errors import CacasError
from cacas.store import files, recovery
from cacas.store import validate as v
from cacas.store.base import DEFAULT_STUDY, ParticipantInfo, PersonasImport, Study


class PreferencesChanged(CacasError):
    """Preferences edited from a version that is no longer the latest (``save_preferences``)."""


class DetailsChanged(CacasError):
    """A participant's details (age range, notes) edited on a form while another form saved other
    ones in the same field (``update_participant`` with ``drawn``)."""


#: Tables holding rows about one participant (a ``participant_id`` column referencing
#: ``participants``), children first: the order :meth:`PeopleMixin.remove_participant` deletes in
#: (interactions and adaptation runs name policy versions and days).
PARTICIPANT_TABLES = ("interactions", "adaptations", "questionnaires", "preferences", "days", "policies")


@dataclass(frozen=True)
class Footprint:
    """What the study keeps about one participant (what removing them deletes): rows of each
    table, their events in the log, their policy files, and the study day open now (None: no
    day is open) with the interactions recorded on it."""

    code: str
    days: int
    interactions: int
    preference_versions: int
    policy_versions: int
    adaptation_runs: int
    questionnaire_answers: int
    events: int
    policy_files: int
    open_day: int | None
    open_day_interactions: int
    kept_files: int = 0        # their policy files that stay, and why (a removal said "0 files" and kept them)
    kept_because: str = ""


class PeopleMixin:
    """Method group of StudyStore: studies, participants, described preferences."""

    # --- studies -------------------------------------------------------------------------------
    def create_study(self, name: str, description: str = "") -> Study:
        """Add a study (a name unique in this database, also in letter case: :meth:`_check_new_study`)."""
        name = v.study(name)
        description = v.text(description, "study description")
        at = v.now()

        def fn(c):
            self._check_new_study(c, name)
            c.execute("INSERT INTO studies (name, description, created_at) VALUES (?, ?, ?)",
                      (name, description, at))
            self._event(c, "create_study", None, study=name)
        self._write(fn)
        return Study(name, description, at)

    @staticmethod
    def _check_new_study(c, name: str) -> None:
        """A new study's name must differ from every study's, also in letter case ("Default" beside
        "default": the sidebar listed both, and participants were added to the one not meant). A
        restored study keeps the name it has (:func:`cacas.store.restore.restore` notes it)."""
        row = c.execute("SELECT name FROM studies WHERE name = ? COLLATE NOCASE", (name,)).fetchone()
        if row is not None:
            same = "already exists" if row[0] == name else f"differs from study {row[0]!r} only in letter case"
            raise CacasError(f"study {name!r} {same}; study names must be unique, also in letter case")

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
        names, no phone number or date, no name Windows keeps for a device: :func:`validate.new_code`). ``age_range`` like "25-34" or
        "65+"; a code already in use raises CacasError, as does one that differs only in letter case
        from a participant of a study database beside this one where the file system does not tell
        letter case apart (:meth:`_refuse_case_twins_beside`)."""
        code, age_range, notes, study = v.each(lambda: v.new_code(code), lambda: v.age_range(age_range),
                                               lambda: v.text(notes, "notes"), lambda: v.study(study))

        def fn(c):
            sid = self._study_id(c, study)
            self._check_new_code(c, code)
            self._refuse_case_twins_beside([code], "nothing was added")
            at = v.now()
            c.execute("INSERT INTO participants (study_id, code, age_range, notes, created_at, updated_at) "
                      "VALUES (?, ?, ?, ?, ?, ?)", (sid, code, age_range, notes, at, at))
            self._event(c, "add_participant", code, study=study, age_range=age_range)
        self._write(fn)
        return self.get_participant(code)

    def update_participant(self, code: str, age_range: str | None = None,
                           notes: str | None = None, drawn: tuple[str, str] | None = None) -> ParticipantInfo:
        """Change a participant's age range and/or notes (None: unchanged). The age range they hold
        stays as it is, also one the store took before it refused ages above ``validate.AGE_MAX``
        (the Participants page sends it with the notes); a new one is checked in full.

        ``drawn``: the (age range, notes) the form was filled with, when it sends both fields
        whether or not they were changed (the Participants page). A field the form left as drawn
        keeps what is stored now (another tab may have saved it since); a field changed here that
        another tab changed too since is refused with :class:`DetailsChanged`, nothing written (two
        researchers on one participant: the later save undid the earlier one's notes without a word).
        Notes replaced do not stay in the database file or its write-ahead log (as a removal's rows)."""
        age, notes = v.each(lambda: None if age_range is None else v.age_range(age_range, bounded=False),
                            lambda: None if notes is None else v.text(notes, "notes"))
        who = str(code).strip()

        def fn(c):
            pid = self._pid(c, code)
            row = c.execute("SELECT age_range, notes FROM participants WHERE id = ?", (pid,)).fetchone()
            new_age, new_notes = age, notes
            if drawn is not None:
                clashes = [field for field, sent, was, now in (("age range", age, drawn[0], row[0]),
                                                                ("notes", notes, drawn[1], row[1]))
                           if sent is not None and sent != was and now != was and sent != now]
                if clashes:
                    raise DetailsChanged(f"{who}'s {' and '.join(clashes)} {'was' if clashes == ['age range'] else 'were'} "
                                         "saved (in another tab) while this form was changed; nothing was saved, as "
                                         "saving would undo that change")
                new_age = None if age == drawn[0] else age  # left as drawn: what is stored now stays
                new_notes = None if notes == drawn[1] else notes
            if new_age is not None and new_age != row[0]:
                v.age_range(age_range)
            new = (row[0] if new_age is None else new_age, row[1] if new_notes is None else new_notes)
            with self._overwriting(c):  # notes edited to take something out: the old words do not stay in the file
                c.execute("UPDATE participants SET age_range = ?, notes = ?, updated_at = ? WHERE id = ?",
                          (*new, v.now(), pid))
            self._event(c, "update_participant", str(code).strip(), age_range=new[0],
                        notes_changed=new_notes is not None)
        self._write(fn)
        self._empty_log()  # nor in the write-ahead log's copy of the page
        return self.get_participant(code)

    # --- withdrawal: removing a participant and everything recorded about them ----------------
    def _participant_folder(self, code: str):
        """The participant's own folder of policy checkpoints (``policies/<code>/``)."""
        return self.policy_dir / code

    def _named_beside(self, code: str) -> set[str] | None:
        """The files under ``policies/<code>/`` that the other study databases in this folder name
        (they share ``policies/``: a pilot database beside the main one, a bundle imported twice),
        as policy paths; None when one of them cannot be read (then no file is certain to be
        unused: :meth:`_beside` names it)."""
        named, unreadable, _ = self._beside(code)
        return None if unreadable else named

    def _beside(self, code: str) -> tuple[set[str], str, list[str]]:
        """The policy paths the readable study databases beside this one name, the name of one
        that cannot be read ("" if none), and the names of those that name a file of ``code``'s
        (each holds a participant ``code`` of its own, maybe the same person: an imported copy)."""
        named: set[str] = set()
        namers: list[str] = []
        found, unreadable = self._read_beside("SELECT path FROM policies")
        for name, paths in found.items():
            named |= paths
            if any(path.startswith(f"{code}/") for path in paths):
                namers.append(name)
        return named, unreadable, namers

    def _read_beside(self, sql: str) -> tuple[dict[str, set], str]:
        """``sql``'s first column in each readable study database beside this one (file name ->
        the values), and the name of one that cannot be read ("" if none): it may hold anything."""
        from cacas.store import db

        found: dict[str, set] = {}
        unreadable = ""
        for other in sorted(self.path.parent.iterdir()):
            # never opened: this database, and the files SQLite keeps beside a database (opened and
            # closed here, they would drop SQLite's locks on them: see db.open_study_file)
            if other.resolve() == self.path.resolve() or not other.is_file() or db.is_sidecar(other):
                continue
            try:
                conn = db.open_study_file(other)
            except db.NotAStudyDatabase:
                continue  # a CSV, a notes file, another application's database, ...
            except CacasError:
                unreadable = unreadable or other.name  # busy, damaged: it may name any file
                continue
            try:
                found[other.name] = {r[0] for r in conn.execute(sql).fetchall()}
            except Exception:  # noqa: BLE001 - unreadable, busy, damaged: it may hold anything
                unreadable = unreadable or other.name
            finally:
                conn.close()
        return found, unreadable

    def _case_twin_beside(self, codes: Iterable[str]) -> tuple[str, str, str] | None:
        """(code, twin, file name) for the first of ``codes`` that differs only in letter case from
        a participant ``twin`` of the study database ``file name`` beside this one (they share
        ``policies/``; the same code is not a twin: a copy of a participant, whose files removal
        keeps, also where that database holds a twin of it as well); None if none does. A database
        beside that cannot be read is passed over."""
        codes = [str(c) for c in codes]
        found, _ = self._read_beside("SELECT code FROM participants")
        for name, theirs in sorted(found.items()):
            theirs = {str(c) for c in theirs}
            folded = {c.casefold(): c for c in sorted(theirs)}
            hit = next((c for c in codes if c.casefold() in folded and c not in theirs), None)
            if hit is not None:
                return hit, folded[hit.casefold()], name
        return None

    def _refuse_case_twins_beside(self, codes: list[str], done: str) -> None:
        """Refuse (CacasError ending in ``done``, e.g. "nothing was added") a new participant whose
        code differs only in letter case from a participant of a study database beside this one,
        where the file system does not tell letter case apart (macOS's and Windows' default): the
        two would share one folder of policy files, and removing one would delete the other's
        (safety audit L4; an import is refused the same way, :func:`cacas.export.import_bundle`)."""
        if not files.ignores_letter_case(self.policy_dir):  # probed first: reading the databases beside costs more
            return
        hit = self._case_twin_beside(codes)
        if hit is None:
            return
        code, twin, name = hit
        raise CacasError(f"participant {code} differs only in letter case from participant {twin} of the study "
                         f"database {name} beside this one; the file system of {self.path.parent} does not tell "
                         "letter case apart (as macOS's and Windows' do by default), so they would share one folder "
                         "of policy files, and removing one would delete the other's; valid: a code that differs "
                         f"from {twin} in more than letter case; {done}")

    def _files_to_remove(self, c, code: str) -> tuple[list, int, str]:
        """The files in the participant's policy folder no other study database in this folder
        names: removing the participant deletes these, and keeps the others'; with the number kept
        and why. A database beside that cannot be read may name any: every file is kept, and those
        no readable one names are listed for the researcher to delete once they know. On a file
        system that does not tell letter case apart (macOS's default), P01 and p01 (of an imported
        study, or of two databases beside each other) share the folder: a file named in any letter
        case, also by this database for another participant, is kept (safety audit L4)."""
        folder = self._participant_folder(code)
        if not folder.is_dir():
            return [], 0, ""
        every = [f for f in sorted(folder.rglob("*")) if f.is_file()]
        named, unreadable, namers = self._beside(code)
        twins: list[str] = []  # this database's participants whose files share the folder
        if files.ignores_letter_case(folder):
            rows = c.execute("SELECT p.code, o.path FROM policies o JOIN participants p ON p.id = o.participant_id "
                             "WHERE p.code != ?", (code,)).fetchall()
            folded = {path.casefold() for path in named | {path for _, path in rows}}
            unused = [f for f in every if f.relative_to(self.policy_dir).as_posix().casefold() not in folded]
            twins = records.by_code({who for who, path in rows if path.casefold().startswith(f"{code.casefold()}/")})
        else:
            unused = [f for f in every if f.relative_to(self.policy_dir).as_posix() not in named]
        if unreadable:
            listed = ", ".join(f"policies/{f.relative_to(self.policy_dir).as_posix()}" for f in unused[:3]) + (
                f" and {len(unused) - 3} more in policies/{code}/" if len(unused) > 3 else "")
            why = f"the study database {unreadable} beside this one cannot be read, and may name these files"
            return [], len(every), why + (f": once you know it does not, delete {listed} by hand" if unused else "")
        kept = len(every) - len(unused)
        if kept and twins:
            return unused, kept, (f"participant {', '.join(twins)} of this study database shares the folder "
                                  f"policies/{code}/ (the codes differ only in letter case, which this disk does not "
                                  "tell apart): their files are kept")
        which = f"the study database{'s' if len(namers) > 1 else ''} {', '.join(namers)} beside this one"
        return unused, kept, (f"{which} name{'' if len(namers) > 1 else 's'} these files and hold{'' if len(namers) > 1 else 's'} "
                              f"a participant {code} of {'their' if len(namers) > 1 else 'its'} own: if that is the same "
                              "person (a copy imported there), remove them there too") if kept else ""

    def _footprint(self, c, pid: int, code: str, files: tuple | None = None) -> Footprint:
        """``files``: :meth:`_files_to_remove`'s answer, if the caller has it (else found here)."""
        def count(table: str) -> int:
            return c.execute(f"SELECT COUNT(*) FROM {table} WHERE participant_id = ?", (pid,)).fetchone()[0]

        row = c.execute("SELECT day FROM days WHERE participant_id = ? AND closed_at IS NULL ORDER BY day DESC "
                        "LIMIT 1", (pid,)).fetchone()
        open_day = None if row is None else row[0]
        today = 0 if open_day is None else c.execute(
            "SELECT COUNT(*) FROM interactions WHERE participant_id = ? AND day = ?", (pid, open_day)).fetchone()[0]
        events = c.execute("SELECT COUNT(*) FROM events WHERE participant = ?", (code,)).fetchone()[0]
        doomed, kept, why = self._files_to_remove(c, code) if files is None else files
        return Footprint(code, count("days"), count("interactions"), count("preferences"), count("policies"),
                         count("adaptations"), count("questionnaires"), events, len(doomed), open_day, today,
                         kept, why)

    def participant_footprint(self, code: str) -> Footprint:
        """What :meth:`remove_participant` would delete for ``code`` (counts; see
        :class:`Footprint`). An unknown code raises CacasError naming it."""
        def fn(c):
            pid = self._pid(c, code)
            return self._footprint(c, pid, c.execute("SELECT code FROM participants WHERE id = ?",
                                                     (pid,)).fetchone()[0])
        return self._read(fn)

    def remove_participant(self, code: str, confirm: str) -> Footprint:
        """Remove a participant and everything recorded about them (a withdrawal from the study,
        or a code added by mistake): their study days, interactions, preference versions, policy
        versions and adaptation runs, questionnaire answers and their events in the log, in one
        transaction (all or nothing), and their policy checkpoint files (``policies/<code>/``)
        except those another study database in the same folder names (``policies/`` is shared
        by the databases beside each other: the same code in a pilot database keeps its files).
        One event "remove_participant" is kept, holding the code and the study only (no
        participant column, so a new participant given the same code later does not inherit
        it). Deleted rows are overwritten in the file (``secure_delete``) and the write-ahead log
        is emptied when no reader holds it.

        ``confirm`` must equal ``code`` exactly (the researcher types it); else CacasError saying
        what to type. An unknown code raises CacasError naming it. Nothing is removed in either
        case. A day still open is removed with the rest. Returns what was removed."""
        code = str(code).strip()
        if not isinstance(confirm, str) or confirm != code:
            typed = "nothing" if not confirm else repr(confirm)
            raise CacasError(f"to remove participant {code}, type its code {code} exactly to confirm "
                             f"(typed: {typed}); nothing was removed")
        folder = self._participant_folder(code)
        trash = self.policy_dir / f".removed-{code}-{os.getpid()}-{time.time_ns()}"
        moved: list[tuple] = []  # (file, where it went in the trash)
        held = contextlib.ExitStack()  # the trash's lock, held until it is deleted (recovery.busy)

        def fn(c):
            pid = self._pid(c, code)
            study = c.execute("SELECT s.name FROM participants p JOIN studies s ON s.id = p.study_id "
                              "WHERE p.id = ?", (pid,)).fetchone()[0]
            to_remove = self._files_to_remove(c, code)  # read the neighbouring databases once
            doomed = to_remove[0]
            removed = self._footprint(c, pid, code, to_remove)
            with self._overwriting(c):  # the deleted rows' bytes are overwritten in the file
                for table in PARTICIPANT_TABLES:
                    c.execute(f"DELETE FROM {table} WHERE participant_id = ?", (pid,))
                c.execute("DELETE FROM events WHERE participant = ?", (code,))
                c.execute("DELETE FROM participants WHERE id = ?", (pid,))
            self._event(c, "remove_participant", None, code=code, study=study)
            for f in doomed:  # last: a failure before it leaves the files in place
                target = trash / f.relative_to(folder)
                try:
                    if not trash.exists():  # a crash from here on is put right at the next opening
                        trash.mkdir(parents=True)
                        held.enter_context(recovery.busy(trash / recovery.REMOVAL_LOCK))
                    target.parent.mkdir(parents=True, exist_ok=True)
                    os.replace(f, target)
                except OSError as exc:
                    raise CacasError(f"{f}: the participant's policy file cannot be removed "
                                     f"({exc.strerror or exc}); nothing was removed") from None
                moved.append((f, target))
            if moved:  # the moves on disk before the commit: a power cut cannot bring the files back without rows
                for where in sorted({*(f.parent for f, _ in moved), *(t.parent for _, t in moved), trash.parent}):
                    files.fsync_folder(where)
            return removed

        with held:
            return self._remove_and_tidy(code, fn, folder, trash, moved, held)

    def _remove_and_tidy(self, code: str, fn, folder, trash, moved: list, held: contextlib.ExitStack) -> Footprint:
        """:meth:`remove_participant`'s transaction ``fn``, then its files: put back if it failed,
        deleted with the trash folder once it committed. The trash's lock (``held``) is released
        before the trash is deleted: Windows deletes no file that is open, and the lock file stayed
        (with the trash folder, and a "could not be deleted" after every withdrawal). Released, it
        guards nothing any more: the files are home again, or no row names them."""
        try:
            removed = self._write(fn)
        except BaseException:
            for f, target in reversed(moved):  # the transaction was rolled back: put the files back
                if target.exists() and not f.exists():
                    os.replace(target, f)
            held.close()
            shutil.rmtree(trash, ignore_errors=True)
            raise
        self._empty_log()  # old pages leave the log (if no reader)
        # the folder goes with the last file; another database's files keep it
        files.remove_empty([*(d for d in folder.rglob("*") if d.is_dir()), folder] if folder.is_dir() else [])
        held.close()
        if trash.exists():
            shutil.rmtree(trash, ignore_errors=True)
            if trash.exists():
                raise CacasError(f"participant {code} was removed from the study database, but their policy files "
                                 f"in {trash} could not be deleted: delete that folder by hand")
            files.fsync_folder(self.policy_dir)  # (a trash folder brought back is deleted at the next opening)
        return removed

    def get_participant(self, code: str) -> ParticipantInfo:
        """One participant; an unknown code raises CacasError listing the known ones."""
        def fn(c):
            self._pid(c, code)
            row = c.execute(self._PARTICIPANT_SQL + " WHERE p.code = ?", (str(code).strip(),)).fetchone()
            return ParticipantInfo(*row)
        return self._read(fn)

    def list_participants(self, study: str | None = None) -> list[ParticipantInfo]:
        """Participants (of one study, or all) in the order a person reads their codes
        (:func:`cacas.records.code_order`: "P2" before "P10", letter case ignored); the exported tables
        keep the exact code's order."""
        with self._lock:
            if study is None:
                rows = self._conn.execute(self._PARTICIPANT_SQL)
            else:
                rows = self._conn.execute(self._PARTICIPANT_SQL + " WHERE s.name = ?", (study,))
            return sorted((ParticipantInfo(*r) for r in rows), key=lambda p: records.code_order(p.code))

    def participants_frame(self, study: str | None = None) -> pd.DataFrame:
        """participants.csv: participant, study, age_range, notes, active_policy, created_at,
        updated_at, preference_version (latest saved, empty if none)."""
        sql = ("SELECT p.code AS participant, s.name AS study, p.age_range, p.notes, p.active_policy, "
               "p.created_at, p.updated_at, (SELECT MAX(version) FROM preferences f "
               "WHERE f.participant_id = p.id) AS preference_version "
               "FROM participants p JOIN studies s ON s.id = p.study_id")
        df = self._frame(sql + (" WHERE s.name = ?" if study is not None else "") + " ORDER BY p.code",
                         (study,) if study is not None else ())
        for col in ("active_policy", "preference_version"):
            df[col] = df[col].astype("Int64")
        return df

    # --- described preferences (persona format, design.md) ------------------------------------
    @staticmethod
    def _parse_preferences(code: str, preferences: Any) -> prefs.Participant:
        if isinstance(preferences, dict) and "preferences" in preferences:  # design.md's participant object
            other = preferences.get("id", code)
            if str(other).strip() != code:
                raise CacasError(f"participant {code}: these preferences are participant {other}'s "
                                 f"(their \"id\"); valid: {code}'s own, or the list of preferences alone")
            preferences = preferences["preferences"]
        if isinstance(preferences, prefs.Participant):
            if preferences.id != code:
                raise CacasError(f"participant {code}: these preferences are participant {preferences.id}'s; "
                                 f"valid: {code}'s own, or the list of preferences alone")
            items = [p.to_dict() for p in preferences.preferences]
        else:
            items = [p.to_dict() if isinstance(p, prefs.Preference) else p for p in (preferences or [])]
        return prefs.parse_participant({"id": code, "preferences": items})

    def save_preferences(self, code: str, preferences: Any, edited_version: int | None = None) -> int:
        """Store a participant's described preferences as a new version; return the version
        (preferences equal to the latest version are not stored again: its number is returned).

        ``preferences``: a list of Preference objects or persona-format dicts, or the
        participant's own object in the persona format (``{"id": code, "preferences": [...]}``)
        or :class:`cacas.preferences.Participant` (another participant's is refused). Validated with
        :func:`cacas.preferences.parse_participant` (fields, names, conflicts); an invalid one
        raises CacasError naming the preference and field, and nothing is written.
        ``edited_version``: the version these preferences were edited from (0: none); refused,
        nothing written, if another version was saved since (two researchers on one form: the
        later save undid the earlier one without a word).
        """
        code = str(code).strip()
        person = self._parse_preferences(code, preferences)
        prefs.check_private_words(person)  # on the way in only: versions saved before the check still read

        def fn(c):
            pid = self._pid(c, code)
            if edited_version is not None:
                latest = c.execute("SELECT COALESCE(MAX(version), 0) FROM preferences WHERE participant_id = ?",
                                   (pid,)).fetchone()[0]
                if latest < edited_version:  # the participant removed and added again meanwhile
                    raise PreferencesChanged(
                        f"{code}'s preferences are not the ones this form was drawn from (version {edited_version}; "
                        f"{'none is saved' if not latest else f'the latest is version {latest}'} now); nothing was "
                        "saved")
                if latest != edited_version:
                    raise PreferencesChanged(
                        f"version {latest} of {code}'s preferences was saved (in another tab, or by an import) "
                        f"while these changes were made to version {edited_version}; nothing was saved, as saving "
                        "would undo it")
            return self._save_version(c, pid, code, person)
        return self._write(fn)

    @staticmethod
    def _check_new_code(c, code: str) -> None:
        """A new code must differ from every code in use, in any study, also in letter case (P01
        and p01 would be two participants a reader takes for one). The message names the study of
        the code in use: "already exists" beside "0 participant(s) in study 'Default'" read as wrong."""
        row = c.execute("SELECT p.code, s.name FROM participants p JOIN studies s ON s.id = p.study_id "
                        "WHERE p.code = ? COLLATE NOCASE", (code,)).fetchone()
        if row is not None:
            where = f"(in study {row[1]!r})"
            same = f"already exists {where}" if row[0] == code else \
                f"differs from participant {row[0]} {where} only in letter case"
            raise CacasError(f"participant {code} {same}; codes must be unique across all studies")

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
        # an export: the exact code's order, as the file has always had (a list on a page reads case-blind)
        wanted = sorted(p.code for p in self.list_participants(study)) if codes is None else list(codes)
        people = [p for p in (self.get_preferences(c) for c in wanted) if p is not None]
        return prefs.dumps_personas(people)

    def import_personas(self, data: Any, study: str = DEFAULT_STUDY, source: str | None = None,
                        replace: bool = False) -> PersonasImport:
        """Import a persona document (JSON text or parsed JSON): add participants that are
        missing (to ``study``) and save each one's preferences as a new version (unless they equal
        the latest). A participant already in the study with other preferences gets the file's as
        a new version only with ``replace`` (a walkthrough imported the example personas, P01-P08,
        into a study under way: its P01 and P02 silently got the examples' preferences mid-study).
        All or nothing: one invalid participant or preference, a participant of another study, a
        code that differs from one in use only in letter case (or, where the file system does not
        tell letter case apart, from a participant of a study database beside), or other preferences without
        ``replace`` raises CacasError and nothing is written. Returns what was done with each
        participant: added, preferences replaced, first preferences saved, or unchanged."""
        if isinstance(data, (str, bytes)):
            data = prefs.persona_json(data, source or "persona file")
        people = prefs.parse_personas(data, source)
        v.persona_codes(people, source)
        for person in people:
            prefs.check_private_words(person, source)
        study = v.study(study)

        def fn(c):
            sid = self._study_id(c, study)
            adding: list[str] = []
            for p in people:  # check every code first: all or nothing (case twins within the file: parse_personas)
                row = c.execute("SELECT s.name FROM participants p JOIN studies s ON s.id = p.study_id "
                                "WHERE p.code = ?", (p.id,)).fetchone()
                if row is None:
                    self._check_new_code(c, p.id)  # a new participant: not a case twin of a code in use
                    adding.append(p.id)
                elif row[0] != study:
                    raise CacasError(f"{source or 'persona file'}: participant {p.id} belongs to study {row[0]!r}, "
                                     f"not {study!r}; nothing was imported. Import into study {row[0]!r}, or give "
                                     "the new participant a code not in use")
            if adding:
                try:
                    self._refuse_case_twins_beside(adding, "nothing was imported")
                except CacasError as exc:
                    raise CacasError(f"{source or 'persona file'}: {exc}") from None
            if not replace:
                others = [f"{code} (day {day})" if day else code for code, day in self._other_preferences(c, people)]
                if others:
                    raise CacasError(
                        f"{source or 'persona file'}: {', '.join(others)} {'is' if len(others) == 1 else 'are'} in "
                        f"study {study!r} already, with other preferences; nothing was imported. To save the "
                        "file's as their new version, choose to replace them (the days already run stay scored on "
                        "the preferences of their time), or import a file without them")
            done: dict[str, list[str]] = {"added": [], "replaced": [], "first": [], "unchanged": []}
            for p in people:
                new = c.execute("SELECT 1 FROM participants WHERE code = ?", (p.id,)).fetchone() is None
                if new:
                    at = v.now()
                    c.execute("INSERT INTO participants (study_id, code, created_at, updated_at) "
                              "VALUES (?, ?, ?, ?)", (sid, p.id, at, at))
                    self._event(c, "add_participant", p.id, study=study, source="personas")
                pid = self._pid(c, p.id)
                latest = c.execute("SELECT MAX(version) FROM preferences WHERE participant_id = ?", (pid,)).fetchone()
                version = self._save_version(c, pid, p.id, p, source="personas")
                done["added" if new else "first" if latest[0] is None else
                     "unchanged" if version == latest[0] else "replaced"].append(p.id)
            return PersonasImport(tuple(p.id for p in people), **{k: tuple(codes) for k, codes in done.items()})
        return self._write(fn)

    @staticmethod
    def _other_preferences(c, people) -> list[tuple[str, int]]:
        """(code, latest study day) of each of ``people`` already in the database whose latest
        preferences differ from theirs (a participant without any has nothing to lose)."""
        out = []
        for p in people:
            row = c.execute("SELECT f.preferences, (SELECT MAX(day) FROM days d WHERE d.participant_id = q.id) "
                            "FROM participants q JOIN preferences f ON f.participant_id = q.id WHERE q.code = ? "
                            "ORDER BY f.version DESC LIMIT 1", (p.id,)).fetchone()
            if row is not None and json.loads(row[0]) != [x.to_dict() for x in p.preferences]:
                out.append((p.id, row[1] or 0))
        return out

    def preferences_frame(self, study: str | None = None) -> pd.DataFrame:
        """preferences.csv: participant, version, preferences (persona-format JSON list), created_at."""
        sql = ("SELECT p.code AS participant, f.version, f.preferences, f.created_at FROM preferences f "
               "JOIN participants p ON p.id = f.participant_id JOIN studies s ON s.id = p.study_id")
        return self._frame(sql + (" WHERE s.name = ?" if study is not None else "") + " ORDER BY p.code, f.version",
                           (study,) if study is not None else ())
