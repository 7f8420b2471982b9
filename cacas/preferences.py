"""Described preferences and the persona file (design.md's contract), validation and coverage.

A participant describes ~5 preferences (Section V-B.1): in some context (activities S1, scenes
S2, hours S3, repeat interval S4, optionally the robot's current task S5) they want one action.
A preference *covers* every S1-S4 combination its fields allow; a participant's covered states
are the union (the paper counts 1564 on average for 5 preferences).

The adaptation never reads these (the paper: "the system has no access to them"); they drive the
simulated participant and the evaluation of Fig. 4 only.
"""

from __future__ import annotations

import json
import math
import re
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np

from cacas import spaces
from cacas.errors import CacasError, Problems, nearest, not_utf8, shortened, visible
from cacas.privacy import contact_details

FIELDS = ("description", "activity", "scene", "hours", "interval", "task", "action")


@dataclass(frozen=True)
class Preference:
    """One described preference; ``None`` in an optional field means "any"."""

    activity: tuple[str, ...]
    action: str
    scene: tuple[str, ...] | None = None
    hours: tuple[tuple[int, int], ...] | None = None
    interval: tuple[int, int] | None = None
    task: tuple[str, ...] | None = None
    description: str = ""

    # --- index sets over Table I -------------------------------------------------------------
    @property
    def action_index(self) -> int:
        return spaces.action_index(self.action)

    def activity_indices(self) -> list[int]:
        return spaces.parse_names("activity", self.activity)

    def scene_indices(self) -> list[int]:
        return list(range(spaces.N_SCENES)) if self.scene is None else spaces.parse_names("scene", self.scene)

    def slot_indices(self) -> list[int]:
        if self.hours is None:
            return list(range(spaces.N_SLOTS))
        return sorted({i for i, (s0, s1) in enumerate(spaces.TIME_SLOTS)
                       for (h0, h1) in self.hours if h0 <= s0 and s1 <= h1})

    def interval_indices(self) -> list[int]:
        if self.interval is None:
            return list(range(spaces.N_INTERVALS))
        lo, hi = self.interval
        return [i for i, b in enumerate(spaces.INTERVAL_BINS) if lo <= b <= hi]

    def task_indices(self) -> list[int]:
        return list(range(spaces.N_ACTIONS)) if self.task is None else spaces.parse_names("action", self.task)

    def coverage_mask(self) -> np.ndarray:
        """Boolean (33, 6, 12, 12) array: the S1-S4 states this preference covers."""
        mask = np.zeros((spaces.N_ACTIVITIES, spaces.N_SCENES, spaces.N_SLOTS, spaces.N_INTERVALS), bool)
        mask[np.ix_(self.activity_indices(), self.scene_indices(), self.slot_indices(),
                    self.interval_indices())] = True
        return mask

    def covered_count(self) -> int:
        return int(self.coverage_mask().sum())

    def label(self) -> str:
        return self.description or f"{'/'.join(self.activity)} -> {self.action}"

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        if self.description:
            out["description"] = self.description
        out["activity"] = list(self.activity)
        if self.scene is not None:
            out["scene"] = list(self.scene)
        if self.hours is not None:
            out["hours"] = [list(h) for h in self.hours]
        if self.interval is not None:
            out["interval"] = list(self.interval)
        if self.task is not None:
            out["task"] = list(self.task)
        out["action"] = self.action
        return out


@dataclass(frozen=True)
class Participant:
    """A pseudonymous participant code and their described preferences."""

    id: str
    preferences: tuple[Preference, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "preferences": [p.to_dict() for p in self.preferences]}

    def without_words(self) -> "Participant":
        """The same preferences without the participant's own words (``description``): what a
        simulated run of a study's participants keeps, as its files stay after a participant's
        removal (labels fall back to "activity -> action")."""
        return replace(self, preferences=tuple(replace(p, description="") for p in self.preferences))

    def coverage_mask(self) -> np.ndarray:
        """Union of the preferences' covered S1-S4 states."""
        mask = np.zeros((spaces.N_ACTIVITIES, spaces.N_SCENES, spaces.N_SLOTS, spaces.N_INTERVALS), bool)
        for p in self.preferences:
            mask |= p.coverage_mask()
        return mask

    def covered_count(self) -> int:
        return int(self.coverage_mask().sum())

    def preferred_action_table(self) -> np.ndarray:
        """int8 array (33, 6, 12, 12, 14) over S1..S5: the preferred action, or -1 where none.

        Validation guarantees no two preferences disagree on a state, so the table is unique.
        """
        table = np.full((spaces.N_ACTIVITIES, spaces.N_SCENES, spaces.N_SLOTS, spaces.N_INTERVALS,
                         spaces.N_ACTIONS), -1, dtype=np.int8)
        for p in self.preferences:
            table[np.ix_(p.activity_indices(), p.scene_indices(), p.slot_indices(),
                         p.interval_indices(), p.task_indices())] = p.action_index
        return table


# --- validation ----------------------------------------------------------------------------------

def check_private_words(person: "Participant", source: str | None = None, numbers=None) -> None:
    """Study data are pseudonymous: a preference's own words (its description) must hold no
    e-mail address or phone number (:func:`cacas.privacy.contact_details`). The error names the
    source, participant, preference and field. Checked where preferences enter the study
    database or the Simulation lab's runs (``cacas simulate`` reads the researcher's own file
    and does not refuse it). ``numbers``: the preferences' numbers (default 1, 2, ...)."""
    for i, pref in enumerate(person.preferences):
        found = contact_details(pref.description)
        if found:
            n = (numbers[i] if numbers is not None else i + 1) - 1
            where = _where(source, person.id, n, "description", {"description": pref.description})
            raise CacasError(f"{where}: holds what looks like contact details ({found!r}); valid: the participant's "
                             "words without e-mail addresses or phone numbers (study data are pseudonymous)")


def _where(source: str | None, pid: str | None = None, pref: int | None = None,
           fld: str | None = None, pref_obj: Any = None) -> str:
    parts = []
    if source:
        parts.append(str(source))
    if pid is not None:
        parts.append(f"participant {visible(pid)}")
    if pref is not None:
        parts.append(f"preference {pref + 1}{_quoted(pref_obj.get('description') if isinstance(pref_obj, dict) else None)}")
    if fld is not None:
        parts.append(f"field '{visible(fld)}'")
    return ": ".join([", ".join(parts)]) if parts else ""


def _quoted(description: Any) -> str:
    """A preference's own words after its number in a message, their start: ' ("remind me to drink...")';
    nothing when it has none."""
    return f' ("{shortened(description, 43)}")' if isinstance(description, str) and description.strip() else ""


def _names_list(value: Any, kind: str, where: str, required: bool) -> tuple[str, ...] | None:
    if value is None:
        if required:
            raise CacasError(f"{where}: is missing; it must be a non-empty list of {kind} names")
        return None
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise CacasError(f"{where}: must be a non-empty list of {kind} names, got {json.dumps(value)}")
    out = []
    for v in value:
        try:
            out.append(spaces.canonical(kind, v))
        except CacasError as exc:
            raise CacasError(f"{where}: {exc}") from None
    return tuple(dict.fromkeys(out))


def _hours(value: Any, where: str) -> tuple[tuple[int, int], ...] | None:
    if value is None:
        return None
    hint = "a list of [start, end) pairs in whole even hours 0-24 with start < end, e.g. [[6, 10], [16, 20]]"
    if not isinstance(value, list) or not value:
        raise CacasError(f"{where}: must be {hint}, got {json.dumps(value)}")
    out = []
    for pair in value:
        ok = (isinstance(pair, list) and len(pair) == 2
              and all(isinstance(h, int) and not isinstance(h, bool) for h in pair))
        if not ok or not (0 <= pair[0] < pair[1] <= 24) or pair[0] % 2 or pair[1] % 2:
            extra = ""
            if ok and 0 <= pair[0] <= 24 and 0 <= pair[1] <= 24 and pair[0] >= pair[1]:
                extra = _past_midnight(*pair)
            elif ok and 0 <= pair[0] < pair[1] <= 24:  # odd: the slots are 2 hours from midnight (Table I)
                cover = [pair[0] - pair[0] % 2, pair[1] + pair[1] % 2]
                extra = (f" (the day is in 2-hour slots from midnight, so a range starts and ends at an even hour: "
                         f"{json.dumps(cover)}, {cover[0]:02d}:00-{cover[1]:02d}:00, holds {pair[0]:02d}:00-{pair[1]:02d}:00)")
            elif isinstance(pair, list) and any(isinstance(h, float) for h in pair):
                extra = " (hours are whole numbers, written without a decimal point: 6, not 6.0)"
            elif isinstance(pair, list) and any(isinstance(h, str) for h in pair):  # "7am", "06:00" (walkthrough)
                extra = " (hours are numbers of the 24-hour clock, not text: 6 for 06:00, 18 for 6 pm)"
            elif not isinstance(pair, list) and len(value) == 2 and all(
                    isinstance(h, (int, float)) and not isinstance(h, bool) for h in value):
                # [6, 10] for [[6, 10]]: "6 is invalid" named a number the researcher never meant as a range
                pair = value
                extra = f" (one range is a list of one pair: [{json.dumps(value)}], not {json.dumps(value)})"
            raise CacasError(f"{where}: {json.dumps(pair)} is invalid{extra}; valid: {hint}")
        out.append((pair[0], pair[1]))
    return tuple(out)


def _past_midnight(start: int, end: int) -> str:
    """What a range of whole hours 0-24 whose ``start`` is not before its ``end`` is meant to be, for
    :func:`_hours`' message: the ranges of even hours (S3's 2-hour slots, Table I) that hold it. It said
    "e.g. [[22, 24], [0, 2]]" for each: [22, 0], 22:00 "until midnight", was then written 22:00-02:00."""
    def clock(a: int, b: int) -> str:
        return f"{a:02d}:00-{b:02d}:00"

    if start % 24 == end % 24:  # [6, 6]; [24, 0], midnight to midnight
        return (" (its start and end are the same hour, so it holds no time; the whole day is [[0, 24]], or leave "
                "'hours' out)")
    low, high = start - start % 2, end + end % 2  # the even hours around it
    held = "" if (low, high) == (start, end) else f", holds {clock(start, end)}"
    if end == 0:
        return f" (midnight as a range's end is 24: [{low}, 24], {clock(low, 24)}{held.replace('00:00', '24:00')})"
    if start == 24:
        return f" (midnight as a range's start is 0: [0, {high}], {clock(0, high)}{held.replace('24:00', '00:00')})"
    even = "" if not held else ", in even hours as the day is in 2-hour slots from midnight"
    return (f" (a range over midnight is two ranges{even}: {json.dumps([[low, 24], [0, high]])}, "
            f"{clock(low, 24)} and {clock(0, high)}{held})")


def _interval(value: Any, where: str) -> tuple[int, int] | None:
    if value is None:
        return None
    hint = f"[min, max] minutes with 0 <= min <= max, covering at least one of {list(spaces.INTERVAL_BINS)}"
    ok = (isinstance(value, list) and len(value) == 2
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
    if not ok or value[0] < 0 or value[0] > value[1] or not any(
            value[0] <= b <= value[1] for b in spaces.INTERVAL_BINS):
        raise CacasError(f"{where}: {json.dumps(value)} is invalid; valid: {hint}")
    return (value[0], value[1])


def parse_preference(obj: Any, source: str | None = None, pid: str | None = None,
                     index: int = 0) -> Preference:
    """Validate one preference dict; errors name the source, participant, preference and field."""
    w = lambda fld=None: _where(source, pid, index, fld, obj)  # noqa: E731
    if not isinstance(obj, dict):
        raise CacasError(f"{w()}: must be an object with fields {', '.join(FIELDS)}")
    unknown = sorted(set(obj) - set(FIELDS))
    if unknown:
        raise CacasError(f"{w(unknown[0])}: unknown field; {nearest(unknown[0], FIELDS)}"
                         f"valid fields: {', '.join(FIELDS)}")
    desc = obj.get("description", "")
    if desc is None:
        desc = ""
    if not isinstance(desc, str):
        raise CacasError(f"{w('description')}: must be text (the participant's own words)")
    if "action" not in obj:
        raise CacasError(f"{w('action')}: is missing; valid: one of {', '.join(spaces.ACTIONS)}")
    if not isinstance(obj["action"], str):
        raise CacasError(f"{w('action')}: must be one action name; valid: {', '.join(spaces.ACTIONS)}")
    try:
        action = spaces.canonical("action", obj["action"])
    except CacasError as exc:
        raise CacasError(f"{w('action')}: {exc}") from None
    if "activity" in obj and obj["activity"] is None:  # it is there: "is missing" misled (review)
        raise CacasError(f"{w('activity')}: is null; it must be a non-empty list of activity names")
    pref = Preference(
        activity=_names_list(obj.get("activity"), "activity", w("activity"), required=True),
        action=action,
        scene=_names_list(obj.get("scene"), "scene", w("scene"), required=False),
        hours=_hours(obj.get("hours"), w("hours")),
        interval=_interval(obj.get("interval"), w("interval")),
        task=_names_list(obj.get("task"), "action", w("task"), required=False),
        description=desc.strip(),
    )
    return pref


#: The persona file's fields (design.md) that narrow a preference, named in the advice of
#: :func:`check_conflicts`.
FILE_FIELDS = "activity, scene, hours, interval or task"


def check_conflicts(preferences: Iterable[Preference], source: str | None = None,
                    pid: str | None = None, fields: str = FILE_FIELDS, numbers: Sequence[int] | None = None) -> None:
    """Two preferences covering the same state with different actions: an error naming both, by their
    ``numbers`` (default 1, 2, ...: a form gives its own) and the start of their words, advising to narrow
    ``fields`` (default the persona file's; a form names its own)."""
    prefs = list(preferences)
    numbers = list(numbers) if numbers is not None else list(range(1, len(prefs) + 1))
    for i in range(len(prefs)):
        for j in range(i + 1, len(prefs)):
            a, b = prefs[i], prefs[j]
            if a.action == b.action:
                continue
            tasks = sorted(set(a.task_indices()) & set(b.task_indices()))
            if not tasks:
                continue
            overlap = a.coverage_mask() & b.coverage_mask()
            if overlap.any():
                act, sc, sl, iv = (int(x[0]) for x in np.nonzero(overlap))
                example = (f"{spaces.ACTIVITIES[act]} {spaces.in_scene(spaces.SCENES[sc])} at "
                           f"{spaces.time_slot_label(sl)}, interval {spaces.interval_label(iv)}")
                if a.task is not None or b.task is not None:  # S5 matters: say during which task
                    example += f", while the robot's task is {spaces.ACTIONS[tasks[0]]!r}"
                where = _where(source, pid)
                raise CacasError(
                    # each named by the start of its words too, as the file's other refusals (walk3: by number only)
                    f"{where}: preferences {numbers[i]}{_quoted(a.description)} and {numbers[j]}{_quoted(b.description)} "
                    f"both cover {int(overlap.sum())} states "
                    f"(e.g. {example}) with different actions ({a.action!r} vs {b.action!r}); "
                    f"narrow their {fields} so they do not overlap")


def redundant_preferences(preferences: Iterable[Preference]) -> list[tuple[int, int]]:
    """Pairs (inner, outer) of 0-based positions where preference ``inner`` asks for the same
    action as ``outer`` in states ``outer`` already covers, all of them (S1-S4 and the tasks S5
    it applies during): it adds nothing to what the participant described, and Fig. 4's
    breakdown by preference counts those states under both. Each inner preference is listed
    once, with the first preference that covers it (of two identical ones, the later is inner)."""
    prefs = list(preferences)
    masks = [p.coverage_mask() for p in prefs]
    tasks = [set(p.task_indices()) for p in prefs]
    out = []
    for i, inner in enumerate(prefs):
        for j, outer in enumerate(prefs):
            if i == j or inner.action != outer.action:
                continue
            inside = not (masks[i] & ~masks[j]).any() and tasks[i] <= tasks[j]
            identical = inside and tasks[i] == tasks[j] and bool((masks[i] == masks[j]).all())
            if inside and not (identical and i < j):
                out.append((i, j))
                break
    return out


def parse_participant(obj: Any, source: str | None = None, index: int = 0) -> Participant:
    """Validate one participant of a persona document; the first problem is a CacasError naming the
    source, participant, preference and field (:func:`participant_problems` lists them all)."""
    person, problems = participant_problems(obj, source, index)
    if problems:
        raise CacasError(problems[0])
    return person


def participant_problems(obj: Any, source: str | None = None,
                         index: int = 0) -> tuple[Participant | None, list[str]]:
    """The participant of a persona document and ``[]``, or None and every problem found, one line
    each: the participant's own (its object, code, fields), else each invalid preference's first
    (its fields are read in the file's order), else the first overlap of two valid ones."""
    if not isinstance(obj, dict):
        return None, [f"{_where(source)}: participant {index + 1} must be an object with 'id' and 'preferences'"]
    pid = obj.get("id")
    if not isinstance(pid, str) or not pid.strip():
        return None, [f"{_where(source)}: participant {index + 1}, field 'id': must be a non-empty "
                      f"pseudonymous code such as \"P01\""]
    pid = pid.strip()
    if "," in pid:  # "Smith, Anna": `cacas simulate --participants` could not name it (comma-separated codes)
        from cacas.store.validate import CODE_HINT

        return None, [f"{_where(source)}: participant {index + 1}, field 'id': {pid!r} holds a comma, which "
                      f"separates the codes of `cacas simulate --participants`; valid: {CODE_HINT}"]
    unknown = sorted(set(obj) - {"id", "preferences"})
    if unknown:
        return None, [f"{_where(source, pid, fld=unknown[0])}: unknown field; "
                      f"{nearest(unknown[0], ('id', 'preferences'))}valid fields: id, preferences"]
    raw = obj.get("preferences")
    if not isinstance(raw, list) or not raw:
        return None, [f"{_where(source, pid, fld='preferences')}: must be a non-empty list of preferences"]
    prefs, problems = [], []
    for i, p in enumerate(raw):
        try:
            prefs.append(parse_preference(p, source, pid, i))
        except CacasError as exc:
            problems.append(str(exc))
    if problems:  # overlaps are judged once every preference reads
        return None, problems
    try:
        check_conflicts(prefs, source, pid)
    except CacasError as exc:
        return None, [str(exc)]
    return Participant(pid, tuple(prefs)), []


def parse_personas(data: Any, source: str | None = None) -> list[Participant]:
    """Validate a persona document (already parsed JSON) into participants.

    Every problem is found in one reading (walk3: a file with three mistakes took three runs to
    mend): one is its own line, as before; several are one CacasError whose one line (design.md's
    contract) numbers them, each naming its participant, preference and field, the first
    eight written out (:class:`cacas.errors.Problems`)."""
    if not isinstance(data, dict) or not isinstance(data.get("participants"), list):
        raise CacasError(f"{_where(source)}: must be a JSON object with a list 'participants'")
    unknown = sorted(set(data) - {"participants"})
    if unknown:  # a misspelt key was passed over without a word, as participants' and preferences' are not
        raise CacasError(f"{_where(source, fld=unknown[0])}: unknown field; {nearest(unknown[0], ('participants',))}"
                         "valid fields: participants")
    if not data["participants"]:
        raise CacasError(f"{_where(source)}: 'participants' is empty; add at least one participant")
    people, problems = [], []
    for i, obj in enumerate(data["participants"]):
        person, found = participant_problems(obj, source, i)
        problems += found
        if person is not None:
            people.append(person)
    seen: dict[str, str] = {}  # by letter-case-folded code: P01 and p01 are two participants a reader takes for one
    for code in map(_code, data["participants"]):
        if code is None:
            continue
        other = seen.get(code.casefold())
        if other == code:
            problems.append(f"{_where(source, code, fld='id')}: appears twice; codes must be unique")
        elif other is not None:
            problems.append(f"{_where(source, code, fld='id')}: differs from participant {visible(other)} only in "
                            "letter case; codes must be unique")
        seen[code.casefold()] = code
    _raise_problems(problems, source)
    return people


def _code(obj: Any) -> str | None:
    """A participant object's code as :func:`participant_problems` reads it, or None."""
    pid = obj.get("id") if isinstance(obj, dict) else None
    return pid.strip() if isinstance(pid, str) and pid.strip() else None


def _raise_problems(problems: list[str], source: str | None) -> None:
    """Nothing for none; the one problem's own message; or :class:`cacas.errors.Problems`, the place's
    ``source`` written once at its start."""
    if not problems:
        return
    if len(problems) == 1:
        raise CacasError(problems[0])
    head = f"{source}: " if source else ""
    lines = [p[len(head):] if head and p.startswith(head) else
             p[len(source) + 2:] if source and p.startswith(f"{source}, ") else p for p in problems]
    raise Problems(head, lines)


def load_personas(path: str | Path) -> list[Participant]:
    """Read and validate a persona file; any problem is one CacasError naming file and field."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise CacasError(f"{path}: no such persona file") from None
    except OSError as exc:
        raise CacasError(f"{path}: cannot be read ({exc.strerror or exc.__class__.__name__})") from None
    return parse_personas(persona_json(data, str(path)), str(path))


class _TwiceInOneObject(CacasError):
    pass


def _once_each(pairs: list[tuple[str, Any]]) -> dict:
    """A JSON object whose keys appear once each (``json`` keeps the last of two without a word:
    ``"action": "pain check", "action": "chitchat"`` ran as chitchat)."""
    seen = {}
    for key, value in pairs:
        if key in seen:
            raise _TwiceInOneObject(f"field '{key}' appears twice in one object; write each field once")
        seen[key] = value
    return seen


def persona_json(data: str | bytes, source: str) -> Any:
    """The JSON document of a persona file's text or bytes; CacasError naming ``source`` if it is
    not UTF-8 text, not JSON, or nested too deeply to be a persona file. A UTF-8 byte-order mark
    (as some editors save) is accepted and dropped."""
    try:
        text = data.decode("utf-8-sig") if isinstance(data, bytes) else data
    except UnicodeDecodeError:
        raise CacasError(f"{source}: cannot be read as UTF-8 text ({not_utf8(data)}); valid: a JSON persona "
                         "file saved as UTF-8") from None
    text = text.removeprefix("\ufeff")  # text decoded by the caller as plain utf-8
    try:
        doc = json.loads(text, object_pairs_hook=_once_each)
    except json.JSONDecodeError as exc:
        raise CacasError(f"{source}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") from None
    except _TwiceInOneObject as exc:  # (a CacasError is a ValueError)
        raise CacasError(f"{source}: {exc}") from None
    except ValueError as exc:  # a whole number longer than int() reads (sys.get_int_max_str_digits); CLI audit
        limit = sys.get_int_max_str_digits()
        long = re.search(r"\d{%d,}" % (limit + 1), text) if limit else None
        if long is None:
            raise CacasError(f"{source}: not valid JSON ({exc})") from None
        raise CacasError(f"{source}: the number on line {text.count(chr(10), 0, long.start()) + 1} has "
                         f"{len(long.group())} digits, more than can be read ({limit}); valid: the format of "
                         "docs/personas.md (hours 0-24, minutes since the last activity)") from None
    except RecursionError:
        raise CacasError(f"{source}: nested too deeply to be a persona file; valid: the format of docs/personas.md") from None
    half = _half_character(doc) if _HALF_ESCAPE.search(text) or _HALF.search(text) else None
    if half is not None:
        path, char = half
        raise CacasError(f"{_where(source, *_place(doc, path))}: holds half of a character ('{visible(char)}' "
                         "without the other half of its pair), which cannot be saved as UTF-8 text; valid: whole "
                         "characters (the character itself, or both halves of its \\u escape)")
    return doc


#: half of a UTF-16 pair (a surrogate), which json reads from a lone "\ud83d" escape and UTF-8 cannot hold
_HALF = re.compile("[\ud800-\udfff]")
#: such an escape in a JSON text (a pair of them makes one whole character)
_HALF_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")


def _half_character(doc: Any) -> tuple[tuple, str] | None:
    """The path (keys and list indices) to the first string of a JSON document, a value or a key,
    that holds half of a character, and that half; None if none does. A whole run writes nothing
    else: such a description or code failed only when the tables were written (CLI audit)."""
    stack: list[tuple[tuple, Any]] = [((), doc)]  # not recursive: a document json read may be nested ~1,000 deep
    while stack:
        path, obj = stack.pop()
        if isinstance(obj, str):
            found = _HALF.search(obj)
            if found:
                return path, found.group()
        elif isinstance(obj, dict):
            for key in obj:
                found = _HALF.search(key)
                if found:
                    return path + (key,), found.group()
            stack += [(path + (key,), value) for key, value in reversed(obj.items())]
        elif isinstance(obj, list):
            stack += [(path + (i,), value) for i, value in reversed(list(enumerate(obj)))]
    return None


def _place(doc: Any, path: tuple) -> tuple[str | None, int | None, str | None]:
    """The participant (its code, else its number), the preference (index) and the field (the
    last key) that a path into a persona document (:func:`_half_character`) leads to, for
    :func:`_where`."""
    pid = pref = fld = None
    obj, before = doc, None
    for key in path:
        if isinstance(key, str):
            fld = key
        elif before == "participants" and pid is None:
            code = obj[key].get("id") if isinstance(obj[key], dict) else None
            pid = code.strip() if isinstance(code, str) and code.strip() and not _HALF.search(code) else str(key + 1)
        elif before == "preferences" and pref is None:
            pref = key
        obj, before = obj[key], key
    return pid, pref, fld


def dumps_personas(participants: Iterable[Participant]) -> str:
    """The persona file text (design.md's format) for these participants."""
    return json.dumps({"participants": [p.to_dict() for p in participants]}, indent=2, ensure_ascii=False) + "\n"


def save_personas(participants: Iterable[Participant], path: str | Path) -> None:
    """Write a persona file atomically (:func:`cacas.store.files.atomic_write`: a temporary file of
    this process, fsynced, renamed into place); a failure is a CacasError naming the file, which is
    left as it was."""
    from cacas.store.files import atomic_write

    atomic_write(Path(path), dumps_personas(participants).encode("utf-8"))
