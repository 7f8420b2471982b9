"""The study database (issue 4): participants, preferences, study days, interactions,
adaptation runs, policy versions, questionnaires and an event log, in SQLite.

``from cacas.store import StudyStore``; see :mod:`cacas.store.store` for the API,
:mod:`cacas.store.schema` for the tables and :mod:`cacas.export` for the CSV bundle.
"""

from cacas.store.schema import SCHEMA_VERSION
from cacas.store.store import (DB_ENV, DEFAULT_STUDY, INTERACTION_EXTRA_COLUMNS, DayInfo, ParticipantInfo,
                               PersonasImport, PolicyVersion, ResumeInfo, Study, StudyStore, default_db_path)

__all__ = ["StudyStore", "ResumeInfo", "ParticipantInfo", "PersonasImport", "DayInfo", "PolicyVersion", "Study",
           "DEFAULT_STUDY", "DB_ENV", "INTERACTION_EXTRA_COLUMNS", "SCHEMA_VERSION", "default_db_path"]
