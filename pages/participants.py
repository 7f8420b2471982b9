"""Participants: pseudonymous codes, age range, notes, and the 5 preferences each one describes."""

import streamlit as st

from cacas import app_support, preference_form, spaces, table_layouts
from cacas.preferences import persona_json
from cacas.errors import CacasError, one_a_line
from cacas.jobs import RUNNER
from cacas.store.people import DetailsChanged, PreferencesChanged
from cacas.study_day import day_status
from pages import ui

ui.require_app()

store = ui.store()
study = ui.study()
code = ui.participant()

st.title("Participants", anchor=False)
st.caption("Participants are known by pseudonymous codes only (e.g. P01), never by name. Each one describes "
           "5 preferences, as the paper's participants did (more or fewer can be saved): in which context they want "
           "which robot action. The robot never sees them; "
           "they drive the simulated participant and the evaluation of Fig. 4 (Su & Sheng, Section V-B).")

ANY = "(choose an action)"
OPEN_TAB = "participants-open-tab"
#: participant -> {interval slider key: range} put back by "Put version n on the form": a range
#: slider takes its starting range from value=, never from the session (see the slider below)
RESTORED = "participants-restored-intervals"


# --- callbacks: validate everything first, write once --------------------------------------------

def _add_participant() -> None:
    s = st.session_state
    sent = (str(s["new-code"]).strip(), s["new-age"], s["new-notes"], study)
    added = s.get("just-added")
    if added is not None and added[:4] == sent and _untouched(added[0], added[4]):
        # the same form again, e.g. a double click: the first click added them (walkthrough: the second
        # said 'already exists' in red and stayed on this tab, so the add looked failed)
        _open_new(added[0])
        return
    try:
        info = store.add_participant(s["new-code"], age_range=s["new-age"], notes=s["new-notes"], study=study)
    except CacasError as exc:
        s["add-error"] = str(exc)
        return
    s["just-added"] = (info.code, *sent[1:], info.created_at)
    _open_new(info.code)
    st.toast(f"Participant {info.code} added: describe their preferences below.", icon=":material/check_circle:")


def _untouched(code: str, created_at: str) -> bool:
    """``code`` is the participant this session added (the same one: not removed and added again
    since) and has no preferences and no study day yet."""
    try:
        info = store.get_participant(code)
    except CacasError:
        return False
    return info.created_at == created_at and store.get_preferences(code) is None and not store.days(code)


def _open_new(code: str) -> None:
    """Clear the add form and open the new participant's preferences, the next step."""
    s = st.session_state
    s["add-error"] = None
    ui.select_participant(code)
    s["new-code"], s["new-age"], s["new-notes"] = "", "", ""
    s[OPEN_TAB] = f"Preferences of {code}"


def _update_details(who: str) -> None:
    s = st.session_state
    try:
        store.update_participant(who, age_range=s[f"age-{who}"], notes=s[f"notes-{who}"],
                                 drawn=s.get(f"details-drawn-{who}"))
    except DetailsChanged as exc:  # the form shows the saved details next, to be changed again
        _refill_details(who)
        s["details-error"] = f"{str(exc)[0].upper()}{str(exc)[1:]}. The form now shows them: make your changes again."
        return
    except CacasError as exc:
        s["details-error"] = str(exc)
        return
    s["details-error"] = None
    _refill_details(who)  # the form shows what is saved now: another tab's change to the other field too
    st.toast(f"Details of {who} saved.", icon=":material/check_circle:")


def _refill_details(who: str) -> None:
    """``who``'s details form is filled afresh from the store at its next drawing."""
    for key in (f"age-{who}", f"notes-{who}", f"details-drawn-{who}"):
        st.session_state.pop(key, None)


def _form_key(who: str, version: int, n: int, field: str) -> str:
    """The session key of a preference-form widget: slot ``n``'s ``field`` (slot 0: the count)."""
    return f"{ui.FORM_KEY_PREFIX}{who}-v{version}-{n}-{field}"


def _count_key(who: str, version: int) -> str:
    return _form_key(who, version, 0, "count")


def _form_owner(key) -> tuple[str, str] | None:
    """(participant, version) of a preference-form key, None for another key. Read from the right:
    a code may itself hold "-" or "-v"."""
    key = str(key)
    if not key.startswith(ui.FORM_KEY_PREFIX):
        return None
    who_version = key[len(ui.FORM_KEY_PREFIX):].rsplit("-", 2)[0]
    who, _, version = who_version.rpartition("-v")
    return (who, version) if who else None


FIELDS = ("words", "activity", "scene", "slots", "interval", "action")


def _interval_bin(minutes: int) -> str:
    """An S4 mark of the form's slider (a bin's lower end in minutes, as the persona file's ``interval``
    holds it) as the tablet names that bin: 30 -> "30-60 min" (Table I)."""
    return spaces.interval_label(spaces.INTERVAL_BINS.index(minutes))


def _form_start(existing: list, version: int, who: str) -> dict:
    """What the form of ``who``'s saved ``version`` shows before any change: key -> value."""
    start = {_count_key(who, version): max(5, len(existing))}
    for n in range(1, max(10, len(existing)) + 1):
        old = existing[n - 1] if n <= len(existing) else None
        values = ((old.description or "", list(old.activity), list(old.scene or []),
                   preference_form.hours_to_slots(old.hours), preference_form.interval_to_bins(old.interval),
                   old.action) if old is not None else
                  ("", [], [], [], preference_form.interval_to_bins(None), ANY))
        start.update({_form_key(who, version, n, f): v for f, v in zip(FIELDS, values)})
    return start


def _form_items(values, who: str, version: int, count: int, tasks: dict) -> tuple[list[dict], list[int]]:
    """The preference dicts the form's first ``count`` slots hold (untouched slots left out), and
    their slot numbers; ``values`` maps widget keys to values (the session, or the saved start)."""
    items, numbers = [], []
    for n in range(1, count + 1):
        k = lambda f: _form_key(who, version, n, f)  # noqa: E731
        action = values[k("action")]
        item = preference_form.preference_from_form(
            values[k("words")], values[k("activity")], values[k("scene")], values[k("slots")], values[k("interval")],
            None if action == ANY else action, tasks.get(n))
        if item is not None:
            items.append(item)
            numbers.append(n)
    return items, numbers


def _drop_form(who: str) -> None:
    """Forget ``who``'s form (every version's): it is re-filled from the saved preferences."""
    s = st.session_state
    for key in [k for k in s if (_form_owner(k) or ("",))[0] == who]:
        del s[key]
    s.setdefault(ui.UNSAVED_FORMS_KEY, {}).pop(who, None)
    s.setdefault(RESTORED, {}).pop(who, None)


def _is_interval(key) -> bool:
    return str(key).endswith("-interval")


def _form_values(who: str, version) -> dict:
    """What ``who``'s form of ``version`` holds now (lists as tuples, so values compare equal
    whichever a widget returned)."""
    s = st.session_state
    return {k: tuple(s[k]) if isinstance(s[k], list) else s[k]
            for k in s if _form_owner(k) == (who, str(version))}


def _save_preferences(who: str, version: int, count: int, tasks: dict) -> None:
    s = st.session_state
    items, numbers = _form_items(s, who, version, count, tasks)
    person, errors, overall = preference_form.check_preferences(who, items, numbers)
    # shown on this participant's form only, and only while the form holds what was checked
    s["pref-check"] = (who, errors, overall, _form_values(who, version))
    if person is None:
        return
    try:
        new_version = store.save_preferences(who, person, edited_version=version)
    except PreferencesChanged as exc:  # the form is of an older version now: it shows the latest next
        s.pop("pref-check", None)
        s["pref-conflict"] = (who, f"{str(exc)[0].upper()}{str(exc)[1:]}. The form now shows the latest version: "
                                   "make your changes again on it.")
        return
    except CacasError as exc:
        s["pref-check"] = (who, {}, str(exc), _form_values(who, version))
        return
    s.pop("pref-check", None)
    _drop_form(who)  # saved: the form shows the saved version again
    s["pref-saved"] = (who, new_version, len(person.preferences), person.covered_count())
    # the page may be scrolled to the form's end, far from the banner at its top
    st.toast(f"Saved version {new_version} of {who}'s preferences.", icon=":material/check_circle:")


def _restore_version(who: str, version: int, old: int) -> None:
    """Put saved version ``old`` of ``who``'s preferences on the form of the version in force, as
    unsaved changes: saving it makes it the newest version (nothing is overwritten)."""
    s = st.session_state
    earlier = store.get_preferences(who, version=old)
    _drop_form(who)
    start = _form_start(list(earlier.preferences), version, who)
    s.update({k: v for k, v in start.items() if not _is_interval(k)})
    s[RESTORED][who] = {k: v for k, v in start.items() if _is_interval(k)}
    s.pop("pref-check", None)
    st.toast(f"Version {old} is on the form: save it to make it {who}'s preferences again.", icon=":material/history:")


def _discard_changes(who: str) -> None:
    _drop_form(who)
    st.session_state.pop("pref-check", None)
    st.toast(f"Changes to {who}'s preferences discarded.", icon=":material/undo:")


def _import_personas() -> None:
    s = st.session_state
    _forget_import()
    upload = s.get("persona-upload")
    if upload is None:
        s["import-error"] = "choose a persona file (.json) first"
        return
    try:
        done = store.import_personas(upload.getvalue(), study=study, source=upload.name,
                                     replace=bool(s.get("persona-replace")))
    except CacasError as exc:
        s["import-error"] = one_a_line(exc)  # a persona file's problems one a line
        return
    # the page opens the first participant's preferences: the toast says it there, and the Import tab
    # keeps its message for when the researcher comes back to it (until the next import or file)
    s["import-done"] = app_support.personas_imported(done, upload.name)
    st.toast(s["import-done"], icon=":material/check_circle:")
    codes = done.codes
    if codes:
        ui.select_participant(codes[0])
        s[OPEN_TAB] = f"Preferences of {codes[0]}"


def _forget_import() -> None:
    """The last import's message (done or refused) is of the file it was given: gone once another
    file is chosen, or imported."""
    st.session_state["import-error"] = st.session_state["import-done"] = None


def _create_study() -> None:
    """Create the study and switch the sidebar to it (callbacks run before the sidebar is drawn)."""
    s = st.session_state
    try:
        new = store.create_study(s["new-study-name"], s["new-study-description"])
    except CacasError as exc:
        s["study-error"] = str(exc)
        return
    s["study-error"] = None
    s[ui.STUDY_KEY] = new.name
    ui.select_participant(None)
    s["new-study-name"] = s["new-study-description"] = ""
    s[OPEN_TAB] = "Add a participant"  # the next step: its participants
    st.toast(f"Study {new.name!r} created and selected: add its participants.", icon=":material/check_circle:")


def _remove_participant(who: str) -> None:
    """Remove ``who`` and everything recorded about them (the store checks the typed code); the
    sidebar moves to the next participant of the study (callbacks run before it is drawn)."""
    s = st.session_state
    if _adapting(who):  # begun in another tab since this page was drawn with the button enabled
        s["remove-error"] = (who, f"A policy is being adapted for {who} (begun since this page was drawn): "
                                  "remove them once it has finished (Adaptation page). Nothing was removed.")
        return
    codes = [p.code for p in store.list_participants(study)]
    try:
        gone = store.remove_participant(who, s.get(f"remove-confirm-{who}", ""))
    except CacasError as exc:
        s["remove-error"] = (who, str(exc))
        return
    s.pop("remove-error", None)
    _drop_form(who)
    for key in (f"age-{who}", f"notes-{who}", f"details-drawn-{who}", f"old-version-{who}", f"remove-confirm-{who}"):
        s.pop(key, None)  # nothing typed about them stays in this tab either
    for key in ("pref-check", "pref-saved"):
        if (s.get(key) or ("",))[0] == who:
            del s[key]
    rest = [c for c in codes if c != who]
    after = [c for c in rest if c > who]
    ui.select_participant(after[0] if after else (rest[-1] if rest else None))
    s.pop(OPEN_TAB, None)
    s["removed"] = (who, _kept_note(gone))
    st.toast(f"Participant {who} removed, with everything recorded about them." if not gone.kept_files else
             f"Participant {who} removed. Some of their policy files stay: see the note at the top of the page.",
             icon=":material/delete:")


def _adapting(who: str) -> bool:
    """Whether a policy is being adapted for ``who`` (the Adaptation page's job, in any tab)."""
    return any(j.key.startswith(f"adapt:{ui.db_path()}:{who}:") for j in RUNNER.running())


def _kept_note(footprint) -> str:
    """What the removal leaves of the participant's policy files, and why; "" if nothing."""
    k = footprint.kept_files
    return f"{k} policy file{'' if k == 1 else 's'} of {footprint.code} stay{'s' if k == 1 else ''}: " \
           f"{footprint.kept_because}." if k else ""


def _removal_section(who: str) -> None:
    """What removing ``who`` deletes, the code to type, and the button (enabled once it matches)."""
    left = store.participant_footprint(who)

    def n(count: int, what: str) -> str:
        return f"{count} {what}{'' if count == 1 else 's'}"

    st.markdown(f"For a participant who withdraws from the study, or a code added by mistake. This deletes {who} "
                f"and everything recorded about them, for good: {n(left.days, 'study day')}, "
                f"{n(left.interactions, 'interaction')}, {n(left.preference_versions, 'preference version')}, "
                f"{n(left.policy_versions, 'policy version')} ({n(left.policy_files, 'file')}), "
                f"{n(left.adaptation_runs, 'adaptation run')}, {n(left.questionnaire_answers, 'questionnaire answer')} "
                f"and their {n(left.events, 'event')} in the log, which keeps one entry: '{who} removed'.")
    st.caption("Not linked to the participant, so not removed here (delete by hand what holds them): exports and "
               "persona files downloaded before; Simulation lab runs of this study's participants (their code and "
               "the contexts and actions of their preferences, not their words; runs/ beside the database); photos "
               "and recordings added to the scene and sound libraries, and the models trained on them. "
               + _kept_note(left))
    if left.open_day is not None:
        st.warning(f"Day {left.open_day} is open ({n(left.open_day_interactions, 'interaction')} so far): removing "
                   f"{who} ends it and deletes it with the rest; their tablet then says its address names no "
                   "participant.", icon=":material/warning:")
    busy = _adapting(who)
    if busy:
        st.info(f"A policy is being adapted for {who}: remove them once it has finished (Adaptation page).",
                icon=":material/hourglass_top:")
    typed = st.text_input(f"Type {who} to confirm", key=f"remove-confirm-{who}", disabled=busy)
    ui.button(st, f"Remove {who}", _remove_participant, args=(who,), type="secondary", icon=":material/delete:",
              key=f"remove-{who}", disabled=busy or typed != who)
    error = st.session_state.get("remove-error")
    if error and error[0] == who:
        st.error(error[1], icon=":material/error:")


# --- page -------------------------------------------------------------------------------------------

def preferences_grid(table, room: int) -> None:
    """A participant's saved preferences (:func:`preference_form.preferences_table`) with every column in
    view in ``room`` px at 1280 px (:func:`table_layouts.preferences_table_layout`): it scrolled sideways."""
    widths, row_height = table_layouts.preferences_table_layout(table.columns, room)
    headings = table_layouts.PREFERENCES_HEADINGS
    st.dataframe(table, hide_index=True, width="stretch", row_height=row_height, column_config={
        c: (st.column_config.NumberColumn if c in ("#", "covered states") else st.column_config.TextColumn)(
            headings.get(c), width=w, **({"format": "%d"} if c == "covered states" else {}),
            help={"since last activity": "Since the last activity (S4)",
                  "covered states": "The S1-S4 states the preference covers"}.get(c))
        for c, w in widths.items()})


people = store.list_participants(study)
removed = st.session_state.pop("removed", None)
if removed:
    st.success(f"Participant {removed[0]} was removed, with everything recorded about them"
               + (f"; {code} is selected now." if code else "."), icon=":material/check_circle:")
    if removed[1]:
        st.warning(removed[1], icon=":material/folder_open:")
# Always four tabs, in the same places, with or without a participant. After adding or importing
# participants the callbacks open the first one's preferences tab, and the browser's tabs follow a
# tab the page opens only when it stands at another place than the one the page opened last: it
# keeps the tab it shows if a tab of that name is still there. With no participant, the tabs were
# only "Add a participant" and "Import / export", so adding the first participant asked for place 0
# ("Preferences of P01"), the place "Add a participant" had had, and a browser that drew the new
# tabs in one go stayed on "Add a participant" (CI; a page of these tabs alone did so in 5 of 12 tries
# with the browser slowed 20x, and 0 of 12 with the tabs always four).
tab_names = ([f"Preferences of {code}", f"Details of {code}"] if code else ["Preferences", "Details"]) + [
    "Add a participant", "Import / export"]
if st.session_state.get(OPEN_TAB) not in tab_names:  # e.g. another participant chosen in the sidebar
    st.session_state.pop(OPEN_TAB, None)
if not code:  # nobody to show: the next step is adding someone
    st.session_state.setdefault(OPEN_TAB, "Add a participant")
tabs = dict(zip(tab_names, st.tabs(tab_names, key=OPEN_TAB, on_change="rerun")))

if code:
    saved = store.get_preferences(code)
    versions = store.preference_versions(code)
    version = versions[-1]["version"] if versions else 0
    with tabs[f"Preferences of {code}"]:
        done = st.session_state.pop("pref-saved", None)
        if done and done[0] == code:
            st.success(f"Saved version {done[1]} of {code}'s preferences: {done[2]} "
                       f"preference{'s' if done[2] != 1 else ''} covering {done[3]:,} states.",
                       icon=":material/check_circle:")
        if saved is not None:
            n_prefs = len(saved.preferences)
            states = spaces.N_ACTIVITIES * spaces.N_SCENES * spaces.N_SLOTS * spaces.N_INTERVALS
            st.markdown(f"**Saved (version {version})** · {n_prefs} preference{'s' if n_prefs != 1 else ''} covering "
                        f"**{saved.covered_count():,}** of the {states:,} S1-S4 states "
                        "(the paper counts 1,564 on average for 5 preferences).")
            preferences_grid(preference_form.preferences_table(saved), table_layouts.PREFERENCES_TABLE_ROOM)
            for note in preference_form.redundancy_notes(saved):
                st.warning(note, icon=":material/content_copy:")
            earlier = [v for v in versions if v["version"] != version]
            if earlier:
                with st.expander(f"Earlier versions ({len(earlier)}): every saved version is kept"):
                    labels = {v["version"]: f"version {v['version']} · saved {app_support.short_time(v['created_at'])}"
                                            f" · {v['count']} preference{'s' if v['count'] != 1 else ''}"
                              for v in reversed(earlier)}
                    old = st.selectbox("Version", list(labels), format_func=labels.get, key=f"old-version-{code}")
                    before = store.get_preferences(code, version=old)
                    preferences_grid(preference_form.preferences_table(before), table_layouts.EARLIER_PREFERENCES_ROOM)
                    if any(p.task for p in before.preferences):
                        st.caption("This version has preferences limited to robot tasks (from an imported file), "
                                   "which the form cannot hold: import that file again to restore it.")
                    else:
                        ui.button(st, f"Put version {old} on the form", _restore_version,
                                  args=(code, version, old), icon=":material/history:",
                                  help="It becomes unsaved changes below: save them to make it the newest version.")
        else:
            st.info(f"{code} has no preferences yet. Describe them below, in the participant's own words.")

        existing = list(saved.preferences) if saved is not None else []
        owners = {_form_owner(k) for k in st.session_state}
        stale = {v for who, v in filter(None, owners) if who == code and v != str(version)}
        if stale:  # e.g. a persona file imported meanwhile: the form would edit a version no longer in force
            was_unsaved = st.session_state.get(ui.UNSAVED_FORMS_KEY, {}).get(code)
            _drop_form(code)
            conflict = st.session_state.pop("pref-conflict", None)
            if conflict and conflict[0] == code:
                st.error(conflict[1], icon=":material/error:")
            elif was_unsaved:
                st.warning(f"Changes typed on the form of version {', '.join(sorted(stale))} were not saved: "
                           f"version {version} of {code}'s preferences was saved meanwhile (e.g. by an import), "
                           "and the form now shows it.", icon=":material/warning:")
        # what each widget starts from: the saved version, or an earlier one put back on the form
        start = {**_form_start(existing, version, code), **st.session_state.get(RESTORED, {}).get(code, {})}
        for key, value in start.items():  # widgets take their values from the session, filled once
            if not _is_interval(key):  # a range slider's starting range is its value= (below)
                st.session_state.setdefault(key, value)
        form_now = {**start, **{k: st.session_state[k] for k in st.session_state
                                if _form_owner(k) == (code, str(version))}}
        most = max(10, len(existing), int(st.session_state[_count_key(code, version)]))  # a restored version's
        count = int(st.number_input("Preferences on the form", min_value=1, max_value=most,
                                    key=_count_key(code, version),
                                    help="The paper asks each participant for 5; an imported file may have more."))
        if count < len(existing):  # the slots left off the form are not saved with it
            gone = range(count + 1, len(existing) + 1)
            st.warning(f"Preference{'s' if len(gone) > 1 else ''} {', '.join(map(str, gone))} of the saved version "
                       f"{'are' if len(gone) > 1 else 'is'} not on the form: saving removes "
                       f"{'them' if len(gone) > 1 else 'it'} from the participant's preferences (version {version} "
                       "stays in the database).", icon=":material/warning:")
        checked, errors, overall, seen = st.session_state.get("pref-check") or (None, {}, None, None)
        # messages about another participant's form stay with it; a changed form is not what was checked
        if checked != code or seen != _form_values(code, version):
            errors, overall = {}, None
        tasks = {n: list(old.task) for n, old in enumerate(existing, 1) if old.task}
        # not an st.form: a form sends nothing before its button, and leaving the page lost what was typed
        unsaved = (_form_items(form_now, code, version, count, tasks)
                   != _form_items(_form_start(existing, version, code), code, version, len(existing), tasks))
        st.session_state.setdefault(ui.UNSAVED_FORMS_KEY, {})[code] = unsaved
        # one caption whatever the state: an element appearing above the form would shift the widgets
        # below it while the researcher clicks them (and Streamlit would redraw them, closing an open list)
        if unsaved:
            ui.noted("edit_note", f"**Unsaved changes to {code}'s preferences**: they are kept while you open other "
                                  "pages or participants in this browser tab, until you save or discard them below; "
                                  "a reload loses them.")
        else:
            ui.noted("info", "Changes on this form are kept while you open other pages or participants in this "
                             "browser tab, until you save or discard them; a reload loses them.")
        for n in range(1, count + 1):
            k = lambda f: _form_key(code, version, n, f)  # noqa: E731
            old = existing[n - 1] if n <= len(existing) else None
            with st.container(border=True):
                st.markdown(f"**Preference {n}**")
                st.text_input("In the participant's words", key=k("words"),
                              placeholder="e.g. When I use the stove, remind me to turn it off.")
                c1, c2 = st.columns(2)
                c1.multiselect("Activities (S1)", spaces.ACTIVITIES, key=k("activity"),
                               placeholder="one or more sound activities")
                c2.multiselect("Rooms (S2)", spaces.SCENES, key=k("scene"), placeholder="any room")
                c3, c4 = st.columns(2)
                c3.multiselect("Time of day (S3)", list(range(spaces.N_SLOTS)), format_func=spaces.time_slot_label,
                               key=k("slots"), placeholder="any time")
                # value= (a pair) makes it a range slider, so its value is never set through the session
                # (Streamlit warns when both are); persist_state keeps it while other pages are open
                # each mark is one of Table I's S4 bins, read as the tablet and the day's table say it: "0" to "30"
                # read as "within 30 minutes" but takes in 30-59 min, the bin the tablet calls "30-60 min"
                c4.select_slider("Minutes since the last activity (S4)", options=list(spaces.INTERVAL_BINS),
                                 value=start[k("interval")], key=k("interval"), persist_state="session",
                                 format_func=_interval_bin,
                                 help="From one S4 bin to another, both included, as the tablet offers them "
                                      "(0-1 min ... 200+ min). The whole range means any interval.")
                st.selectbox("The robot should (action)", [ANY, *spaces.ACTIONS], key=k("action"))
                if n in tasks:
                    st.caption(f"Only while the robot is busy with: {', '.join(tasks[n])} (from the imported file).")
                if n in errors:
                    st.error(f"Preference {n}: {errors[n]}", icon=":material/error:")
                elif old is not None:
                    st.caption(f"Covers {old.covered_count():,} states.")
                elif existing:  # the paper's 5 slots after fewer saved: said what they are (walkthrough: after
                    # saving 3, "Preferences on the form: 5" and two blank blocks, as if something was left undone)
                    st.caption(f"A slot for one more preference ({app_support.counted(len(existing), 'preference')} "
                               "saved; the paper asks for 5): saved if filled in, left out if empty.")
        if overall:  # an overlap among the valid ones, said with the others' errors (one round of fixes)
            st.error(overall, icon=":material/error:")
        if errors:  # the messages sit with their preferences, maybe far above this button
            bad = sorted(errors)
            st.error(f"Not saved: preference{'s' if len(bad) > 1 else ''} {', '.join(map(str, bad))} "
                     f"need{'' if len(bad) > 1 else 's'} fixing (the message is under "
                     f"{'each' if len(bad) > 1 else 'it'} above)"
                     + (", and so does the overlap just above." if overall else "."), icon=":material/error:")
        c1, c2 = st.columns([1, 1])
        ui.button(c1, "Save preferences", _save_preferences, args=(code, version, count, tasks), type="primary",
                  icon=":material/save:", key=f"save-prefs-{code}")
        if unsaved:
            ui.button(c2, "Discard changes", _discard_changes, args=(code,), icon=":material/undo:",
                      key=f"discard-{code}")
            started = day_status(store, code).day
            if started and existing:  # mid-study: Fig. 4's scores change version from here on
                ui.noted("warning", f"{code} is on day {started} of the study. Saved, these preferences score the "
                                    "policies adapted from now on (Fig. 4, the Adaptation page); the days before keep "
                                    f"their scores against version {version}.")

    with tabs[f"Details of {code}"]:
        info = store.get_participant(code)
        if f"age-{code}" not in st.session_state:  # the form is filled afresh: what it was drawn with (the store's check)
            st.session_state[f"details-drawn-{code}"] = (info.age_range, info.notes)
        with st.form(f"details-{code}", border=True):
            st.text_input("Age range", value=info.age_range, key=f"age-{code}", placeholder="e.g. 25-34 or 65+")
            st.text_area("Notes (no names or contact details)", value=info.notes, key=f"notes-{code}")
            if st.session_state.get("details-error"):
                st.error(st.session_state["details-error"], icon=":material/error:")
            ui.button(st, "Save details", _update_details, args=(code,), submit=True)
        st.caption(f"Added {app_support.short_time(info.created_at)} · study {info.study} · tablet address:")
        ui.tablet_address_note(code)
        with st.expander(f"Remove {code}", icon=":material/person_remove:"):
            _removal_section(code)

if not code:
    for name in ("Preferences", "Details"):
        with tabs[name]:
            st.info("No participant is selected: add one (Add a participant) or import a persona file (Import / "
                    f"export){' or choose one in the sidebar' if people else ''}.", icon=":material/person_search:")

with tabs["Add a participant"]:
    with st.form("add-participant", border=True):
        st.text_input("Pseudonymous code", key="new-code", placeholder="P01",
                      help="1-16 letters A-Z (no accents), digits, '-' or '_'. Never a name.")
        st.text_input("Age range", key="new-age", placeholder="e.g. 25-34 or 65+ (optional)")
        st.text_area("Notes", key="new-notes", placeholder="Optional; no names or contact details")
        if st.session_state.get("add-error"):
            st.error(st.session_state["add-error"], icon=":material/error:")
        ui.button(st, "Add participant", _add_participant, submit=True, type="primary",
                  icon=":material/person_add:")
    st.caption(f"{app_support.counted(len(people), 'participant')} in study '{study}'.")
    with st.expander("New study: participants are added to the study chosen in the sidebar"):
        with st.form("new-study", border=False):
            st.text_input("Study name", placeholder="e.g. pilot-2026", key="new-study-name")
            st.text_input("Description", key="new-study-description")
            if st.session_state.get("study-error"):
                st.error(st.session_state["study-error"], icon=":material/error:")
            ui.button(st, "Create study", _create_study, submit=True)

with tabs["Import / export"]:
    c1, c2 = st.columns(2)
    with c1:
        st.markdown("**Import a persona file**")
        st.caption("The persona format (docs/personas.md in the project): `{\"participants\": [{\"id\": \"P01\", \"preferences\": [...]}]}`. "
                   f"Missing participants are added to study '{study}' with the file's preferences. All or "
                   "nothing: one bad entry, a participant of another study, or one of this study with other "
                   "preferences (unless you choose to replace them), and nothing is imported.")
        st.file_uploader("Persona file", type=["json"], key="persona-upload", on_change=_forget_import)
        st.checkbox("Replace the preferences of participants already in the study", key="persona-replace",
                    help="Without this, a file naming a participant of this study with other preferences is "
                         "refused. With it, the file's become their new version (the days already run stay "
                         "scored on the preferences of their time).")
        ui.button(st, "Import", _import_personas, icon=":material/upload:")
        if st.session_state.get("import-error"):
            st.error(st.session_state["import-error"], icon=":material/error:")
        done = st.session_state.get("import-done")
        if done:
            st.success(done, icon=":material/check_circle:")
    with c2:
        st.markdown("**Export the study's preferences**")
        text = store.export_personas(study=study)
        n = len(persona_json(text, "the study's persona file")["participants"])
        st.caption(f"{app_support.counted(n, 'participant')} with preferences in study '{study}'.")
        # written at the click: a participant removed since this page was drawn (a withdrawal, in another tab) is
        # not in it, with their own words
        st.download_button("Download personas.json", lambda: ui.store().export_personas(study=study).encode("utf-8"),
                           file_name=app_support.study_file_name("personas", study, ".json"),
                           mime="application/json", disabled=n == 0, icon=":material/download:", on_click="ignore")
