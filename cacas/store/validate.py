"""Checks on what goes into the study database: each raises one CacasError naming the field.

Every write method of :class:`cacas.store.StudyStore` runs these before it opens its transaction,
so bad input writes nothing. Names are checked through :mod:`cacas.spaces` (Table I).
"""

from __future__ import annotations

import json
import math
import re
import threading
import unicodedata
from datetime import datetime, timedelta, timezone
from typing import Any, Mapping

import numpy as np

from cacas import spaces
from cacas.errors import CacasError, each  # noqa: F401 (each: v.each, every problem of a form at once)
from cacas.privacy import contact_details
from cacas.store.files import windows_device_name
from cacas.records import ROBOT_INITIATED, USER_INITIATED, line_feeds

#: Pseudonymous participant codes: a letter or digit, then letters, digits, "-" or "_"; at most 16.
CODE_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,15}$")
CODE_HINT = 'a pseudonymous code of 1-16 letters A-Z (no accents), digits, "-" or "_" (e.g. "P01"), never a name'
#: Age ranges: "25-34", "65+" or "30" (years); empty means not recorded.
AGE_RE = re.compile(r"^(\d{1,3})(?:-(\d{1,3})|\+)?$")
#: Method names (cacas, cacas-no-pr, orl, nn, ...).
METHOD_RE = re.compile(r"^[a-z0-9][a-z0-9_.-]{0,31}$")
STUDY_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9 _.-]{0,63}$")
NOTES_MAX = 2000
TYPES = (ROBOT_INITIATED, USER_INITIATED)


_last_now = datetime.min.replace(tzinfo=timezone.utc)
_now_lock = threading.Lock()


def now() -> str:
    """UTC timestamp with milliseconds, e.g. 2026-11-21T09:47:34.123Z (sorts as text).

    Strictly increasing within a process (a call in the same millisecond as the previous one, or
    after the clock stepped back, gets the previous one plus 1 ms): records written one after
    another sort in the order they were written, e.g. an interaction recorded just before a new
    version of the described preferences is scored against the version before it (daily.csv's
    success ceiling, which compared equal milliseconds as "saved by then")."""
    global _last_now
    with _now_lock:
        t = datetime.now(timezone.utc)
        t = t.replace(microsecond=t.microsecond // 1000 * 1000)
        t = max(t, _last_now + timedelta(milliseconds=1))
        _last_now = t
    return _utc_text(t)


def _utc_text(t: datetime) -> str:
    """An aware datetime as the store writes times: UTC, milliseconds (cut), "Z"."""
    return t.astimezone(timezone.utc).replace(tzinfo=None).isoformat(timespec="milliseconds") + "Z"


def code(value: Any) -> str:
    if isinstance(value, str) and not value.strip():  # "participant code '' is invalid" read oddly (walkthrough)
        raise CacasError(f"the participant code is empty; valid: {CODE_HINT}")
    if not isinstance(value, str) or not CODE_RE.fullmatch(value.strip()):
        # "ｐ０１" from a Japanese or Chinese keyboard reads as p01, but a code is an identity across files: said,
        # never changed (i18n's left-alone item)
        narrow = unicodedata.normalize("NFKC", value).strip() if isinstance(value, str) else ""
        hint = (f"it is written in full-width letters or digits: type it as {narrow!r} (half-width); "
                if any("\uff01" <= c <= "\uff5e" for c in str(value)) and CODE_RE.fullmatch(narrow) else "")
        raise CacasError(f"participant code {value!r} is invalid; {hint}valid: {CODE_HINT}")
    return value.strip()


def new_code(value: Any) -> str:
    """A code for a participant being added (a form, a persona import): :func:`code`,
    and not a phone number or a date a contact check finds (:func:`contact_details`:
    "0612345678", "20261121"), which the code would carry into every export. Codes already in a
    study keep working through :func:`code`, and a restored backup keeps them (with a note)."""
    checked = code(value)
    found = contact_details(checked)
    if found:
        raise CacasError(f"participant code {checked!r} looks like a phone number or a date, which could identify "
                         f"the participant; valid: {CODE_HINT}")
    if windows_device_name(checked):
        raise CacasError(f"participant code {checked!r} {DEVICE_NAME_PROBLEM}; valid: {CODE_HINT}, other than "
                         f"{DEVICE_NAMES_SAID}")
    return checked


#: Why a participant code that Windows keeps for a device is refused (:func:`new_code`) or noted (an import).
DEVICE_NAME_PROBLEM = ("is a name Windows keeps for a device: a participant's policy files go in a folder named by "
                       "the code (policies/<code>/), which Windows cannot make")
#: The names :data:`cacas.store.files.WINDOWS_DEVICE_NAMES` keeps, said briefly.
DEVICE_NAMES_SAID = "CON, PRN, AUX, NUL, COM1-COM9 or LPT1-LPT9 (in any letter case)"


def persona_codes(people, source: str | None = None) -> None:
    """Every participant of a persona file has a pseudonymous code (:func:`new_code`); the error
    names the file."""
    for p in people:
        try:
            new_code(p.id)
        except CacasError as exc:
            raise CacasError(f"{source or 'persona file'}: {exc}") from None


def study(value: Any, check_contacts: bool = True) -> str:
    """A study's name: 1-64 letters, digits, spaces, ".", "-" or "_", and (``check_contacts``) no
    contact details (:func:`contact_details`)."""
    if not isinstance(value, str) or not STUDY_RE.fullmatch(value.strip()):
        raise CacasError(f"study name {value!r} is invalid; valid: 1-64 letters A-Z (no accents), "
                         f"digits, spaces, '.', '-' or '_'")
    found = check_contacts and contact_details(value)  # a study's name is in every export, as notes are
    if found:
        raise CacasError(f"study name {value!r} holds what looks like a phone number ({found!r}); valid: a name "
                         "without contact details (study data are pseudonymous)")
    return value.strip()


#: The oldest age an age range may name, in years (it took "200").
AGE_MAX = 120


def age_range(value: Any, bounded: bool = True) -> str:
    """An age range as the forms take it: "25-34", "65+", one age, or empty; ages up to
    :data:`AGE_MAX`. ``bounded=False`` takes older ages too, as the store did before it refused them
    (a study may hold such a range: its restore and its participant's details keep it)."""
    if value is None:
        return ""
    # full-width ("２５-３４", a Japanese keyboard's) as their ASCII; other digits (Arabic-Indic "٣٠") match \d
    text = unicodedata.normalize("NFKC", str(value)).strip().replace(" ", "")
    if not text:
        return ""
    # a dash as word processors and macOS write one between two numbers ("25–34": an en dash, i18n) is the hyphen
    text = re.sub(r"(?<=\d)[\u2010-\u2015\u2212](?=\d)", "-", text)
    m = AGE_RE.fullmatch(text)
    ages = [int(a) for a in m.groups() if a is not None] if m else []
    if not m or ages != sorted(ages) or (bounded and max(ages) > AGE_MAX):
        raise CacasError(f"age range {value!r} is invalid; valid: e.g. \"25-34\", \"65+\" or empty, ages up to "
                         f"{AGE_MAX}")
    # written with the digits 0-9: "２５-３４" and "٢٥-٣٤" were kept as typed, beside "25-34" in participants.csv
    return "".join(str(unicodedata.decimal(c)) if c.isdecimal() else c for c in text)


def text(value: Any, field: str, limit: int = NOTES_MAX, check_contacts: bool = True) -> str:
    """Free text (notes, comments, descriptions): at most ``limit`` characters, and (``check_contacts``)
    no contact details (:func:`contact_details`). Line breaks are kept as line feeds (a browser's
    text area sends them so; a lone carriage return broke the exported CSV's rows), and text that
    is not Unicode (a lone surrogate, which no file can hold) is refused."""
    if value is None:
        return ""
    if not isinstance(value, str):
        raise CacasError(f"{field} must be text, got {type(value).__name__}")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise CacasError(f"{field} holds a character that is not valid Unicode text (at position {exc.start}); "
                         "valid: text as typed") from None
    value = line_feeds(value)
    if len(value) > limit:
        raise CacasError(f"{field} is {len(value)} characters long; valid: at most {limit}")
    found = check_contacts and contact_details(value)
    if found:
        raise CacasError(f"{field} contain{'' if field.endswith('s') else 's'} what looks like contact details "
                         f"({found!r}); valid: no names, e-mail addresses or phone numbers (study data "
                         "are pseudonymous)")
    return value.strip()


def method(value: Any) -> str:
    if not isinstance(value, str) or not METHOD_RE.fullmatch(value):
        raise CacasError(f"method {value!r} is invalid; valid: a short lower-case name such as "
                         f"\"cacas\", \"cacas-no-pr\", \"orl\" or \"nn\"")
    return value


#: The largest whole number SQLite stores (64-bit INTEGER): a larger day, version or index was
#: given to SQLite as it was, which raised OverflowError (a traceback) instead of a CacasError.
MAX_INT = 2**63 - 1


def integer(value: Any, field: str, low: int, high: int | None = None) -> int:
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
    if not ok or value < low or (high is not None and value > high):
        rng = f"{low}..{high}" if high is not None else f">= {low}"
        raise CacasError(f"{field} {value!r} is invalid; valid: a whole number {rng}")
    if value > MAX_INT:
        raise CacasError(f"{field} {value!r} is too large; valid: a whole number >= {low} (at most {MAX_INT})")
    return int(value)


def number(value: Any, field: str, low: float, high: float | None = None) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if not ok or not math.isfinite(float(value)) or value < low or (high is not None and value >= high):
        rng = f"{low} <= {field} < {high}" if high is not None else f"{field} >= {low}"
        raise CacasError(f"{field} {value!r} is invalid; valid: a number with {rng}")
    return float(value)


def name(kind: str, value: Any, field: str) -> str:
    """The paper's spelling of a Table I name; unknown -> CacasError naming field and value."""
    try:
        return spaces.canonical(kind, value)
    except CacasError as exc:
        raise CacasError(f"{field}: {exc}") from None
    except (TypeError, AttributeError):
        raise CacasError(f"{field}: {value!r} is not a {kind} name") from None


def model_id(value: Any, field: str) -> str | None:
    """A recogniser's id as :func:`cacas.recognition.model_id` gives it (12 lower-case hex
    digits), or None for none ("" too, as an export writes it)."""
    from cacas.recognition import MODEL_ID_DIGITS

    if value is None or value == "":
        return None
    text_value = str(value)
    if len(text_value) != MODEL_ID_DIGITS or any(c not in "0123456789abcdef" for c in text_value):
        raise CacasError(f"{field}: {value!r} is not a model id; valid: {MODEL_ID_DIGITS} hex digits "
                         "(0-9, a-f) naming a saved model, or empty")
    return text_value


def conversation_type(value: Any) -> str:
    if value not in TYPES:
        raise CacasError(f"interaction type {value!r} is invalid; valid: {ROBOT_INITIATED!r} "
                         f"(robot-initiated) or {USER_INITIATED!r} (user-initiated)")
    return value


def user_action(kind: str, value: Any, response: str, robot_action: str) -> str | None:
    """The action the participant asked for, by the interaction's ``kind`` (Table II): a
    user-initiated (type_2) interaction names one other than "do nothing" and other than the
    robot's proposal, and its ``response`` is "accept" (the confirmed request: D_i); a
    robot-initiated (type_1) one has none (None; "" as an export writes it). ``response`` and
    ``robot_action`` are the checked names."""
    if kind == USER_INITIATED:
        if value is None or value == "":
            raise CacasError("user_action is missing: a user-initiated (type_2) interaction names the "
                             "action the participant asked for")
        action = name("action", value, "user_action")
        if action == "do nothing":
            raise CacasError("user_action 'do nothing' is not a request; valid: one of the 13 other actions")
        if response != "accept":
            raise CacasError(f"response {response!r} given for a user-initiated (type_2) interaction; valid: "
                             "'accept' (the participant's confirmed request, Table II's D_i)")
        if action == robot_action:
            raise CacasError(f"user_action {action!r} is the robot's own proposal (robot_action); valid: a "
                             "request for another action, or the proposal's accept as a robot-initiated "
                             "(type_1) interaction, as the tablet records it")
        return action
    if value not in (None, ""):
        raise CacasError(f"user_action {value!r} given for a robot-initiated (type_1) "
                         f"interaction; only type_2 interactions have one")
    return None


def _as_exported(x: float | None) -> float | None:
    """A time kept to the 6 decimals that CSV export writes (cut, not rounded, so that it stays in
    its slot or bin: 23.9999999 h would be written as 24.000000, which no import accepts)."""
    if x is None:
        return None
    scaled = x * 1e6
    return math.floor(scaled) / 1e6 if math.isfinite(scaled) else x  # a float that large has no decimals to cut


def time_slot(hour: Any, slot: Any) -> tuple[float | None, int]:
    """S3 from an hour of the day and/or a slot index; both given must agree."""
    if hour is None and slot is None:
        raise CacasError("time of day is missing; give hour (0 <= hour < 24) or time_slot (0..11)")
    h = None if hour is None else _as_exported(number(hour, "hour", 0, 24))
    s = None if slot is None else integer(slot, "time_slot", 0, spaces.N_SLOTS - 1)
    if h is not None and s is not None and spaces.time_slot(h) != s:
        raise CacasError(f"hour {h:g} is in time slot {spaces.time_slot(h)}, not {s}; give one of them")
    return h, (s if s is not None else spaces.time_slot(h))


def interval(minutes: Any, bin_index: Any) -> tuple[float | None, int]:
    """S4 from minutes since the previous activity and/or a bin index; both given must agree."""
    if minutes is None and bin_index is None:
        raise CacasError("repeat interval is missing; give interval_minutes (>= 0) or interval_bin (0..11)")
    m = None if minutes is None else _as_exported(number(minutes, "interval_minutes", 0))
    b = None if bin_index is None else integer(bin_index, "interval_bin", 0, spaces.N_INTERVALS - 1)
    if m is not None and b is not None and spaces.interval_bin(m) != b:
        raise CacasError(f"interval {m:g} minutes is in bin {spaces.interval_bin(m)}, not {b}; give one of them")
    return m, (b if b is not None else spaces.interval_bin(m))


def probabilities(value: Any) -> str | None:
    """The policy's 14 action probabilities (Eq. 4's pi_theta(s)) as JSON, or None."""
    if value is None:
        return None
    if isinstance(value, Mapping):
        unknown = [k for k in value if k not in spaces.ACTIONS]
        if unknown:
            name("action", unknown[0], "probabilities")
        value = [value.get(a, 0.0) for a in spaces.ACTIONS]
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise CacasError(f"probabilities must be {spaces.N_ACTIONS} numbers, one per action") from None
    if arr.shape != (spaces.N_ACTIONS,):
        raise CacasError(f"probabilities has shape {arr.shape}; valid: {spaces.N_ACTIONS} numbers, one per "
                         f"action in Table I's order")
    if not np.all(np.isfinite(arr)) or arr.min() < 0 or arr.max() > 1 + 1e-6 or abs(arr.sum() - 1) > 1e-3:
        raise CacasError(f"probabilities must be {spaces.N_ACTIONS} numbers in [0, 1] that sum to 1 "
                         f"(sum is {arr.sum():.4f})")
    return json.dumps([float(p) for p in arr])


#: What :func:`timestamp` takes, for its messages.
TIME_HINT = ('an ISO 8601 time with a time zone, such as "2026-11-21T10:00:00Z" (UTC) or '
             '"2026-11-21T11:00:00+01:00"')


def iso_time(text: str) -> datetime:
    """``datetime.fromisoformat`` of ``text`` (surrounding spaces and a lower-case "z" for UTC
    allowed); ValueError if it is no ISO 8601 date or time."""
    text = text.strip()
    return datetime.fromisoformat(text[:-1] + "+00:00" if text[-1:] in ("Z", "z") else text)


def timestamp(value: Any, field: str = "time") -> str:
    """An interaction's time in the store's format, UTC as :func:`now` writes it
    ("2026-11-21T09:47:34.123Z"): now if None; an aware datetime, or an ISO 8601 text with a time
    zone ("Z" or an offset such as "+01:00"), converted to UTC. A time without a zone, a date alone
    or anything else raises CacasError: which moment it names is not known, and times are compared
    as text (daily.csv's success ceiling picks the preference version saved by then). ``field``
    names the value in the message (an import checks other time columns with it)."""
    if value is None:
        return now()
    given = value
    if isinstance(value, str):
        text = value.strip()
        try:
            value = iso_time(text)
        except ValueError:
            raise CacasError(f"{field} {given!r} is invalid; valid: {TIME_HINT}") from None
        if "T" not in text.upper() and " " not in text:
            raise CacasError(f"{field} {given!r} is a date alone; valid: {TIME_HINT}")
    if not isinstance(value, datetime):
        raise CacasError(f"{field} {given!r} is invalid; valid: a datetime with a time zone (tzinfo), or {TIME_HINT}")
    try:
        offset = value.utcoffset()
    except ValueError:  # pandas' NaT (a missing time in a frame) is a datetime that has none
        raise CacasError(f"{field} {given!r} is missing; valid: {TIME_HINT}, or None for now") from None
    if offset is None:
        raise CacasError(f"{field} {given!r} has no time zone, so which moment it names is not known; valid: "
                         f"{TIME_HINT}{'' if isinstance(given, str) else ', or a datetime with tzinfo'}")
    try:
        return _utc_text(value)
    except OverflowError:  # 0001-01-01T00:30+01:00 is before the first moment a datetime holds
        raise CacasError(f"{field} {given!r} is out of range; valid: {TIME_HINT}") from None


def json_dict(value: Any, field: str) -> str:
    """A dict of parameters / metrics as JSON text (numpy numbers become plain numbers)."""
    if value is None:
        value = {}
    if not isinstance(value, Mapping):
        raise CacasError(f"{field} must be a dict, got {type(value).__name__}")

    def plain(o):
        if isinstance(o, np.integer):
            return int(o)
        if isinstance(o, np.floating):
            return float(o)
        if isinstance(o, np.ndarray):
            return o.tolist()
        raise TypeError(type(o).__name__)

    try:
        return json.dumps(dict(value), sort_keys=True, default=plain, allow_nan=True)
    except (TypeError, ValueError) as exc:
        raise CacasError(f"{field} cannot be stored as JSON ({exc})") from None


def satisfaction(value: Any) -> int:
    """The post-test question (Section V-B.1): a linear scale, 1 very dissatisfied .. 10 very satisfied."""
    return integer(value, "satisfaction", 1, 10)
