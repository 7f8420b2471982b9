"""Study session: the participant's tablet (the paper's web page to set the context, Section V-B.1).

The participant sets the time of day (S3), the time since their last activity (S4), the
activity (S1) and the room (S2); the activity's sound plays; the robot recognises it and proposes
an action; the participant accepts, rejects, ignores it, or asks for an action themselves.
Every answer is written to the study database the moment it is given.
"""

from __future__ import annotations

import time

import pandas as pd
import streamlit as st

from cacas import app_support, dialogue, lab, spaces, table_layouts
from cacas.records import RESPONSE_WORDS
from cacas.errors import AlreadyRecorded, CacasError
from cacas.jobs import FAILED, RUNNER
from cacas.lab import audio_mime
from cacas.on_tablet import Asked, Shown, board_name
from cacas.recognition import Recognition
from cacas.store.db import WriteRefused
from cacas.study_day import (ANSWERS, STUDY_DAYS, TARGET_INTERACTIONS, Context, answer, clip_for, day_of, day_status,
                             initial_policy_ready, is_same_answer, prepare_initial_policy,
                             previous_interaction, propose, proposal_draws, recorded_answer,
                             request_accepts_proposal, start_day, waiting_for_preferences)
from pages import ui

ui.require_app()

store = ui.store()
code = ui.need_participant()
tablet = ui.tablet_mode()


# --- cached resources (one per server process; the policies': ui.policy_version) ---------------------------

board, db = ui.tablet_board(), ui.db_path()
#: the participant as the board names them: a new participant given a removed one's code is someone else
who = board_name(store, code)


def _library(kind: str, name: str) -> list[str]:
    """The library's clips of an activity ("sound") or photos of a room ("scene"), as its folder
    holds them now (clips added while the app runs are played)."""
    try:
        stamp = lab.library_stamp(kind, name)
    except (CacasError, OSError):
        return []
    return _library_files(kind, name, stamp)


@st.cache_data(show_spinner=False, max_entries=512)
def _library_files(kind: str, name: str, stamp: tuple) -> list[str]:
    from cacas.audio.library import clip_paths
    from cacas.vision.library import image_paths

    try:
        return [str(p) for p in (clip_paths(name) if kind == "sound" else image_paths(name))]
    except (CacasError, OSError):
        return []


def _warm_up() -> None:
    """Load the sound and scene models and recognise one library item of each (librosa's first
    call is slow), once per server process, while the participant chooses a context: the first
    proposal after a server start spent about 8 s on it (20 s on a busy machine; walkthrough).
    Both land in the caches the proposal uses."""
    for kind, name in (("sound", spaces.ACTIVITIES[0]), ("scene", spaces.SCENES[0])):
        items = _library(kind, name)
        if items:
            _recognise(kind, items[0], ui.model_stamp(kind))


@st.cache_data(show_spinner=False, max_entries=256)
def _recognise(kind: str, path: str, stamp: float | None) -> Recognition | None:
    """The recognition of a clip or photo, or None without a model or for a bad file."""
    rec = ui.recognizer(kind)  # ``stamp`` keys the cache: a retrained model recognises afresh
    if rec is None:
        return None
    try:
        r = rec.recognize(path)
    except CacasError:
        return None
    return r


# --- callbacks ------------------------------------------------------------------------------------

#: What the tablet says when the day cannot start (a set-up problem the researcher must mend):
#: the participant is not shown the researcher's message, which stays one click away.
NOT_READY = "The robot is not ready to start the day: please ask the researcher."
#: What the tablet says when the study database refuses to save an answer (a full disk, a database
#: held busy, a file that cannot be written): the researcher's message stays one click away.
NOT_SAVED = ("Your answer was not saved: the robot could not store it just now. Please try again in a moment, "
             "and if it happens again, tell the researcher.")
#: The tablet's plain words whose researcher's message is kept under "For the researcher".
_PLAIN = (NOT_READY, NOT_SAVED)


def _start_day() -> None:
    st.session_state["session-error-detail"] = None
    try:
        day = start_day(store, code)
    except CacasError as exc:
        st.session_state["session-error"] = NOT_READY if tablet else str(exc)
        st.session_state["session-error-detail"] = str(exc) if tablet else None
    else:
        st.session_state["session-error"] = None
        _cancel()  # a new day never opens on a context left from the day before
        st.toast(f"Day {day} started.", icon=":material/today:")


def _status_or_gone():
    """The participant's day status; None when they were removed meanwhile (a tap on a tablet left
    open then showed a traceback naming the other participants): the page, run next, says that the
    address names no participant."""
    try:
        return day_status(store, code)
    except CacasError:
        _cancel()
        return None


#: An empty context form sent this soon after an answer was saved is a double tap's second tap: ignored.
DOUBLE_TAP_SECONDS = 2.0


def _set_context() -> None:
    s = st.session_state
    # the researcher's view names the participant, as its labels do ("Time since P01's last activity (S4)")
    missing = [what for what, key in (("the time of day", "ctx-slot"),
                                      (f"the time since {_whose()} last activity", "ctx-interval"),
                                      ("an activity", "ctx-activity"), ("a room", "ctx-scene")) if s.get(key) is None]
    if len(missing) == 4 and time.monotonic() - s.get("saved-at", (float("-inf"), ""))[0] < DOUBLE_TAP_SECONDS:
        # the second tap of a double tap on an answer: "Do it" is drawn where the answer was (walkthrough at
        # 1024 x 768: it said "Choose the time of day ... first" in red in place of "Saved")
        s["last-saved"] = s["saved-at"][1]
        return
    if missing:
        s["session-error"] = f"Choose {', '.join(missing[:-1]) + ' and ' if len(missing) > 1 else ''}{missing[-1]} first."
        return
    try:
        ctx = Context.from_choices(s["ctx-slot"], s["ctx-interval"], s["ctx-activity"], s["ctx-scene"])
    except CacasError as exc:
        s["session-error"] = str(exc)
        return
    s["session-error"] = None
    status = _status_or_gone()
    if status is None:
        return
    if not status.open:  # the form was drawn on an open day: the researcher closed it meanwhile (a tablet left
        # on the form overnight showed "Start day 2" at "Do it" with not a word about the context just set)
        s["session-error"] = (f"That was not used: day {status.day} was closed meanwhile."
                              + (" Ask the researcher whether to start the next day." if tablet else ""))
        _cancel()
        return
    # the proposal belongs to one interaction: the browser's Back button brings its address back after
    # it was answered, and the page must not take it for the next interaction (a second answer)
    ui.set_address(ctx=ctx.to_token(), at=_interaction_mark(status.day, status.interactions_today + 1))
    _clear_request()


def _whose() -> str:
    """Whose activity the page speaks of: the participant's own ("your") on the tablet; on the
    researcher's view, the participant's code ("P01's"): the researcher sets the context for them."""
    return "your" if tablet else f"{code}'s"


def _interaction_mark(day: int, index: int) -> str:
    """The address's mark of the interaction a proposal is for: "<day>.<index>"."""
    return f"{day}.{index}"


def _clear_request() -> None:
    """A new proposal starts clean: no typed or picked request, no message about the last one."""
    s = st.session_state
    for key in ("request-match", "request-said", "request-error"):
        s.pop(key, None)
    s["request-text"], s["request-pick"] = "", None
    if tablet:
        board.withdraw(db, who)


def _cancel() -> None:
    ui.set_address(ctx=None, at=None)
    _clear_request()
    if tablet:  # the participant left the proposal: a reopened tablet must not return to it
        board.clear(db, who)
    st.session_state.pop("run-here", None)  # the researcher's view follows the tablet again


def _record(day: int, index: int, proposal, response: str | None = None, user_action: str | None = None) -> None:
    """Write the answer once: it is for the day's interaction ``index``, so a second click (or a
    second tab) on the same proposal writes nothing (the store checks it as it writes)."""
    s = st.session_state
    status = _status_or_gone()
    if status is None:
        return
    if not status.open or status.day != day:  # the researcher closed the day while this proposal was on the tablet
        s["session-error"] = (f"This answer was not saved: day {day} was closed meanwhile. Ask the researcher "
                              "whether to start the next day.")
        _cancel()  # the proposal belongs to the closed day: the next day starts with a context of its own
        return
    try:
        answer(store, code, day, proposal, response=response, user_action=user_action, index=index)
    except AlreadyRecorded:  # already saved: a second click, the same tap on another tablet, or another answer
        _cancel()
        other = recorded_answer(store, code, day, index)
        if other is not None and is_same_answer(other, proposal, response, user_action):
            # this very answer, saved by a second click or by the same tap on another tablet at this address: it
            # said nothing there, and its proposal went without a word (lan: two tablets, "Accept" on both)
            s["session-error"] = None
            _say_saved(index, proposal, response, user_action)
        elif other is not None:
            said = app_support.interactions_view(pd.DataFrame([other]))["answer"].iloc[0]  # as the day's table says it
            # the tablet's count has no such number; nor was it "this proposal" that the other screen answered: the
            # tablet said "this proposal was answered meanwhile ... (watch TV, accepted)" under its own hair-dryer
            # proposal, which the researcher's view had not taken over (walkthrough)
            what = (f"another screen recorded an answer first ({other['activity']}, {said})" if tablet else
                    f"interaction {index} was answered meanwhile on another screen ({other['activity']}, {said})")
            s["session-error"] = f"This answer was not saved: {what}. Set what you are doing again for the next one."
        return
    except WriteRefused as exc:  # the database's or its disk's doing, not the participant's: plain words on the tablet
        s["session-error"] = NOT_SAVED if tablet else str(exc)
        s["session-error-detail"] = str(exc) if tablet else None
        return
    except CacasError as exc:
        s["session-error"] = str(exc)
        return
    s["session-error"] = None
    _cancel()
    _say_saved(index, proposal, response, user_action)


def _say_saved(index: int, proposal, response: str | None, user_action: str | None) -> None:
    """Say that the answer to interaction ``index`` was saved, in the words of what was saved."""
    s = st.session_state
    if user_action and request_accepts_proposal(proposal, user_action):
        what = "accepted: that is what the robot offered"
    else:
        what = (f"{'you' if tablet else code} asked: {dialogue.request_words(user_action)}"
                + ("" if tablet else f"; recorded as {user_action}")
                if user_action else RESPONSE_WORDS[ANSWERS[response]] if proposal.robot_speaks else "nothing needed")
    # the participant sees the day's count of recorded interactions, which leaves out unanswered ones: a number
    # here ("Interaction 6" under "5 of about 15") would not match it; the researcher's number is the day's table's
    s["last-saved"] = f"Saved ({what})." if tablet else f"Interaction {index} saved ({what})."
    s["saved-at"] = (time.monotonic(), s["last-saved"])


def _match_request(day: int, index: int, context: str) -> None:
    s = st.session_state
    try:
        m = dialogue.match_request(s.get("request-text", ""))
    except CacasError as exc:
        s["request-error"] = str(exc)
        s.pop("request-match", None)
        if tablet:  # said in place, below the fold at 1024 x 768 (walkthrough): a toast is seen at once
            typed = str(s.get("request-text") or "").strip()
            st.toast(("Sorry, the robot did not understand." if typed else "Type your request first.")
                     + " More below the request.", icon=":material/help:")
        return
    s["request-error"] = None
    s["request-match"] = m.action
    # kept apart from the text field's own state, which Streamlit drops while the field is not shown
    s["request-said"] = s.get("request-text", "")
    if tablet:  # and on the board, where a reload of the tablet finds it (the session is new then)
        board.ask(db, who, Asked(day, index, context, m.action, s["request-said"]))


def _reject_match() -> None:
    s = st.session_state
    s.pop("request-match", None)
    if tablet:
        board.withdraw(db, who)
    s["request-text"] = s.pop("request-said", "")  # back in the field, to be said differently
    s["request-error"] = "Sorry. Pick what you would like from the list, or say it differently."
    if tablet:  # said under the request form, below the fold at 1024 x 768 (walkthrough): a toast is seen at once
        st.toast(s["request-error"], icon=":material/help:")


FOLLOW_EVERY_SECONDS = 3


@st.fragment(run_every=FOLLOW_EVERY_SECONDS)
def _follow_the_tablet(drawn, drawn_shown, drawn_pending) -> None:
    """The researcher's view follows the participant's tablet: once an interaction is saved there (or the
    day is opened, closed or adapted elsewhere), or the tablet shows another proposal, the whole page is
    drawn again, without a reload. The tablet itself is never redrawn under the participant's hands."""
    try:
        now = day_status(store, code)
    except CacasError:  # the participant was removed meanwhile: the whole page says so
        st.rerun()
    if now != drawn or board.shown(db, who) != drawn_shown or board.pending(db, who) != drawn_pending:
        st.rerun()


#: How often a tablet left waiting for the researcher (a day to adapt, preferences to describe) looks again.
WAIT_EVERY_SECONDS = 5


def _waiting_for(now=None) -> tuple | None:
    """What a tablet left waiting shows: the day status (``now``, or read as it stands) and whether it
    waits for the preferences; None once the participant is gone."""
    try:
        now = now or day_status(store, code)
    except CacasError:
        return None
    return now, waiting_for_preferences(store, code, now)


@st.fragment(run_every=WAIT_EVERY_SECONDS)
def _wait_for_the_researcher(drawn: tuple | None) -> None:
    """The tablet left on "Day N is finished" (or "The study has not started yet") moves on by itself
    once the researcher has adapted the robot (described the preferences): it had no button, and only a
    reload of the browser, which a participant does not think of, drew "Start day N" (walkthrough)."""
    if _waiting_for() != drawn:
        st.rerun()


@st.fragment(run_every=WAIT_EVERY_SECONDS)
def _follow_the_day(drawn_day: int) -> None:
    """The tablet on an open day (its context form, or a proposal) is drawn again once the researcher has
    closed that day (or adapted the robot from it, or removed the participant) on their own screen: it kept
    asking "What are you doing?" for a closed day, and what was set then was not used (walkthrough). It
    reruns only then, so what the participant is tapping is never redrawn under their hands meanwhile."""
    try:
        now = day_status(store, code)
    except CacasError:  # the participant was removed meanwhile: the whole page says so
        st.rerun()
    if not now.open or now.day != drawn_day:
        st.rerun()


def _say_a_proposal_its_closed_day_left_unanswered(status) -> None:
    """The address's proposal is of a day closed since it was drawn (the researcher closed the day on their own
    screen) and nobody answered it: said once (kept until the next day starts), and the proposal leaves the
    address. The tablet, drawn again by :func:`_follow_the_day`, showed "Start day N" (or the wait for the
    adaptation) with not a word about the question it had just shown, which nothing saved (walkthrough); an
    answer tapped on it says so (:func:`_record`). An answered proposal's address (the browser's Back) says
    nothing here: the page says it was answered already."""
    token, mark = st.query_params.get("ctx"), st.query_params.get("at")
    try:
        day, index = (int(x) for x in str(mark).split("."))
    except ValueError:
        return
    if not token or (status.open and status.day == day) or day > status.day:
        return
    if recorded_answer(store, code, day, index) is not None:
        return
    _cancel()
    st.session_state["session-error"] = (
        f"The robot's last question was not answered before day {day} was closed, so nothing was saved for it."
        + ("" if status.open or status.finished else " Ask the researcher whether to start the next day.") if tablet else
        f"Day {day} was closed while interaction {index}'s proposal was on this screen, unanswered: nothing was "
        "saved for it.")


def _mark(as_chosen: bool) -> str:
    """The mark beside what the robot recognised: a check where it is what was chosen, a question mark where
    not; a screen reader reads it in words (it read "check icon" and "help icon": ui.icon)."""
    return ui.icon("check", "as chosen") if as_chosen else ui.icon("help", "not as chosen")


def _run_here() -> None:
    st.session_state["run-here"] = True


def _on_the_tablet(shown: Shown) -> None:
    """The researcher's view of the proposal the participant is answering on the tablet, in place of a
    context form of its own for the same interaction."""
    with st.container(border=True):
        st.markdown(f"**On {code}'s tablet now** · interaction {shown.index}, shown at "
                    f"{shown.shown_at}")
        st.caption(f"{shown.activity} {spaces.in_scene(shown.scene)} · {shown.time_slot}"
                   + (f" · {shown.interval} since {code}'s last activity" if shown.interval else ""))
        with st.chat_message("assistant", avatar=":material/smart_toy:"):
            st.markdown(shown.line)
        asked = board.pending(db, who)
        if asked is not None and (asked.day, asked.index) == (shown.day, shown.index):  # typed, awaiting their yes
            with st.chat_message("user", avatar=":material/person:"):
                st.markdown(f"“{asked.said}”")
            words = dialogue.request_words(asked.action)
            other = f" ({asked.action})" if words != asked.action else ""  # the action's name, if other
            ui.noted("hourglass_empty", f"The robot understood: {words}{other}; it waits for {code}'s yes on the "
                                        "tablet.")
        st.caption("The participant answers on the tablet; this page follows it. 'Run it from here instead' opens "
                   "this page's own context form: you set the context and the robot proposes again (the tablet's "
                   "proposal is not taken over). Whichever answer is saved first, here or on the tablet, is kept; "
                   "the other is refused.")
        ui.button(st, "Run it from here instead", _run_here, icon=":material/tablet:")


# --- page -------------------------------------------------------------------------------------------

status = day_status(store, code)
_say_a_proposal_its_closed_day_left_unanswered(status)
if not tablet:
    _follow_the_tablet(status, board.shown(db, who), board.pending(db, who))
# [3, 1] cut "Choose a different activity" at 768 px, and [2, 1] the tablet's larger words ("Hello, P01" is short)
head, back = st.columns([1, 1] if tablet else [2, 1], vertical_alignment="center")
if tablet:
    # no anchor-link icons beside the headings (a heading's link, shown when hovered or tapped near it, is of no
    # use on a tablet: walkthrough)
    # the robot is a decoration: a screen reader reads the heading "Hello, P01" (ui.icon)
    head.markdown(f"# {ui.icon('smart_toy')} Hello, {code}", anchors=False, unsafe_allow_html=True)  # the page's h1
else:
    head.title(f"Study session\u00a0· {code}", anchor=False)  # "·" not first on a line (a phone)
back = back.empty()  # "Choose a different activity" while a proposal is shown: in view, not below the request form
if not tablet:
    with st.expander(f"{code}'s own tablet view (no researcher pages): its address"):
        ui.tablet_address_note(code)

if st.session_state.get("session-error"):
    st.error(st.session_state["session-error"], icon=":material/error:")
    if st.session_state["session-error"] in _PLAIN and st.session_state.get("session-error-detail"):
        with st.expander("For the researcher"):
            st.write(st.session_state["session-error-detail"])
saved = st.session_state.pop("last-saved", None)
if saved:
    st.success(saved, icon=":material/check_circle:")

if not status.open:
    if tablet:
        board.clear(db, who)
        if not status.finished:  # nothing there for the participant to do until the researcher has
            _wait_for_the_researcher(_waiting_for(status))  # as drawn below, not read again
    # the tablet thanks and reassures the participant; the researcher's view says the researcher's next step
    # (walkthrough: it thanked the researcher for taking part, and told them to wait for the researcher)
    if status.finished and tablet:
        st.success(f"All {STUDY_DAYS} days are done. Thank you for taking part!", icon=":material/celebration:")
    elif status.finished:
        st.success(f"All {STUDY_DAYS} days of {code} are done. Next: the satisfaction questionnaire (Section V-B.1), "
                   "on the Results page.", icon=":material/celebration:")
        ui.link("pages/results.py", "Record the questionnaire", ":material/monitoring:")
    elif status.waiting_for_adaptation and tablet:
        st.info(f"Day {status.day} is finished. The robot is learning from it; you can start day "
                f"{status.day + 1} once the researcher has adapted the robot.", icon=":material/hourglass_top:")
    elif status.waiting_for_adaptation:
        st.info(f"Day {status.day} is finished: adapt the robot from it, then {code} can start day "
                f"{status.day + 1} on the tablet.", icon=":material/hourglass_top:")
        ui.link("pages/adaptation.py", "Adapt the robot now", ":material/model_training:")
    elif waiting_for_preferences(store, code, status):
        if tablet:
            st.info("The study has not started yet: the researcher will tell you when.", icon=":material/schedule:")
        else:
            st.warning(f"{code} has no described preferences yet: describe them before day 1 (Section V-B).",
                       icon=":material/warning:")
            ui.link("pages/participants.py", "Describe the preferences", ":material/group:")
    else:
        routine = "your" if tablet else f"{code}'s"  # the tablet speaks to the participant, this view to the researcher
        st.markdown(f"Day **{status.day_on_screen}** of {STUDY_DAYS}: about {TARGET_INTERACTIONS} interactions "
                    f"with the robot, following {routine} daily routine.")
        ui.button(st, f"Start day {status.day_on_screen}", _start_day, type="primary",
                  icon=":material/play_arrow:")
    st.stop()

day = status.day
if tablet:
    _follow_the_day(day)
done = status.interactions_today  # saved today: the next interaction's number is done + 1
# the ~15 a day are interactions the paper records (answered, or asked for): an unanswered one is saved apart,
# and said apart on the researcher's view only (a participant who tapped "Nothing needed" read that their tap
# was "without an answer")
unanswered = status.unanswered_today
# the researcher's view says the count of all the day's interactions too: the number an interaction has here
# ("On P01's tablet now · interaction 4", "Interaction 4 saved") and in the day's table counts them all
# (walkthrough: "interaction 4" beside "2 of about 15" with nothing saying where the other one went)
# One line at 1024-1440 px: which interactions are not counted is said in "Today's interactions", which lists them
# (the reasons in the counter took it to two lines at 1280 px: the ui helper)
st.progress(min(status.recorded_today / TARGET_INTERACTIONS, 1.0),
            text=f"Day {day_of(day)} · {app_support.day_count(status.recorded_today)}"
                 + (f"; {done} in all with {unanswered} not counted" if unanswered and not tablet else ""))

token_ctx = st.query_params.get("ctx")
context = None
if token_ctx:
    try:
        context = Context.from_token(token_ctx)
    except CacasError:
        _cancel()
    else:
        if st.query_params.get("at") != _interaction_mark(day, done + 1):  # answered already (Back), or stale
            context = None
            _cancel()
            # numbered for the researcher only: the tablet's count leaves out unanswered interactions (see _record)
            st.info("That proposal was answered already. Set what you are doing now"
                    + ("." if tablet else f" for interaction {done + 1}."), icon=":material/info:")

reopened = board.shown(db, who, day, done + 1) if tablet and not token_ctx else None
if reopened is not None and reopened.context:
    # the tablet opened again at its plain address (closed and reopened, the address typed again) while its
    # proposal for this interaction awaits an answer: it returns to it (it showed the empty form, and the
    # researcher's view lost the proposal the participant had not answered yet)
    context = Context.from_token(reopened.context)
    ui.set_address(ctx=reopened.context, at=_interaction_mark(day, done + 1))
on_tablet = None if tablet else board.shown(db, who, day, done + 1)
if context is None and on_tablet is not None and not st.session_state.get("run-here"):
    _on_the_tablet(on_tablet)
elif context is None:
    if tablet:
        board.clear(db, who)
    if status.recorded_today >= TARGET_INTERACTIONS:  # on the form only: over a proposal it pushed the request
        # form below the fold at 1024 x 768 (walkthrough)
        if tablet:
            st.info("That's about enough for today, thank you! You may carry on, or stop here.", icon=":material/thumb_up:")
        else:  # the researcher's next step, in the researcher's words (docs and lan walkthroughs: it said the tablet's
            # thanks to the researcher, and no next step)
            st.info(f"{code} has had about {TARGET_INTERACTIONS} interactions today, the day's plan (Section V-B): they "
                    f"may carry on, or stop here. Once they stop, close the day on Adaptation (\"Close day {day} and "
                    "adapt\").", icon=":material/thumb_up:")
            ui.link("pages/adaptation.py", f"Close day {day} on Adaptation", ":material/model_training:")
    # the paper's sub-state names (S1-S4) help the researcher; the participant's tablet goes without
    part = (lambda name: "") if tablet else (lambda name: f" ({name})")
    if not tablet and not board.heard(db, who):
        # after a restart a tablet left open shows its proposal without being drawn: this page cannot know
        ui.noted("info", f"This page has not heard from {code}'s tablet since the app started "
                         f"({app_support.short_time(board.started)}). If the tablet shows a "
                         f"proposal, let {code} answer it there: this page follows it from the tablet's next tap.")
    with st.form("context", border=True):
        st.markdown("## What are you doing?" if tablet else f"## What is {code} doing?",  # the researcher sets it
                    anchors=False)
        # all four chosen every time (Section VI-B: the participant sets S3, S4 and S1): a preset value
        # (the time since the last activity at 20 min; the time of day at the previous interaction's) was kept
        # unnoticed by participants and recorded as theirs. Chips to tap where there are a dozen choices or
        # fewer: a select box is a text field that may raise a tablet's keyboard at each tap (walkthrough)
        st.pills(f"Time of day{part('S3')}", range(spaces.N_SLOTS), key="ctx-slot",
                 format_func=spaces.time_slot_label)
        st.pills(f"Time since {_whose()} last activity{part('S4')}", range(spaces.N_INTERVALS), key="ctx-interval",
                 format_func=spaces.interval_label)  # the bin, as the day's table and the export say it
        c3, _ = st.columns(2)
        # 33: a list to scroll (or type in), not a wall of chips; alphabetical, to be found (Table I's order put
        # "fall down" between "sniff" and "burp")
        c3.selectbox(f"Activity{part('S1')}", sorted(spaces.ACTIVITIES, key=str.lower), index=None,
                     key="ctx-activity", placeholder="choose an activity")
        # a row of its own: in half the width the chips ran off its edge ("dining ro"); Table I's "others" is
        # "another room" to the participant, as the proposal's caption says
        st.pills(f"Room{part('S2')}", spaces.SCENES, key="ctx-scene", format_func=spaces.scene_words if tablet else str)
        ui.button(st, "Do it", _set_context, submit=True, type="primary", icon=":material/play_arrow:",
                  width="stretch")
    _warm_up()  # after the form: it is on the screen meanwhile
else:
    index = done + 1
    clip = clip_for(context, code, day, index, _library("sound", context.activity))
    heard = _recognise("sound", str(clip), ui.model_stamp("sound")) if clip else None
    photo = clip_for(context, code, day, index, _library("scene", context.scene))  # what the robot's camera sees
    seen = _recognise("scene", str(photo), ui.model_stamp("scene")) if photo else None
    if status.policy_version is None and not initial_policy_ready():
        # first use on this machine: the initial policy is trained once, in the background
        job, _ = RUNNER.start("initial-policy", prepare_initial_policy, label="The robot is getting ready (first use only)")
        if job.status == FAILED:
            st.error(f"The robot could not get ready: {job.error}")
        else:
            ui.job_progress("initial-policy")
        st.stop()
    try:
        with st.spinner("The robot is getting ready..."):
            in_force = store.active_policy(code)
            # the policy this interaction was first proposed with: one put in force meanwhile (Adaptation page) is
            # "in force from the next interaction", and the robot's line stays the one the participant is answering
            held_version, held_sha256 = board.policy_for(db, who, day, index, context.to_token(),
                                                         (in_force.version, in_force.sha256) if in_force else (None, None))
            policy, version = ui.policy_version(ui.db_path(), code, held_version, held_sha256)
    except CacasError as exc:
        st.error(f"The robot's policy cannot be loaded ({exc}). The researcher can put another version in force "
                 "on the Adaptation page.", icon=":material/error:")
        st.stop()
    proposal = propose(policy, context, previous_interaction(store, code, day),
                       heard=heard.label if heard else None, heard_confidence=heard.confidence if heard else None,
                       policy_version=version, seen=seen.label if seen else None,
                       sound_model=heard.model if heard else None, scene_model=seen.model if seen else None,
                       draws=proposal_draws(code, day, index, held_sha256))
    if tablet:  # the researcher's view shows it, and offers no second form for this interaction
        board.show(db, who, Shown(day, index, context.activity, context.scene,
                                   spaces.time_slot_label(context.time_slot), proposal.action, proposal.line,
                                   spaces.interval_label(context.interval_bin), context.to_token()))

    left, right = st.columns([1, 1])
    # each card says what it is about and its name on one line: the name under a heading of its own took the
    # room the tablet's larger buttons need at 1024 x 768 (walkthrough)
    with left.container(border=True, key="card-activity"):
        st.markdown(f"## {'Your' if tablet else _whose()} activity: {context.activity}", anchors=False)
        st.caption(f"{spaces.in_scene(context.scene)} · {spaces.time_slot_label(context.time_slot)} · "
                   f"{spaces.interval_label(context.interval_bin)} since {_whose()} last activity")
        if clip:
            st.audio(str(clip), format=audio_mime(clip), autoplay=True)
        else:
            st.caption("No sound clip for this activity in the library.")
    with right.container(border=True, key="card-heard"):
        if heard:
            st.markdown(f"## The robot heard: {heard.label} {_mark(heard.label == context.activity)}", anchors=False,
                        unsafe_allow_html=True)
            if heard.unsure:  # under a check mark, "not sure it heard that right" read as a contradiction
                st.caption(ui.icon("help") + " " + ("The robot was not sure, but it heard that right."
                                                 if heard.label == context.activity else
                                                 "The robot is not sure it heard that right."), unsafe_allow_html=True)
            if not tablet:  # the participant sees plain labels; the researcher the numbers
                st.caption("Also possible: " + ", ".join(f"{a} {share}" for a, share in heard.top3_words[1:]) +
                           f" · confidence {heard.percent}%")
        else:
            st.markdown(f"## The robot heard: {context.activity}", anchors=False)
            st.caption("No sound model: the robot uses the activity as chosen.")
        if seen:
            unsure = " (not sure)" if seen.unsure else ""
            st.markdown(f"and sees the **{seen.label}** {_mark(seen.label == context.scene)}{unsure}" +
                        ("" if tablet else f" ({seen.percent}%)"), unsafe_allow_html=True)

    with st.chat_message("assistant", avatar=":material/smart_toy:"):
        st.markdown(f"**{proposal.line}**")

    if tablet and not st.session_state.get("request-match"):
        kept = board.asked(db, who, day, index, context.to_token())
        if kept is not None:  # the tablet was reloaded while its request awaited the participant's "Yes"
            st.session_state["request-match"], st.session_state["request-said"] = kept.action, kept.said
    matched = st.session_state.get("request-match")
    if matched:
        # the robot's question about a typed request comes where its proposal's buttons were, in view on a
        # tablet (below the request form it was under the fold at 1024 x 768): said, then asked, then answered
        said = st.session_state.get("request-said", "")
        with st.chat_message("user", avatar=":material/person:"):
            st.markdown(said)
        with st.chat_message("assistant", avatar=":material/smart_toy:"):
            st.markdown(dialogue.confirmation_line(matched, proposal.heard, said))
        # side by side also on a phone (app.TABLET_STYLE: tablet-row-*)
        y, n, _ = st.container(key="tablet-row-confirm").columns([1, 1, 2])
        # ui.button: a tap is not lost after a server restart (a new session's first click runs no callback)
        ui.button(y, "Yes, please", _record, args=(day, index, proposal), kwargs={"user_action": matched},
                  type="primary", icon=":material/check:", width="stretch")
        ui.button(n, "No", _reject_match, icon=":material/close:", width="stretch")
    else:
        if proposal.robot_speaks:
            b1, b2, b3 = st.container(key="tablet-row-answers").columns(3)  # side by side on a phone too
            # the three answers look alike: a highlighted "Accept" would nudge the participant's feedback
            ui.button(b1, "Accept", _record, args=(day, index, proposal, "accept"), icon=":material/thumb_up:",
                      width="stretch")
            ui.button(b2, "Reject", _record, args=(day, index, proposal, "reject"), icon=":material/thumb_down:",
                      width="stretch")
            ui.button(b3, "No response", _record, args=(day, index, proposal, "no response"),
                      icon=":material/do_not_disturb_on:", width="stretch")
        else:
            ui.button(st, "Nothing needed", _record, args=(day, index, proposal, "no response"),
                      icon=":material/check:")

        with st.container(border=True):
            # the tablet speaks to the participant; the researcher's view to the researcher, who records what the
            # participant asked for (it said "Or ask the robot yourself" there too: walkthrough)
            st.markdown("**Or ask the robot yourself**" if tablet else f"**Or record what {code} asked for**")
            c1, c2 = st.columns([3, 1], vertical_alignment="bottom")
            pick = c1.selectbox("Pick an action", list(dialogue.REQUESTS), index=None, key="request-pick",
                                format_func=dialogue.REQUESTS.get,
                                placeholder="choose what you would like" if tablet else f"choose what {code} asked for")
            ui.button(c2, "Ask" if tablet else "Record", _record, args=(day, index, proposal),
                      kwargs={"user_action": pick}, icon=":material/record_voice_over:", disabled=pick is None,
                      width="stretch")
            # a form: Enter (a tablet keyboard's Go) says it as the button does (walkthrough: it did nothing),
            # and leaving the field for the list above does not
            with st.form("request-form", border=False, enter_to_submit=True):
                c3, c4 = st.columns([3, 1], vertical_alignment="bottom")
                c3.text_input("Or type your request" if tablet else f"Or type {code}'s request, in their words",
                              key="request-text", placeholder="e.g. remind me to turn off the stove")
                ui.button(c4, "Say it", _match_request, args=(day, index, context.to_token()), submit=True,
                          icon=":material/chat:", width="stretch")
            if st.session_state.get("request-error"):
                st.warning(st.session_state["request-error"], icon=":material/help:")
    ui.button(back, "Choose a different activity", _cancel, icon=":material/arrow_back:", width="stretch")

if done and not tablet:
    # a key keeps it open while the count in its label follows the tablet
    with st.expander(f"Today's interactions ({status.recorded_today} recorded"
                     + (f", {unanswered} not counted)" if unanswered else ")"), key="today-interactions"):
        if unanswered:  # what the counter above leaves out, and why (Section V-B, IV-C.1)
            st.caption(f"Not counted toward the ~{TARGET_INTERACTIONS}: no response, nothing needed while the robot "
                       "was quiet, or a request while doing nothing.")
        today = store.interactions_frame(code, method=None, extra=True)
        view = app_support.interactions_view(today[today["day"] == day]).drop(columns="day")  # one day: room for
        # the answer. The words first: a number needs little room, an answer ("asked for remind to take medicine")
        # much (walkthrough at 1280 px: "asked for pa…", "use hair dry…" cut while "#" had room to spare); what the
        # robot heard and saw only when a recogniser was used (else every row says "(as set)")
        view = view.drop(columns=[c for c in ("robot heard", "robot saw") if (view[c] == app_support.AS_SET).all()])
        # what happened first, then where and when (walkthrough at 1024 px beside the sidebar: the answer was
        # scrolled out of a 560 px table, behind the time, the interval and the room)
        first = ["#", "activity", "robot proposed", "answer"]
        view = view[first + [c for c in view.columns if c not in first]]
        # every column in view at 1280 px, names whole (table_layouts.today_table_layout)
        widths, row_height = table_layouts.today_table_layout(view.columns)
        st.dataframe(view, hide_index=True, width="stretch", row_height=row_height, column_config={
            c: (st.column_config.NumberColumn if c == "#" else st.column_config.TextColumn)(
                "since last" if c == "since last activity" else None, width=w) for c, w in widths.items()})
