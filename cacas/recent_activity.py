"""The Overview's recent activity: the study database's latest events in words, newest first, a
method comparison's runs merged into one line each (:func:`recent_events`). No streamlit.
"""

from __future__ import annotations

import json

import pandas as pd

from cacas import records
from cacas.app_support import adapted_from, short_time
from cacas.plots import method_names  # the methods named as the figures name them ('CACAS w/o PR')


#: A method comparison records its runs seconds apart (one adaptation each, the participants side by
#: side): a run this long after the last run of a comparison's line begins another line.
COMPARISON_GAP_S = 600


def recent_events(store, participant: str | None = None, limit: int = 8,
                  study: str | None = None) -> pd.DataFrame:
    """The last events in words, newest first: when, who, what (of one participant, or of the
    participants of one ``study``).

    A method comparison's runs take two lines, each placed at its last run: the comparison runs
    (methods, participants, up to which day) and the initial policy scored for it (methods,
    participants; one participant's only: no codes, the participant column names them).
    They are told apart from the events recorded meanwhile, which keep their lines: other
    participants' adaptations (a real adaptation's initial-policy score, recorded with its saved
    policy, is never merged), days closed, questionnaires. A run joins a comparison's line unless
    that line already has its participant, day and method, its participant was added or its day
    closed after the line began (the comparison takes both at its start), or it comes more than
    :data:`COMPARISON_GAP_S` after the line's last run: then it begins another."""
    wanted = max(1, limit) * 8  # runs merged below take several events a line
    while True:
        ev = store.events(participant=participant, limit=wanted, study=study)
        rows = _activity_lines(ev)
        if len(ev) < wanted or (len(rows) > limit and not _may_begin_earlier(rows[-limit:], ev)):
            break
        wanted *= 4
    rows = rows[-limit:] if limit > 0 else []
    return pd.DataFrame({"when": [short_time(r.at) for r in rows],
                         "participant": [r.participant() for r in rows],
                         "what": [r.words() for r in rows]}).iloc[::-1]


class _Line:
    """One line of recent activity: an event, or the merged runs of a method comparison (``kind``
    "initial" or "comparison"; None for an event merged with nothing)."""

    def __init__(self, at, who: str, words: str, position: int, kind: str | None = None):
        self.at, self.codes, self.own_words, self.position, self.kind = at, [who], words, position, kind
        self.first, self.first_at = position, at
        self.runs: set = set()
        self.methods: list = []
        self.days: set = set()

    def add_run(self, at, who: str, day: int, method, position: int) -> None:
        self.at, self.position = at, position
        self.runs.add((who, day, method))
        if who not in self.codes:
            self.codes.append(who)
        if method not in self.methods:
            self.methods.append(method)
        self.days.add(day)

    def participant(self) -> str:
        return self.codes[0] if len(self.codes) == 1 else f"{len(self.codes)} participants"

    def words(self) -> str:
        if len(self.runs) < 2:
            return self.own_words
        rank = {m: i for i, m in enumerate(records.METHOD_ORDER)}
        methods = method_names(sorted(self.methods, key=lambda m: rank.get(m, len(rank))))
        codes = records.by_code(self.codes)
        whom = "" if len(codes) == 1 else \
            " for " + ", ".join(codes[:8]) + (f" and {len(codes) - 8} more" if len(codes) > 8 else "")
        if self.kind == "initial":
            return f"initial policy scored ({methods}){whom}"
        return f"comparison runs ({methods}){whom} on {adapted_from(max(self.days))}, no policy saved"


def _activity_lines(ev: pd.DataFrame) -> list[_Line]:
    """The events (oldest first) as lines, oldest first, a comparison's runs merged (see
    :func:`recent_events`)."""
    whos, whats = list(ev["participant"].fillna("")), list(ev["what"])
    details = [_details(d) for d in ev["details"]]  # None for details that are not a JSON object
    lines: list[_Line] = []
    open_line: dict[str, _Line] = {}  # of each kind, the line a comparison's next run may join
    added: dict[str, int] = {}  # participant -> position of their addition
    closed: dict[tuple, int] = {}  # (participant, day) -> position of the day's close
    recorded = {(who, d.get("day"), d.get("method")): i for i, (who, what, d) in enumerate(zip(whos, whats, details))
                if what == "record_adaptation" and d is not None}  # each adaptation's last run
    for i, (at, who, what) in enumerate(zip(ev["at"], whos, whats)):
        d = details[i]
        if what == "adapt_start" and d is not None and recorded.get((who, d.get("day"), d.get("method")), -1) > i:
            continue  # its adaptation was recorded: its line says it (a start that saved nothing keeps its own)
        words = _event_words(what, details[i])
        key, method = _scoring_run(what, details[i])
        if what == "add_participant":
            added[who] = i
        elif what == "close_day":
            closed[(who, (details[i] or {}).get("day"))] = i
        if key is not None and key[0] == "initial" and i + 1 < len(ev) and whats[i + 1] == "save_policy" \
                and whos[i + 1] == who:
            key = None  # the initial policy scored with a day's real adaptation, in its transaction
        if key is None:
            lines.append(_Line(at, who, words, i))
            continue
        kind, day = key
        line = open_line.get(kind)
        if line is None or (who, day, method) in line.runs or added.get(who, -1) > line.first \
                or closed.get((who, day), -1) > line.first or _seconds_between(line.at, at) > COMPARISON_GAP_S:
            line = open_line[kind] = _Line(at, who, words, i, kind)
            lines.append(line)
        line.add_run(at, who, day, method, i)
    return sorted(lines, key=lambda line: line.position)


def _may_begin_earlier(lines: list[_Line], ev: pd.DataFrame) -> bool:
    """Whether a comparison's line among ``lines`` may have runs before the first of the events
    ``ev`` (a window of the newest): it began within :data:`COMPARISON_GAP_S` of that event."""
    return bool(len(ev)) and any(line.kind is not None and _seconds_between(ev["at"].iloc[0], line.first_at)
                                 <= COMPARISON_GAP_S for line in lines)


def _details(details: str | None) -> dict | None:
    """An event's details (its JSON object; {} for none), or None when they are not a JSON object."""
    try:
        d = json.loads(details or "{}")
    except json.JSONDecodeError:
        return None
    return d if isinstance(d, dict) else None


def _seconds_between(earlier, later) -> float:
    """Seconds from one event's time (the store's ISO stamps) to another's; 0 if either is no time."""
    from datetime import datetime

    try:
        return (datetime.fromisoformat(str(later).replace("Z", "+00:00"))
                - datetime.fromisoformat(str(earlier).replace("Z", "+00:00"))).total_seconds()
    except (TypeError, ValueError):
        return 0.0


def _scoring_run(what: str, d: dict | None) -> tuple[tuple | None, str | None]:
    """An event of a run that scores a policy and saves none: the initial policy scored (day 0) or
    a Fig. 4 comparison run: (its kind and day, its method); (None, None) for any other event.
    ``d``: the event's parsed details (:func:`_details`)."""
    if what != "record_adaptation" or d is None:
        return None, None
    if not d.get("day"):
        return ("initial", 0), d.get("method")
    if d.get("policy_version") is None:
        return ("comparison", d.get("day")), d.get("method")
    return None, None


def _event_words(what: str, d: dict | None) -> str:
    """An event in words, from its kind and its parsed details (:func:`_details`; None for details
    that are not a JSON object: the kind alone, said so)."""
    if d is None:
        return f"{what.replace('_', ' ')} (its details are not readable)"
    if what == "record_interaction":
        if d.get("type") == records.USER_INITIATED:
            asked = f"asked for '{d['user_action']}'" if d.get("user_action") else "asked for an action"
            if d.get("robot_action") not in (None, "do nothing"):  # a request that answered a proposal
                asked = f"robot proposed '{d['robot_action']}', participant {asked} instead"
            return f"day {d.get('day')}, interaction {d.get('index')}: {asked}"
        if d.get("robot_action") == "do nothing":
            return f"day {d.get('day')}, interaction {d.get('index')}: robot stayed quiet, nothing asked"
        answer = records.RESPONSE_WORDS.get(d.get("response"), "")
        return (f"day {d.get('day')}, interaction {d.get('index')}: robot proposed '{d.get('robot_action')}', "
                f"{answer}")
    if what in ("record_adaptation", "adapt_start"):
        method, days = method_names([d.get("method")]), adapted_from(d.get("day"))
        if what == "adapt_start":
            return f"adaptation ({method}) from {days} started"
        if not d.get("day"):
            return f"initial policy scored ({method})"
        if d.get("policy_version") is None:  # a Fig. 4 comparison run: scored, no policy saved
            return f"comparison run ({method}) on {days}, no policy saved"
        return f"adaptation ({method}) from {days}: version {d.get('policy_version')}"
    if what == "import_bundle":
        n, m = d.get("participants"), d.get("interactions")
        return f"study imported ({n} participant{'' if n == 1 else 's'}, {m} interaction{'' if m == 1 else 's'})"
    if what in ("open_day", "close_day"):
        return f"day {d.get('day')} {'started' if what == 'open_day' else 'closed'}"
    if what == "save_policy":
        return f"policy version {d.get('version')} saved" + (" and put in force" if d.get("active") else "")
    if what == "set_active_policy":
        v = d.get("version")
        return "initial policy put in force" if v is None else f"policy version {v} put in force"
    if what == "save_preferences":
        n = d.get("count")
        return f"preferences saved (version {d.get('version')}, {n} preference{'' if n == 1 else 's'})"
    if what == "record_questionnaire":
        return f"questionnaire: satisfaction {d.get('satisfaction')}"
    if what == "remove_questionnaire":  # saved by mistake (Results' questionnaire tab)
        return f"questionnaire answer removed (satisfaction {d.get('satisfaction')}, saved {short_time(d.get('saved_at'))})"
    if what == "remove_participant":  # stored with no participant: the code is in the details
        return f"participant {d.get('code')} removed, with everything recorded about them"
    return {"add_participant": "participant added", "update_participant": "details edited",
            "create_study": f"study {d.get('study', '')} created"}.get(what, what.replace("_", " "))
