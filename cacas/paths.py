"""Where the shipped study data lives (``study_data/`` beside the package, or $CACAS_STUDY_DATA)."""

from __future__ import annotations

import os
from pathlib import Path

PROJECT_ROOT = Path(__file__).resolve().parents[1]
#: The environment variable that moves the study data folder.
STUDY_DATA_ENV = "CACAS_STUDY_DATA"
#: What the shipped folder holds that a study uses, and what a folder without it cannot do. Only
#: the D4A pairs stop a study (the generic user, Section IV-B.3: the initial policy trains
#: against them and every adaptation's decision model asks them); without the others the study
#: runs with less.
SHIPPED = {
    "d4a.csv": "the robot cannot get ready (the initial policy trains against the D4A pairs) and no policy can "
               "be adapted",
    "personas": "the Simulation lab has no example personas",
    "sounds": "the tablet plays no activity sound and no sound model can be trained",
    "scenes": "the tablet shows no room photo and no scene model can be trained",
    "models": "the robot recognises nothing (it uses the context as set) and trains its initial policy on first "
              "use",
}
#: The shipped entry without which no study day can start.
REQUIRED = "d4a.csv"


def study_data_dir() -> Path:
    """The study data folder: ``$CACAS_STUDY_DATA`` if set, else ``<project>/study_data``."""
    return Path(os.environ.get(STUDY_DATA_ENV, PROJECT_ROOT / "study_data"))


def missing_shipped(folder: str | Path | None = None) -> list[str]:
    """The entries of :data:`SHIPPED` that the study data folder lacks (an empty folder given as
    ``$CACAS_STUDY_DATA`` lacks them all)."""
    folder = Path(folder) if folder is not None else study_data_dir()
    return [name for name in SHIPPED if not (folder / name).exists()]


def study_data_problem(folder: str | Path | None = None) -> str | None:
    """One line naming what the study data folder lacks of the shipped files, what that stops,
    and how to set it up, or None when nothing is missing. The advice copies the missing entries
    alone and overwrites nothing (``cp -rn``): the folder may already hold a study database."""
    folder = Path(folder) if folder is not None else study_data_dir()
    missing = missing_shipped(folder)
    if not missing:
        return None
    import shlex

    shipped = PROJECT_ROOT / "study_data"
    # quoted as a shell reads them: the command is pasted, and a path with a space ("/Users/Jane Doe/...") was split
    copy = " ".join(shlex.quote(str(shipped / name)) for name in missing)
    target = shlex.quote(f"{folder}/")
    return (f"the study data folder {folder} lacks the shipped {', '.join(missing)} "
            f"({'; '.join(f'without {name}, {SHIPPED[name]}' for name in missing)}); valid: copy "
            f"{'it' if len(missing) == 1 else 'them'} from the shipped folder (cp -rn {copy} {target}), or "
            f"${STUDY_DATA_ENV} unset (to keep only the study database elsewhere, set $CACAS_DB to its file)")


def study_data_blocked(folder: str | Path | None = None) -> bool:
    """Whether the study data folder lacks what every study day needs (:data:`REQUIRED`)."""
    return REQUIRED in missing_shipped(folder)
