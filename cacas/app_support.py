"""Small presentation helpers for the study dashboard (tables a page shows as they are).

Everything here reads the study database or formats library results; no streamlit, so that the
pages stay thin and these are tested without a browser.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pandas as pd

from cacas import plots, records, spaces
from cacas.errors import CacasError
from cacas.study_day import STUDY_DAYS, TARGET_INTERACTIONS, day_of, day_status, scored_version


def adapted_from(day: int) -> str:
    """The study days a policy adapted after ``day`` learnt from, in words: "day 1", "days 1-3"."""
    return "day 1" if day == 1 else f"days 1-{day}"


# --- overview ------------------------------------------------------------------------------------

def next_step(has_preferences: bool, status, questionnaire_recorded: bool = False) -> str:
    """What the researcher should do next for one participant; after the last day, the post-test
    questionnaire (Section V-B.1) until an answer given after the study is recorded."""
    if not has_preferences:
        return "Describe 5 preferences (Participants)"
    if status.finished:
        return ("Study done; questionnaire recorded" if questionnaire_recorded
                else "Study done: record the questionnaire (Results)")
    if status.day == 0:
        return "Start day 1 on the tablet (Study session)"
    if status.open:
        left = TARGET_INTERACTIONS - status.recorded_today  # answered or asked for: as the tablet counts
        if left > 0:
            return f"Day {status.day}: {counted(left, 'more interaction')} on the tablet"
        return f"Close day {status.day} and adapt (Adaptation)"
    if status.waiting_for_adaptation:
        return f"Adapt after day {status.day} (Adaptation)"
    return f"Start day {status.day_on_screen} on the tablet (Study session)"


def day_count(recorded: int) -> str:
    """The day's count of recorded interactions (answered, or asked for) beside the paper's "around 15
    times a day": "5 of about 15 interactions today"; once past it, "54 interactions today (about 15
    planned)" (walkthrough: "54 of about 15 interactions today" said what was not true)."""
    if recorded > TARGET_INTERACTIONS:
        return f"{recorded} interactions today (about {TARGET_INTERACTIONS} planned)"
    return f"{recorded} of about {TARGET_INTERACTIONS} interactions today"


def latest_study(store) -> str | None:
    """The study a visit without one in its address opens: the one whose participant was the
    subject of the latest event (the study being run), None if no event is about a participant.
    It was always "default", so a researcher whose study has another name was greeted with "No
    participants yet"."""
    who = store.latest_participant()  # however many events about no participant follow (it read the last 200)
    try:
        return None if who is None else store.get_participant(who).study
    except CacasError:  # removed by another process meanwhile
        return None


def overview_frame(store, study: str | None = None) -> pd.DataFrame:
    """One row per participant: day (of 7), interactions today, success rate so far (Fig. 3's
    definition, all days), policy in force, when the last interaction was recorded and what to do next."""
    cols = ["participant", "age range", "day", "interactions today", "success rate so far",
            "policy", "last recorded", "next step"]
    rows = []
    people = store.list_participants(study)
    if not people:
        return pd.DataFrame(columns=cols)
    inter = store.interactions_frame(method=None, study=study)
    answers = store.questionnaire_frame(study)
    after_the_study = set(answers.loc[answers["day"].fillna(0) >= STUDY_DAYS, "participant"])
    # each participant's counts from one pass over the study's interactions (a filter of the whole table per
    # participant, and their latest day's interactions read again by day_status, were most of the Overview's
    # run: 0.6 s for 60 participants x 21 days, scripts/bench_pages.py)
    by_who = inter.assign(recorded=records.is_recorded(inter), success=records.is_success(inter)) \
        .groupby(["participant", "day"])[["recorded", "success"]].sum()
    # the interaction's own time, not a questionnaire's; by the moment, not the text (a time an older version stored
    # with an offset, kept by an import, sorted among the app's UTC times by its local date)
    timed = inter.dropna(subset=["time"]).reset_index(drop=True)
    by_moment = pd.to_datetime(timed["time"], utc=True, format="ISO8601", errors="coerce") \
        .sort_values(kind="stable", na_position="first").index
    last_time = timed.loc[by_moment].groupby("participant")["time"].last()
    described = set(store.preferences_frame(study)["participant"])  # not each one's preferences parsed and checked
    for p in people:
        mine = by_who.loc[p.code] if p.code in by_who.index.get_level_values(0) else by_who.iloc[:0]
        status = day_status(store, p.code, {int(d): int(n) for d, n in mine["recorded"].items()})
        recorded = int(mine["recorded"].sum())
        success = int(mine["success"].sum()) / recorded if recorded else float("nan")  # records.success_rate's
        last = last_time.get(p.code)
        has_prefs = p.code in described
        rows.append({
            "participant": p.code, "age range": p.age_range,
            "day": day_of(status.day) + (" (open)" if status.open else "") if status.day else "not started",
            "interactions today": status.recorded_today if status.open else 0,
            "success rate so far": success,
            "policy": policy_label(status.policy_version, store.policy_versions(p.code)),
            "last recorded": short_time(last) if last is not None else "",
            "next step": next_step(has_prefs, status, p.code in after_the_study),
        })
    return pd.DataFrame(rows, columns=cols)


def rolled_back_note(events: pd.DataFrame, participants: pd.DataFrame | None = None,
                     policies: pd.DataFrame | None = None, interactions: pd.DataFrame | None = None) -> str:
    """For the Results page: what a roll-back on the Adaptation page changes in Fig. 3 and Fig. 4,
    naming the participants who had one ("" if none did). Given ``participants`` and ``policies``
    (participants.csv's ``active_policy``, policies.csv's versions), a roll-back that a later
    version has ended since (a roll-forward, or a day adapted after it: the newest version is in
    force) is said as past: it is about the days that used the version it put in force (the note
    read as if it still held after a roll-forward). Given ``interactions`` too (interactions.csv's
    ``policy_version`` and ``created_at``), a past roll-back is named only where an interaction was
    recorded under it (:func:`recorded_under_a_roll_back`): one between two days changed no figure
    (walkthrough: the note named a participant rolled back and forward before their next day)."""
    who = records.by_code(set(events.loc[events["what"] == "set_active_policy", "participant"].dropna()))
    if not who:
        return ""
    ended = set()
    if participants is not None and policies is not None and len(policies):
        newest = policies.groupby("participant")["version"].max()
        for code, active in zip(participants["participant"], participants["active_policy"]):
            if code in who and code in newest.index and pd.notna(active) and int(active) == int(newest[code]):
                ended.add(code)
    now, past = [c for c in who if c not in ended], [c for c in who if c in ended]
    if interactions is not None and policies is not None:
        used = recorded_under_a_roll_back(interactions, policies)
        past = [c for c in past if c in used]
        if not now and not past:
            return ""
    how = "(a day rolled back in its middle, the version most of its interactions had)"
    scored = ": Fig. 4 scores that version for CACAS, while the baselines keep their runs adapted from days 1..d-1."
    held = f"while a roll-back held ({', '.join(past)}; a later version is in force again), a day used the version " \
           "it put in force"
    if not past:
        return f" After a roll-back ({', '.join(now)}), a day uses the version put in force instead {how}{scored}"
    if not now:
        return f" {held[0].upper()}{held[1:]} {how}{scored}"
    return f" After a roll-back ({', '.join(now)}), a day uses the version put in force instead; {held} {how}{scored}"


def recorded_under_a_roll_back(interactions: pd.DataFrame, policies: pd.DataFrame) -> set[str]:
    """The participants with an interaction recorded under a rolled-back policy: its ``policy_version``
    (empty: the initial policy) is not the newest version of theirs saved by the interaction's
    ``created_at`` (policies.csv's). A roll-back put forward again before any interaction leaves none."""
    if not len(interactions):
        return set()
    when = pd.to_datetime(interactions["created_at"], utc=True, format="ISO8601")
    saved = policies.assign(at=pd.to_datetime(policies["created_at"], utc=True, format="ISO8601"))
    mine = {code: list(zip(g["at"], g["version"].astype(int))) for code, g in saved.groupby("participant")}
    under = set()
    for code, at, version in zip(interactions["participant"], when, interactions["policy_version"]):
        newest = max((v for t, v in mine.get(code, ()) if t <= at), default=None)
        if (None if pd.isna(version) else int(version)) != newest:
            under.add(code)
    return under


def policy_label(in_force: int | None, versions) -> str:
    """The policy in force in words ("initial", "version 2"), saying when a newer version was rolled
    back from ("version 1 (newest: 2)"): a roll-back shown as a plain "version 1" read as if no
    later adaptation existed."""
    label, newest = policy_in_force(in_force, versions)
    return label if newest is None else f"{label} (newest: {newest})"


def policy_in_force(in_force: int | None, versions) -> tuple[str, int | None]:
    """:func:`policy_label` in two parts: the policy in force in words, and the newest version when
    a roll-back put an older one in force (else None)."""
    newest = max((v.version for v in versions), default=None)
    return ("initial" if in_force is None else f"version {in_force}"), (None if newest == in_force else newest)


def open_days(store, study: str | None = None) -> dict[str, int]:
    """The participants whose study day is open (in progress), with that day: their figures for
    it are so far, not final (Fig. 3 of a study under way)."""
    days = store.days_frame(study)  # one query, not a day_status (and its interactions) per participant
    if not len(days):
        return {}
    latest = days.assign(day=days["day"].astype(int)).sort_values("day").drop_duplicates("participant", keep="last")
    return {str(who): int(day) for who, day, closed in zip(latest["participant"], latest["day"], latest["closed_at"])
            if not (isinstance(closed, str) and closed)}


def last_participant(store, study: str | None = None) -> str | None:
    """The participant of ``study`` whom the latest event is about (the one the researcher or the
    tablet last worked with: a recorded answer, an adaptation, a preference saved), else the
    first by code, else None: the app's sidebar starts there rather than at the first code. A
    removal, the study's latest event about no participant, is passed over, however many there
    are (the last 20 events were read: a run of removals hid the participant)."""
    latest = store.latest_participant(study)
    if latest is not None:
        return latest
    people = store.list_participants(study)
    return people[0].code if people else None


def personas_imported(done, source: str) -> str:
    """What an import of the persona file ``source`` did (a :class:`cacas.store.PersonasImport`),
    group by group: it said "Imported 3 participants: P01, P02, P03" of one unchanged and one whose
    preferences were replaced."""
    groups = [("added", done.added), ("preferences replaced for", done.replaced),
              ("first preferences for", done.first), ("unchanged", done.unchanged)]
    # short: a toast shows about 100 characters before its "view more"
    return f"Imported {source}: " + " · ".join(f"{what} {', '.join(codes)}" for what, codes in groups if codes) + "."


def study_file_name(prefix: str, study: str, suffix: str) -> str:
    """A download's file name for a study: no spaces or other characters a shell or a file
    system trips on ("pilot walkB" -> "cacas-study-pilot_walkb.zip"; "study" if nothing is left)."""
    from cacas.media_library import slug

    return f"{prefix}-{slug(study) or 'study'}{suffix}"


#: A run folder's name that a download may carry as it is: what :func:`cacas.saved_runs.new_run_name` makes
#: ("20260301-101500-seed0-8p-7d", "...-2" for a second run in that second), no character a shell trips on.
_RUN_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")


def run_file_name(prefix: str, run: str, suffix: str) -> str:
    """A simulated run's download named after its folder, as the folder is named: "daily-" plus
    "20260301-101500-seed0-8p-7d.csv" (:func:`study_file_name` made it "20260301_101500_seed0_8p_7d",
    which matched no folder on disk). A folder renamed by hand to something a shell trips on ("my run")
    is made safe as a study's name is."""
    return f"{prefix}-{run}{suffix}" if _RUN_NAME.fullmatch(run) else study_file_name(prefix, run, suffix)


def synthetic_words(training_data: dict) -> str:
    """How much of a model's training data was synthetic, after its item count: " (synthetic)" when
    all was, " (131 synthetic)" when some was (a model trained on 131 generated clips and 4
    recordings read "not synthetic"), "" when none was or it is not recorded (models trained before
    the count was kept record all or nothing: ``synthetic``)."""
    some = training_data.get("synthetic_items")
    if training_data.get("synthetic"):
        return " (synthetic)"
    return f" ({some} synthetic)" if isinstance(some, int) and some > 0 else ""


#: How far (s) the study's newest record may be ahead of the clock before the researcher's pages say so: a record
#: written a moment ago by another machine whose clock runs a little ahead is not a clock set back.
CLOCK_SLACK_S = 120


def clock_behind(store, now=None) -> str | None:
    """One line for the researcher's pages when this computer's clock is behind the study's newest record by more
    than :data:`CLOCK_SLACK_S` (clock walk: a server restarted with its clock set back, a Raspberry Pi without a
    real-time clock before it synchronises, records what follows as earlier than what came before: the Overview's
    "last recorded", which preferences an interaction is scored against, the export's order of times); else None.
    ``now``: an aware datetime (default: the clock's)."""
    from datetime import datetime, timezone

    from cacas.store.validate import iso_time

    newest = store.newest_time()
    if not newest:
        return None
    try:
        then = iso_time(newest)
    except ValueError:
        return None
    if then.utcoffset() is None:  # a time without a zone (an old import's): not comparable
        return None
    now = now or datetime.now(timezone.utc)
    if (then - now).total_seconds() <= CLOCK_SLACK_S:
        return None
    return (f"this computer's clock says {short_time(now.timestamp())}, before the study's latest record "
            f"({short_time(newest)}): set the clock right before recording more, or what is recorded now will be "
            "dated before what was recorded then")


def short_time(stamp) -> str:
    """'2026-11-21T09:47:34.123Z' (or seconds since the epoch) -> '2026-11-21 09:47 UTC'. A time
    with another offset is said in UTC ('2026-10-26T01:30:00+02:00' -> '2026-10-25 23:30 UTC'); one
    without a zone, as a study imported from an older version may hold (``restore``'s notes), says
    so ('2026-03-29 00:59 (no time zone)'); a date alone, or what is no time, is given as it is."""
    from datetime import datetime, timezone

    from cacas.store.validate import iso_time

    if isinstance(stamp, (int, float)):
        return datetime.fromtimestamp(stamp, timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    s = str(stamp)
    if len(s) < 16:
        return s
    try:
        t = iso_time(s)
    except ValueError:
        return s
    if t.utcoffset() is None:
        return f"{t:%Y-%m-%d %H:%M} (no time zone)"
    return f"{t.astimezone(timezone.utc):%Y-%m-%d %H:%M} UTC"


def _scored_on(metrics: str | None) -> str:
    """The described preferences' version a run's Fig. 4 metrics were scored against, in words
    ("version 2"); "" for a run not scored, or recorded before runs named it."""
    version = scored_version(metrics)
    return "" if version is None else f"version {version}"


def versions_table(versions, runs: pd.DataFrame) -> pd.DataFrame:
    """The Adaptation page's policy versions: version, adapted from, method (as the figures name it), saved, in force,
    preference accuracy (percent, from the run that saved it; NaN if none), scored on (the described
    preferences' version it was scored against), sha256 (12 digits). ``versions``: the store's policy
    versions; ``runs``: its adaptations_frame."""
    cols = ["version", "adapted from", "method", "saved", "in force", "preference accuracy", "scored on",
            "sha256"]
    saved = runs.dropna(subset=["policy_version"]).set_index("policy_version")
    return pd.DataFrame([{
        "version": v.version, "adapted from": adapted_from(v.day) if v.day else "-",
        "method": plots.method_names([v.method]),
        "saved": short_time(v.created_at), "in force": "yes" if v.active else "",
        "preference accuracy": 100 * float(saved["preference_accuracy"].get(v.version, float("nan"))),
        "scored on": _scored_on(saved["metrics"].get(v.version)), "sha256": v.sha256[:12],
    } for v in versions], columns=cols)


def runs_table(runs: pd.DataFrame) -> pd.DataFrame:
    """The Adaptation page's adaptation runs (the store's adaptations_frame), in words: day,
    what (the method; the initial policy's Fig. 4 score, recorded as day 0, says so, with the method
    whose day 1 it is: a method comparison scores it once for each baseline, and four rows read alike;
    a run that saved no policy is a comparison), duration (s), preference accuracy (percent; NaN if not
    scored), scored on (the described preferences' version), policy version (empty where none was
    saved; it read "None"), saved (short time)."""
    initial = [json.loads(p or "{}").get("initial", False) for p in runs["parameters"]]
    what = [(f"initial policy, scored for Fig. 4 ({m})" if first else
             f"{m} (comparison)" if pd.isna(v) else m)  # the method as the figures name it (the CSV keeps its code)
            for m, v, first in zip(map(plots.method_names, ([m] for m in runs["method"])), runs["policy_version"],
                                   initial)]
    return pd.DataFrame({"day": runs["day"], "what": what, "duration (s)": runs["duration_s"],
                         "preference accuracy": 100 * runs["preference_accuracy"].astype(float),
                         "scored on": [_scored_on(m) for m in runs["metrics"]],
                         "policy version": ["" if pd.isna(v) else str(int(v)) for v in runs["policy_version"]],
                         "saved": [short_time(c) for c in runs["created_at"]]})


# --- wording ------------------------------------------------------------------------------------

def counted(n: int, word: str, plural: str | None = None) -> str:
    """``n`` and ``word`` in agreement: "1 participant", "0 participants", "3 clips" (``plural``
    where adding "s" is wrong). The pages said "participant(s)"."""
    return f"{n:,} {word if n == 1 else plural or word + 's'}"


# --- questionnaire -------------------------------------------------------------------------------

def questionnaire_summary(answers: pd.DataFrame) -> dict[str, float]:
    """Section V-B.2's summary of the satisfaction scale (latest answer per participant): n, mean,
    sample standard deviation and the share rating 8 or higher (the paper: mean 8.125, SD 0.64,
    87.5% at 8 or above), and ``mid_study``: the participants whose answer counted was given
    before their 7th study day (the paper asks after the study)."""
    if answers is None or answers.empty:
        return {"n": 0, "mean": math.nan, "sd": math.nan, "share_8_or_more": math.nan, "mid_study": []}
    last = answers.drop_duplicates("participant", keep="last")
    latest = last["satisfaction"].astype(float)
    # the paper asks after the 7 days: answers given earlier are counted, and named (``day``: the
    # participant's study day when they answered, as questionnaire.csv has it)
    early = (last["day"].fillna(0).astype(int) < STUDY_DAYS if "day" in last.columns
             else pd.Series(False, index=last.index))
    return {"n": int(len(latest)), "mean": float(latest.mean()),
            "sd": float(latest.std(ddof=1)) if len(latest) > 1 else math.nan,
            "share_8_or_more": float((latest >= 8).mean()),
            "mid_study": records.by_code(last.loc[early, "participant"])}


# --- interactions as a readable table ------------------------------------------------------------

#: What the day's table says where no model recognised the context (the robot used it as set).
AS_SET = "(as set)"


def interactions_view(df: pd.DataFrame) -> pd.DataFrame:
    """The interactions table with names instead of indices, for reading on a page: what the
    participant set (S1-S4), what the robot heard and saw (when ``df`` has the store's extra columns and
    a recogniser was used; else :data:`AS_SET`), the robot's proposal and the answer
    ("asked for X" for a participant's request, where the robot's proposal was not taken)."""
    columns = ["day", "#", "time of day", "since last activity", "activity", "room", "robot heard", "robot saw",
               "robot proposed", "answer"]
    if df.empty:
        return pd.DataFrame(columns=columns)
    slot = df["time_slot"].astype(int)
    request = (df["type"] == records.USER_INITIATED).to_numpy()
    answer = np.where(request, "asked for " + df["user_action"].astype(str),
                      df["response"].map(records.RESPONSE_WORDS))
    heard = df["recognised_activity"] if "recognised_activity" in df else pd.Series([None] * len(df), index=df.index)
    saw = df["recognised_scene"] if "recognised_scene" in df else pd.Series([None] * len(df), index=df.index)
    return pd.DataFrame({
        "day": df["day"].astype(int), "#": df["index"].astype(int),
        "time of day": [spaces.time_slot_label(s) for s in slot],
        # S4: interactions.csv's interval is the bin's minutes
        "since last activity": [spaces.interval_label(spaces.interval_bin(float(m))) for m in df["interval"]],
        "activity": df["activity"], "room": df["scene"],
        # no recogniser (or a frame without the store's extra columns): the robot used the context as set,
        # and says so rather than repeat it as if heard (the export's recognised_* columns are empty then)
        "robot heard": heard.where(heard.notna() & (heard != ""), AS_SET),
        "robot saw": saw.where(saw.notna() & (saw != ""), AS_SET),
        "robot proposed": df["robot_action"], "answer": answer,
    }, columns=columns)


def day_ranges(days) -> str:
    """Days as short ranges: [1, 2, 3, 5] -> "1-3, 5"."""
    out: list[list[int]] = []
    for d in sorted({int(x) for x in days}):
        if out and d == out[-1][1] + 1:
            out[-1][1] = d
        else:
            out.append([d, d])
    return ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in out)


def _each_participant(df: pd.DataFrame):
    """(participant, rows) of ``df``, participants as a person reads them (:func:`cacas.records.code_order`)."""
    return sorted(df.groupby("participant"), key=lambda kv: records.code_order(kv[0]))


def left_out_note(left: pd.DataFrame, again: bool = False) -> str:
    """The Fig. 4 caption's sentence on the participant-days left out so that every method is
    averaged over the same participants (:func:`cacas.plots.incomplete_comparisons`); "" if none.
    ``again``: a human study, where comparing the methods again adds them."""
    if not len(left):
        return ""
    # each participant's days by what they lack (days lacking different methods are said apart: "P06
    # days 1-7 (no ORL, NN, CACAS w/o PR)" lumped days 1-2, which had w/o PR, with days 3-7), and the
    # participants whose days read the same named together (19 participants were listed one by one)
    said: dict[str, list[str]] = {}
    for who, g in _each_participant(left):
        by_missing: dict[tuple, list[int]] = {}
        for day, missing in zip(g["day"], g["missing"]):
            by_missing.setdefault(tuple(missing), []).append(int(day))
        segments = sorted(by_missing.items(), key=lambda kv: min(kv[1]))
        words = ", ".join(f"day{'s' if len(days) > 1 else ''} {day_ranges(days)} "
                          f"(no {', '.join(plots.METHOD_LABELS.get(m, m) for m in missing)})"
                          for missing, days in segments)
        said.setdefault(words, []).append(str(who))
    parts = [f"{', '.join(people)} {words}" for words, people in said.items()]
    return (" Methods are compared on the same participants, so these are left out: " + "; ".join(parts)
            + ("; compare methods again to add them." if again else "."))


def comparison_done(runs, elapsed: float, finished: float | None = None) -> str:
    """What the Results page says when "Compare methods" has ended: the runs it recorded
    (:class:`cacas.method_comparison.Compared`, said as what they are: adaptations after study days and
    scores of the initial policy; none: every closed day had every method's run already, or there was no
    closed day of a participant with described preferences), how long it
    took and, given ``finished`` (epoch seconds), when it ended: the server keeps the last comparison
    for every session, and a session opened later read it as news (walkthrough)."""
    took = f"{elapsed:.0f} s" if elapsed < 120 else f"{elapsed / 60:.0f} min"
    if finished is not None:
        took += f", ended {short_time(finished)}"
    if not runs.runs and runs.participants == 0:  # nothing there to compare
        return (f"Nothing compared ({took}): no participant with described preferences has a closed study day yet. "
                "Each method is adapted from a participant's closed days: compare again once a day is closed "
                "(Adaptation page).")
    if not runs.runs:
        return (f"Methods compared ({took}): no new run; each method has one for every closed day of the participants "
                "with described preferences already (a day is compared once it is closed).")
    return f"Methods compared ({took}): {runs.words()} recorded, in Fig. 4 and the tables below."


def uncompared_note(daily: pd.DataFrame, closed_loop: str = "cacas") -> str:
    """The Fig. 4 caption's sentence on a human study's days whose baselines have not been
    compared yet: the comparison adapts them from the days recorded when it runs, so days
    recorded since show the closed-loop method alone and its baselines' lines end early; ""
    when every day with a score is compared, or no comparison has been run."""
    d = daily[daily["preference_accuracy"].notna()]
    baselines = [m for m in dict.fromkeys(d["method"]) if m != closed_loop]
    if not baselines:
        return ""
    parts = []
    for who, g in _each_participant(d):
        compared = set(g.loc[g["method"] != closed_loop, "day"].astype(int))
        alone = sorted(set(g.loc[g["method"] == closed_loop, "day"].astype(int)) - compared)
        if compared and alone:
            parts.append(f"{who} day{'s' if len(alone) > 1 else ''} {day_ranges(alone)}")
    if not parts:
        return ""
    return (f" Not compared yet, so {plots.METHOD_LABELS.get(closed_loop, closed_loop)} alone: " + "; ".join(parts)
            + "; compare methods again to add them.")


def next_day_view(ahead: pd.DataFrame) -> pd.DataFrame:
    """The Results page's table of the policies adapted for a day not started yet
    (:func:`cacas.export.next_day_accuracy`): one row per participant and day, one column per
    method (in the figures' order) with its accuracy in percent, the policy in force marked."""
    rows = []
    for (who, day), g in sorted(ahead.groupby(["participant", "day"]),
                                key=lambda kv: (records.code_order(kv[0][0]), kv[0][1])):
        row = {"participant": who, "day": int(day)}
        for m in plots.in_method_order(g["method"]):
            r = g[g["method"] == m].iloc[0]
            row[plots.METHOD_LABELS.get(m, m)] = percent(r["preference_accuracy"]) + (" in force" if r["in_force"] else "")
        rows.append(row)
    return pd.DataFrame(rows).fillna("–")


#: A study zip above this many bytes is better written to disk by ``cacas export`` than built in
#: the server's memory for a download (the large-study walkthrough: 200 MB for 24 participants x 14
#: days, the server grew by 400 MB while it was built).
LARGE_BUNDLE_BYTES = 50_000_000


def bundle_note(policies: pd.DataFrame, db_path, study: str | None = None) -> str:
    """The Results page's line under "Download everything" for a study whose policy files make the
    zip large (:data:`LARGE_BUNDLE_BYTES`): its size and the command that writes it to disk; ""
    otherwise. ``policies``: the study's policies.csv frame (its ``size`` column)."""
    total = int(pd.to_numeric(policies["size"], errors="coerce").fillna(0).sum()) if len(policies) else 0
    if total < LARGE_BUNDLE_BYTES:
        return ""
    from shlex import quote

    study_option = f" --study {quote(study)}" if study else ""
    return (f"The zip holds {total / 1e6:.0f} MB of policy files ({len(policies)} versions), built in the app's "
            f"memory on the click; `cacas export --db {quote(str(db_path))}{study_option} --out export/` "
            "writes the same zip (and the tables) straight to disk.")


def time_left(elapsed_s: float, fraction: float, first_step: tuple[float, float] | None = None) -> str:
    """A long job's progress line's estimate of the time left, from the time so far and the share
    done (work of even pace: a simulation's adaptations, a comparison's): ", about 40 s left",
    ", about 3 min left"; "" while too little is done to tell (under a fifth, or 10 s: starting the
    worker processes is a cost of the first seconds alone, and a simulation of about 2.5 minutes
    was said to have 6 minutes left at 12 %) or when it is done. With ``first_step`` (elapsed s,
    fraction) of the job's first report of work done (:attr:`cacas.jobs.Job.first_step`), the pace is
    measured from there, once a tenth more is done: a 46-s simulation that began with 9 s of
    start-up said 'about 39 s left' at 25 s, and says about 26 s (walkthrough)."""
    if not 0.2 <= fraction < 1 or elapsed_s < 10:
        return ""
    if first_step is not None and fraction - first_step[1] >= 0.1 and elapsed_s > first_step[0]:
        left = (elapsed_s - first_step[0]) * (1 - fraction) / (fraction - first_step[1])
    else:
        left = elapsed_s * (1 - fraction) / fraction
    return f", about {left:.0f} s left" if left < 90 else f", about {left / 60:.0f} min left"


def percent(x: float | None) -> str:
    """A share as a whole percentage, halves rounded up as the tables' "%.0f%%" columns show them
    (72.5 -> "73%" in both; Python's format rounds halves to even); "–" for none."""
    return "–" if x is None or pd.isna(x) else f"{math.floor(100 * x + 0.5):.0f}%"


def is_phone(user_agent: str | None) -> bool:
    """Whether a browser's User-Agent is a phone's: "Mobi" in it, as MDN's "Browser detection using the user
    agent" recommends (iPhone and Android phones' browsers say "Mobile"; tablets and laptops do not). The server
    does not know a page's width; a phone gets the layouts drawn for ~360 px (Fig. 4's heatmap by preference,
    whose row labels took 300 px of it)."""
    return "Mobi" in str(user_agent or "")
