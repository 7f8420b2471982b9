import json
from pathlib import Path

from apphelpers import no_exception, texts
from cacas import table_layouts
from cacas.paths import PROJECT_ROOT, SHIPPED, study_data_problem


def test_overview_opens_empty(app):
    at = app()
    no_exception(at)
    assert "No participants yet" in texts(at)


def test_overview_lists_participants_with_next_step(app, store):
    store.add_participant("P01", age_range="25-34")
    store.add_participant("P02")
    store.save_preferences("P02", [{"activity": ["cough"], "action": "pain check"}])
    at = app()
    no_exception(at)
    df = at.dataframe[0].value
    assert list(df["participant"]) == ["P01", "P02"]
    steps = dict(zip(df["participant"], df["next step"]))
    assert steps["P01"].startswith("Describe 5 preferences")
    assert steps["P02"].startswith("Start day 1")
    # what to do next comes second: a narrower window cuts the other columns, not it (walkthrough)
    assert list(at.dataframe[0].proto.column_order)[:2] == ["participant", "next step"]
    # the sidebar picked the participant last worked with (P02's preferences, saved last); the address carries it
    assert at.session_state["participant"] == "P02"
    assert at.query_params["participant"] == ["P02"] or at.query_params["participant"] == "P02"


def test_the_participants_table_shows_every_column_at_1280_px_with_names_whole(app, store):
    """The ui helper saw "last recorded" cut at the right edge at 1280 px (six columns of 920 px in a table of
    820). Every column shown has a width now, all of them fit the page at 1280 px (the table stretches them on a
    wider page), and a row is three lines high: the policy's "(newest: 2)" and the time of "last recorded" wrap."""
    room = 818  # the table's width at 1280 x 800 beside the sidebar (headless Chromium; table_layouts.OVERVIEW_TABLE_ROOM)
    store.add_participant("P01")
    store.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])
    store.open_day("P01")
    store.record_interaction("P01", 1, activity="cough", scene="bedroom", hour=9, interval_minutes=5,
                             robot_action="pain check", response="accept")
    at = app()
    no_exception(at)
    grid = at.dataframe[0]
    shown = list(grid.proto.column_order)
    widths = {name: config.get("width") for name, config in json.loads(grid.proto.columns).items()
              if name in shown}
    assert set(widths) == set(shown) and all(isinstance(w, int) for w in widths.values()), widths
    assert sum(widths.values()) <= room, widths
    # on one line: the header "participant" (about 80 px), "1 of 7 (open)" (about 100), "Start day 1 on the tablet
    # (Study session)" (about 245), the header "success rate so far" (about 136); the rest wraps (rows over 4rem)
    assert widths["participant"] >= 80 and widths["day"] >= 100 and widths["next step"] >= 245
    assert widths["success rate so far"] >= 136 and min(widths["policy"], widths["last recorded"]) >= 100
    assert grid.proto.row_height > 64


def test_the_longest_participant_code_is_whole_in_every_table_of_the_overview(app, store):
    """A code has up to 16 characters (store.validate.CODE_RE). In the data grid's 14-px Source Sans (measured in
    headless Chromium) the widest, "mmmmmmmmmmmmmmmm", is 185.7 px and "participant_0001" 99.3: a participant
    column of 85 px (69 px of text, 8 px of padding a side) cut the one at "participant_0" and wrapped the other
    mid-code over three lines; the recent activity's 110 px cut both. Each table's participant column now has
    room for the codes it shows, the columns together still fit the page at 1280 px (the next step wraps)."""
    room = 818  # table_layouts.OVERVIEW_TABLE_ROOM
    codes = ("mmmmmmmmmmmmmmmm", "participant_0001")
    for code in codes:
        store.add_participant(code)
        store.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
        store.open_day(code)
        store.record_interaction(code, 1, activity="cough", scene="bedroom", hour=9, interval_minutes=5,
                                 robot_action="pain check", response="accept")
    at = app()
    no_exception(at)
    grid, recent = at.dataframe[0], at.dataframe[-1]
    assert set(recent.value["participant"]) >= set(codes)
    shown = list(grid.proto.column_order)
    widths = {name: config.get("width") for name, config in json.loads(grid.proto.columns).items() if name in shown}
    assert set(widths) == set(shown) and widths["participant"] >= 186 + 16, widths
    assert sum(widths.values()) <= room and grid.proto.row_height > 64, widths
    recent_widths = {name: config.get("width") for name, config in json.loads(recent.proto.columns).items()
                     if name in recent.value.columns}
    assert recent_widths["participant"] >= 186 + 16 and recent_widths["when"] >= 125 + 16, recent_widths
    assert sum(recent_widths.values()) <= 165 + 85 + 640 + 5, recent_widths  # as wide as before


def test_participants_are_listed_by_code_whatever_its_letter_case(app, store):
    """Walkthrough: the sidebar offered "R01, p01, r02" (sorted as stored, capitals first); a person reads them
    case-blind, as the Overview's table and the Results page's questionnaire list them too."""
    for code in ("r02", "R01", "p01"):
        store.add_participant(code)
    at = app()
    no_exception(at)
    assert at.sidebar.selectbox(key="participant").options == ["p01", "R01", "r02"]
    assert list(at.dataframe[0].value["participant"]) == ["p01", "R01", "r02"]
    at.switch_page("pages/results.py").run()
    no_exception(at)
    assert next(b for b in at.selectbox if b.label == "Participant").options == ["p01", "R01", "r02"]


def test_participants_are_listed_in_natural_order(app, store):
    """P2 before P10 in the sidebar and the Overview's table (as text: "P10, P2"; records.code_order)."""
    for code in ("P10", "P2", "P1"):
        store.add_participant(code)
    at = app()
    no_exception(at)
    assert at.sidebar.selectbox(key="participant").options == ["P1", "P2", "P10"]
    assert list(at.dataframe[0].value["participant"]) == ["P1", "P2", "P10"]


def test_address_selects_the_participant(app, store):
    store.add_participant("P01")
    store.add_participant("P02")
    at = app(participant="P02")
    no_exception(at)
    assert at.session_state["participant"] == "P02"
    assert "Next for P02" in texts(at)


def test_unknown_participant_in_address_is_reported(app, store):
    store.add_participant("P01")
    at = app(participant="P77")
    no_exception(at)
    assert "Participant 'P77' is not in this study database: choose one below." in texts(at)
    assert at.sidebar.selectbox(key="participant").value is None  # P01 does not stand in for P77


def test_a_fresh_load_starts_at_the_participant_last_worked_with(app, store):
    """Not at the first code: a researcher opening the app mid-study finds the participant of the day."""
    for code in ("P01", "P02", "P03"):
        store.add_participant(code)
    store.open_day("P02")
    at = app()
    no_exception(at)
    assert at.session_state["participant"] == "P02" and "Next for P02" in texts(at)


def test_choosing_another_participant_in_the_sidebar(app, store):
    store.add_participant("P01")
    store.add_participant("P02")
    at = app(participant="P01")
    at.sidebar.selectbox(key="participant").set_value("P02").run()
    no_exception(at)
    assert at.session_state["participant"] == "P02"
    assert at.query_params["participant"] in ("P02", ["P02"])
    assert "Next for P02" in texts(at)


def test_the_tablet_link_leads_to_the_apps_root_from_any_page(app, store):
    """A link relative to the current page (/results?participant=...&view=tablet) opened
    Streamlit's "Page not found" dialog: the tablet has only the session page, at the root."""
    store.add_participant("P01")
    at = app(participant="P01")
    no_exception(at)
    links = [str(c.value) for c in at.sidebar.caption if "tablet view" in str(c.value)]
    assert links == ["Participant's tablet: [open the tablet view](./?participant=P01&view=tablet)"]


def test_sidebar_counts_the_days_interactions_in_words(app, store):
    store.add_participant("P01")
    day = store.open_day("P01")
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
    at = app(participant="P01")
    no_exception(at)
    captions = [c.value for c in at.sidebar.caption]
    assert "Day 1 (open) · 1 interaction that day · policy initial" in captions
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=9, interval_minutes=5,
                             robot_action="pain check", response="accept")
    at = app(participant="P01")
    assert "Day 1 (open) · 2 interactions that day · policy initial" in [c.value for c in at.sidebar.caption]



def test_the_sidebar_reads_the_participants_day_once_a_run(app, store, monkeypatch):
    """Helper's profile: the sidebar's caption and the address's day each read day_status (a few
    queries, and the day's interactions), twice a run for what one read gives; the caption and the
    address stay as they were (the tests above)."""
    import sys

    import cacas.study_day

    store.add_participant("P01")
    day = store.open_day("P01")
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept")
    real = cacas.study_day.day_status
    callers = []

    def counting(*args, **kwargs):
        callers.append(sys._getframe(1).f_code.co_filename)
        return real(*args, **kwargs)
    monkeypatch.setattr(cacas.study_day, "day_status", counting)  # app.py imports it on each run
    at = app(participant="P01")
    no_exception(at)
    assert "Day 1 (open) · 1 interaction that day · policy initial" in [c.value for c in at.sidebar.caption]
    assert at.query_params["day"] in ("1", ["1"])
    assert sum(Path(c).name == "app.py" for c in callers) == 1

def test_the_address_day_is_the_day_the_tablet_shows(app, store):
    """The address carried the last day recorded (day=1) while the tablet offered "Start day 2"."""
    from cacas.study_day import start_day
    store.add_participant("P01")
    store.save_preferences("P01", [{"activity": ["cough"], "action": "pain check"}])

    def address_day():
        at = app(participant="P01")
        no_exception(at)
        value = at.query_params["day"]
        return value[0] if isinstance(value, list) else value

    assert address_day() == "1"
    day = start_day(store, "P01")
    store.close_day("P01", day)
    assert address_day() == "1"  # day 1 finished, waiting for its adaptation
    store.save_policy("P01", day, "cacas", b"an adapted policy")
    assert address_day() == "2"
    at = app("pages/session.py", participant="P01")
    assert "Start day 2" in [b.label for b in at.button]


def test_a_new_visit_opens_the_study_being_run(app, store):
    """Without a study in the address, the study whose participants were last active opens (it was
    always "default": "No participants yet" while the study ran under another name)."""
    store.create_study("pilot-walk")
    store.add_participant("W01", study="pilot-walk")
    store.open_day("W01")
    at = app()
    no_exception(at)
    assert at.selectbox(key="study").value == "pilot-walk"
    assert at.selectbox(key="participant").value == "W01"
    store.add_participant("P01")  # then a default-study participant is added: that study is the latest
    assert app().selectbox(key="study").value == "default"
    assert app(study="pilot-walk").selectbox(key="study").value == "pilot-walk"  # the address wins


def test_default_chosen_beside_other_studies_stays_on_a_reload(app, store):
    """Walkthrough: with another study being run, choosing "default" in the sidebar left the address
    without a study, and a reload opened the other study."""
    store.create_study("pilot-walk")
    store.add_participant("W01", study="pilot-walk")
    store.open_day("W01")
    at = app()
    assert at.selectbox(key="study").value == "pilot-walk"
    at.selectbox(key="study").set_value("default").run()
    no_exception(at)
    assert at.query_params["study"] in ("default", ["default"])
    reloaded = app(**{k: v[0] if isinstance(v, list) else v for k, v in at.query_params.items()})
    assert reloaded.selectbox(key="study").value == "default"


def test_a_database_of_the_default_study_alone_keeps_it_out_of_the_address(app, store):
    store.add_participant("P01")
    at = app(participant="P01")
    no_exception(at)
    assert "study" not in at.query_params and at.query_params["participant"] in ("P01", ["P01"])


def test_recent_activity_shows_a_removal_also_of_the_studys_last_participant(app, store):
    """Walkthrough: a participant's removal never appeared under "Recent activity" (its event is
    stored with no participant, and the study's events were its participants' only); and once the
    study's last participant was removed, the page stopped before the list."""
    removed = "participant P02 removed, with everything recorded about them"
    for code in ("P01", "P02"):
        store.add_participant(code)
    store.create_study("pilot")
    store.add_participant("Q01", study="pilot")
    store.remove_participant("Q01", confirm="Q01")  # another study's removal is not this one's
    store.remove_participant("P02", confirm="P02")
    at = app()
    no_exception(at)
    recent = at.dataframe[-1].value
    assert recent["what"].tolist() == [removed, "participant added"]
    assert recent["participant"].tolist() == ["", "P01"]
    store.remove_participant("P01", confirm="P01")
    at = app()
    no_exception(at)
    assert "No participants now" in texts(at) and "Recent activity" in texts(at)
    assert at.dataframe[-1].value["what"].tolist() == [removed.replace("P02", "P01"), removed]
    assert app(study="pilot").dataframe[-1].value["what"].tolist() == [removed.replace("P02", "Q01"),
                                                                       "study pilot created"]


def test_a_study_data_folder_without_the_shipped_files_is_said_on_every_researcher_page(app, tmp_path, monkeypatch):
    monkeypatch.setenv("CACAS_STUDY_DATA", str(tmp_path / "empty"))
    for page in (None, "pages/participants.py", "pages/results.py"):
        at = app(page)
        assert not at.exception
        setup = [e.value for e in at.error if e.value.startswith("Set-up: the study data folder")]
        assert len(setup) == 1 and "lacks the shipped d4a.csv" in setup[0] and "cp -rn" in setup[0]
    # without the D4A pairs no day can start (an error); without the sound library the study runs
    # with less (a warning: the tablet plays no sound)
    data = tmp_path / "no-sounds"
    data.mkdir()
    for name in SHIPPED:
        if name != "sounds":
            (data / name).symlink_to(PROJECT_ROOT / "study_data" / name)
    monkeypatch.setenv("CACAS_STUDY_DATA", str(data))
    at = app()
    assert not [e for e in at.error if e.value.startswith("Set-up")]
    assert [w.value for w in at.warning if w.value.startswith("Set-up")] == [
        f"Set-up: {study_data_problem(data)}."]
    monkeypatch.delenv("CACAS_STUDY_DATA")
    at = app()
    assert not [e for e in at.error if e.value.startswith("Set-up")] + [w for w in at.warning
                                                                        if w.value.startswith("Set-up")]


def test_a_database_the_server_created_is_said_to_be_new(app, db):
    """Review: a mistyped $CACAS_DB silently created a new empty database, which looked like a
    study that had lost its participants. The sidebar says the server created it, while it is empty."""
    assert not db.exists()
    at = app()
    no_exception(at)
    assert f"Database: `{db}`" in [c.value for c in at.sidebar.caption]
    assert [i.value for i in at.sidebar.info] == [
        "New: this server created it, empty. If you meant an existing database, check $CACAS_DB and start the "
        "app again."]
    from cacas.store import StudyStore
    with StudyStore(db) as s:
        s.add_participant("P01")
    at.run()
    no_exception(at)
    assert not at.sidebar.info  # no longer empty: nothing to say


def test_an_existing_database_is_not_called_new(app, store):
    at = app()
    no_exception(at)
    assert not at.sidebar.info


def test_a_database_that_fails_while_a_page_reads_it_is_a_message_not_a_traceback(app, store, monkeypatch):
    """Data steward's audit: damage found only when a page read it showed every page (the tablet
    too) as a Python traceback."""
    import sqlite3

    from cacas import app_support

    def damaged(*args, **kwargs):
        raise sqlite3.DatabaseError("database disk image is malformed")

    monkeypatch.setattr(app_support, "overview_frame", damaged)
    at = app()
    no_exception(at)
    assert any("cannot be read (database disk image is malformed). Restore it from a backup or an export" in e.value
               for e in at.error)


def test_damage_the_sidebar_meets_is_a_message_too_and_a_locked_database_is_not_called_damaged(app, store,
                                                                                                monkeypatch):
    """Review: the message covered the page only (the sidebar and the address's participant read
    the database before it), and it told the researcher to restore a healthy database after any
    SQLite error ("database is locked" is one)."""
    import sqlite3

    from cacas import app_support
    from cacas.store import StudyStore

    store.add_participant("P01")
    real = StudyStore.list_participants

    def damaged(self, *args, **kwargs):
        raise sqlite3.DatabaseError("database disk image is malformed")
    monkeypatch.setattr(StudyStore, "list_participants", damaged)
    at = app()
    no_exception(at)
    assert any("cannot be read (database disk image is malformed)" in e.value for e in at.error)
    monkeypatch.setattr(StudyStore, "list_participants", real)

    def locked(*args, **kwargs):
        raise sqlite3.OperationalError("database is locked")
    monkeypatch.setattr(app_support, "overview_frame", locked)
    at = app()
    no_exception(at)  # safety audit: it was a traceback
    assert not any("Restore it from a backup" in e.value for e in at.error)
    assert any("is busy (database is locked): another program has held it for more than 10 s (a database tool left "
               "open on it?). Nothing was lost; reload the page in a moment." in w.value for w in at.warning)


def test_a_disk_that_refuses_a_read_is_not_called_damage_to_restore_from_a_backup(app, store, monkeypatch):
    """Safety audit: "disk I/O error" met while a page read the database (a full disk: SQLite could not
    grow the -shm file of a large write-ahead log) told the researcher to restore the database from a
    backup, which would throw away what was saved since the backup. The message says the disk may be
    full or failing and to keep the file."""
    import sqlite3

    from cacas import app_support

    def refused(*args, **kwargs):
        raise sqlite3.OperationalError("disk I/O error")

    monkeypatch.setattr(app_support, "overview_frame", refused)
    at = app()
    no_exception(at)
    said = [e.value for e in at.error]
    assert not any("Restore it from a backup" in e for e in said)
    assert any("cannot be read from the disk now (disk I/O error). The disk may be full or failing: free some disk "
               "space (or check the disk) and reload the page. The file is not known to be damaged: do not replace "
               "it with a backup, which would lose what was saved since" in e for e in said), said


def test_recent_activity_shows_a_comparisons_participants_whole(app, store):
    """The ui helpers saw "2 participants" (a method comparison's line in the recent activity) cut at its "s"
    in a participant column of 85 px; the data grid draws text on a canvas, so it is measured in Chromium: in
    the grid's 14-px Source Sans "999 participants" is 94 px, "2026-11-27 10:55 UTC" 125 px, each with 8 px of
    padding a side (table_layouts.RECENT_ACTIVITY_WIDTHS)."""
    for code in ("P01", "P02"):
        store.add_participant(code)
    for code in ("P01", "P02"):  # the initial policy scored for a comparison of both: one line
        store.record_adaptation(code, 0, "orl", {"initial": True}, 1.0, {})
    at = app(participant="P01")
    no_exception(at)
    recent = at.dataframe[-1]
    assert recent.value["participant"].iloc[0] == "2 participants"
    widths = {name: config.get("width") for name, config in json.loads(recent.proto.columns).items()
              if name in recent.value.columns}
    assert widths["participant"] >= 94 + 16 and widths["when"] >= 125 + 16, widths
    # in the page's width: 895 px scrolled sideways at 1280 px, a long line cut at the page's edge
    assert sum(widths.values()) == table_layouts.OVERVIEW_TABLE_ROOM, widths
    assert recent.proto.row_height in (0, None)  # these lines are short: one line each



def test_a_clock_set_back_is_said_on_every_researcher_page(app, store):
    """Clock walk: nothing said that the server's clock was behind the study's records (a restart with the clock
    set back); the tablet's participant is not told (the researcher sets the clock)."""
    from datetime import datetime, timedelta, timezone

    store.add_participant("P01")
    ahead = (datetime.now(timezone.utc) + timedelta(days=1)).strftime("%Y-%m-%dT%H:%M:%S.000Z")
    with store._lock:
        store._conn.execute("INSERT INTO events (at, what, participant, details) VALUES (?, 'note', NULL, '{}')",
                            (ahead,))
        store._conn.commit()
    for page in ("pages/overview.py", "pages/adaptation.py"):
        at = app(page, participant="P01")
        no_exception(at)
        assert any(w.value.startswith("Clock: this computer's clock says ") and "before the study's latest record"
                   in w.value for w in at.warning), page
    assert not [w for w in app("pages/session.py", participant="P01", view="tablet").warning
                if w.value.startswith("Clock:")]
