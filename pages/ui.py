"""Streamlit pieces shared by the pages: the study database, the selected participant, downloads,
background-job progress. Layout only; everything that computes or stores is in ``cacas``."""

from __future__ import annotations

import html
import sqlite3
import threading
import time

import pandas as pd
import streamlit as st

from cacas import app_support, lab, plots, records, saved_runs
from cacas.errors import CacasError
from cacas.jobs import RUNNER, STOPPED, Job
from cacas.on_tablet import TabletBoard
from cacas.store import StudyStore, default_db_path
from cacas.study_day import day_status

#: Whether this script thread's run went through ``app.py``'s navigation (:func:`routed`), read once
#: by :func:`require_app`.
_ROUTED = threading.local()


def routed() -> None:
    """``app.py``, just before it runs the page: this run is the app's, with its sidebar and the
    participant from the address."""
    _ROUTED.run = True


def require_app() -> None:
    """Run this page through ``app.py``. Streamlit treats a ``pages/`` folder as old-style pages
    until the first ``st.navigation`` call of a server process, so a first request straight to
    e.g. ``/results`` after a restart would run the page alone (no sidebar, no participant from
    the address). Then switch the old mode off and rerun: ``app.py`` runs and routes to the same
    page. Called first thing by every page. Whether this run is the app's is known from
    :func:`routed`, not from the old mode's flag, which is the server's: two pages reconnecting to a
    restarted server at once (a page with a fragment that reruns by itself asks for a run on
    reconnecting) both started alone, the first switched the flag off, and the second, reading it
    off, went on alone: "Select a participant in the sidebar" under an address naming one."""
    from streamlit.runtime.pages_manager import PagesManager

    was_routed, _ROUTED.run = getattr(_ROUTED, "run", False), False
    if not was_routed:
        PagesManager.uses_pages_directory = False
        st.rerun()


def icon(name: str, says: str | None = None) -> str:
    """A Material icon for ``st.markdown(..., unsafe_allow_html=True)`` that a screen reader reads as ``says``,
    or skips when None (a decoration beside words that say it). Streamlit names a ``:material/check:`` in text
    after its ligature: the tablet's heading was read "smart_toy icon Hello, P01", and the robot's recognition
    "The robot heard: cough check icon", where the mark means "as chosen" (accessibility walkthrough)."""
    hidden = f'<span aria-hidden="true">:material/{name}:</span>'
    return hidden if says is None else f'<span role="img" aria-label="{html.escape(says)}">{hidden}</span>'


def noted(icon_name: str, text: str, where=None, caption: bool = True) -> None:
    """``text`` (markdown) as a caption (or, ``caption=False``, markdown) after a decorative Material icon that a
    screen reader skips (:func:`icon`): ":material/info: ..." in text was read "info icon ...", before every such
    note (accessibility walkthrough). The HTML this needs is allowed for the icon only: ``text``'s "&", "<" and ">"
    are escaped, so a file name or a participant's words in it stay words."""
    safe = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    draw = (where or st).caption if caption else (where or st).markdown
    draw(f"{icon(icon_name)} {safe}", unsafe_allow_html=True)


PARTICIPANT_KEY = "participant"
STUDY_KEY = "study"
#: participant code -> whether their preference form (Participants page) holds unsaved changes
UNSAVED_FORMS_KEY = "participants-unsaved"
#: the start of the session keys of the Participants page's preference-form widgets
FORM_KEY_PREFIX = "pf-"


def tablet_address(code: str, url: str | None = None) -> str:
    """The full address of ``code``'s tablet view, from ``url``, the address this browser opened
    the app at (default ``st.context.url``); ``?participant=...&view=tablet`` alone when unknown."""
    query = f"?participant={code}&view=tablet"
    url = (st.context.url if url is None else url) or ""
    base = url.split("?")[0].split("#")[0]
    if "://" in base:  # scheme://host[:port]/ ; the app serves every page from its root
        scheme, rest = base.split("://", 1)
        base = f"{scheme}://{rest.split('/')[0]}/"
        return base + query
    return query


def tablet_address_note(code: str) -> None:
    """The tablet address to copy (st.code has a copy button) and, when the app was opened at
    this machine's own name, that another device needs the network address."""
    address = tablet_address(code)
    st.code(address, language=None)
    if any(h in address for h in ("://localhost", "://127.0.0.1", "://[::1]")):
        # the app listens on this computer only (.streamlit/config.toml), so Streamlit prints no Network URL
        st.caption("That address works on this computer only: the app listens here alone, as study data are "
                   "personal. For the participant's tablet, start it with `streamlit run app.py --server.address "
                   "<this computer's address on the lab network>` and put that address in place of "
                   f"`{address.split('://')[1].split('/')[0]}`.")
    noted("lock_open", "The tablet view hides the researcher's pages; it does not lock them: anyone "
                       "who can reach the app on the network can open every page. Use it on a network you trust.")


def keep_preference_forms() -> None:
    """Streamlit drops the state of the widgets a run does not draw, so opening another page lost
    what was typed on a preference form. Writing each of the forms' values back into the session
    (before any page runs) makes them plain session values that stay until the form is saved or
    discarded. Called by ``app.py`` on every run."""
    s = st.session_state
    for key in [k for k in s if str(k).startswith(FORM_KEY_PREFIX) and not str(k).endswith("-interval")]:
        s[key] = s[key]  # the interval range sliders keep theirs themselves (persist_state="session")


def unsaved_preference_forms() -> list[str]:
    """The participants whose preference form holds changes not saved yet."""
    return records.by_code(code for code, unsaved in st.session_state.get(UNSAVED_FORMS_KEY, {}).items() if unsaved)


@st.cache_resource(show_spinner=False)
def _open_store(path: str) -> StudyStore:
    return StudyStore(path)


def db_path() -> str:
    """The study database: $CACAS_DB, else study_data/cacas.sqlite."""
    return str(default_db_path())


def store() -> StudyStore:
    """The study database, opened once per server process (thread-safe)."""
    return _open_store(db_path())


@st.cache_resource(show_spinner=False)
def tablet_board() -> TabletBoard:
    """What each participant's tablet shows now, shared by this server's sessions (the Study
    session page writes it from the tablet and reads it on the researcher's view; Adaptation
    reads it before a day is closed)."""
    return TabletBoard()


#: Which callback ran for the click of this run (see :func:`button`).
_CALLBACK_RAN = "button-callback-ran"
#: a click whose callback Streamlit did not run: (callback, args, kwargs), run by the next run's start
_MISSED_CLICK = "button-missed-click"


def button(where, label: str, on_click, *, args=(), kwargs=None, key: str | None = None, submit: bool = False,
           **options) -> None:
    """``where.button`` (``where.form_submit_button`` with ``submit``) whose ``on_click`` runs once
    for every click, also for the first click that reaches a session which has not drawn the button
    yet. A server restarted under an open page gives the page a new session at its next click, and
    Streamlit calls a widget's callback only in a session that drew the widget before: the first
    click after a restart was lost without a word. Here the click, seen in the button's value, is
    kept, and the page runs again, calling it first thing (``run_missed_click``, from ``app.py``):
    where Streamlit calls callbacks, before any widget is drawn, so that a callback may still set
    the sidebar's participant or the page's open tab."""
    kwargs = kwargs or {}
    key = key or f"button:{label}"

    def callback(*a, **k):
        st.session_state[_CALLBACK_RAN] = key
        _run_click(on_click, a, k)

    draw = where.form_submit_button if submit else where.button
    if draw(label, key=key, on_click=callback, args=args, kwargs=kwargs, **options) \
            and st.session_state.pop(_CALLBACK_RAN, None) != key:
        st.session_state[_MISSED_CLICK] = (on_click, args, kwargs)
        st.rerun()  # a rerun keeps the widgets' values, those drawn after this button too


def run_missed_click() -> None:
    """Call the callback of a click that Streamlit did not call (``button``); first thing in a run."""
    missed = st.session_state.pop(_MISSED_CLICK, None)
    if missed is not None:
        on_click, args, kwargs = missed
        _run_click(on_click, args, kwargs)


#: Where a click that met a busy or unreadable study database leaves its message for the page (:func:`_run_click`).
_CLICK_NOT_DONE = "button-click-not-done"


def _run_click(on_click, args, kwargs) -> None:
    """Call a button's callback. The study database held by another program past the busy timeout,
    or a disk that refuses a read or a write, is said at the top of the page (:func:`click_not_done`)
    rather than as a traceback: Streamlit runs callbacks before the page, out of reach of
    ``app.main``'s handler (safety audit: a tablet's answer met a locked read so). The store writes in
    transactions, so nothing of the click is half-saved; other errors are raised as before."""
    from cacas.store.db import disk_trouble, is_busy

    try:
        on_click(*args, **kwargs)
    except sqlite3.OperationalError as exc:
        if is_busy(exc):
            why = f"the study database was busy ({exc}): another program held it for more than 10 s"
        elif disk_trouble(exc):
            why = f"the study database could not be read or written on the disk ({exc}): it may be full or failing"
        else:
            raise
        st.session_state[_CLICK_NOT_DONE] = (f"That tap or click was not carried out: {why}. Nothing of it was "
                                             "saved; try it again in a moment.")


def click_not_done() -> None:
    """Say, at the top of the page, that the last click was not carried out (:func:`_run_click`)."""
    said = st.session_state.pop(_CLICK_NOT_DONE, None)
    if said:
        st.warning(said, icon=":material/hourglass_empty:")


def participant() -> str | None:
    """The participant selected in the sidebar (or fixed by the tablet address)."""
    return st.session_state.get(PARTICIPANT_KEY)


def select_participant(code: str | None) -> None:
    """Select ``code`` (None: none) in the sidebar and the address, from a callback (before the
    sidebar is drawn); the day and proposal in the address belonged to the previous participant.
    The new participant's day goes in with them, in the same change of address (the page's own
    writing of the address then changes nothing: one entry in the browser's history)."""
    st.session_state[PARTICIPANT_KEY] = code
    try:
        day = str(day_status(store(), code).day_on_screen) if code else None
    except CacasError:  # not (or no longer) in the database: the page's run settles it
        day = None
    set_address(participant=code or None, day=day, ctx=None, at=None)


def set_address(**params: str | None) -> None:
    """Change the address's query parameters (a value of None removes one) in one message to the
    browser, and only when something changes: each message the browser takes as a new address
    pushes an entry into its history, and writing the participant, day and study one at a time
    on every run made the researcher press Back three or four times to leave a page
    (walkthrough)."""
    qp = st.query_params
    now = qp.to_dict()
    wanted = {k: v for k, v in now.items() if k not in params}
    wanted.update({k: str(v) for k, v in params.items() if v is not None})
    if wanted != now:
        qp.from_dict(wanted)


def study() -> str | None:
    return st.session_state.get(STUDY_KEY)


def tablet_mode() -> bool:
    return st.query_params.get("view") == "tablet"


def need_participant() -> str:
    """The selected participant, or a message and stop."""
    code = participant()
    if not code:
        st.info("Select a participant in the sidebar, or add one on the **Participants** page.")
        st.stop()
    return code


#: The query parameters a link to another researcher's page carries (Streamlit clears the address
#: on a page change; writing it again would push a second entry into the browser's history).
CARRIED = ("participant", "day", "study")


def carried() -> dict[str, str]:
    """The address's participant, day and study, for a link to another page."""
    qp = st.query_params
    return {k: qp[k] for k in CARRIED if k in qp}


def link(page: str, label: str, icon: str | None = None, container=None) -> None:
    """A link to another page of the app, carrying the participant, day and study (left out if that
    page is not in the navigation)."""
    try:
        (container or st).page_link(page, label=label, icon=icon, query_params=carried())
    except st.errors.StreamlitPageNotFoundError:
        pass


def model_stamp(kind: str) -> float | None:
    """The saved sound or scene model's file time (None: no model, or it cannot be read)."""
    try:
        return lab.model_stamp(kind)
    except (CacasError, OSError):
        return None


#: The saved models :func:`_saved_recognizer` keeps, the latest used: the sound and the scene model in use. Keyed by
#: the file's time, it kept every model a page had loaded until the server stopped, one more each training (the
#: scene model, a ResNet-18, is 43 MB in memory).
RECOGNIZERS_KEPT = 2


@st.cache_resource(show_spinner=False, max_entries=RECOGNIZERS_KEPT)
def _saved_recognizer(kind: str, stamp: float):
    return lab.load_recognizer(kind)


#: The policies :func:`policy_version` keeps at a time, the latest used: a participant's every study day adds a
#: version, and every version a tablet had used stayed in the server's memory (~1.7 MB each: 56 after 8 participants
#: x 7 days, 336 for 24 x 14; ``scripts/bench_long_run.py``). 32 tablets' policies in force fit, or the Adaptation
#: page's versions beside them; one dropped is read again when next used (~35 ms).
POLICIES_KEPT = 32


@st.cache_resource(show_spinner=False, max_entries=POLICIES_KEPT)
def policy_version(db: str, who: str, version: int | None, sha256: str | None):
    """(policy, version): the participant's policy ``version`` (None: the initial policy), for the tablet's
    proposals (Study session) and the Adaptation page's comparison of two versions alike: one cache, so a version
    both use is in memory once (each page kept its own, 32 each: up to 64 policies, ~110 MB, the long-run
    benchmark's count). The checkpoint's sha256 is part of the key (a code given to a new participant after a
    removal starts again at version 1). The latest :data:`POLICIES_KEPT` used are kept."""
    from cacas.study_day import policy_of_version

    return policy_of_version(store(), who, version)


def recognizer(kind: str):
    """The saved sound or scene model, loaded once per file version (reloaded when retrained),
    or None when there is none or it cannot be read. The replaced version is dropped from memory
    (:data:`RECOGNIZERS_KEPT`)."""
    stamp = model_stamp(kind)
    if stamp is None:
        return None
    try:
        return _saved_recognizer(kind, stamp)
    except (CacasError, OSError):
        return None


def load_run(db: str, name: str) -> saved_runs.Run:
    """A saved simulated run of the Simulation lab, or its error shown and the page stopped."""
    try:
        return saved_runs.load_run(saved_runs.runs_dir(db) / name)
    except CacasError as exc:
        st.error(str(exc), icon=":material/error:")
        st.stop()


def download_csv(df, file_name: str, label: str | None = None, key: str | None = None) -> None:
    """A download button for ``df`` as ``records.csv_bytes`` makes it. The CSV is written when the
    button is clicked, not on every run of the page (Streamlit's deferred download: the Results page
    of a 24 x 7 study wrote its 8 tables' CSVs, a quarter of its run, on every rerun). ``df`` may be
    a function that reads the frame then: the study database's tables as they are at the click (a
    page drawn before a participant's removal downloaded their rows)."""
    st.download_button(label or f"Download {file_name}", lambda: records.csv_bytes(df() if callable(df) else df),
                       file_name=file_name,
                       mime="text/csv", key=key or f"dl-{file_name}", icon=":material/download:",
                       on_click="ignore")  # no rerun: a download right after another one found its file gone


def run_zip_button(db: str, name: str, key: str) -> None:
    """"Download the whole run (zip of its folder)": the Simulation lab's run ``name`` with its
    settings.json and checksums.sha256 (:func:`cacas.saved_runs.run_zip`, made at the click), named as
    its folder; the Results page's upload takes it as it is."""
    st.download_button("Download the whole run (zip of its folder)",
                       lambda: saved_runs.run_zip(saved_runs.runs_dir(db) / name),
                       file_name=app_support.run_file_name("cacas-run", name, ".zip"), mime="application/zip",
                       key=key, icon=":material/folder_zip:", on_click="ignore")


def metric_row():
    """A row for ``st.metric``s side by side (``row.metric(...)``): on a narrow page (800 px beside
    the sidebar) a metric that does not fit goes on to the next line whole. In ``st.columns``
    each had a quarter or a third of the width, and its label and value were cut ("Interaction…",
    "9.7 dat…")."""
    return st.container(horizontal=True, gap="small")


#: A share as a whole percentage (halves rounded up), "–" for none.
percent = app_support.percent


#: What a stopped job leaves, for work that saves only at its end (trainers, simulations).
NOTHING_SAVED = "nothing was saved."


def job_progress(key: str, stoppable: bool = False, when_stopped: str = NOTHING_SAVED) -> Job | None:
    """Show a background job's progress bar and log (and, if ``stoppable``, a Stop button);
    rerun the page when it ends. A stopped job shows ``when_stopped``: what it left behind.

    Returns the job (running or ended) or None if there is none under ``key``.
    """
    job = RUNNER.get(key)
    if job is None:
        return None
    if job.running:
        _job_fragment(key, stoppable, when_stopped)
    elif job.status == STOPPED:
        st.info(f"{job.label} was stopped after {job.elapsed:.0f} s; {when_stopped}", icon=":material/stop_circle:")
    return job


@st.fragment(run_every=0.5)
def _job_fragment(key: str, stoppable: bool = False, when_stopped: str = NOTHING_SAVED) -> None:
    job = RUNNER.get(key)
    if job is None:
        return
    snap = job.snapshot()
    st.progress(snap["fraction"], text=f"{snap['label']}: {snap['message'] or 'starting'} "
                                       f"({snap['elapsed']:.0f} s"
                                       f"{app_support.time_left(snap['elapsed'], snap['fraction'], snap['first_step'])})")
    if stoppable and job.running:
        st.button("Stopping..." if job.stopping else "Stop", key=f"stop-{key}", icon=":material/stop:",
                  disabled=job.stopping, on_click=RUNNER.stop, args=(key,),
                  help=f"Stops at the next progress step; {when_stopped}")
    if snap["log"]:
        with st.expander("Log", expanded=False):
            st.code("\n".join(snap["log"][-30:]), language=None)
    if not job.running:
        time.sleep(0.05)
        st.rerun(scope="app")


def on_a_phone() -> bool:
    """Whether this page is drawn for a phone (its browser's User-Agent: :func:`cacas.app_support.is_phone`)."""
    return app_support.is_phone(st.context.headers.get("User-Agent"))


def chart(fig, where=None, **options) -> None:
    """``st.plotly_chart`` (in ``where``, default the page) with a description a screen reader reads
    (:func:`cacas.plots.describe`): without one a chart was read as its tick labels run together."""
    (where or st).plotly_chart(fig, alt=plots.describe(fig), **options)


#: Participants whose preferences the heatmap shows at first (more are chosen in a list).
HEATMAP_PARTICIPANTS = 8


def preference_heatmaps(by_preference: pd.DataFrame, key: str, file_name: str = "by_preference.csv") -> None:
    """Fig. 4 by described preference (``by_preference.csv``): every method side by side on one
    day, or one method day by day; then the table's download (as ``file_name``). The choices are kept while
    the page's tab that holds them is not drawn (Results runs only its open tab)."""
    st.caption(plots.preferences_caption())
    whole = by_preference  # the download is the whole table, whoever is shown
    people = records.by_code(by_preference["participant"].astype(str).unique())
    if len(people) > HEATMAP_PARTICIPANTS:  # a row per preference: 24 participants made 120 rows, 3,300 px
        chosen = st.multiselect("Participants", people, default=people[:HEATMAP_PARTICIPANTS], key=f"{key}-who", persist_state="page",
                                help=f"{len(people)} participants have rows here; the first "
                                     f"{HEATMAP_PARTICIPANTS} are shown at first.")
        if not chosen:
            st.info("Choose at least one participant.")
            download_csv(whole, file_name, "Download by_preference.csv", key=f"{key}-dl")
            return
        by_preference = by_preference[by_preference["participant"].astype(str).isin(chosen)]
    methods = plots.in_method_order(by_preference["method"])
    days = sorted(int(d) for d in by_preference["day"].unique())
    by_method, by_day = "Methods on one day", "One method, day by day"
    view = st.segmented_control("Show", [by_method, by_day], default=by_method, key=f"{key}-view",
                                persist_state="page") or by_method
    if view == by_method:
        day = st.select_slider("Day", days, value=days[-1], key=f"{key}-day", persist_state="page") if len(days) > 1 else days[0]
        fig = plots.preference_methods_figure(by_preference, day, narrow=on_a_phone())
    else:
        method = st.selectbox("Method", methods, key=f"{key}-method", persist_state="page",
                              format_func=lambda m: plots.METHOD_LABELS.get(m, m))
        fig = plots.preference_days_figure(by_preference, method, narrow=on_a_phone())
    if on_a_phone():
        st.caption("Rows: participant · preference number; tap a cell for the preference's activities and action.")
    chart(fig, width="stretch", key=f"{key}-chart")
    download_csv(whole, file_name, "Download by_preference.csv", key=f"{key}-dl")
