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

from pathlib import Path

import pandas as pd

from cacas.errors import CacasError
from cacas.store import recovery
from cacas.store import validate as v
from cacas.store.base import (DB_ENV, DEFAULT_STUDY, DayInfo, ParticipantInfo, PersonasImport, PolicyVersion,
                              ResumeInfo, StoreBase, Study, default_db_path)
from cacas.store.people import Footprint, PeopleMixin
from cacas.store.policies import PoliciesMixin
from cacas.store.sessions import INTERACTION_EXTRA_COLUMNS, SessionsMixin

__all__ = ["StudyStore", "Study", "Footprint", "ParticipantInfo", "PersonasImport", "DayInfo", "PolicyVersion",
           "ResumeInfo", "DB_ENV", "DEFAULT_STUDY", "INTERACTION_EXTRA_COLUMNS", "default_db_path"]


class StudyStore(PeopleMixin, SessionsMixin, PoliciesMixin, StoreBase):
    """The study database (SQLite, WAL, foreign keys on, schema version + migrations).

    ``StudyStore(path=None)`` opens ``path`` (default :func:`default_db_path`), creating the file
    and schema if missing. An existing file that is not a study database raises CacasError naming
    it. ``readonly=True`` opens an existing study database without creating or changing anything
    (writes then raise CacasError). Use as a context manager or call :meth:`close`.

    Method groups: studies, participants and preferences (:class:`PeopleMixin`); study days,
    interactions and resume (:class:`SessionsMixin`); adaptation runs and policy checkpoints
    (:class:`PoliciesMixin`); the questionnaire and the event log (here).
    """

    def __init__(self, path: str | Path | None = None, readonly: bool = False):
        super().__init__(path, readonly)
        if not readonly:
            recovery.tidy(self)  # what a removal or an import killed mid-way left beside the database

    # --- questionnaire (Section V-B.1) ---------------------------------------------------------
    def record_questionnaire(self, participant: str, satisfaction: int, comments: str = "") -> int:
        """The post-test question "What is your satisfaction level regarding the robot's ability to
        adapt to your preferences?": ``satisfaction`` 1 (very dissatisfied) .. 10 (very
        satisfied), with free-text ``comments``. Returns the row id. A participant who has had no
        study day yet cannot answer it (most likely the wrong participant was picked)."""
        score, comments = v.satisfaction(satisfaction), v.text(comments, "comments")
        code = str(participant).strip()

        def fn(c):
            pid = self._pid(c, participant)
            if c.execute("SELECT 1 FROM days WHERE participant_id = ?", (pid,)).fetchone() is None:
                raise CacasError(f"participant {code} has had no study day yet; the questionnaire asks about "
                                 "the robot's adaptation, after the study days")
            cur = c.execute("INSERT INTO questionnaires (participant_id, satisfaction, comments, created_at) "
                            "VALUES (?, ?, ?, ?)", (pid, score, comments, v.now()))
            self._event(c, "record_questionnaire", code, satisfaction=score, id=cur.lastrowid)
            return cur.lastrowid
        return self._write(fn)

    def remove_questionnaire_answer(self, participant: str, confirm: str) -> int:
        """Remove the participant's latest questionnaire answer (the one the summary counts), saved
        for the wrong participant or by mistake: the researcher types the participant's code in
        ``confirm``, as for a participant's removal; else CacasError saying what to type. A code
        that is not a participant, or one with no answer, is a CacasError naming it. Nothing is
        removed in those cases. The event "remove_questionnaire" keeps the removed score and when
        it was saved. Its row's bytes, comments included, are overwritten in the file and its write-ahead
        log (as a participant's removal's). Returns the satisfaction score removed."""
        code = str(participant).strip()
        if not isinstance(confirm, str) or confirm.strip() != code:
            typed = "nothing" if not confirm else repr(confirm)
            raise CacasError(f"to remove {code}'s latest questionnaire answer, type the code {code} to confirm "
                             f"(typed: {typed}); nothing was removed")

        def fn(c):
            pid = self._pid(c, participant)
            row = c.execute("SELECT id, satisfaction, created_at FROM questionnaires WHERE participant_id = ? "
                            "ORDER BY id DESC LIMIT 1", (pid,)).fetchone()
            if row is None:
                raise CacasError(f"participant {code} has no questionnaire answer to remove")
            with self._overwriting(c):  # the comments, the participant's words, are not left in the file
                c.execute("DELETE FROM questionnaires WHERE id = ?", (row[0],))
            self._event(c, "remove_questionnaire", code, satisfaction=row[1], saved_at=row[2], id=row[0])
            return int(row[1])
        removed = self._write(fn)
        self._empty_log()
        return removed

    def questionnaire_frame(self, study: str | None = None) -> pd.DataFrame:
        """questionnaire.csv: participant, day, satisfaction, comments, created_at (every answer).
        ``day`` is the participant's study day when they answered: the latest day opened by then
        (an answer after day 7 of 7 says 7; one given mid-study says so)."""
        sql = ("SELECT p.code AS participant, (SELECT MAX(d.day) FROM days d "
               "WHERE d.participant_id = q.participant_id AND d.opened_at <= q.created_at) AS day, "
               "q.satisfaction, q.comments, q.created_at FROM questionnaires q "
               "JOIN participants p ON p.id = q.participant_id JOIN studies s ON s.id = p.study_id")
        df = self._frame(sql + (" WHERE s.name = ?" if study is not None else "") + " ORDER BY q.id", (study,) if study is not None else ())
        df["day"] = df["day"].astype("Int64")
        return df

    # --- event log ------------------------------------------------------------------
    def latest_participant(self, study: str | None = None) -> str | None:
        """The participant (of ``study``, or of any study) whom the latest event of the log is about:
        the one the researcher or the tablet last worked with; None if no event is about one of
        them. Events about no participant (a removal, a study's creation, an import) are passed
        over however many follow (the last 20 events were read: 21 removals hid the participant
        last worked with). One look-up per participant in the log's index, not a read of the log."""
        sql = ("SELECT code FROM (SELECT p.code, (SELECT MAX(e.id) FROM events e WHERE e.participant = p.code) "
               "AS last FROM participants p JOIN studies s ON s.id = p.study_id"
               + (" WHERE s.name = ?" if study is not None else "") + ") WHERE last IS NOT NULL "
               "ORDER BY last DESC LIMIT 1")
        row = self._read(lambda c: c.execute(sql, (study,) if study is not None else ()).fetchone())
        return None if row is None else row[0]

    def newest_time(self, recent: int = 1000) -> str | None:
        """The latest time of the ``recent`` last events written (every write logs one), as stored; None for an
        empty log. Ahead of the clock: the computer's clock was set back since (:func:`cacas.app_support.
        clock_behind`)."""
        return self._read(lambda c: c.execute("SELECT MAX(at) FROM (SELECT at FROM events ORDER BY id DESC LIMIT ?)",
                                              (int(recent),)).fetchone()[0])

    def events(self, participant: str | None = None, what: str | None = None,
               limit: int | None = None, study: str | None = None) -> pd.DataFrame:
        """The event log (newest last): id, at, what, participant, details (JSON); optionally of
        one participant, of one ``study``, or of one kind; the last ``limit`` only.

        A study's events are those of its participants, its creation (:meth:`create_study`: no
        participant, its details naming the study; the "default" study every database has was
        created with the database, without one) and the removals of its participants
        (:meth:`remove_participant` keeps that event with no participant, its details naming the
        code and the study, as it has since removals exist); other events about no participant,
        such as an import, are left out then."""
        where, params = [], []
        if participant is not None:
            where.append("participant = ?")
            params.append(str(participant).strip())
        if study is not None:
            # CASE: details are read as JSON only where a study's creation or a removal holds them (a
            # malformed cell elsewhere would fail the whole query)
            where.append("(participant IN (SELECT p.code FROM participants p JOIN studies s ON s.id = p.study_id "
                         "WHERE s.name = ?) OR CASE WHEN participant IS NULL AND what IN ('create_study', "
                         "'remove_participant') AND json_valid(details) THEN json_extract(details, '$.study') END = ?)")
            params += [study, study]
        if what is not None:
            where.append("what = ?")
            params.append(what)
        sql = "SELECT id, at, what, participant, details FROM events" + \
              (" WHERE " + " AND ".join(where) if where else "") + " ORDER BY id DESC"
        if limit is not None:
            sql += f" LIMIT {v.integer(limit, 'limit', 0)}"
        return self._frame(sql, params).iloc[::-1].reset_index(drop=True)
