"""Results: Fig. 3 (success rate and cumulative feedback per day), Fig. 4 (the methods' preference
accuracy per day), the satisfaction questionnaire, and a CSV download for every table."""

from __future__ import annotations

import math


import pandas as pd
import streamlit as st

from cacas import app_support, plots, records, saved_runs, uploaded_run
from cacas.errors import CacasError
from cacas.export import bundle_bytes, export_tables, next_day_accuracy
from cacas.jobs import DONE, FAILED, RUNNER
from cacas.parallel import default_jobs
from cacas.method_comparison import compare_methods
from cacas.study_day import STUDY_DAYS, day_status, questionnaire_timing
from pages import ui


@st.cache_data(show_spinner=False, max_entries=8)
def _study_tables(path: str, study: str | None, stamp: tuple[int, int]) -> dict[str, pd.DataFrame]:
    return export_tables(ui.store(), study)


def study_tables(study: str | None) -> dict[str, pd.DataFrame]:
    """``export_tables(ui.store(), study)``, read again only when the database has changed since
    (:meth:`StudyStore.data_stamp`: a write by this server, another program or a worker process): the
    Results page read every table on each of its runs, a third of the run for a 24 x 7 study (a change of
    participant, of the days shown, a click). The stamp is taken before the tables are read, so tables
    cached under it are never older than it. Each caller gets its own copy (``st.cache_data``). Here, not in
    ``ui``: ``app.py`` imports ``ui``, also bare in a Simulation lab worker, where a ``st.cache_data`` made at
    import wrote a warning to the server's log."""
    return _study_tables(ui.db_path(), study, ui.store().data_stamp())


ui.require_app()

store = ui.store()
study = ui.study()
db = ui.db_path()
HUMAN = "Human study (this database)"
TAB = "results-tab"  #: the open tab's key

st.title("Results", anchor=False)

# --- which data ------------------------------------------------------------------------------------
runs_root = saved_runs.runs_dir(db)
runs = saved_runs.list_runs(runs_root)
SIMULATED, UPLOAD = "A simulated run", "Upload CSV files or a zip"
source = st.segmented_control("Data", [HUMAN, SIMULATED, UPLOAD], default=HUMAN, key="results-source") or HUMAN
if source == SIMULATED:
    if not runs:
        st.info("No simulated run yet: run one in the **Simulation lab**.")
        st.stop()
    source = "Simulated run: " + st.selectbox("Run", runs, key="results-run",
                                               format_func=lambda r: saved_runs.run_label(runs_root, r),
                                               help="Saved by the Simulation lab, newest first.")

def table_file_name(table: str) -> str:
    """A table's download named as the zip is, after the study (the simulated run) it is of: two studies'
    "interactions.csv" met in a Downloads folder as "interactions (1).csv" (walkthrough). The tables of an
    upload keep their plain names: they are the researcher's own files."""
    if source == HUMAN:
        return app_support.study_file_name(table, study, ".csv")
    if source.startswith("Simulated run: "):
        return app_support.run_file_name(table, source.removeprefix("Simulated run: "), ".csv")
    return f"{table}.csv"


if source == HUMAN:
    tables = study_tables(study)
    daily = tables["daily"]
    n_people, n_started = len(tables["participants"]), tables["days"]["participant"].nunique()  # as Overview's "Started"
    st.caption(f"Study **{study}**: {n_people} participant{'s' if n_people != 1 else ''} "
               f"({n_started} with a study day), {len(tables['interactions'])} "
               f"interaction{'' if len(tables['interactions']) == 1 else 's'} logged, "
               f"{int(records.is_recorded(tables['interactions']).sum())} of them recorded (answered, or asked for during an "
               "activity), "
               "which the success rate counts. Day d's success rate uses the policy adapted from "
               "days 1..d-1 (Section V-B.2)." + app_support.rolled_back_note(
                   tables["events"], tables["participants"], tables["policies"], tables["interactions"]))
elif source.startswith("Simulated run: "):
    name = source.removeprefix("Simulated run: ")
    run = ui.load_run(db, name)
    tables, daily = run.tables, run.daily
    st.caption(f"Simulated run **{name}** (Simulation lab): "
               f"{app_support.counted(daily['participant'].nunique(), 'simulated participant')}, "
               f"methods {plots.method_names(plots.in_method_order(daily['method']))}"  # as the figures name them
               + (", each in its own closed loop." if run.settings.get("loop") == "each" else "."))
else:
    ups = st.file_uploader("A daily.csv from `cacas simulate`, the Simulation lab or an export; add its "
                           "by_preference.csv and interactions.csv to see them too, and the checksums.sha256 "
                           "beside them to check they are of one run. Or the zip of a run or a study",
                           type=["csv", "sha256", "zip"], accept_multiple_files=True, key="results-upload")
    if not ups:
        st.stop()
    try:
        uploaded = uploaded_run.unpacked_uploads([(up.name, up.getvalue()) for up in ups])
        tables = uploaded_run.load_uploaded_tables(uploaded)
    except CacasError as exc:
        st.error(str(exc), icon=":material/error:")
        st.stop()
    daily = tables["daily"]
    checked = next((name for name, _ in uploaded if name.lower().endswith(".sha256")), None)
    said, unchecked = uploaded_run.upload_caption(list(tables), checked,
                                                  [up.name for up in ups if up.name.lower().endswith(".zip")])
    st.caption(said)
    if unchecked:
        ui.noted("info", f"{unchecked}")

# a study in progress: participants on different days make each day's mean one of different people
shown, reached = daily, plots.participants_reached(daily) if len(daily) else pd.Series(dtype=int)
common = int(reached.min()) if len(reached) else None
if common is not None and common < int(reached.max()):
    late = [f"{who} on day {day}" for who, day in reached[reached < reached.max()].items()]
    behind = ", ".join(late[:4]) + (f" and {len(late) - 4} more" if len(late) > 4 else "")  # a radio label, not a list
    through = "day 1" if common == 1 else f"days 1-{common}"
    whole = st.radio("Days in the figures", ["every", "common"], horizontal=True, key="results-days",
                     format_func={"every": f"Every day (later days average fewer participants: {behind})",
                                  "common": f"Only {through}, which every participant has reached"}.get,
                     help="Each day's mean is over the participants who had that day: while some are behind, a "
                          "line can rise or fall only because fewer people are averaged. The day labels say how "
                          "many each day averages. The tables are whole either way.") == "every"
    shown = daily if whole else daily[daily["day"].astype(int) <= common]

# Only the open figure tab runs (Fig. 4 with its heatmap was over half of a rerun of a 24 x 7 study); a change of
# tab reruns the page. Their widgets keep their values meanwhile (persist_state). The questionnaire's form and
# the tables' expanders are drawn in every run: a form keeps what was typed, and an expander its state, only
# while drawn, and both are quick.
fig3, fig4, quest, data = st.tabs(["Fig. 3 · success rate", "Fig. 4 · methods", "Questionnaire", "Tables"],
                                  key=TAB, on_change="rerun")

if fig3.open:
    with fig3:
        method, looped = plots.loop_method(shown), plots.in_method_order(plots.closed_loop_methods(shown))
        if method is None:
            st.info("No study day with interactions yet. Run a day on the **Study session** page." if source == HUMAN
                    else "No success rate in this daily.csv: no method acted with the participants (its accuracies are "
                         "under Fig. 4).")
        else:
            if len(looped) > 1:  # a simulated run with --loop each, or a human study adapted with several methods
                human = source == HUMAN
                ui.chart(plots.success_methods_figure(
                    shown, title="Success rate by the method whose policy was in force" if human else None), width="stretch")
                if few := plots.few_interactions_note(shown):  # its hollow points (Fig. 3's own caption is below)
                    st.caption(few)
                method = st.selectbox("Method", looped, index=looped.index(method), key="results-fig3-method", persist_state="page",
                                      format_func=lambda m: plots.METHOD_LABELS.get(m, m),
                                      help=("Participants' days count under the method whose policy was in force that "
                                            "day; Fig. 3 below shows one method." if human else
                                            "Each of these methods acted in a study of its own; Fig. 3 below shows one."))
            per_day = plots.success_by_day(shown, method).set_index("day")
            last = per_day.index.max()
            row = ui.metric_row()
            first = per_day.index.min()
            change, paired = plots.success_change(shown, method, first, last)
            # halves up, as the percentages beside it (25 % -> 38 % is "+13", not round()'s "+12": review)
            change = math.floor(100 * change + 0.5) if paired else 0
            n_last, n_all = int(per_day.loc[last, "participants"]), int(per_day["on_day"].max())
            in_progress = records.by_code(c for c, d in app_support.open_days(store, study).items() if d == last) \
                if source == HUMAN else []
            n_first = int(per_day.loc[first, "participants"])
            row.metric(f"Day {last} mean success rate" + (" so far" if in_progress else ""),
                      ui.percent(per_day.loc[last, "mean"]),
                      # a day begun with nothing recorded yet: "–" alone read as a missing figure (walkthrough)
                      "nothing recorded yet" if n_last == 0 else
                      None if len(per_day) < 2 or not paired else f"{change:+d} points since day {first}"
                      # paired: over the participants with both days, not the difference of the two plotted means
                      + ("" if paired == n_first == n_last else f" ({paired} with both days)"),
                      delta_color="normal" if change and n_last else "off", delta_arrow="auto" if n_last else "off",
                      help=" ".join(filter(None, [
                          f"Day {last}: the mean over the {n_last} participant{'s' if n_last != 1 else ''} with a "
                          f"success rate that day; the change is over the {paired} with both day {first} and day {last}."
                          if len(per_day) > 1 else None,
                          f"Day {last} is still open for {', '.join(in_progress)}: its figures change until the day "
                          "is closed." if in_progress else None])) or None)
            row.metric(f"Mean cumulative feedback, day {last}", plots.data_points(per_day.loc[last, "cumulative_feedback"]))
            on_day = int(per_day.loc[last, "on_day"])  # also those with nothing recorded yet that day
            row.metric(f"Participants on day {last}", on_day if on_day == n_all else f"{on_day} of {n_all}",
                      help=None if on_day == n_all else f"{n_all} participants have a day in the figure; "
                      f"{on_day} {'has' if on_day == 1 else 'have'} reached day {last}.")
            if in_progress:
                ui.noted("pending", f"Day {last} is still open for {', '.join(in_progress)}: its figures "
                                    "are so far, and change until the day is closed.")
            ui.chart(plots.success_figure(shown, method=method), width="stretch")
            st.caption(plots.success_caption(shown, method))

if fig4.open:
    with fig4:
        if source == HUMAN:
            st.markdown("The paper did not rerun the study with each method: it adapted each one from the same "
                        "daily interactions and scored it on states generated from the described preferences.")
            key = f"compare:{db}:{study}"
            job = ui.job_progress(key, stoppable=True, when_stopped="the runs recorded so far are kept, and comparing "
                                                                    "again goes on from where it stopped.")
            if job is None or not job.running:
                if st.button("Compare methods on this study's data", icon=":material/compare_arrows:",
                             help="Adapts CACAS w/o PR, ORL and NN (and CACAS, for a participant adapted with "
                                  "another method) day by day from each participant's interactions, where a day has no "
                                  "run yet (in the background, participants side by side, one worker process per "
                                  "core; a few seconds per participant, method and day)."):
                    RUNNER.start(key, compare_methods, db, study=study, jobs=default_jobs(), label="Comparing methods")
                    st.rerun()
                if job is not None and job.status == FAILED:
                    st.error(f"The comparison failed: {job.error}")
                elif job is not None and job.status == DONE:  # said, not only drawn: a figure may change little
                    said = app_support.comparison_done(job.result, job.elapsed, job.finished)
                    if job.result.participants == 0:  # nothing there was to compare
                        st.info(said, icon=":material/info:")
                    else:
                        st.success(said, icon=":material/check_circle:")
        # Fig. 4 is daily.csv's, whatever the source: the day a policy was in force (re-plotting the export
        # draws the same figure); policies adapted for a day not started yet are listed below it
        accuracy, by_pref = shown, tables.get("by_preference")
        summary = plots.accuracy_table(accuracy)
        if summary.empty:
            st.info("No preference accuracy yet: it is computed after an adaptation, for participants who "
                    "described preferences.")
        else:
            ui.chart(plots.methods_figure(accuracy), width="stretch")
            st.dataframe(100 * summary, width="stretch", placeholder="–",  # "–": a method without a score that day
                         column_config={"_index": st.column_config.TextColumn("method", width="medium"),
                                        **{day: st.column_config.NumberColumn(format="%.0f%%") for day in summary}})
            left = plots.incomplete_comparisons(accuracy)
            st.caption(plots.METHODS_CAPTION + app_support.left_out_note(left, again=source == HUMAN)
                       + (app_support.uncompared_note(accuracy) if source == HUMAN else ""))
        ahead = next_day_accuracy(tables) if source == HUMAN else []
        if len(ahead):
            st.markdown("**Adapted for the next day, not started yet**")
            st.dataframe(app_support.next_day_view(ahead), hide_index=True, width="stretch")
            st.caption("Each method's policy adapted after the participant's last day, scored as in Fig. 4; \"in "
                       "force\" marks the policy the robot will use (after a roll-back, an earlier one). Fig. 4 and "
                       "daily.csv take these in once the day has begun.")
        if not summary.empty and by_pref is not None and len(by_pref):
            st.header("Which preferences each method learnt", anchor=False)
            ui.preference_heatmaps(by_pref, key=f"results-prefs:{source}",  # each source's own day and method
                                   file_name=table_file_name("by_preference"))

def _remove_latest_answer(who: str) -> None:
    """Remove ``who``'s latest questionnaire answer (the store checks the typed code)."""
    s = st.session_state
    try:
        score = ui.store().remove_questionnaire_answer(who, s.get("quest-remove-confirm", ""))
    except CacasError as exc:
        s["quest-remove-error"] = str(exc)
        return
    s.pop("quest-remove-error", None)
    s["quest-remove-confirm"] = ""
    st.toast(f"Removed {who}'s latest answer ({score}).", icon=":material/delete:")


def _remove_an_answer(answers: pd.DataFrame) -> None:
    """An answer saved for the wrong participant, or by mistake: the participant's latest answer (the
    one the summary counts) is removed once their code is typed; the event log keeps what it was."""
    with st.expander("Remove an answer saved by mistake"):
        latest = answers.drop_duplicates("participant", keep="last")
        said = {r.participant: f"{r.participant}: {r.satisfaction}, saved {app_support.short_time(r.created_at)}"
                for r in latest.itertuples()}
        codes = list(said)
        who = st.selectbox("Latest answer of", codes, format_func=said.get, key="quest-remove-who",
                           index=codes.index(ui.participant()) if ui.participant() in codes else 0)
        typed = st.text_input(f"Type {who} to confirm", key="quest-remove-confirm")
        st.caption("The summary then counts the participant's answer before it, if any. The answer leaves "
                   "questionnaire.csv; the event log (events.csv) keeps its score and when it was saved.")
        ui.button(st, "Remove this answer", _remove_latest_answer, args=(who,), icon=":material/delete:",
                  disabled=typed.strip() != who)
        if st.session_state.get("quest-remove-error"):
            st.error(st.session_state["quest-remove-error"], icon=":material/error:")


with quest:
    if source != HUMAN:
        st.info(("Simulated participants answer no questionnaire. " if source != UPLOAD else
                 "The questionnaire is recorded in the study database, not in uploaded tables. ")
                + f"Study **{study}**'s answers, and the form to record one, are under \"Human study (this "
                "database)\" above.", icon=":material/info:")
    else:
        st.markdown("*\"What is your satisfaction level regarding the robot's ability to adapt to your "
                    "preferences?\"* 1 = very dissatisfied, 10 = very satisfied (Section V-B.1).")
        answers = store.questionnaire_frame(study)
        s = app_support.questionnaire_summary(answers)
        row = ui.metric_row()
        row.metric("Answers", s["n"])
        row.metric("Mean", "–" if pd.isna(s["mean"]) else f"{s['mean']:.2f}")
        row.metric("SD", "–" if pd.isna(s["sd"]) else f"{s['sd']:.2f}")
        row.metric("Rated 8 or higher", ui.percent(s["share_8_or_more"]))
        early = s["mid_study"]
        st.caption("Latest answer per participant; sample standard deviation. The paper: mean 8.125, SD 0.64, "
                   "87.5% at 8 or higher, asked after the 7 days."
                   + (f" Counted here though given before their day {STUDY_DAYS}: {', '.join(early)} (questionnaire.csv's "
                      "day says when)." if early else ""))
        codes = [p.code for p in store.list_participants(study)]
        if codes:
            # a refused answer keeps what was entered; a saved one empties the form (new widget keys)
            entry = st.session_state.setdefault("quest-entry", 0)
            with st.form("questionnaire", border=True):
                who = st.selectbox("Participant", codes,
                                   index=codes.index(ui.participant()) if ui.participant() in codes else 0)
                # no preset score: an answer is the participant's choice, never a default saved by accident
                score = st.segmented_control("Satisfaction (1 = very dissatisfied, 10 = very satisfied)",
                                             list(range(1, 11)), default=None, key=f"quest-score-{entry}")
                comments = st.text_area("Comments (optional; no names)", key=f"quest-comments-{entry}")
                refused = st.empty()
                if st.form_submit_button("Save answer", icon=":material/save:"):
                    try:
                        if score is None:
                            raise CacasError("choose the participant's score, from 1 (very dissatisfied) to 10 "
                                             "(very satisfied)")
                        store.record_questionnaire(who, score, comments)
                    except CacasError as exc:
                        refused.error(str(exc), icon=":material/error:")
                    else:
                        note = questionnaire_timing(day_status(store, who))
                        earlier = answers.loc[answers["participant"] == who, "satisfaction"]
                        if len(earlier):  # each save adds a row; the summary counts the latest
                            note += (f"{' ' if note else ''}It replaces {who}'s earlier answer ({earlier.iloc[-1]}) "
                                     "in the summary; questionnaire.csv keeps both.")
                        # on the page until the next run: a toast of ~25 words left in ~4 s (accessibility walkthrough)
                        st.session_state["quest-saved"] = f"Saved {who}'s answer ({score}).{' ' + note if note else ''}"
                        st.session_state["quest-entry"] = entry + 1
                        st.rerun()
            if saved := st.session_state.pop("quest-saved", None):
                st.success(saved, icon=":material/check_circle:")
        if len(answers):
            st.dataframe(answers.assign(created_at=[app_support.short_time(t) for t in answers["created_at"]])
                         .rename(columns={"created_at": "saved"}), hide_index=True, width="stretch")
            ui.download_csv(lambda: ui.store().questionnaire_frame(study),  # as at the click
                            table_file_name("questionnaire"), "Download questionnaire.csv", key="dl-questionnaire.csv")
            _remove_an_answer(answers)

with data:
    st.markdown("Long-format tables, the same columns as `cacas simulate` and `cacas export` write.")
    for name, df in tables.items():
        if name in ("events", "policies", "studies", "preferences", "days") and source == HUMAN:
            continue
        # a closed table's rows are not sent to the browser: opening it reruns the page and draws it (a 24 x 7
        # study's interactions, adaptations and by_preference tables were 3.4 MB on every load of the page)
        with st.expander(f"{name}.csv · {len(df)} row{'s' if len(df) != 1 else ''}", expanded=name == "daily",
                         key=f"results-table-{name}", on_change="rerun") as table:
            if table.open is not False:
                st.dataframe(df, hide_index=True, width="stretch", height=min(400, 38 + 35 * len(df)),
                             placeholder="")  # an empty cell as the CSV holds it, not "None"
            # the study's tables as the database holds them at the click (a participant removed since the page
            # was drawn is not in them); a simulated or uploaded run's as shown
            ui.download_csv((lambda name=name: export_tables(ui.store(), study)[name]) if source == HUMAN else df,
                            table_file_name(name), f"Download {name}.csv", key=f"dl-table-{name}")
    if source.startswith("Simulated run: "):  # as the Simulation lab offers it
        ui.run_zip_button(db, source.removeprefix("Simulated run: "), key="results-dl-run-zip")
    # the zip only while the tab is open: whether it can be made reads every policy file once a server's life (its
    # sha256; 790 MB and 2.5 s of the page's first run for 60 participants x 21 days, wherever the page opened)
    if source == HUMAN and data.open:
        def _bundle() -> bytes:  # made in memory: no copy of the study left on disk by a server killed meanwhile
            return bundle_bytes(ui.store(), study)

        missing, damaged = store.missing_policy_files(study), store.damaged_policy_files(study)
        if missing or damaged:
            said = [f"{app_support.counted(len(found), 'policy file')} {how[len(found) == 1]} "
                    f"({', '.join(found[:3])}{', ...' if len(found) > 3 else ''})"
                    for found, how in ((missing, (f"are missing from `{store.policy_dir}`",
                                                  f"is missing from `{store.policy_dir}`")),
                                       (damaged, ("do not match their recorded sha256 (changed or damaged)",
                                                  "does not match its recorded sha256 (changed or damaged)"))) if found]
            one = len(missing) + len(damaged) == 1
            st.warning(f"No zip: {' and '.join(said)}, and the zip must hold every one to be imported. Restore "
                       f"{'it' if one else 'them'} from a backup; the tables above download one by one.",
                       icon=":material/warning:")
        else:
            note = app_support.bundle_note(tables["policies"], db, study)
            if note:
                st.caption(note)
            st.download_button("Download everything (zip of every table and policy file)", _bundle,
                               file_name=app_support.study_file_name("cacas-study", study, ".zip"),
                               mime="application/zip", icon=":material/folder_zip:",
                               on_click="ignore")  # a rerun would drop the other buttons' prepared files
