"""Adaptation: close the study day, adapt the robot's policy with CACAS (Table III, step 2), see
what changed, and roll back to an earlier day's policy."""

from __future__ import annotations

import streamlit as st

from cacas import app_support, plots, table_layouts
from cacas.adaptation import METHODS, policy_changes, preferences_learnt
from cacas.errors import AlreadyAdapted, CacasError
from cacas.jobs import DONE, FAILED, RUNNER
from cacas.on_tablet import Shown, board_name
from cacas.study_day import (STUDY_DAYS, TARGET_INTERACTIONS, adapt_day, day_status, in_force_words,
                             unfinished_adaptation)
from pages import ui

ui.require_app()

store = ui.store()
code = ui.need_participant()
db = ui.db_path()

st.title(f"Adaptation\u00a0· {code}", anchor=False)  # "·" not first on a line (a phone)
st.caption("After each study day the robot's policy is adapted from all of the participant's interactions so "
           "far: the user model (UMA, Table II), the MLP policy and SAC against the decision model, combined "
           "by policy reshaping (Eq. 5). The participant's described preferences are never used for this; "
           "they only score the new policy afterwards (Fig. 4).")


@st.cache_resource(show_spinner=False)
def _initial():
    from cacas.adaptation import load_initial_policy

    return load_initial_policy()


def _job_key(who: str, day: int) -> str:
    return f"adapt:{db}:{who}:{day}"


def _start(who: str, day: int, drawn_shown: Shown | None = None) -> None:
    """Close (if open) and adapt ``who``'s ``day``. ``drawn_shown``: the tablet's proposal as the page drew it,
    for "Close day N and adapt": a proposal the tablet showed since (between two looks of
    :func:`_follow_the_tablet`) stops this click, said so; the next click closes the day anyway."""
    s = st.session_state
    key = _job_key(who, day)
    try:
        now = day_status(store, who)
        shown = _on_the_tablet(who, now) if now.open and now.day == day else None
    except CacasError:  # removed meanwhile: the adaptation says so, as before
        shown = None
    s["adapt-held"] = None
    if shown is not None and shown != drawn_shown:
        s["adapt-held"] = (who, day)  # said under the button while the proposal is on the tablet
        return
    mine = s.get("adapt-started") == key  # this tab started it: this click is its own second one (a double click)
    done = RUNNER.get(key)
    if done is not None and done.status == DONE:  # adapted in this server: a stale tab's click keeps its result
        s["adapt-note"] = None if mine else f"Day {day} was adapted already, in another tab: this click did nothing."
        return
    job, started = RUNNER.start(key, adapt_day, db, who, day, method=s.get("adapt-method", "cacas"),
                                seed=int(s.get("adapt-seed", 0)), label=f"Adapting {who} after day {day}")
    if started:
        s["adapt-started"] = key
    # not started: this adaptation runs already (a double click's second click, or another tab's), and the page
    # shows its progress in place of the button. A note "already running (started in another tab?)" was shown
    # only once the run was over, beside its result, and blamed another tab for this tab's double click
    s["adapt-note"] = None


def _rollback(who: str, key: str) -> None:
    choice = st.session_state.get(key)
    try:
        store.set_active_policy(who, None if choice == 0 else choice)
    except CacasError as exc:
        st.session_state["rollback-error"] = str(exc)
    else:
        st.session_state["rollback-error"] = None
        st.toast(f"{'The initial policy' if choice == 0 else f'Version {choice}'} is in force from {who}'s next "
                 "interaction.", icon=":material/history:")


#: How often the page looks at the participant's tablet while their day is open (as the Study session's view does).
FOLLOW_EVERY_SECONDS = 3


def _on_the_tablet(who: str, now) -> Shown | None:
    """The proposal ``who``'s tablet shows for their open day's next interaction (``now``: their day status),
    or None."""
    if not now.open:
        return None
    return ui.tablet_board().shown(db, board_name(store, who), day=now.day, index=now.interactions_today + 1)


@st.fragment(run_every=FOLLOW_EVERY_SECONDS)
def _follow_the_tablet(drawn, drawn_shown) -> None:
    """While the day is open the page is drawn again once the tablet shows another proposal or saves an
    answer (or the day is closed elsewhere). A study day with several tablets (lan): the page was opened, then
    the participant set a context; its warning that the tablet shows a proposal is drawn with the page only, so
    it never came, and "Close day N and adapt" lost the answer the participant was about to give."""
    try:
        now = day_status(store, code)
        if now != drawn or _on_the_tablet(code, now) != drawn_shown:
            st.rerun()
    except CacasError:  # the participant was removed meanwhile: the whole page says so
        st.rerun()


status = day_status(store, code)
versions = store.policy_versions(code)
runs = store.adaptations_frame(code)

# --- 1. the day and the adaptation --------------------------------------------------------------
st.header("Close the day and adapt", anchor=False)
day = status.day
running = next((j for j in RUNNER.running() if j.key.startswith(f"adapt:{db}:{code}:")), None)
if day == 0:
    st.info(f"{code} has not started day 1 yet. Adaptation runs after a study day.")
elif running is not None:
    ui.job_progress(running.key)
else:
    row = ui.metric_row()
    row.metric("Study day", f"{day} ({'open' if status.open else 'closed'})")
    row.metric("Interactions that day", status.recorded_today,
              help="Answered, or asked for: the interactions that give user data (Section V-B)"
                   + (f"; {status.unanswered_today} more saved that give none: unanswered, or a request while doing "
                      "nothing." if status.unanswered_today else "."))
    in_force, newest = app_support.policy_in_force(status.policy_version, versions)
    # the roll-back in the delta line: in the value, "version 1 (newest: 2)" was cut to "version 1 (newes…"
    row.metric("Policy in force", in_force, delta=None if newest is None else f"rolled back; newest: version {newest}",
              delta_color="off", delta_arrow="off")
    with st.expander("Options"):
        st.selectbox("Method", METHODS, key="adapt-method", format_func=plots.METHOD_LABELS.get,
                     help="CACAS for the study; the others are the paper's baselines (Fig. 4), a bandit and SAC "
                          "on the user data alone.")
        st.number_input("Seed", min_value=0, value=0, step=1, key="adapt-seed")
    if status.open:
        shown = _on_the_tablet(code, status)
        _follow_the_tablet(status, shown)
        if shown is not None:  # the participant is about to answer: an answer after closing is not saved
            # no interaction number: the tablet counts recorded interactions ("7 of about 15"), this index counts
            # every moment of the day, unanswered ones too ("interaction 16" beside "7 of about 15": walkthrough)
            st.warning(f"{code}'s tablet shows a proposal ({shown.activity}, shown at "
                       f"{shown.shown_at}): let the participant answer it "
                       "before closing the day, or the answer is not saved.", icon=":material/tablet:")
        # closing cannot be undone: a day short of the ~15 interactions is closed only when the researcher says so
        short = 0 < status.interactions_today and status.recorded_today < TARGET_INTERACTIONS
        sure = not short or st.checkbox(
            f"Close day {day} with {status.recorded_today} of about {TARGET_INTERACTIONS} interactions",
            key=f"close-short-{code}-{day}",
            help="A closed day takes no more interactions and cannot be reopened. If the tablet shows a proposal, "
                 "let the participant answer it first: an answer given after closing is not saved.")
        ui.button(st, f"Close day {day} and adapt", _start, args=(code, day, shown), type="primary",
                  icon=":material/model_training:", disabled=status.interactions_today == 0 or not sure,
                  help="Closes the day (no more interactions on it) and adapts the policy.")
        if status.interactions_today == 0:
            st.caption("No interactions on this day yet.")
        if shown is not None and st.session_state.get("adapt-held") == (code, day):
            st.warning(f"Day {day} was not closed: {code}'s tablet showed a proposal after this page was drawn "
                       "(above). Click again to close the day anyway.", icon=":material/tablet:")
    elif status.waiting_for_adaptation:
        unfinished = None if RUNNER.get(_job_key(code, day)) else unfinished_adaptation(store, code, day)
        if unfinished:  # this server knows no such run: it was stopped during it (or another server runs it)
            st.warning(f"An adaptation of day {day} with {plots.method_names([unfinished['method']])}, begun "
                       f"{app_support.short_time(unfinished['at'])}, saved nothing: the app was probably stopped "
                       "during it, or it failed. The day's data are all kept; adapt again (unless another server "
                       "is adapting it now).", icon=":material/restart_alt:")
        ui.button(st, f"Adapt after day {day}", _start, args=(code, day), type="primary",
                  icon=":material/model_training:")
    elif status.finished:  # there is no day 8 (it said "day 8 can start on the tablet")
        st.success(f"Day {day} is closed and adapted: all {STUDY_DAYS} study days are done. Next: the satisfaction "
                   "questionnaire (Results page).", icon=":material/check_circle:")
    else:
        st.success(f"Day {day} is closed and adapted; day {day + 1} can start on the tablet.",
                   icon=":material/check_circle:")
    if st.session_state.get("adapt-note"):
        st.warning(st.session_state["adapt-note"])

    job = RUNNER.get(_job_key(code, day)) if day else None
    if job is not None and job.status == FAILED and isinstance(job.exception, AlreadyAdapted):
        st.info(f"Day {day} had been adapted already, in another tab or by another server: this click saved "
                "nothing (the policy versions are below).", icon=":material/info:")
    elif job is not None and job.status == FAILED:
        st.error(f"The adaptation failed: {job.error}", icon=":material/error:")
    elif job is not None and job.status == DONE:
        res = job.result
        now = "initial" if status.policy_version is None else f"version {status.policy_version}"
        method = plots.method_names([res.method])  # as the figures and the Method box name it
        msg = (f"Adapted with {method} in {res.duration_s:.1f} s; policy version {res.policy_version} is "
               f"{in_force_words(res.day)}." if status.policy_version == res.policy_version else
               f"Adapted with {method} in {res.duration_s:.1f} s into policy version {res.policy_version}; "
               f"since then the {now} policy was put in force (Roll back, below).")
        if res.preference_accuracy is not None:  # the run's, named as version N's once another is in force
            msg += (f" Preference accuracy (Fig. 4): {ui.percent(res.preference_accuracy)}."
                    if status.policy_version == res.policy_version else
                    f" Version {res.policy_version}'s preference accuracy (Fig. 4): "
                    f"{ui.percent(res.preference_accuracy)}.")
        st.success(msg, icon=":material/check_circle:")
        with st.expander("Adaptation log"):
            st.code("\n".join(res.log) or "(no log)", language=None)

# --- 2. what changed -------------------------------------------------------------------------------
st.header("What changed", anchor=False)
if not versions:
    st.caption("No adapted policy yet: the initial policy (trained against the generic user simulator) is in force.")
else:
    labels = {0: "initial policy"} | {v.version: f"version {v.version} (after day {v.day}, {plots.method_names([v.method])})"
                                   for v in versions}
    active = next((v.version for v in versions if v.active), 0)
    # the widgets start afresh when a version is added or put in force, at the policy in force
    stamp = f"{code}-{versions[-1].version}-{active}"
    c1, c2 = st.columns(2)
    keys = list(labels)
    after = c2.selectbox("After", keys, index=keys.index(active), format_func=labels.get, key=f"cmp-after-{stamp}")
    # before: the version preceding "after"; after a roll back to the initial policy, the latest version
    before_default = keys.index(after) - 1 if after != 0 else len(keys) - 1
    before = c1.selectbox("Before", keys, index=before_default, format_func=labels.get, key=f"cmp-before-{stamp}")
    data = store.interactions_frame(code, method=None)
    try:
        sha = {v.version: v.sha256 for v in versions}
        # the tablet's cache (ui.policy_version): a version both use is in memory once
        p_before = _initial() if before == 0 else ui.policy_version(db, code, before, sha[before])[0]
        p_after = _initial() if after == 0 else ui.policy_version(db, code, after, sha[after])[0]
        changes = policy_changes(p_before, p_after, data)
    except CacasError as exc:
        st.error(str(exc))
    else:
        if changes.empty:
            st.caption("No interactions yet.")
        else:
            n = int(changes["changed"].sum())
            where = f"{code}'s **1 context**" if len(changes) == 1 else f"each of {code}'s **{len(changes)} contexts**"
            st.markdown(f"The robot's action in {where} (most frequent first, "
                        f"then the most recent), each as at its latest interaction (the robot's task, its previous "
                        f"action and the answer): **{n}** changed.")
            view = changes.rename(columns={"time_slot": "time of day", "interval": "since last activity",
                                           "times": "seen", "action_before": "before", "action_after": "after"})
            st.dataframe(view.style.apply(
                lambda r: ["background-color: #fff4d6" if r["changed"] else "" for _ in r], axis=1),
                hide_index=True, width="stretch")
        described = store.get_preferences(code)
        if described is not None and described.preferences:
            latest = store.preference_versions(code)[-1]
            # two counts of states side by side, each said where it is shown (walkthrough: "128 test states" here
            # for a preference the Participants page says "Covers 72 states", explained only in a hover help)
            st.markdown(f"**{code}'s described preferences** (version {latest['version']}, the latest, saved "
                        f"{app_support.short_time(latest['created_at'])}): how often each policy chooses the "
                        "preferred action (Fig. 4; evaluation only). **States covered**: the S1-S4 states the "
                        "preference covers, as the Participants page counts them. **Fig. 4 draws**: how many of "
                        "Fig. 4's 400 test states fell in it (drawn from all the described preferences, with the "
                        "robot's task, previous action and answer, and repeats); before and after are shares of "
                        "these.")
            learnt = preferences_learnt(p_before, p_after, described)
            learnt.insert(learnt.columns.get_loc("states"), "covers",
                          [described.preferences[k - 1].covered_count() for k in learnt["preference"]])
            learnt = learnt.drop(columns="preference")
            learnt[["before", "after"]] *= 100
            bar = {"format": "%.0f%%", "min_value": 0, "max_value": 100}
            widths, row_height = table_layouts.learnt_table_layout(learnt.columns)
            st.dataframe(learnt, hide_index=True, width="stretch", row_height=row_height,
                         column_config={"label": st.column_config.TextColumn("preference", width=widths["label"]),
                                        "action": st.column_config.TextColumn("action", width=widths["action"]),
                                        "covers": st.column_config.NumberColumn(
                                            "states covered", width=widths["covers"], format="%d",
                                            help="S1-S4 states (activity, room, time of day, time since the "
                                                 "last activity) the preference covers, as on the Participants "
                                                 "page"),
                                        "states": st.column_config.NumberColumn(
                                            "Fig. 4 draws", width=widths["states"],
                                            help="Of Fig. 4's 400 test states, drawn from the described "
                                                 "preferences, those in this preference (a state can be drawn "
                                                 "more than once)"),
                                        "before": st.column_config.ProgressColumn("before", width=widths["before"],
                                                                                  **bar),
                                        "after": st.column_config.ProgressColumn("after", width=widths["after"],
                                                                                 **bar)})

def _named(table):
    """The table's columns, without "scored on" where no run names its preferences' version (runs
    recorded before runs named it)."""
    return [c for c in table.columns if c != "scored on" or table[c].astype(bool).any()]


# --- 3. versions and roll back ----------------------------------------------------------------------
st.header("Policy versions", anchor=False)
if versions:
    table = app_support.versions_table(versions, runs)
    st.dataframe(table, hide_index=True, width="stretch", column_order=_named(table),
                 column_config={"preference accuracy": st.column_config.NumberColumn(
                     format="%.0f%%", help="Fig. 4's accuracy, computed when the version was adapted, on the "
                                           "described preferences saved at that time")})
    if not active:
        ui.noted("info", "The initial policy is in force (no version above).")
    with st.form("rollback", border=True):
        st.markdown("**Roll back (or forward)**: put an earlier policy in force for the next interactions.")
        options = [0] + [v.version for v in versions]
        st.selectbox("Policy", options, format_func=lambda v: "initial policy" if v == 0 else f"version {v}",
                     index=options.index(active), key=f"rollback-version-{stamp}")
        ui.button(st, "Put in force", _rollback, args=(code, f"rollback-version-{stamp}"), submit=True,
                  icon=":material/history:")
    if st.session_state.get("rollback-error"):
        st.error(st.session_state["rollback-error"])
else:
    st.caption("None yet.")

if len(runs):
    scored = int((runs["day"] == 0).sum())  # day 0: the initial policy scored for Fig. 4's day 1, not adapted
    with st.expander(f"Adaptation runs ({len(runs) - scored} after study days"
                     + (f", {scored} scoring the initial policy as day 0" if scored else "") + ")"):
        table = app_support.runs_table(runs)
        st.dataframe(table, hide_index=True, width="stretch", column_order=_named(table),
                     column_config={"duration (s)": st.column_config.NumberColumn(format="%.1f"),
                                    "preference accuracy": st.column_config.NumberColumn(format="%.0f%%")})
        # as at the click; named after the study too, as Results' tables are (two studies' P01 met in Downloads)
        ui.download_csv(lambda: ui.store().adaptations_frame(code),
                        app_support.study_file_name("adaptations", ui.study() or "", f"-{code}.csv"),
                        f"Download adaptations-{code}.csv")
