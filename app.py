"""CACAS Studio: the study dashboard (``streamlit run app.py``).

Navigation and the shared sidebar (study and participant); no study logic here. The address
carries the participant and the day the tablet is about (``?participant=P03&day=2``: the open
day, or the next one once the previous day is adapted), so a browser refresh, or
coming back the next day, returns to the same place; the data comes from the study database.
``?participant=P03&view=tablet`` shows the tablet page alone for that participant: no navigation
to the researcher's pages, no preferences, no other participants.
"""


import os
import sqlite3
import threading
from pathlib import Path

import streamlit as st
from streamlit.runtime.scriptrunner import get_script_run_ctx

from cacas import app_support
from cacas.errors import CacasError
from cacas.paths import study_data_blocked, study_data_problem
from cacas.store import DB_ENV, DEFAULT_STUDY
from cacas.store.db import disk_trouble, is_busy
from cacas.study_day import day_status
from pages import ui

# A local favicon: a ":material/..." page icon makes the browser fetch it from Google's servers,
# and the app makes no requests beyond this machine.
ICON = Path(__file__).resolve().parent / "study_data" / "icon.png"

#: (section, file, title, icon) of each page, in navigation order.
PAGES = [
    ("Study", "pages/overview.py", "Overview", ":material/dashboard:"),
    ("Study", "pages/participants.py", "Participants", ":material/group:"),
    ("Study", "pages/session.py", "Study session", ":material/tablet:"),
    ("Study", "pages/adaptation.py", "Adaptation", ":material/model_training:"),
    ("Study", "pages/results.py", "Results", ":material/monitoring:"),
    ("Lab", "pages/simulation.py", "Simulation lab", ":material/science:"),
    ("Lab", "pages/sounds.py", "Sounds and scenes", ":material/graphic_eq:"),
]


def _navigation() -> dict[str, list]:
    sections: dict[str, list] = {}
    for section, path, title, icon in PAGES:
        sections.setdefault(section, []).append(
            st.Page(path, title=title, icon=icon, default=path.endswith("overview.py")))
    return sections


#: The code an address named that no participant has: no participant is chosen for the user
#: until they choose one (a mistyped link must not open another participant's session).
_UNKNOWN_KEY = "participant-unknown"


def _sync_participant(store) -> None:
    """The address and the session agree on the participant (and study); the database wins."""
    qp = st.query_params
    studies = [s.name for s in store.studies()]
    wanted = qp.get("participant") or st.session_state.get(ui.PARTICIPANT_KEY)
    if wanted:
        try:
            info = store.get_participant(wanted)
        except CacasError:  # codes are unique whatever their case: "r01" in a typed address is R01
            info = next((p for p in store.list_participants(None) if p.code.lower() == str(wanted).strip().lower()),
                        None)
        if info is None:
            st.session_state[ui.PARTICIPANT_KEY] = None
            st.session_state[_UNKNOWN_KEY] = wanted  # no other participant stands in, until one is chosen
            qp.pop("participant", None)
        else:
            st.session_state[ui.PARTICIPANT_KEY] = info.code
            st.session_state[ui.STUDY_KEY] = info.study
            st.session_state.pop(_UNKNOWN_KEY, None)
    if st.session_state.get(ui.STUDY_KEY) not in studies:  # a new visit: the address's study, or the one being run
        latest = app_support.latest_study(store)
        st.session_state[ui.STUDY_KEY] = (qp.get("study") if qp.get("study") in studies
                                          else latest if latest in studies else studies[0])


def _address(store, status=None) -> dict[str, str | None]:
    """The address's participant, day and study (None: left out) for the session's choice;
    ``status``: the participant's :func:`day_status`, if the caller has it (the sidebar: each is a
    few queries, and one of the day's interactions)."""
    code = st.session_state.get(ui.PARTICIPANT_KEY)
    study = st.session_state.get(ui.STUDY_KEY)
    if code and status is None:
        status = day_status(store, code)
    # "default" too once there are other studies: a reload without it opened the study last active
    # (walkthrough: "default" chosen, a refresh showed another study's participants)
    return {"participant": code or None, "day": str(status.day_on_screen) if code else None,
            "study": study if study is not None and (study != "default" or len(store.studies()) > 1) else None}


def _page_links(nav, address: dict[str, str | None]) -> None:
    """The researcher's pages, in ``nav`` (the top of the sidebar), as links that carry the
    address's participant, day and study: Streamlit's own navigation clears the address on a page
    change, and writing it again pushed a second entry into the browser's history, so Back took
    two presses to leave a page (three or four when the address was written a parameter at a time)."""
    carried = {k: v for k, v in address.items() if v is not None}
    for section, pages in _navigation().items():
        nav.caption(section)
        for page in pages:
            nav.page_link(page, label=page.title, icon=page.icon, query_params=carried, width="stretch")


def _on_study_change() -> None:
    st.session_state[ui.PARTICIPANT_KEY] = None
    st.session_state.pop(_UNKNOWN_KEY, None)
    ui.select_participant(None)


def _on_participant_change() -> None:
    """The sidebar's choice goes into the address at once (the address wins on every run)."""
    st.session_state.pop(_UNKNOWN_KEY, None)
    ui.select_participant(st.session_state.get(ui.PARTICIPANT_KEY))  # a proposal belongs to its participant


#: The page that says beside its forms which preference changes are unsaved (the sidebar does not repeat it there).
FORMS_PAGE = "pages/participants.py"


def _sidebar(store, page) -> dict[str, str | None]:
    """Draw the sidebar; returns the address (:func:`_address`) for the participant it settled on."""
    with st.sidebar:
        st.markdown(f"## {ui.icon('smart_toy')} CACAS Studio", unsafe_allow_html=True)  # read "CACAS Studio"
        links = st.container(key="page-links")  # filled last, with the participant chosen below
        st.divider()
        studies = [s.name for s in store.studies()]
        st.selectbox("Study", studies, key=ui.STUDY_KEY, on_change=_on_study_change,
                     help="Studies group participants; every database has the study 'default'.")
        codes = [p.code for p in store.list_participants(st.session_state[ui.STUDY_KEY])]
        unknown = st.session_state.get(_UNKNOWN_KEY)
        if st.session_state.get(ui.PARTICIPANT_KEY) not in codes:  # a fresh load, another study, a removal
            st.session_state[ui.PARTICIPANT_KEY] = None if unknown else app_support.last_participant(
                store, st.session_state[ui.STUDY_KEY])
        if unknown:
            st.warning(f"Participant {unknown!r} is not in this study database: choose one below.")
        st.selectbox("Participant", codes, key=ui.PARTICIPANT_KEY, placeholder="none yet",
                     on_change=_on_participant_change,
                     help="Pseudonymous codes only. Add participants on the Participants page.")
        code = st.session_state.get(ui.PARTICIPANT_KEY)
        status = None
        if code:
            status = day_status(store, code)
            if status.day == 0:
                st.caption("Not started yet.")
            else:
                state = "open" if status.open else "closed"
                n, more = status.recorded_today, status.unanswered_today
                st.caption(f"Day {status.day} ({state}) · {n} interaction{'' if n == 1 else 's'} that day"
                           + (f" (+{more} not counted)" if more else "") + " · "
                           f"policy {'initial' if status.policy_version is None else 'v' + str(status.policy_version)}")
            st.caption(f"Participant's tablet: [open the tablet view](./?participant={code}&view=tablet)")
        unsaved = ui.unsaved_preference_forms()
        if unsaved and page.url_path != Path(FORMS_PAGE).stem:  # that page says it beside the form itself
            st.warning(f"Unsaved preference changes: {', '.join(unsaved)}. Save or discard them on the Participants "
                       "page.", icon=":material/edit_note:")
        st.caption(f"Database: `{ui.db_path()}`")
        if store.created and os.environ.get(DB_ENV) and not codes and studies == [DEFAULT_STUDY]:
            st.info(f"New: this server created it, empty. If you meant an existing database, check ${DB_ENV} and "
                    "start the app again.", icon=":material/new_releases:")
        st.html(CLOSE_SIDEBAR_SCRIPT, unsafe_allow_javascript=True)  # last: its placeholder moves nothing
    address = _address(store, status)  # the participant's status read above, not again
    _page_links(links, address)
    return address


#: What the pages import on first use, which took the first visit of a page after the server's start
#: 3.5-7.4 s (torch 1.9-2.6 s for Adaptation, torchvision 2.5 s for Sounds and scenes; helper's profile of a
#: 24 x 7 study), and librosa's features, which the tablet's first proposal needs. librosa's own modules
#: load lazily: ``librosa.feature`` alone imported a stub, and the tablet's first recognition of a clip
#: still imported the rest (scipy.signal, soundfile, numba: some 1,000 modules, 3.6 s; profile of the first
#: proposal), so the module that computes the MFCC is named.
PRELOADED = ("cacas.adaptation", "torchvision.models", "librosa.feature.spectral")


@st.cache_resource(show_spinner=False)
def _preload() -> threading.Thread:
    """Import :data:`PRELOADED` in a thread of its own, once per server process, started after the first
    page is drawn: the researcher reads that page meanwhile. A page that needs a module being imported
    waits for that import (Python's import lock), never imports it twice.

    No automatic garbage collection while it runs. Python 3.11 keeps the AST constructor's recursion
    depth per interpreter, not per call (CPython gh-106905): torch's import parses source about 100
    times (``ast.parse``, for its ``_overload`` decorators and ``inspect.signature``), and a page that
    Streamlit compiled meanwhile (its "magic" parses the page) failed once in a while with
    "SystemError: AST constructor recursion depth mismatch" (the tests: about one run in eight of a
    page's test file). The two constructions interleave only when a collection in the middle of one
    runs Python code (a finalizer, a weakref callback) and the other thread takes the interpreter;
    without collections they run one after the other. The collector is on again once the imports end.

    Then the saved sound and scene models are loaded into the page's cache (``ui.recognizer``): the first
    visit of Sounds and scenes loaded them (0.7-1.5 s of its run, the scene model's most, after the imports;
    profile of a 24 x 7 study), and so did the tablet's first form. A page that needs one meanwhile waits
    for that load (the cache's lock), never loads it twice."""
    import gc
    import importlib

    def load() -> None:
        collecting = gc.isenabled()
        gc.disable()
        try:
            for name in PRELOADED:
                try:
                    importlib.import_module(name)
                except Exception:  # noqa: BLE001  the page that needs it says what is wrong, in its place
                    pass
            for kind in ("sound", "scene"):
                try:
                    ui.recognizer(kind)  # None without a model, or one that cannot be read: the pages say why
                except Exception:  # noqa: BLE001
                    pass
        finally:
            if collecting:
                gc.enable()

    thread = threading.Thread(target=load, name="cacas-preload", daemon=True)
    thread.start()
    return thread


def main() -> None:
    """Open the study database, route to the page and draw the sidebar."""
    st.set_page_config(page_title="CACAS Studio", page_icon=str(ICON) if ICON.exists() else None, layout="wide")
    try:
        store = ui.store()
    except CacasError as exc:
        # navigation, hidden and not run: without it Streamlit listed the pages/ folder's files ("ui" among them)
        st.navigation(_navigation(), position="hidden")
        st.error(f"The study database cannot be opened: {exc}")
        st.stop()
    # the tablets' board begins with the server's first page, whichever it is: begun with the first Study session
    # page, its "has not heard from the tablet since the app started (HH:MM)" gave that page's time (walkthrough)
    ui.tablet_board()

    try:
        _route(store)
    except sqlite3.DatabaseError as exc:
        if disk_trouble(exc):  # a full or failing disk: the file is not known to be damaged, and must be kept
            st.error(f"The study database {ui.db_path()} cannot be read from the disk now ({exc}). The disk may be "
                     "full or failing: free some disk space (or check the disk) and reload the page. The file is not "
                     "known to be damaged: do not replace it with a backup, which would lose what was saved since.",
                     icon=":material/error:")
            return
        if isinstance(exc, sqlite3.OperationalError) and is_busy(exc):  # held by another program for long
            st.warning(f"The study database {ui.db_path()} is busy ({exc}): another program has held it for more "
                       "than 10 s (a database tool left open on it?). Nothing was lost; reload the page in a moment.",
                       icon=":material/hourglass_empty:")
            return
        if not _damaged(exc):  # a constraint: not the file's fault, not to be restored
            raise
        # damage quick_check did not see on opening, met by the sidebar or a page: a message, not a traceback
        st.error(f"The study database {ui.db_path()} cannot be read ({exc}). Restore it from a backup or an "
                 "export (`cacas import`).", icon=":material/error:")
    finally:  # also after a page's st.stop()
        _preload()


def _damaged(exc: sqlite3.DatabaseError) -> bool:
    """Whether SQLite's error says the file itself is damaged (and a backup is the remedy)."""
    said = str(exc).lower()
    return any(words in said for words in ("malformed", "not a database", "database corrupt"))


#: Every page's look (the tablet's and the researcher's): Streamlit fades a caption to 0.6, #828180 on white, 3.89:1,
#: under WCAG 1.4.3's 4.5:1 for text of its 14-15 px (the tablet's "in the bedroom · 08:00-10:00 · ...", the
#: researcher's explanations under every figure and table; accessibility walkthrough); at 0.75, #636260, 6.1:1,
#: still lighter than the text around it. The sidebar's captions too (on its grey, 5.6:1).
#: Headings go down one level at a time, as a screen reader lists them (accessibility walkthrough: h1 -> h3 on the
#: researcher's pages, h2 -> h4 -> h5 on the tablet): a page's sections are h2 (st.header), the sidebar's title and
#: the study session's form and cards too, drawn at the sizes they had as h3, h4 and h5.
#: A multi-choice field shows every option chosen, its chips wrapping onto more lines (Participants' preference form).
#: A text field takes the direction of what is typed in it (Unicode's rule, its first letter's): Streamlit's are
#: left to right, so Arabic or Hebrew typed there (a participant's request on the tablet, a preference's words, notes,
#: comments) stood at the left edge, a closing "!" or emoji at its right, the start of an Arabic sentence.
#: Streamlit draws an st.html once it has loaded its code for it, so at a page's first load the page stands in
#: Streamlit's own style for a moment (0.1-0.7 s here): ``--cacas-styled`` says when these styles are in force
#: (the browser tests wait for it before they look at the page).
APP_STYLE = """
:root { --cacas-styled: 1; }
/* the tablet's and the researcher's words about a lost connection appear after a second (TABLET_STYLE, CONNECTION_STYLE) */
@keyframes cacas-appear { from { opacity: 0; } to { opacity: 1; } }
[data-testid='stCaptionContainer'] { opacity: 0.75; }
[data-testid='stTextInput'] input, [data-testid='stTextArea'] textarea { unicode-bidi: plaintext; text-align: start; }
/* every option chosen in a multi-choice field in view, on as many lines as they need (as in a form): outside a form
   Streamlit keeps them on one line that scrolls sideways, and a preference's third time of day was cut and faded at
   the field's edge ("16:00-18" on a phone; at 1280 px from the fifth), the rest out of sight */
[data-testid='stMain'] [data-testid='stMultiSelect'] div:has(> [data-testid='stMultiSelectTagsContainer']) {
  height: auto; max-height: none; }
[data-testid='stMain'] [data-testid='stMultiSelectTagsContainer'] { flex-wrap: wrap; height: auto; }
/* on a phone the title starts under the header's sidebar button, not 6rem down (Streamlit's room above every page:
   the title stood at 120 px of 844, phone walkthrough); the tablet's page sets its own */
@media (max-width: 640px) { [data-testid='stMainBlockContainer'] { padding-top: 4rem; } }
[data-testid='stMain'] h2 { font-size: 1.75rem; line-height: 1.2; padding: 0.75rem 0 1rem; }
[data-testid='stSidebar'] h2 { font-size: 1.125rem; line-height: 1.2; padding: 0.75rem 0 1rem; }
[data-testid='stMain'] [data-testid='stForm'] h2 { font-size: 1.5rem; letter-spacing: normal; padding: 0.5rem 0 1rem; }
[class*='st-key-card-'] h2 { font-size: 1.25rem; letter-spacing: normal; padding: 0.375rem 0 1rem; }
/* the keyboard's focus in a solid ring of the primary colour, 5.5:1 on white: Streamlit's is that colour at half
   strength (#97b7c7 on white, 2.1:1, under WCAG 1.4.11's 3:1), faint beside a chip's own border; a checkbox and
   the sidebar's page links showed none (accessibility walkthrough) */
:is([data-testid='stMain'], [data-testid='stSidebar']) :is(button, [role='radio'], [role='tab'], audio, a,
    summary):focus-visible, label:has(input[type='checkbox']:focus-visible) { outline: 3px solid #2f6f8f;
                                                                                 outline-offset: 2px; }
/* a touch screen (a phone or tablet between rooms) has no hover: Streamlit shows a table's toolbar and Plotly its
   modebar always, not only under the mouse. The table's toolbar stood 44 px above the table, over the last line of
   what came before (Adaptation: "before and after are shares of ..."); the modebar over a chart's title at a phone's
   width ("Success rate and cumulative feedback"). Each now has a row of its own above its table or chart. */
@media (hover: none) {
  .stElementContainer:has([data-testid='stDataFrame']) { padding-top: 1.75rem; }
  .stElementContainer:has([data-testid='stPlotlyChart']) { margin-top: 1.75rem; overflow: visible; }
  [data-testid='stPlotlyChart'] .js-plotly-plot { overflow: visible !important; }
  [data-testid='stPlotlyChart'] .modebar-container { top: -1.75rem !important; }
}
"""


#: The researcher's pages on a touch screen (a phone or a tablet carried between rooms during a study day; the
#: participant's tablet page has its own, larger, :data:`TABLET_STYLE`): what is tapped is at least 44 px each way
#: (WCAG 2.5.5; walkthrough at 390 x 844 and 768 x 1024, touch): the sidebar's open and close buttons were 28 x 28,
#: the page links 28 px high (the Overview's "Open the study session" too), a chosen option's "x" in a multi-choice
#: field 15 x 7 (now its chip's height, 28, and 34 wide: an unseen box around it, inside the chip), buttons and tabs
#: 40 px high (Results' "Tables" tab 38 wide), an expander's heading 38, a choice of buttons (Results' data, Fig. 4's
#: "Methods on one day") 32, a number's "-" and "+" 32 x 38 (Participants' "Preferences on the form"; the field's
#: look unchanged: the buttons reach 5 px below its edge, unseen).
TOUCH_STYLE = """
@media (pointer: coarse) {
  [data-testid='stExpandSidebarButton'], [data-testid='stSidebarCollapseButton'] button {
    min-width: 2.75rem; min-height: 2.75rem; }
  [data-testid='stPageLink-NavLink'] { min-height: 2.75rem; }
  :is([data-testid='stMain'], [data-testid='stSidebar']) :is(button[data-testid^='stBaseButton'],
    [data-testid='stButtonGroup'] button) { min-height: 2.75rem; }
  [data-testid='stMain'] [data-testid='stTab'] { min-height: 2.75rem; min-width: 2.75rem; flex-shrink: 0; }
  [data-testid='stMain'] [data-testid='stExpander'] summary { min-height: 2.75rem; }
  [data-testid^='stNumberInputStep'] { min-width: 2.75rem; min-height: 2.75rem; }
  [data-testid='stMultiSelect'] button[aria-label^='Remove'] { position: relative; }
  [data-testid='stMultiSelect'] button[aria-label^='Remove']::after {
    content: ''; position: absolute; inset: -1.1rem -0.6rem; }
}
"""

#: While a researcher's page has lost its server (the server restarting, stopped, its laptop asleep), Streamlit's
#: dialog said "Connection error: Streamlit server is not responding. Are you connected to the internet?" over the
#: page, dimmed (a lab's server runs on its own laptop: the internet is not the question). A band at the top says
#: what it is and what to do, in the app's words, the page left readable under it (after a second: a blink of the
#: network says nothing); Streamlit's dialog is not shown meanwhile, and it closes it itself once reconnected. The
#: participant's tablet says it in its own words (:data:`TABLET_STYLE`).
#: An element whose code did not load: Streamlit loads most elements' code when a page first draws one (a multi-choice
#: field's, a button's), and a fetch that failed (the lab's Wi-Fi dropped, the server restarted, while the page
#: loaded) left the element as "TypeError: Failed to fetch dynamically imported module: http://.../Multiselect....js"
#: in a red box for the page's life: the browser keeps a module that failed, so no rerun draws it (seen: the
#: Participants page's preference fields, all of them). A reload does. A band of the same look says so at once
#: (Streamlit's box for an element it could not draw holds a stack, ``stErrorElementStack``, an st.error none); the
#: researcher's pages are not reloaded for it, which would lose a form's unsaved changes (the tablet reloads itself,
#: :data:`TABLET_RELOAD_SCRIPT`). Under the connection band while both show: the connection comes first.
CONNECTION_STYLE = """
:root:has([data-testid='stApp']:is([data-test-connection-state='PINGING_SERVER'],
                                   [data-test-connection-state='DISCONNECTED_FOREVER'])) [data-testid='stDialog'] {
  display: none !important; }
[data-testid='stApp'][data-test-connection-state='PINGING_SERVER']::after,
[data-testid='stApp'][data-test-connection-state='DISCONNECTED_FOREVER']::after,
:root:has([data-testid='stErrorElementStack']) [data-testid='stApp']::before {
  position: fixed; top: 0; left: 0; right: 0; z-index: 1000100; padding: 0.9rem 1.5rem; white-space: pre-line;
  font-size: 1rem; line-height: 1.5; color: #262730; background: #fff3cd; border-bottom: 2px solid #e0a800;
  box-shadow: 0 0.25rem 0.75rem rgba(0, 0, 0, 0.15); animation: cacas-appear 0.3s ease-in 1s both; }
[data-testid='stApp'][data-test-connection-state='PINGING_SERVER']::after {
  content: "CACAS Studio's server is not answering: it is restarting, was stopped, or its computer is asleep.\\A "
           "This page reconnects by itself once the server is back. If it stays, start it again in its terminal "
           "(streamlit run app.py)."; }
[data-testid='stApp'][data-test-connection-state='DISCONNECTED_FOREVER']::after {
  content: "CACAS Studio's server did not come back. Start it again in its terminal (streamlit run app.py), "
           "then reload this page."; }
:root:has([data-testid='stErrorElementStack']) [data-testid='stApp']::before {
  content: "Part of this page could not be drawn: its code did not load (the connection dropped, or the server "
           "restarted, while the page loaded).\\A Reload the page (F5) to draw it again; changes not yet saved on a "
           "form are lost then.";
  z-index: 1000090; animation-delay: 0s; }
"""

#: The tablet reloads itself when an element's code did not load (:data:`CONNECTION_STYLE`): its answers or
#: its context form would stay red boxes that a participant can do nothing with. Once connected again (a reload
#: meanwhile would fail too), at most 3 times in 10 minutes a tab (an element that fails for another reason is not
#: reloaded for ever; the tablet then says to tell the researcher, :data:`TABLET_STYLE`). The page comes back from
#: its address (the proposal's context and interaction mark), as after any reload. Drawn after the page (its
#: element is hidden once drawn; Streamlit's placeholder while it loads its code would push the page down).
TABLET_RELOAD_SCRIPT = """
<style>.stElementContainer:has(> [data-testid='stHtml'] script) { display: none; }</style>
<script>
if (!window.cacasReloadsBrokenElements) {
  window.cacasReloadsBrokenElements = true;
  setInterval(() => {
    const app = document.querySelector("[data-testid='stApp']");
    if (!app || app.getAttribute('data-test-connection-state') !== 'CONNECTED') return;
    if (!document.querySelector("[data-testid='stErrorElementStack']")) return;
    const now = Date.now();
    const recent = JSON.parse(sessionStorage.getItem('cacasReloads') || '[]').filter(t => now - t < 600000);
    if (recent.length >= 3) return;
    sessionStorage.setItem('cacasReloads', JSON.stringify([...recent, now]));
    location.reload();
  }, 1000);
}
</script>"""

#: A page link tapped in the sidebar where the sidebar lies over the page (a phone, a tablet upright: Streamlit draws
#: it over the page below 768 px) closes the sidebar, as Streamlit's own navigation does there: the links are ours
#: (``_page_links``, to carry the address), and Streamlit's page link leaves the sidebar open, so the page opened
#: stood behind it until the researcher closed it (walkthrough at 390 x 844). Beside the page (a laptop) it stays.
#: Its element takes no room once drawn (with a script the page's title stood 16 px lower, one gap of the page's
#: column; Streamlit hides an st.html of styles alone). It is the sidebar's last element: Streamlit loads its code
#: for st.html at a page's first load and shows a 40-px placeholder meanwhile, and in the page's column before the
#: title that placeholder held the title 56 px lower for up to a second, then the title jumped up (a CI failure).
CLOSE_SIDEBAR_SCRIPT = """
<style>.stElementContainer:has(> [data-testid='stHtml'] script) { display: none; }</style>
<script>
if (!window.cacasClosesSidebar) {
  window.cacasClosesSidebar = true;
  document.addEventListener('click', event => {
    const link = event.target.closest && event.target.closest("[data-testid='stSidebar'] [data-testid='stPageLink-NavLink']");
    const sidebar = document.querySelector("[data-testid='stSidebar']");
    const main = document.querySelector("[data-testid='stMain']");
    if (!link || !sidebar || !main) return;
    if (main.getBoundingClientRect().left < sidebar.getBoundingClientRect().right - 1) {  // over the page
      const close = document.querySelector("[data-testid='stSidebarCollapseButton'] button");
      if (close) close.click();
    }
  }, true);
}
</script>"""

#: The tablet's look. A tablet at 1024 x 768 shows the proposal, its answers and the request form without
#: scrolling: Streamlit's 6rem above the page was room they needed (a style only: it takes no room itself).
#: A form's "Press Enter to submit form" is a developer's words: Enter says the typed request. Buttons and
#: chips to tap are at least 48 px high, and the robot's words, the labels and the buttons' words larger,
#: for participants of 65 and more (walkthrough at tablet sizes: 40 px buttons, 14 px words, the robot's
#: line at 16 px). Toasts come at the bottom: at the top they covered "Choose a different activity". The
#: sound's player is as tall as a button: a tablet that blocks autoplay leaves its play button to tap. On a phone
#: (390 x 844: Streamlit stacks columns under 640 px) the three answers stay side by side, in view under the
#: proposal (stacked, "No response" was below the screen's edge), each icon above its words, as do "Yes, please"
#: and "No" (keys ``tablet-row-*``), and a chip's padding is smaller, three times of day to a row (two: six rows to scroll past).
#: "Hello, P01" is the page's h1, drawn at the size it had as h2.
#: While the tablet's connection to the server is down (the lab's Wi-Fi, a server restarting), Streamlit's dialog
#: said "Connection error: Streamlit server is not responding. Are you connected to the internet?" to the
#: participant (lan): the tablet says in its own words that it comes back by itself (after a second: a blink
#: of the network says nothing), over the page, whose answers Streamlit disables meanwhile; the tablet has no
#: dialog of its own, and Streamlit closes its connection dialog when it reconnects.
TABLET_STYLE = """
[data-testid='stMain'] h1 { font-size: 2.25rem; font-weight: 600; line-height: 1.2; letter-spacing: -0.005em;
                             padding: 1rem 0; }
[data-testid='stMainBlockContainer'] { padding-top: 1.5rem; }
[data-testid='InputInstructions'] { display: none; }
[data-testid='stMain'] button[data-testid^='stBaseButton'] { min-height: 3.25rem; }
[data-testid='stMain'] button[data-testid^='stBaseButton'] p { font-size: 1.1rem; }
[data-testid='stMain'] button[data-variant='pills'] { min-height: 2.75rem; padding: 0 1rem; }
[data-testid='stMain'] button[data-variant='pills'] p { font-size: 1.05rem; }
[data-testid='stMain'] [data-testid='stSelectbox'] [role='group'],
[data-testid='stMain'] [data-testid='stTextInput'] input { min-height: 2.75rem; }
[data-testid='stMain'] [data-testid='stSelectbox'] input,
[data-testid='stMain'] [data-testid='stTextInput'] input { font-size: 1.05rem; }
[data-testid='stMain'] [data-testid='stWidgetLabel'] p { font-size: 1.05rem; }
[data-testid='stMain'] [data-testid='stMarkdownContainer'] p { font-size: 1.05rem; }
[data-testid='stDialog'] { display: none !important; }
[data-testid='stApp'][data-test-connection-state='PINGING_SERVER']::after,
[data-testid='stApp'][data-test-connection-state='DISCONNECTED_FOREVER']::after {
  content: "The tablet has lost its connection to the robot for a moment.\\A "
           "Please wait: it comes back by itself. If this stays, please tell the researcher.";
  white-space: pre-line; position: fixed; inset: 0; z-index: 1000100; display: flex; align-items: center;
  justify-content: center; padding: 2rem; text-align: center; font-size: 1.4rem; line-height: 1.6; color: #262730;
  background: rgba(250, 250, 250, 0.96); animation: cacas-appear 0.3s ease-in 1s both; }
/* an element whose code did not load, the tablet's reloads spent (TABLET_RELOAD_SCRIPT): words, not red boxes */
:root:has([data-testid='stErrorElementStack']) [data-testid='stApp']::before {
  content: "Part of this screen did not load.\\A Please tell the researcher.";
  white-space: pre-line; position: fixed; inset: 0; z-index: 1000090; display: flex; align-items: center;
  justify-content: center; padding: 2rem; text-align: center; font-size: 1.4rem; line-height: 1.6; color: #262730;
  background: rgba(250, 250, 250, 0.96); animation: cacas-appear 0.3s ease-in 5s both; }
[data-testid='stMain'] [data-testid='stCaptionContainer'], [data-testid='stMain'] [data-testid='stCaptionContainer'] p,
[data-testid='stMain'] [data-testid='stProgress'] p { font-size: 0.95rem; }
[data-testid='stMain'] [data-testid='stChatMessage'] p { font-size: 1.35rem; line-height: 1.4; }
[data-testid='stToastContainer'] { top: auto; bottom: 1rem; }
[data-testid='stMain'] audio { width: 100%; height: 3.25rem; }
@media (max-width: 640px) {
  [data-testid='stMainBlockContainer'] { padding-top: 1rem; }
  [data-testid='stMain'] button[data-variant='pills'] { padding: 0 0.55rem; }
  [class*='st-key-tablet-row'] [data-testid='stHorizontalBlock'] { flex-wrap: nowrap; gap: 0.5rem; }
  [class*='st-key-tablet-row'] [data-testid='stColumn'] { min-width: 0 !important; width: auto !important;
                                                         flex: 1 1 0 !important; }
  [class*='st-key-tablet-row'] button { padding: 0.4rem 0.25rem; }
  [class*='st-key-tablet-row'] button > div > span { flex-direction: column; gap: 0.1rem; }
  /* the context form (30 chips, a list) is taller than a phone's screen: "Do it" stays at the screen's bottom
     edge while the form is scrolled, in its place once the form's end is in view */
  [data-testid='stForm'] .st-key-button-Do-it { position: sticky; bottom: 0.75rem; z-index: 2; }
  [data-testid='stForm'] .st-key-button-Do-it button { box-shadow: 0 0.25rem 0.75rem rgba(0, 0, 0, 0.25); }
}
"""


def _route(store) -> None:
    """The participant from the address, the page, the sidebar; then the page itself."""
    ui.run_missed_click()  # where Streamlit runs a button's callback: before anything is drawn
    _sync_participant(store)
    ui.keep_preference_forms()
    if ui.tablet_mode():
        st.html(f"<style>{APP_STYLE}{TABLET_STYLE}</style>")
        if not st.session_state.get(ui.PARTICIPANT_KEY):
            st.error("This tablet address names no known participant. Ask the researcher for your link.")
            st.stop()
        page = st.navigation([st.Page("pages/session.py", title="Study session", default=True)],
                             position="hidden")
        address = _address(store)
    else:
        st.html(f"<style>{APP_STYLE}{TOUCH_STYLE}{CONNECTION_STYLE}</style>")
        page = st.navigation(_navigation(), position="hidden")  # the sidebar draws the links itself
        address = _sidebar(store, page)
        problem = study_data_problem()
        if problem:  # said on every researcher page, before a participant meets it on the tablet
            (st.error if study_data_blocked() else st.warning)(f"Set-up: {problem}.", icon=":material/folder_off:")
        behind = app_support.clock_behind(store)
        if behind:
            st.warning(f"Clock: {behind}.", icon=":material/schedule:")
    ui.set_address(**address)
    ui.click_not_done()  # a click whose callback met a busy or unreadable database, said above the page
    ui.routed()
    try:
        page.run()
    finally:  # also after the page's st.stop()
        if ui.tablet_mode():
            st.html(TABLET_RELOAD_SCRIPT, unsafe_allow_javascript=True)


# A Simulation lab worker process imports this script, the server's __main__, when it starts
# (multiprocessing's spawn), with no Streamlit session: it has nothing to show, nor a database to open.
if get_script_run_ctx(suppress_warning=True) is not None:
    main()
