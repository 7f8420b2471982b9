"""Where the shipped study data lives (``study_data/`` beside the package, or $CACAS_STUDY_DATA)."""

from __future__ import annotations

import os
from pathlib import Path

PROJECT_ROOT = Path(__file__).resolve().parents[1]


def study_data_dir() -> Path:
    """The study data folder: ``$CACAS_STUDY_DATA`` if set, else ``<project>/study_data``."""
    return Path(os.environ.get("CACAS_STUDY_DATA", PROJECT_ROOT / "study_data"))
