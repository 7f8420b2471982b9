"""Where the shipped study data lives (``study_data/`` beside the package, or $CACAS_STUDY_DATA)."""

from __future__ import annotations

import os
from pathlib import Path

PROJECT_ROOT = Path(__file__).resolve().parents[1]
#: The environment variable that moves the study data folder.
STUDY_DATA_ENV = "CACAS_STUDY_DATA"
#: What the shipped folder holds that a study needs: the D4A pairs (the generic user, Section
#: IV-B.3: the initial policy trains against them and every adaptation's decision model asks
#: them), the example personas, the sound and scene libraries, and the trained models.
SHIPPED = ("d4a.csv", "personas", "sounds", "scenes", "models")


def study_data_dir() -> Path:
    """The study data folder: ``$CACAS_STUDY_DATA`` if set, else ``<project>/study_data``."""
    return Path(os.environ.get(STUDY_DATA_ENV, PROJECT_ROOT / "study_data"))


def missing_shipped(folder: str | Path | None = None) -> list[str]:
    """The entries of :data:`SHIPPED` that the study data folder lacks (an empty folder given as
    ``$CACAS_STUDY_DATA`` lacks them all)."""
    folder = Path(folder) if folder is not None else study_data_dir()
    return [name for name in SHIPPED if not (folder / name).exists()]


def study_data_problem(folder: str | Path | None = None) -> str | None:
    """One line naming what the study data folder lacks of the shipped files and how to set it
    up, or None when nothing is missing."""
    folder = Path(folder) if folder is not None else study_data_dir()
    missing = missing_shipped(folder)
    if not missing:
        return None
    why = (": without d4a.csv the robot cannot get ready (the initial policy trains against it) and no "
           "policy can be adapted" if "d4a.csv" in missing else "")
    return (f"the study data folder {folder} lacks the shipped {', '.join(missing)}{why}; valid: a copy of the "
            f"shipped folder (cp -r {PROJECT_ROOT / 'study_data'}/. {folder}), or ${STUDY_DATA_ENV} unset "
            f"(to keep only the study database elsewhere, set $CACAS_DB to its file)")
