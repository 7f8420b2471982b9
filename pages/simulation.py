"""Simulation lab: run the study with simulated participants first, to tune and to compare methods
(design.md; the same as ``cacas simulate``)."""

from __future__ import annotations

import streamlit as st

from cacas import app_support, plots, records, saved_runs
from cacas.errors import CacasError, one_a_line
from cacas.experiment import LOOPS, METHODS, summary_table
from cacas.jobs import DONE, FAILED, RUNNER
from cacas.paths import study_data_dir
from cacas.preferences import load_personas
from pages import ui

ui.require_app()

store = ui.store()
study = ui.study()
db = ui.db_path()
JOB = f"simulate:{db}"

st.title("Simulation lab", anchor=False)
st.caption("Simulated participants act in the contexts their preferences cover, accept the preferred action, "
           "reject others, sometimes do not respond, and ask for the preferred action when the robot does "
           "nothing. Day 1 uses the initial policy; after each day every method adapts from the same "
           "interactions (Fig. 4), or, if you choose, each method acts and adapts in a study of its own.")

# --- the researcher's choices, kept for the session ----------------------------------------------------
# Streamlit drops a widget's state while its page is not drawn: after a visit to another page the form showed
# its defaults again (8 participants x 7 days x 4 methods), and a second click on Run started that long study.
# The choices are kept under a key of the page's own and given back to the widgets (by their keys) when
# Streamlit has dropped them; a run's choices are what the form shows while it runs, also in another tab.
s = st.session_state
KEPT = "sim-kept"  # widget key -> the value the researcher chose; "sim-upload": the persona file uploaded
kept = s.setdefault(KEPT, {})
EXAMPLES = {"Example personas (P01-P08)": "example.json",
            "The same, each with a 'leave me alone' preference (Q01-Q08)": "example_leave_me_alone.json"}
SOURCES = [*EXAMPLES, "Upload a persona file", "This study's participants"]
LOOP_LABELS = {"first": "the first method; all adapt from its interactions (Fig. 4)",
               "each": "each method, in a study of its own"}
# the form starts from `cacas simulate`'s defaults (records.SIMULATION_DEFAULTS)
DEFAULTS = {"sim-source": SOURCES[0], **{key: records.SIMULATION_DEFAULTS[name] for key, name in (
    ("sim-days", "days"), ("sim-per-day", "interactions"), ("sim-seed", "seed"), ("sim-silent", "no_response_rate"),
    ("sim-ask", "ask_after_reject"), ("sim-loop", "loop"))}, "sim-methods": list(records.SIMULATION_DEFAULTS["methods"])}

job = RUNNER.get(JOB)
running = job is not None and job.running
if running and job.details and s.get("sim-form-run") != job.started:  # once: then the form is the researcher's
    s["sim-form-run"] = job.started
    kept.update(job.details)
    s.update(job.details)
for key, default in DEFAULTS.items():
    if key not in s:
        s[key] = kept.get(key, default)

# --- personas -----------------------------------------------------------------------------------------
choice = st.radio("Personas", SOURCES, horizontal=True, key="sim-source",
                  help="Q01-Q08 are P01-P08 with one more preference: a context where the robot should do nothing.")
people, problem, source = [], None, None
try:
    if choice in EXAMPLES:
        people = load_personas(study_data_dir() / "personas" / EXAMPLES[choice])
        source = saved_runs.persona_source(choice, EXAMPLES[choice])
    elif choice.startswith("Upload"):
        drawn_before = "sim-upload" in s  # else it was not drawn (another page or source) and forgot its file
        up = st.file_uploader("Persona file (.json, the format of docs/personas.md)", type=["json"], key="sim-upload")
        if up is not None:
            kept["sim-upload"] = (up.name, up.getvalue())
        elif drawn_before and s.get("sim-upload-held"):  # it held a file in the last run: the researcher removed it
            kept.pop("sim-upload", None)
        s["sim-upload-held"] = up is not None
        if up is None and kept.get("sim-upload"):
            ui.noted("attach_file", f"{kept['sim-upload'][0]}, uploaded before in this browser tab. "
                                    "Upload another file to replace it.")
        if kept.get("sim-upload"):
            name, data = kept["sim-upload"]
            people = saved_runs.uploaded_personas(name, data)
            source = saved_runs.persona_source(choice, name, data)
    else:
        # without their own words: the run's files (by_preference.csv's labels) stay after a participant's removal;
        # in the exact code's order, their places (random streams) as before the list read case-blind
        people = [p.without_words() for p in (store.get_preferences(c.code) for c in
                                              sorted(store.list_participants(study), key=lambda c: c.code))
                  if p is not None]
        source = saved_runs.persona_source(choice, study=study)
        if not people:
            problem = "No participant of this study has described preferences yet."
except CacasError as exc:
    problem = one_a_line(exc)  # an uploaded persona file's problems one a line
if problem:
    st.error(problem, icon=":material/error:")

by_id = {p.id: p for p in people}
place = {c: i for i, c in enumerate(by_id)}  # a participant's place: their random stream in the run
# offered as the sidebar lists a study's participants (case-blind by code); a file's, in the file's order
listed = records.by_code(by_id) if choice == SOURCES[-1] else list(by_id)
who = f"sim-who:{choice}"  # one choice of participants per persona source
wanted = list(s.get(who, kept.get(who, listed)))
offered = f"{who}:offered"  # the participants the choice was made among: one added to the study since is chosen,
wanted += [c for c in listed if c not in kept.get(offered, by_id) and c not in wanted]  # as all are at first
valid = [c for c in wanted if c in by_id] or ([] if not wanted else listed)  # none left: another file
if s.get(who) != valid:
    s[who] = valid
with st.form("simulation", border=True, enter_to_submit=False):  # a run starts only on its button
    chosen = st.multiselect("Simulated participants", listed, key=who,
                            help="Each follows their described preferences.")
    c1, c2, c3, c4, c5 = st.columns(5)
    # no bounds on the inputs: a value out of range is named by the check under the button (an input's
    # own bound showed only a red mark, and the button did nothing)
    days = c1.number_input("Days", step=1, key="sim-days")
    per_day = c2.number_input("Interactions a day", step=1, key="sim-per-day",
                              help="On average: each simulated day draws its number around this (Poisson), as "
                                   "people's days differ; the paper's ~15.")
    seed = c3.number_input("Seed", step=1, key="sim-seed", help="The same seed gives the same tables.")
    silent = c4.number_input("No-response rate", step=0.05, key="sim-silent")
    ask_rate = c5.number_input("Ask after a rejection", step=0.1, key="sim-ask",
                               help="Share of wrong proposals the simulated participant answers by asking for what "
                                    "they want instead, as the tablet allows. 0: they ask only when the robot does "
                                    "nothing (design.md).")
    # named as the figures and the run's caption name them ('cacas-no-pr' beside 'CACAS w/o PR': figs)
    methods = st.multiselect("Methods", METHODS, key="sim-methods", format_func=plots.METHOD_LABELS.get,
                             help="By default the first method runs in closed loop (its success rate is Fig. 3) "
                                  "and all of them adapt from the same interactions (Fig. 4); see 'Who acts'. "
                                  "`cacas simulate --methods` takes them as " + ", ".join(METHODS) + ".")
    loop = st.radio("Who acts with the participants", LOOPS, horizontal=True, format_func=LOOP_LABELS.get,
                    key="sim-loop",
                    help="The paper adapted its baselines from the day-by-day interactions with CACAS (Fig. 4). "
                         "With 'each method', every method runs a study of its own and has its own success rate: "
                         "how it would do as the robot's policy.")
    st.caption("Every participant, method and day but the last is one adaptation, a few seconds on a laptop CPU "
               "(8 participants x 7 days x 4 methods: about three minutes on two cores; participants run side by "
               "side, one process per core, as in `cacas simulate`).")
    go = st.form_submit_button("Run simulation", type="primary", icon=":material/play_arrow:", disabled=running)
choices = {key: s[key] for key in (*DEFAULTS, who)}
kept.update(choices, **{offered: list(by_id)})
if go:
    try:
        saved_runs.check_simulation(chosen, methods, int(days), int(per_day), int(seed), float(silent),
                                     float(ask_rate))
    except CacasError as exc:  # every problem of the form, one a line
        lines = str(exc).splitlines()
        st.error(lines[0] if len(lines) == 1 else "\n".join(f"- {line}" for line in lines), icon=":material/error:")
    else:
        _, started = RUNNER.start(JOB, saved_runs.run_simulation, [by_id[c] for c in chosen],
                                  saved_runs.runs_dir(db), days=int(days), interactions=int(per_day),
                                  methods=tuple(methods), seed=int(seed), no_response_rate=float(silent),
                                  ask_after_reject=float(ask_rate), loop=loop, personas=source, details=choices,
                                  places=[place[c] for c in chosen],
                                  label=f"Simulating {', '.join(chosen)} · {int(days)} days · "
                                        f"{plots.method_names(methods)} · seed {int(seed)}")
        if not started:
            st.warning("A simulation is already running.")
        else:  # said once the page is drawn again (a toast before st.rerun is not shown)
            s["sim-started"] = True
        st.rerun()

if s.pop("sim-started", False):
    # the progress bar and its Stop button are under the form: at 1280 x 800 below the fold, and the click
    # seemed to do nothing but grey out the button (walkthrough)
    st.toast("Simulation started: its progress, and a Stop button, are under the form.", icon=":material/play_arrow:")
job = ui.job_progress(JOB, stoppable=True)
if job is not None and job.status == FAILED:
    st.error(f"The simulation failed: {job.error}", icon=":material/error:")

# --- results of a run ---------------------------------------------------------------------------------
runs_root = saved_runs.runs_dir(db)
runs = saved_runs.list_runs(runs_root)
if runs:
    st.header("Runs", anchor=False)
    finished = job.result.name if job is not None and job.status == DONE and job.result.name in runs else None
    if finished and st.session_state.get("sim-shown") != finished:  # a run that just ended is shown once
        st.session_state["sim-run"] = st.session_state["sim-shown"] = finished
    if st.session_state.get("sim-run") not in runs:
        st.session_state["sim-run"] = runs[0]
    name = st.selectbox("Run", runs, key="sim-run", format_func=lambda r: saved_runs.run_label(runs_root, r))
    run = ui.load_run(db, name)
    daily, settings = run.daily, run.settings
    if settings:
        st.caption(saved_runs.run_caption(settings))
    c1, c2 = st.columns(2)
    one = None if len(plots.closed_loop_methods(daily)) > 1 else plots.loop_method(daily) or daily["method"].iloc[0]
    fig3 = plots.success_methods_figure(daily) if one is None else plots.success_figure(daily, method=one)
    fig3, fig4 = plots.side_by_side(fig3, plots.methods_figure(daily))  # their plot areas at one height
    ui.chart(fig3, c1, width="stretch")
    ui.chart(fig4, c2, width="stretch")
    if few := plots.few_interactions_note(daily, one):  # Fig. 3's hollow points (one None: Fig. 3 by method's)
        c1.caption(few)
    # in the paper's order, as Fig. 4 and the Results page list them (daily.csv's is the order chosen)
    summary = records.sort_by_method(summary_table(daily), ["method", "day"])
    shares = [c for c in ("success_rate", "success_ceiling", "preference_accuracy") if c in summary.columns]
    # "–" where a method has no success rate (it did not act: the Fig. 4 protocol)
    shown = summary.assign(method=summary["method"].map(lambda m: plots.METHOD_LABELS.get(m, m)),
                           **{c: 100 * summary[c] for c in shares})
    share = {"format": "%.0f%%"}
    st.dataframe(shown, hide_index=True, width="stretch", placeholder="–",
                 column_config={"success_rate": st.column_config.NumberColumn("success rate", **share),
                                "success_ceiling": st.column_config.NumberColumn(
                                    "success ceiling", **share,
                                    help="The share of the recorded interactions where a described preference "
                                         "names an action (Fig. 3's dashed line). Not a bound: elsewhere the "
                                         "simulated participant answers by the D4A pairs and may still accept."),
                                "preference_accuracy": st.column_config.NumberColumn("preference accuracy", **share),
                                "cumulative_feedback": st.column_config.NumberColumn(
                                    "cumulative feedback", format="%.1f",
                                    help="User data points collected up to the day's end (mean over the "
                                         "participants). A method with no success rate ('–') did not interact: "
                                         "it adapted from the interactions of the first method, so it shows "
                                         "that method's count.")})
    d1, d2, d3 = st.columns(3)
    # named after the run's folder, as Results names them (two runs' "daily.csv" met in a Downloads folder)
    for where, table, df, key in ((d1, "daily", daily, "sim-dl-daily"), (d2, "interactions", run.interactions,
                                                                         "sim-dl-inter"),
                                  (d3, "summary", summary, "sim-dl-summary")):
        with where:
            ui.download_csv(df, app_support.run_file_name(table, name, ".csv"), f"Download {table}.csv", key=key)
    # the whole folder, with its settings and checksums.sha256 (the Results upload checks the tables by it)
    ui.run_zip_button(db, name, key="sim-dl-zip")
    if run.by_preference is not None:
        st.header("Which preferences each method learnt", anchor=False)
        # keyed by run: one key for every run kept the day picked (or last shown) for the run before, so a 7-day
        # run that ended after a 2-day one opened on day 2 (walkthrough); the Results page keys it by run too
        ui.preference_heatmaps(run.by_preference, key=f"sim-prefs:{name}",
                               file_name=app_support.run_file_name("by_preference", name, ".csv"))
