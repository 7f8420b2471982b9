"""The daily activity-agent action acceptance (D4A) pairs of the user simulator (Section IV-B.3).

"The D4A pairs show the user's sentiment polarity towards the agent action when performing a
specific activity." For each of the 33 activities (S1) and 14 agent actions (S6) of Table I the
generic user's response is accept (+1), reject (-1) or others (0). In ``generate_response`` the
participant's preferences come first and the D4A pairs second; the initial policy (CACAA step 1)
is trained against the generic user, whose preference set ``up`` we read as "accept the actions
D4A marks accept" (:meth:`D4A.accepted_actions`, :meth:`D4A.generic_actions`).

The file is a CSV: header ``activity,<the 14 action names>``, one row per activity, each cell
``accept``, ``reject`` or ``others``. Names match case-insensitively (:func:`cacas.spaces.canonical`);
rows and columns may come in any order. The "do nothing" column is ``others`` in every file
(:data:`DO_NOTHING_RULE`): the robot doing nothing gets no response from the user (see
``study_data/d4a.md``); a table answering it is refused.
Any problem with a researcher's own file is one :class:`CacasError` naming the file, the line
and the column at fault.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from cacas import spaces
from cacas.errors import CacasError, not_utf8
from cacas.paths import study_data_dir

#: Why the "do nothing" column is ``others`` everywhere (Section IV-B: the robot doing nothing
#: initiates nothing, so the user has nothing to accept or reject; reward 0). A table answering it
#: would reward or punish silence in step 1's training, which no response of the paper does.
DO_NOTHING_RULE = ("'others' only: the robot doing nothing gets no response from the user "
                   "(see study_data/d4a.md)")

#: File name of the shipped D4A table inside :func:`cacas.paths.study_data_dir`.
D4A_FILE = "d4a.csv"


def default_d4a_path() -> Path:
    """The shipped D4A table: ``<study_data>/d4a.csv``."""
    return study_data_dir() / D4A_FILE


@dataclass(frozen=True, eq=False)
class D4A:
    """The D4A pairs: ``table[activity, action]`` is ACCEPT, REJECT or OTHERS (Table I indices)."""

    table: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        t = np.asarray(self.table)
        if t.shape != (spaces.N_ACTIVITIES, spaces.N_ACTIONS):
            raise CacasError(f"a D4A table has shape {t.shape}; valid: "
                             f"({spaces.N_ACTIVITIES}, {spaces.N_ACTIONS}) activities x actions")
        if not np.isin(t, (spaces.ACCEPT, spaces.REJECT, spaces.OTHERS)).all():
            raise CacasError("a D4A table holds a value other than ACCEPT, REJECT or OTHERS (0, 1, 2)")
        answered = np.flatnonzero(t[:, spaces.DO_NOTHING_ACTION] != spaces.OTHERS)
        if len(answered):
            where = f"{self.source}: " if self.source else ""
            first = int(answered[0])
            n = len(answered) - 1
            more = f" (and {n} more {'activity' if n == 1 else 'activities'})" if n else ""
            raise CacasError(f"{where}a D4A table's 'do nothing' column holds "
                             f"{spaces.RESPONSES[int(t[first, spaces.DO_NOTHING_ACTION])]!r} for "
                             f"{spaces.ACTIVITIES[first]!r}{more}; valid: {DO_NOTHING_RULE}")
        t = t.astype(np.int8, copy=True)
        t.setflags(write=False)
        object.__setattr__(self, "table", t)

    def response(self, activity: int, action: int) -> int:
        """The generic user's response index (spaces.ACCEPT / REJECT / OTHERS)."""
        return int(self.table[activity, action])

    def reward(self, activity: int, action: int) -> float:
        """The reward of that response: accept +1, reject -1, others 0 (Section IV-B.1)."""
        return spaces.REWARDS[spaces.RESPONSES[self.response(activity, action)]]

    def accepted_actions(self, activity: int) -> list[int]:
        """Action indices the generic user accepts during ``activity`` (may be empty)."""
        return [int(a) for a in np.flatnonzero(self.table[activity] == spaces.ACCEPT)]

    def generic_actions(self, activity: int) -> list[int]:
        """The generic user's preferred actions: the accepted ones, or ["do nothing"] if none.

        Activities with no accepted action (e.g. snore, flush toilet) are those where the generic
        user wants the robot to stay quiet.
        """
        return self.accepted_actions(activity) or [spaces.DO_NOTHING_ACTION]

    def to_frame(self) -> pd.DataFrame:
        """Tidy table: one row per (activity, action) with columns activity, action, response."""
        acts, actions = np.meshgrid(np.arange(spaces.N_ACTIVITIES), np.arange(spaces.N_ACTIONS), indexing="ij")
        return pd.DataFrame({
            "activity": [spaces.ACTIVITIES[i] for i in acts.ravel()],
            "action": [spaces.ACTIONS[i] for i in actions.ravel()],
            "response": [spaces.RESPONSES[i] for i in self.table.ravel()],
        })

    def to_csv_text(self) -> str:
        """The file format read by :func:`load_d4a` (wide: one row per activity)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["activity", *spaces.ACTIONS])
        for i, name in enumerate(spaces.ACTIVITIES):
            w.writerow([name, *(spaces.RESPONSES[r] for r in self.table[i])])
        return buf.getvalue()


def differs_from_generic(preference, d4a: D4A) -> bool:
    """True if a described preference's action is not among D4A's accepted actions for any of its
    activities: a personal twist the initial policy (trained on the generic user) cannot know."""
    accepted = set().union(*(d4a.accepted_actions(a) for a in preference.activity_indices()))
    return preference.action_index not in accepted


def persona_summary(participants, d4a: D4A | None = None) -> pd.DataFrame:
    """One row per participant: preferences, covered S1-S4 states (the paper's 1564 on average),
    and how many preferences differ from the generic D4A user (:func:`differs_from_generic`)."""
    d4a = d4a if d4a is not None else load_d4a()
    return pd.DataFrame([{
        "participant": p.id,
        "preferences": len(p.preferences),
        "covered_states": p.covered_count(),
        "differing_from_d4a": sum(differs_from_generic(pref, d4a) for pref in p.preferences),
    } for p in participants], columns=["participant", "preferences", "covered_states", "differing_from_d4a"])


def save_d4a(d4a: D4A, path: str | Path) -> None:
    """Write a D4A table as CSV, atomically (:func:`cacas.store.files.atomic_write`); a failure is a
    CacasError naming the file, which is left as it was."""
    from cacas.store.files import atomic_write

    atomic_write(Path(path), d4a.to_csv_text().encode("utf-8"))


def _canon_or_none(kind: str, name: str) -> str | None:
    try:
        return spaces.canonical(kind, name)
    except CacasError:
        return None


def parse_d4a(text: str, source: str = "D4A file") -> D4A:
    """Validate the text of a D4A CSV file (see the module docstring for the format)."""
    valid_cells = ", ".join(spaces.RESPONSES)
    if "\x00" in text:
        raise CacasError(f"{source}: is not a CSV text file (it contains NUL bytes)")
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    rows: list[tuple[int, list[str]]] = []
    try:
        for row in reader:
            if row and any(c.strip() for c in row):
                rows.append((reader.line_num, row))
    except csv.Error as exc:
        raise CacasError(f"{source}, line {reader.line_num}: is not valid CSV ({exc})") from None
    if not rows:
        raise CacasError(f"{source}: is empty; expected a header 'activity,<the 14 action names>' "
                         f"and one row per activity")
    header_line, header = rows[0]
    if len(header) < 2 or header[0].strip().lower() != "activity":
        raise CacasError(f"{source}, line {header_line}: is not a D4A CSV header; expected "
                         f"'activity,{','.join(spaces.ACTIONS)}' (comma-separated), got {','.join(header)[:80]!r}")
    columns: list[int] = []
    for col, raw in enumerate(header[1:], start=2):
        name = _canon_or_none("action", raw)
        if name is None:
            raise CacasError(f"{source}, line {header_line}, column {col}: unknown action {raw.strip()!r}; "
                             f"valid: {', '.join(spaces.ACTIONS)}")
        index = spaces.ACTIONS.index(name)
        if index in columns:
            raise CacasError(f"{source}, line {header_line}, column {col}: action {name!r} appears twice")
        columns.append(index)
    missing = [spaces.ACTIONS[a] for a in range(spaces.N_ACTIONS) if a not in columns]
    if missing:
        raise CacasError(f"{source}, line {header_line}: missing action column(s): {', '.join(missing)}")

    table = np.full((spaces.N_ACTIVITIES, spaces.N_ACTIONS), -1, dtype=np.int8)
    seen: dict[int, int] = {}
    for line, row in rows[1:]:
        if len(row) != len(header):
            raise CacasError(f"{source}, line {line}: has {len(row)} fields, the header has {len(header)}")
        name = _canon_or_none("activity", row[0])
        if name is None:
            raise CacasError(f"{source}, line {line}, column 1 (activity): unknown activity {row[0].strip()!r}; "
                             f"valid: {', '.join(spaces.ACTIVITIES)}")
        act = spaces.ACTIVITIES.index(name)
        if act in seen:
            raise CacasError(f"{source}, line {line}: activity {name!r} appears twice (also line {seen[act]})")
        seen[act] = line
        for col, (action, cell) in enumerate(zip(columns, row[1:]), start=2):
            value = " ".join(cell.strip().lower().split())
            if value not in spaces.RESPONSES:  # an empty cell said so (walk3: "'' is not a response")
                what = "the cell is empty" if not value else f"{cell.strip()!r} is not a response"
                raise CacasError(f"{source}, line {line}, column {col} ({name} / {spaces.ACTIONS[action]}): "
                                 f"{what}; valid: {valid_cells}")
            if action == spaces.DO_NOTHING_ACTION and value != spaces.RESPONSES[spaces.OTHERS]:
                raise CacasError(f"{source}, line {line}, column {col} ({name} / do nothing): {cell.strip()!r}; "
                                 f"valid: {DO_NOTHING_RULE}")
            table[act, action] = spaces.RESPONSES.index(value)
    missing_rows = [spaces.ACTIVITIES[a] for a in range(spaces.N_ACTIVITIES) if a not in seen]
    if missing_rows:
        raise CacasError(f"{source}: missing activity row(s): {', '.join(missing_rows)}")
    return D4A(table, source)


def load_d4a(path: str | Path | None = None) -> D4A:
    """Read and validate a D4A CSV file; ``None`` loads the shipped ``study_data/d4a.csv``."""
    path = Path(path) if path is not None else default_d4a_path()
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise CacasError(f"{path}: no such D4A file") from None
    except IsADirectoryError:
        raise CacasError(f"{path}: is a folder, not a D4A CSV file") from None
    except OSError as exc:
        raise CacasError(f"{path}: cannot be read ({exc.__class__.__name__})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise CacasError(f"{path}: is not a CSV text file (not UTF-8 text: {not_utf8(raw)}); valid: a D4A CSV file "
                         "saved as UTF-8") from None
    return parse_d4a(text, str(path))
