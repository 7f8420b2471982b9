"""The study database's schema: DDL, the schema version and the list of migrations.

What a human-subject study (paper, Section V-B) keeps, one table each:

* ``studies`` and ``participants`` (pseudonymous codes, age range, notes; no names);
* ``preferences``: each participant's described preferences in the persona format of design.md,
  one row per saved version (the adaptation never reads them; Fig. 4's evaluation does);
* ``days``: study days 1..n per participant, opened and closed;
* ``interactions``: the context S1-S5 as set (Table I), the recognised activity and scene, S6/S7
  of the policy state (previous action and response), who initiated it (Table II: type_1 robot,
  type_2 user), the robot's action with the policy's 14 probabilities (Eq. 4), the response, the
  user's requested action, the policy version in force and the ids of the sound and scene
  models that recognised the context (version 2);
* ``adaptations`` (CACAA runs, Table III) and ``policies`` (checkpoint files and their sha256);
* ``questionnaires`` (the 1-10 satisfaction scale of Section V-B) and ``events`` (what was done
  when).

The file is marked with :data:`APPLICATION_ID` (``PRAGMA application_id``) so that any other
SQLite file is recognised as "not a study database"; ``PRAGMA user_version`` holds the schema
version, and :data:`MIGRATIONS` brings an older file up to :data:`SCHEMA_VERSION`.
"""

from __future__ import annotations

import sqlite3

#: "CACS" in ASCII: marks a SQLite file as a CACAS study database (header offset 68).
APPLICATION_ID = 0x43414353

_RESPONSES = "('accept', 'reject', 'others')"

#: Version 1: the whole study.
_V1 = [
    """CREATE TABLE studies (
        id          INTEGER PRIMARY KEY,
        name        TEXT NOT NULL UNIQUE,
        description TEXT NOT NULL DEFAULT '',
        created_at  TEXT NOT NULL
    )""",
    """CREATE TABLE participants (
        id            INTEGER PRIMARY KEY,
        study_id      INTEGER NOT NULL REFERENCES studies(id),
        code          TEXT NOT NULL UNIQUE,
        age_range     TEXT NOT NULL DEFAULT '',
        notes         TEXT NOT NULL DEFAULT '',
        active_policy INTEGER,
        created_at    TEXT NOT NULL,
        updated_at    TEXT NOT NULL
    )""",
    """CREATE TABLE preferences (
        id             INTEGER PRIMARY KEY,
        participant_id INTEGER NOT NULL REFERENCES participants(id),
        version        INTEGER NOT NULL CHECK (version >= 1),
        preferences    TEXT NOT NULL,
        created_at     TEXT NOT NULL,
        UNIQUE (participant_id, version)
    )""",
    """CREATE TABLE days (
        id             INTEGER PRIMARY KEY,
        participant_id INTEGER NOT NULL REFERENCES participants(id),
        day            INTEGER NOT NULL CHECK (day >= 1),
        opened_at      TEXT NOT NULL,
        closed_at      TEXT,
        UNIQUE (participant_id, day)
    )""",
    """CREATE TABLE policies (
        id             INTEGER PRIMARY KEY,
        participant_id INTEGER NOT NULL REFERENCES participants(id),
        version        INTEGER NOT NULL CHECK (version >= 1),
        day            INTEGER NOT NULL CHECK (day >= 0),
        method         TEXT NOT NULL,
        path           TEXT NOT NULL,
        sha256         TEXT NOT NULL,
        size           INTEGER NOT NULL,
        created_at     TEXT NOT NULL,
        UNIQUE (participant_id, version)
    )""",
    f"""CREATE TABLE interactions (
        id                  INTEGER PRIMARY KEY,
        participant_id      INTEGER NOT NULL REFERENCES participants(id),
        day                 INTEGER NOT NULL,
        idx                 INTEGER NOT NULL CHECK (idx >= 1),
        time                TEXT NOT NULL,
        method              TEXT NOT NULL,
        activity            TEXT NOT NULL,
        scene               TEXT NOT NULL,
        hour                REAL,
        time_slot           INTEGER NOT NULL CHECK (time_slot BETWEEN 0 AND 11),
        interval_minutes    REAL,
        interval_bin        INTEGER NOT NULL CHECK (interval_bin BETWEEN 0 AND 11),
        task                TEXT NOT NULL,
        previous_action     TEXT NOT NULL,
        previous_response   TEXT NOT NULL CHECK (previous_response IN {_RESPONSES}),
        recognised_activity TEXT,
        recognised_scene    TEXT,
        type                TEXT NOT NULL CHECK (type IN ('type_1', 'type_2')),
        robot_action        TEXT NOT NULL,
        probabilities       TEXT,
        response            TEXT NOT NULL CHECK (response IN {_RESPONSES}),
        user_action         TEXT,
        policy_version      INTEGER,
        created_at          TEXT NOT NULL,
        UNIQUE (participant_id, day, idx),
        FOREIGN KEY (participant_id, day) REFERENCES days(participant_id, day),
        FOREIGN KEY (participant_id, policy_version) REFERENCES policies(participant_id, version)
    )""",
    """CREATE TABLE adaptations (
        id             INTEGER PRIMARY KEY,
        participant_id INTEGER NOT NULL REFERENCES participants(id),
        day            INTEGER NOT NULL CHECK (day >= 0),
        method         TEXT NOT NULL,
        parameters     TEXT NOT NULL,
        duration_s     REAL NOT NULL CHECK (duration_s >= 0),
        metrics        TEXT NOT NULL,
        policy_version INTEGER,
        created_at     TEXT NOT NULL,
        FOREIGN KEY (participant_id, policy_version) REFERENCES policies(participant_id, version)
    )""",
    """CREATE TABLE questionnaires (
        id             INTEGER PRIMARY KEY,
        participant_id INTEGER NOT NULL REFERENCES participants(id),
        satisfaction   INTEGER NOT NULL CHECK (satisfaction BETWEEN 1 AND 10),
        comments       TEXT NOT NULL DEFAULT '',
        created_at     TEXT NOT NULL
    )""",
    """CREATE TABLE events (
        id          INTEGER PRIMARY KEY,
        at          TEXT NOT NULL,
        what        TEXT NOT NULL,
        participant TEXT,
        details     TEXT NOT NULL DEFAULT '{}'
    )""",
    "INSERT INTO studies (name, description, created_at) VALUES ('default', 'The default study', "
    "strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))",
    "CREATE INDEX interactions_by_participant ON interactions(participant_id, day, idx)",
    "CREATE INDEX events_by_participant ON events(participant, id)",
    "CREATE INDEX adaptations_by_participant ON adaptations(participant_id, day)",
]

#: Version 2: each interaction names the sound and scene models that recognised its context
#: (:func:`cacas.recognition.model_id`; NULL where none did, and in rows recorded before).
_V2 = [
    "ALTER TABLE interactions ADD COLUMN sound_model TEXT",
    "ALTER TABLE interactions ADD COLUMN scene_model TEXT",
]

#: Migrations: (version reached, statements). Append new ones; never edit a released one.
MIGRATIONS: list[tuple[int, list[str]]] = [
    (1, _V1),
    (2, _V2),
]

SCHEMA_VERSION = MIGRATIONS[-1][0]

#: Tables every study database has (used to recognise one).
TABLES = ("studies", "participants", "preferences", "days", "policies", "interactions",
          "adaptations", "questionnaires", "events")


def migrate(conn: sqlite3.Connection, current: int) -> int:
    """Apply the migrations above ``current`` inside the caller's transaction; return the new
    version. The caller holds a write transaction (BEGIN IMMEDIATE), so two processes opening a
    new file at once create the schema once."""
    for version, statements in MIGRATIONS:
        if version <= current:
            continue
        for sql in statements:
            conn.execute(sql)
        conn.execute(f"PRAGMA user_version = {int(version)}")
        current = version
    conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
    return current
