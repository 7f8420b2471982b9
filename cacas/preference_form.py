"""The Participants page's preference form (Section V-B: the 5 preferences a participant describes),
without streamlit: the form's choices to a preference in the persona format and back (time of day as
S3 slots, minutes since the last activity as S4 bins), the form's checks with one message per
preference, and the table of a participant's preferences with the states each covers.
"""

from __future__ import annotations

from typing import Any, Sequence

import pandas as pd

from cacas import preferences as prefs
from cacas import spaces
from cacas.errors import CacasError


def hours_to_slots(hours) -> list[int]:
    """The S3 slots (0..11) a preference's hours cover (:meth:`Preference.slot_indices`, the one
    definition); [] for any time, the form's empty choice."""
    if not hours:
        return []
    return prefs.Preference(activity=(), action="", hours=tuple(tuple(h) for h in hours)).slot_indices()


def slots_to_hours(slots: Sequence[int]) -> list[list[int]] | None:
    """Two-hour slots -> the persona format's [start, end) ranges, contiguous slots merged;
    None (any time) for no slot or all 12."""
    slots = sorted(set(int(s) for s in slots))
    if not slots or len(slots) == spaces.N_SLOTS:
        return None
    ranges: list[list[int]] = []
    for s in slots:
        start, end = spaces.TIME_SLOTS[s]
        if ranges and ranges[-1][1] == start:
            ranges[-1][1] = end
        else:
            ranges.append([start, end])
    return ranges


def interval_to_bins(interval) -> tuple[int, int]:
    """A preference's interval as (lowest, highest) S4 bin value it covers; all bins for any."""
    if not interval:
        return spaces.INTERVAL_BINS[0], spaces.INTERVAL_BINS[-1]
    covered = [b for b in spaces.INTERVAL_BINS if interval[0] <= b <= interval[1]]
    return (covered[0], covered[-1]) if covered else (spaces.INTERVAL_BINS[0], spaces.INTERVAL_BINS[-1])


def preference_from_form(description: str, activities: Sequence[str], scenes: Sequence[str],
                         slots: Sequence[int], interval: tuple[int, int] | None,
                         action: str | None, task: Sequence[str] | None = None) -> dict[str, Any] | None:
    """A persona-format preference dict from the form's widgets: no rooms = any room, no time
    slot (or all) = any time, the whole interval range = any. None for an untouched slot (no
    words, activity, room, time, interval or action); a slot with only some fields filled in is
    returned as it is, for :func:`check_preferences` to name what is missing."""
    full = interval is None or tuple(interval) == (spaces.INTERVAL_BINS[0], spaces.INTERVAL_BINS[-1])
    if not (description or "").strip() and not activities and not action and not scenes and not slots and full:
        return None
    out: dict[str, Any] = {}
    if description and description.strip():
        out["description"] = description.strip()
    out["activity"] = list(activities)
    if scenes and len(scenes) < spaces.N_SCENES:
        out["scene"] = list(scenes)
    hours = slots_to_hours(slots)
    if hours is not None:
        out["hours"] = hours
    if interval is not None and tuple(interval) != (spaces.INTERVAL_BINS[0], spaces.INTERVAL_BINS[-1]):
        out["interval"] = [int(interval[0]), int(interval[1])]
    if task:
        out["task"] = list(task)
    if action:
        out["action"] = action
    return out


#: The Participants form's fields that narrow a preference (it has no task field: S5 comes only
#: from an imported persona file), named when two preferences overlap.
FORM_FIELDS = "activities (S1), rooms (S2), time of day (S3) or minutes since the last activity (S4)"


def check_preferences(code: str, items: Sequence[dict], numbers: Sequence[int] | None = None
                      ) -> tuple[prefs.Participant | None, dict[int, str], str | None]:
    """Validate a participant's preference dicts one by one, then together.

    Returns (participant or None, {number: message} per invalid preference, a message about the
    set as a whole, e.g. two preferences that cover the same state with different actions).
    ``numbers`` are the preferences' numbers on the form (default 1, 2, ...). Nothing is raised,
    so that a form shows every message in place.
    """
    numbers = list(numbers) if numbers is not None else list(range(1, len(items) + 1))
    errors: dict[int, str] = {}
    parsed, parsed_numbers = [], []
    for n, item in zip(numbers, items):
        missing = [what for key, what in (("activity", "at least one activity"), ("action", "an action"))
                   if not item.get(key)]
        if missing:  # in the form's words; a persona file gets the library's message
            errors[n] = f"choose {' and '.join(missing)}: a preference says which activities lead to which action"
            try:  # and its words' problem at once, not after the fields are chosen (walkthrough)
                words = prefs.Preference(activity=(), action="", description=str(item.get("description") or ""))
                prefs.check_private_words(prefs.Participant(code, (words,)), None, [n])
            except CacasError as exc:
                errors[n] += f"; and {_strip_where(str(exc), code, item, n)}"
            continue
        try:
            one = prefs.parse_preference(item, None, code, n - 1)
            prefs.check_private_words(prefs.Participant(code, (one,)), None, [n])
        except CacasError as exc:
            errors[n] = _strip_where(str(exc), code, item, n)
            continue
        parsed.append(one)
        parsed_numbers.append(n)
    if not parsed and not errors:
        return None, {}, "describe at least one preference (activities and an action)"
    # the valid ones' overlaps are said with the others' errors, in the same save (walkthrough: an
    # overlap was said only on the save after the errors were mended, a second round of fixes)
    overall = None
    for i in range(len(parsed)):
        for j in range(i + 1, len(parsed)):
            try:
                prefs.check_conflicts([parsed[i], parsed[j]], None, code, fields=FORM_FIELDS,
                                      numbers=[parsed_numbers[i], parsed_numbers[j]])
            except CacasError as exc:
                overall = _strip_where(str(exc), code)
                break
        if overall:
            break
    if errors or overall:
        return None, errors, overall
    return prefs.Participant(code, tuple(parsed)), {}, None


def redundancy_notes(participant: prefs.Participant) -> list[str]:
    """One line per described preference that adds nothing (:func:`cacas.preferences.redundant_preferences`):
    which one, which covers it, and what to do. Saving such a set is allowed (it says nothing
    wrong), so the Participants page shows these beside the saved preferences."""
    ps = participant.preferences
    return [f"Preference {i + 1} adds nothing: preference {j + 1} already covers all its states with the same "
            f"action ({ps[i].action}). Delete it or change it; Fig. 4's breakdown by preference would count "
            "these states under both." for i, j in prefs.redundant_preferences(ps)]


def _strip_where(message: str, code: str, item: dict | None = None, number: int | None = None) -> str:
    """'participant P01, preference 2 ("..."), field 'hours': ...' -> "field 'hours': ..."; 'participant P01:
    preferences 1 ("...") and 2 ...' -> "preferences 1 ...". The place is cut as the library writes it for
    ``code``'s preference ``number`` (``item``, its words quoted): a preference's own words holding "field '"
    cut the message inside them (walk3b)."""
    if number is not None:
        where = prefs._where(None, code, number - 1, None, item)
        if message.startswith(where + ", field '"):
            return message[len(where) + 2:]
    overlap = f"participant {code}: preferences "
    if message.startswith(overlap):
        return message[len(overlap) - len("preferences "):]
    if "field '" in message:
        return message[message.index("field '"):]
    return message


def hours_label(hours) -> str:
    """A preference's hours as the tablet and the day's table write a time of day (S3):
    [(6, 12)] -> "06:00-12:00"; one two-hour slot is :func:`cacas.spaces.time_slot_label`'s."""
    if not hours:
        return "any time"
    return ", ".join(f"{a:02d}:00-{b:02d}:00" for a, b in hours)


def preference_interval_label(interval) -> str:
    """A preference's ``interval`` (S4, Table I: [min, max] over the bins' lower ends, both included) as the
    minutes it covers, in the tablet's words for the bins: [5, 30] -> "5-60 min" (the bins 5-10 ... 30-60 min;
    "5-30" read as "up to 30 minutes"), [60, 200] -> "60+ min"; None (any interval) -> "any"."""
    if not interval:
        return "any"
    bins = [i for i, b in enumerate(spaces.INTERVAL_BINS) if interval[0] <= b <= interval[1]]
    if not bins:  # no bin's lower end in the range: the preference covers no state (the file's check says so)
        return f"{interval[0]:g}-{interval[1]:g} (no S4 bin)"
    lo, hi = spaces.INTERVAL_BINS[bins[0]], bins[-1]
    if bins[0] == 0 and hi == spaces.N_INTERVALS - 1:
        return "any"
    return f"{lo}+ min" if hi == spaces.N_INTERVALS - 1 else f"{lo}-{spaces.INTERVAL_BINS[hi + 1]} min"


def preferences_table(participant: prefs.Participant) -> pd.DataFrame:
    """The described preferences as a readable table with each one's covered-state count: the
    context and the action first (what the robot should learn), the participant's words last (the
    widest column, cut first on a narrow screen)."""
    rows = []
    for i, p in enumerate(participant.preferences, 1):
        rows.append({
            "#": i, "activities": ", ".join(p.activity), "action": p.action,
            "rooms": ", ".join(p.scene) if p.scene else "any room", "hours": hours_label(p.hours),
            "since last activity": preference_interval_label(p.interval),
            "covered states": p.covered_count(), "in their words": p.description,
        })
    return pd.DataFrame(rows)
