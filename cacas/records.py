"""Tidy tables shared by simulated and human studies: interactions and the daily metrics.

One definition of an interaction row and of the daily metrics serves ``cacas simulate`` and the
study database's export, so one set of plots reads both (design.md, the ``daily.csv`` contract).

Paper, Section V-B: "A successful event is defined as the robot initiates an action and the user
accepts it. Initiating an action by the user is not regarded as a successful event."
"If the user does not respond, the interaction is not recorded. When the user initiates an
action, two interaction data points are recorded".
"""

from __future__ import annotations

import itertools
import re
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np
import pandas as pd

#: The methods, in one order on every table, figure and CSV: the paper's (Fig. 4: CACAS, CACAS
#: w/o PR, ORL, NN), then ours (``cacas.adaptation.METHODS``).
PAPER_METHODS = ("cacas", "cacas-no-pr", "orl", "nn")
METHOD_ORDER = PAPER_METHODS + ("bandit", "sac-user-data")

#: Bounds of a simulated study (``cacas.experiment`` checks them; kept here, beside the methods,
#: so that the command line's --help says them without importing the learning code): a year of
#: days; at most one interaction a minute (a day has 1440); seeds as numpy takes them.
MAX_DAYS, MAX_INTERACTIONS, MAX_SEED = 365, 1440, 2**32 - 1

#: A simulated study's design unless told otherwise (Section V-B: 7 days of about 15 interactions; the paper's four
#: methods, the first in closed loop as in Fig. 4): ``cacas simulate``'s options and the Simulation lab's form start
#: from them, and ``cacas.experiment.simulate_study``'s keywords default to them (a test binds the three).
SIMULATION_DEFAULTS = MappingProxyType({"days": 7, "interactions": 15, "methods": PAPER_METHODS, "seed": 0,
                                        "no_response_rate": 0.1, "ask_after_reject": 0.0, "loop": "first"})


def _code_piece(c: str) -> int:
    """:func:`code_order`'s kind of character: 1 a digit, 2 a letter, 0 anything else (a separator)."""
    return 1 if c.isdecimal() else 2 if c.isalpha() else 0


def code_order(code: Any) -> tuple:
    """The sort key of a participant code wherever participants are listed to a person (selectors,
    tables, figures, messages), as a researcher reads codes and a file manager lists names: letter
    case ignored ("p01, R01, r02"), numbers by their value ("P2, P10"; "P01" and "P1" side by side),
    and a separator ("_", "-", ...) before digits and letters, one as another ("P_1, P-2, P1, PA";
    compared character by character, "-" came before digits and "_" after them, and ignoring case put
    "_" before letters only). Then the code ignoring case, then the exact code, so that the order is
    total and the same on every run ("P01, p01, P1"). The exported CSVs, and what is recorded in turn
    (a run's random streams, adaptations.csv), keep the exact code's order."""
    code = str(code)
    runs = ((kind, "".join(run)) for kind, run in itertools.groupby(code, _code_piece))
    pieces = tuple((kind, int(run) if kind == 1 else 0, run.casefold() if kind == 2 else "") for kind, run in runs)
    return pieces, code.casefold(), code


def by_code(codes) -> list[str]:
    """``codes`` in :func:`code_order`."""
    return sorted(codes, key=code_order)


def sort_by_method(table: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    """``table`` sorted by ``keys``, its ``method`` column in :data:`METHOD_ORDER` (any other
    method after those, by name), not by name (a human study's export had NN before ORL)."""
    rank = {m: f"{i:02d}" for i, m in enumerate(METHOD_ORDER)}
    return table.sort_values(keys, kind="stable", key=lambda c: c.map(lambda m: rank.get(m, f"99{m}"))
                             if c.name == "method" else c)

#: Who started an interaction (Table II's conversation type).
ROBOT_INITIATED = "type_1"
USER_INITIATED = "type_2"

#: A response (interactions.csv's ``response``) in words, as pages and event logs show it.
RESPONSE_WORDS = {"accept": "accepted", "reject": "rejected", "others": "no response"}

#: Columns of interactions.csv, in order (both simulated and human studies):
#: participant (code), method, day (1..), index (1.. within the day), time (simulated: "HH:MM",
#: the simulated time of day; human studies: the UTC timestamp of the recording, as the context's
#: time of day is the one set on the tablet, in time_slot), activity, scene (names), time_slot
#: (S3 index 0-11), interval (S4 bin value in minutes: 0, 1, 2, 5 ... 200), task (S5 name),
#: previous_action / previous_response (S6 / S7 of the policy state: names), type (type_1
#: robot-initiated, type_2 user-initiated), robot_action (name), response (accept / reject /
#: others; "others" = no response), user_action (the action the participant asked for in a
#: type_2 interaction, else empty). In a type_2 row, response "accept" is the participant's own
#: request (confirmed), not an answer to robot_action: robot_action is "do nothing" (the robot
#: was silent) or the proposal the participant answered by asking for something else instead
#: (the tablet's "Or ask the robot yourself"), i.e. a proposal not accepted. Count acceptances
#: of the robot's proposals with :func:`is_success` (type_1 rows only).
INTERACTION_COLUMNS = [
    "participant", "method", "day", "index", "time", "activity", "scene", "time_slot",
    "interval", "task", "previous_action", "previous_response", "type", "robot_action",
    "response", "user_action",
]

#: Columns of daily.csv, in order: design.md's contract first. ``interactions`` counts the day's
#: recorded interactions, as the paper does (Section V-B: "If the user does not respond, the
#: interaction is not recorded"): a robot action answered with accept or reject, or a
#: user-initiated action (during a sound activity: IV-C.1). ``success_rate`` is of those (Fig. 3).
#: ``unanswered`` counts the day's other moments: a proposal left unanswered, or the robot quiet
#: and nothing asked (where the participant wants to be left alone, that is the right outcome, and
#: not an interaction), or a request made with no sound activity (activity "do nothing").
#: ``success_ceiling`` (closed-loop rows, like ``success_rate``): of the day's recorded
#: interactions, the share in whose context a described preference names an action other than
#: "do nothing", i.e. the success rate a robot proposing the described preference could have had
#: there (empty without described preferences). Outside every described preference it counts 0,
#: though the participant may accept something there (the simulated one answers by the D4A
#: pairs), so it bounds what the preferences allow.
DAILY_COLUMNS = [
    "participant", "method", "day", "success_rate", "preference_accuracy",
    "cumulative_feedback", "interactions", "successes", "user_initiated", "feedback", "success_ceiling",
    "unanswered",
]

#: The columns design.md's contract requires of every daily.csv (the first seven).
DAILY_CONTRACT_COLUMNS = DAILY_COLUMNS[:7]

#: Columns of by_preference.csv (Fig. 4 broken down by described preference), in order:
#: participant, method, day (the policy in force that day), preference (1-based, in the persona
#: file's order), label (the participant's description, else "activities -> action"), activity
#: (its activities, "/"-joined), action, states (test states it covers), correct (of those, where
#: the policy's Eq. 4 action is the preferred one), accuracy.
BY_PREFERENCE_COLUMNS = [
    "participant", "method", "day", "preference", "label", "activity", "action", "states", "correct", "accuracy",
]


def is_recorded_request(interactions: pd.DataFrame) -> pd.Series:
    """A user-initiated action the paper records (IV-C.1: the request is confirmed and recorded
    "if the user intent belongs to one of the Agent Actions ... except do nothing and there is a
    sound activity"): a type_2 row whose activity is not "do nothing". A request made with no
    sound activity is carried out and saved, but is no user data point, for any method."""
    return (interactions["type"] == USER_INITIATED) & (interactions["activity"] != "do nothing")


def feedback_points(interactions: pd.DataFrame) -> pd.Series:
    """User data points each interaction gives (Section V-B): a robot action answered with
    accept or reject gives 1; a user-initiated action gives 2 (the request accepted, "do
    nothing" rejected); no response, the robot doing nothing unanswered, or a request made with
    no sound activity (:func:`is_recorded_request`), gives 0."""
    t1 = (interactions["type"] == ROBOT_INITIATED) & (interactions["robot_action"] != "do nothing") \
        & interactions["response"].isin(["accept", "reject"])
    return t1.astype(int) + 2 * is_recorded_request(interactions).astype(int)


def is_recorded(interactions: pd.DataFrame) -> pd.Series:
    """The interaction is one the paper records (Section V-B): the participant answered the
    robot's action (accept or reject) or initiated one during a sound activity. A proposal left
    unanswered, the robot doing nothing with nothing asked, or a request made with no sound
    activity, is not recorded: it gives no user data point. Every method adapts from the
    recorded interactions only."""
    return feedback_points(interactions) > 0


def success_rate(interactions: pd.DataFrame) -> float:
    """Fig. 3's success rate: of the recorded interactions (:func:`is_recorded`), the share in
    which the robot initiated an action and the participant accepted it (NaN if none)."""
    recorded = int(is_recorded(interactions).sum())
    return int(is_success(interactions).sum()) / recorded if recorded else float("nan")


def is_success(interactions: pd.DataFrame) -> pd.Series:
    """The robot initiated an action (not "do nothing") and the participant accepted it."""
    return ((interactions["type"] == ROBOT_INITIATED) & (interactions["robot_action"] != "do nothing")
            & (interactions["response"] == "accept"))


def _moments(times: pd.Series) -> np.ndarray:
    """ISO times as UTC nanoseconds, to compare moments rather than text (a time an older version
    stored with an offset, kept by an import, is not placed by its local date); a missing or
    unreadable time is the earliest."""
    moment = pd.to_datetime(pd.Series(times, dtype=object).astype(str), utc=True, format="ISO8601", errors="coerce")
    return moment.to_numpy(dtype="datetime64[ns]").view("int64")


def preferred_action_contexts(interactions: pd.DataFrame, preferred: Mapping[str, Any]) -> np.ndarray:
    """Per interaction row: 1.0 where the participant's described preferences name an action
    other than "do nothing" for its context (S1-S5), 0.0 where they name "do nothing" or cover
    nothing, NaN for a participant without described preferences. ``preferred`` maps a
    participant code to its preferred-action table (``Participant.preferred_action_table``), or to
    the versions of it over time, ``[(saved_at, table), ...]`` oldest first: each row is then scored
    against the version saved last at or before its ``time``, compared as moments (a row before the
    first version, against the first), so a version saved mid-study leaves the days before it as
    they were.
    Evaluation only: the adaptation never sees it."""
    from cacas import spaces

    out = np.full(len(interactions), np.nan)
    if len(interactions) == 0 or not preferred:
        return out
    states = policy_states(interactions)
    who = interactions["participant"].astype(str).to_numpy()
    when = _moments(interactions["time"]) if "time" in interactions else None
    for code, tables in preferred.items():
        rows = np.flatnonzero(who == code)
        if not len(rows):
            continue
        if isinstance(tables, np.ndarray):
            tables = [("", tables)]
        saved = _moments(pd.Series([t for t, _ in tables]))
        version = (np.zeros(len(rows), dtype=int) if when is None else
                   np.maximum(np.searchsorted(saved, when[rows], side="right") - 1, 0))
        for v, (_, table) in enumerate(tables):
            mine = rows[version == v]
            s = states[mine]
            action = table[s[:, 0], s[:, 1], s[:, 2], s[:, 3], s[:, 4]]
            out[mine] = ((action >= 0) & (action != spaces.DO_NOTHING_ACTION)).astype(float)
    return out


def daily_table(interactions: pd.DataFrame, accuracy: pd.DataFrame | None = None,
                preferred: Mapping[str, np.ndarray] | None = None) -> pd.DataFrame:
    """Per participant, method and day: the daily.csv table.

    ``interactions`` has INTERACTION_COLUMNS; its ``method`` is the policy in force (closed
    loop). ``accuracy`` optionally has columns participant, method, day, preference_accuracy
    (the policy in force that day on the described preferences). A participant's data are one
    stream, whichever method's policy was in force: ``cumulative_feedback`` counts all of the
    participant's data points up to the end of the day. Rows of ``accuracy`` with no
    interactions of their own (a method adapted from the same data but not run in closed loop,
    Fig. 4) get an empty success rate and the day's interaction and feedback counts; on a day
    with no interactions (begun, nothing recorded yet) those counts are 0 and
    ``cumulative_feedback`` is the participant's so far.
    ``interactions`` and the success rate count recorded interactions only (:func:`is_recorded`);
    ``unanswered`` counts the rest. ``preferred`` (participant code -> preferred-action table)
    gives ``success_ceiling`` (:func:`preferred_action_contexts`, averaged over the day's
    recorded interactions); without it, or for a participant not in it, the ceiling is empty.
    """
    keys = ["participant", "method", "day"]
    counts = ["interactions", "successes", "user_initiated", "feedback", "unanswered"]
    shared = ["interactions", "user_initiated", "feedback", "unanswered"]  # one stream per participant
    if len(interactions):
        recorded = is_recorded(interactions).to_numpy()
        ceiling = preferred_action_contexts(interactions, preferred or {})
        df = interactions.assign(_success=is_success(interactions).astype(int),
                                 _points=feedback_points(interactions),
                                 _t2=is_recorded_request(interactions).astype(int),
                                 _recorded=recorded.astype(int), _unanswered=(~recorded).astype(int),
                                 _ceiling=np.where(recorded, ceiling, np.nan))
        g = df.groupby(keys, sort=True)
        daily = pd.DataFrame({"interactions": g["_recorded"].sum(), "successes": g["_success"].sum(),
                              "user_initiated": g["_t2"].sum(), "feedback": g["_points"].sum(),
                              "unanswered": g["_unanswered"].sum(),
                              "success_ceiling": g["_ceiling"].mean()}).reset_index()
        daily["success_rate"] = daily["successes"] / daily["interactions"].where(daily["interactions"] > 0)
        per_day = daily.groupby(["participant", "day"])[shared].sum()
        per_day["cumulative_feedback"] = per_day.groupby(level="participant")["feedback"].cumsum()
    else:
        daily = pd.DataFrame(columns=keys + counts + ["success_rate", "success_ceiling"])
        per_day = pd.DataFrame(columns=shared + ["cumulative_feedback"],
                               index=pd.MultiIndex.from_tuples([], names=["participant", "day"]))
    if accuracy is not None and len(accuracy):
        daily = daily.merge(accuracy[keys + ["preference_accuracy"]], on=keys, how="outer")
    else:
        daily["preference_accuracy"] = np.nan
    at = pd.MultiIndex.from_arrays([daily["participant"], daily["day"]])
    daily["cumulative_feedback"] = per_day["cumulative_feedback"].reindex(at).to_numpy()
    own = daily["interactions"].notna().to_numpy()
    for col in shared:
        daily[col] = np.where(own, daily[col], per_day[col].reindex(at).to_numpy())
    # a day begun with nothing recorded yet (a human study's open day, scored for Fig. 4): none of
    # the day's counts, and the feedback so far carried over (it was left empty, and Fig. 3's means
    # dropped the participant)
    quiet = daily["interactions"].isna().to_numpy()
    if quiet.any():
        daily.loc[quiet, shared] = 0
        running = per_day["cumulative_feedback"]
        who, when = running.index.get_level_values("participant"), running.index.get_level_values("day")

        def so_far(code, day) -> int:  # the running total is non-decreasing: its last value before ``day``
            earlier = running[(who == code) & (when < day)]
            return int(earlier.max()) if len(earlier) else 0

        daily.loc[quiet, "cumulative_feedback"] = [so_far(c, d) for c, d in
                                                   zip(daily.loc[quiet, "participant"], daily.loc[quiet, "day"])]
    for col in counts + ["cumulative_feedback"]:
        daily[col] = pd.array(pd.to_numeric(daily[col]), dtype="Int64")
    return sort_by_method(daily, keys).reindex(columns=DAILY_COLUMNS).reset_index(drop=True)


_CSV_FORMAT = dict(index=False, float_format="%.6f", lineterminator="\n")

#: Counts in the tables (daily.csv, by_preference.csv, the exports): whole numbers. A CSV read
#: back with an empty cell in such a column (a baseline's ``successes`` in a Fig. 4 run) gives
#: pandas floats; :func:`whole_counts` makes them whole again.
COUNT_COLUMNS = ("cumulative_feedback", "interactions", "successes", "user_initiated", "feedback", "unanswered",
                 "states", "correct", "policy_version")
#: Measured quantities of the human study's interactions.csv (the tablet's hour of day, the
#: minutes since the previous activity): written in their shortest form, 8 and 7.5, not 8.000000.
PLAIN_NUMBER_COLUMNS = ("hour", "interval_minutes")


def whole_counts(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with its :data:`COUNT_COLUMNS` as nullable integers where they hold floats that are
    all whole numbers (or empty); other columns, and counts that are not whole, are left as they are."""
    out = {}
    for col in COUNT_COLUMNS:
        if col in df.columns and pd.api.types.is_float_dtype(df[col]):
            values = df[col].dropna()
            if (values == values.round()).all():
                out[col] = df[col].astype("Int64")
    return df.assign(**out) if out else df


def _plain_number(value) -> str:
    return "" if pd.isna(value) else np.format_float_positional(float(value), trim="-")


#: A text cell a spreadsheet would run as a formula (OWASP's CSV injection: =, +, -, @, tab, CR first).
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")
_NUMBER_RE = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


def escape_formula(value):
    """A text cell as the CSV writes it: one starting as a formula would (``=HYPERLINK(...)`` in a
    participant's notes, ``-2+3``, ``@SUM``) gets a leading ``'``, so a spreadsheet shows the text
    and runs nothing; a cell that starts with ``'`` gets one more, so :func:`unescape_formula`
    gives every text back exactly. A number written as text ("-3") is left as it is."""
    if isinstance(value, str) and value and (value[0] == "'" or (value.startswith(_FORMULA_START)
                                                                 and not _NUMBER_RE.match(value))):
        return "'" + value
    return value


def unescape_formula(value):
    """The text :func:`escape_formula` wrote the cell for (reading a bundle or an exported table):
    its ``'`` taken off only where :func:`escape_formula` would have put it, so a cell written
    before the escaping ("'twas fine", in an older bundle or another tool's CSV) stays as it is."""
    if isinstance(value, str) and value.startswith("'") and escape_formula(value[1:]) == value:
        return value[1:]
    return value


def _is_text(column: pd.Series) -> bool:
    """A column that may hold text: object (mixed) or a string dtype."""
    return column.dtype == object or pd.api.types.is_string_dtype(column.dtype)


#: Columns holding a code or a person's words, where "NA", "None", "null" or "n/a" is what was typed (a
#: participant coded NA, a preference described as "None"): CACAS writes a missing value as an empty cell,
#: and pandas' default NA strings made such a cell missing (:func:`read_csv`).
WORD_COLUMNS = ("participant", "study", "label", "comments", "notes", "description", "name")
#: pandas.read_csv's default NA strings (its documentation's list), kept for every other column: a number
#: column of a table written by another tool (R's write.csv writes NA) still reads as numbers.
PANDAS_NA_STRINGS = ("", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN",
                     "<NA>", "N/A", "NA", "NULL", "NaN", "None", "n/a", "nan", "null")


def _missing_strings(source, options: dict) -> dict:
    """``na_values`` for :func:`read_csv`: only the empty cell in :data:`WORD_COLUMNS`, pandas' defaults
    elsewhere, by the header of ``source`` (a path or a file object, left where it was)."""
    peek = {k: options[k] for k in ("sep", "delimiter", "encoding", "header", "skiprows") if k in options}
    start = source.tell() if hasattr(source, "read") else None
    columns = pd.read_csv(source, nrows=0, **peek).columns
    if start is not None:
        source.seek(start)
    return {col: [""] if col in WORD_COLUMNS else list(PANDAS_NA_STRINGS) for col in columns}


def read_csv(source, **options) -> pd.DataFrame:
    """A CSV this module wrote (or one like it), its text cells as they were before
    :func:`escape_formula`: ``pandas.read_csv`` with ``options``, then :func:`unescape_formula` on
    every text column. A ``participant`` column is read as text: codes such as "007" kept their
    digits only (7) when pandas took them for numbers. In :data:`WORD_COLUMNS` only an empty cell is
    missing (pandas read participant "NA", a valid code, as missing), unless ``options`` say which
    strings are (``na_values``, ``keep_default_na``)."""
    dtype = options.pop("dtype", None)
    if dtype is None or isinstance(dtype, dict):  # a caller's own column types keep the participant's as text
        dtype = {"participant": str, **(dtype or {})}
    if "na_values" not in options and "keep_default_na" not in options:
        options.update(keep_default_na=False, na_values=_missing_strings(source, options))
    df = pd.read_csv(source, dtype=dtype, **options)
    text = {col: df[col].map(unescape_formula) for col in df.columns if _is_text(df[col])}
    return df.assign(**text) if text else df


def line_feeds(value):
    """A text cell's line breaks as line feeds: the CSV writer (lines end in "\\n") quotes a cell
    holding one, but not a cell holding a carriage return alone, which a reader then took for the
    end of the row (notes saved through the library before :func:`cacas.store.validate.text` made
    the same change: their bundle could not be imported)."""
    return value.replace("\r\n", "\n").replace("\r", "\n") if isinstance(value, str) and "\r" in value else value


def _csv_ready(df: pd.DataFrame) -> pd.DataFrame:
    df = whole_counts(df)
    plain = {col: df[col].map(_plain_number) for col in PLAIN_NUMBER_COLUMNS
             if col in df.columns and pd.api.types.is_float_dtype(df[col])}
    text = {col: df[col].map(lambda x: escape_formula(line_feeds(x))) for col in df.columns
            if col not in plain and _is_text(df[col])}
    return df.assign(**plain, **text) if plain or text else df


def write_csv(df: pd.DataFrame, path) -> None:
    """CSV with fixed formatting, so the same data gives the same bytes: rates and other floats
    to 6 decimals, counts (:data:`COUNT_COLUMNS`) as whole numbers, measured hours and minutes
    (:data:`PLAIN_NUMBER_COLUMNS`) in their shortest form, empty cells for missing values, and
    text that would start a spreadsheet formula escaped (:func:`escape_formula`)."""
    _csv_ready(df).to_csv(path, **_CSV_FORMAT)


def csv_bytes(df: pd.DataFrame) -> bytes:
    """The CSV of :func:`write_csv` as UTF-8 bytes (downloads, bundles, atomic writes)."""
    return _csv_ready(df).to_csv(**_CSV_FORMAT).encode("utf-8")


def policy_states(interactions: pd.DataFrame) -> np.ndarray:
    """The policy state S1..S7 of each interaction row as (n, 7) Table I indices."""
    from cacas import spaces

    if len(interactions) == 0:
        return np.zeros((0, 7), dtype=np.int64)
    idx = lambda kind, col: np.array([spaces.index_of(kind, v) for v in interactions[col]], np.int64)  # noqa: E731
    slot = interactions["time_slot"].astype(int).to_numpy()
    interval = np.searchsorted(spaces.INTERVAL_BINS, interactions["interval"].astype(float).to_numpy(),
                               side="right") - 1
    return np.stack([idx("activity", "activity"), idx("scene", "scene"), slot, interval,
                     idx("action", "task"), idx("action", "previous_action"),
                     idx("response", "previous_response")], axis=1)
