"""cacas.uploaded_run: the Results page's uploads. A run's tables without its checksums.sha256: daily.csv,
interactions.csv and by_preference.csv are checked against each other (participants, methods, days and
what each row counts), so tables of two runs side by side (a folder a run stopped part-way left, or files
of two folders) are refused one by one, and the page says that the files' bytes were not checked. Tables
of one run, simulated either way or exported from a study database, upload; so do the zip of a run or a
study, and the lab's summary.csv beside its daily.csv. Each table is recognised by its columns, and a
file that is none names what it lacks."""

import pandas as pd
import pytest

from cacas import records, saved_runs, uploaded_run
from cacas.errors import CacasError
from cacas.experiment import combine_daily
from cacas.export import export_tables
from cacas.store import StudyStore

T1, T2 = records.ROBOT_INITIATED, records.USER_INITIATED


def _row(who, method, day, index, type_, action, response, activity="cough", user_action=""):
    return {"participant": who, "method": method, "day": day, "index": index, "time": "", "activity": activity,
            "scene": "kitchen", "time_slot": 3, "interval": 2, "task": "do nothing",
            "previous_action": "do nothing", "previous_response": "others", "type": type_,
            "robot_action": action, "response": response, "user_action": user_action}


def _interactions(methods=("cacas",), participants=("P01", "P02"), days=(1, 2)):
    """Each participant-method-day: an accepted and a rejected proposal, one left unanswered, a
    request during an activity and one while doing nothing (not recorded), and the participant's
    second day one more accepted proposal."""
    rows = []
    for who in participants:
        for method in methods:
            for day in days:
                day_rows = [(T1, "pain check", "accept"), (T1, "chitchat", "reject"), (T1, "set a timer", "others"),
                            (T2, "do nothing", "accept"), (T2, "do nothing", "accept")]
                day_rows += [(T1, "pain check", "accept")] * (day - 1)
                for i, (type_, action, response) in enumerate(day_rows):
                    idle = i == 4
                    rows.append(_row(who, method, day, i, type_, action, response,
                                     activity="do nothing" if idle else "cough",
                                     user_action="pain check" if type_ == T2 else ""))
    return pd.DataFrame(rows, columns=records.INTERACTION_COLUMNS)


def _accuracy(methods, participants=("P01", "P02"), days=(1, 2)):
    return pd.DataFrame([{"participant": p, "method": m, "day": d, "preference_accuracy": 0.25 * d}
                         for p in participants for m in methods for d in days])


def _by_preference(accuracy):
    """Two preferences of activities of their own, 20 test states each, whose correct give each
    row's accuracy (sum(correct) / sum(states))."""
    rows = []
    for who, method, day, acc in accuracy.itertuples(index=False):
        for pref, activity in ((1, "cough"), (2, "use stove")):
            correct = round(acc * 20)
            rows.append({"participant": who, "method": method, "day": day, "preference": pref,
                         "label": f"preference {pref}", "activity": activity, "action": "pain check", "states": 20,
                         "correct": correct, "accuracy": correct / 20})
    return pd.DataFrame(rows, columns=records.BY_PREFERENCE_COLUMNS)


def _run(loop="first", methods=("cacas", "orl", "nn")):
    """A simulated run's three tables, daily.csv made as ``cacas simulate`` makes it (with ``loop``)."""
    acting = methods if loop == "each" else methods[:1]
    inter = _interactions(acting)
    accuracy = _accuracy(methods)
    daily = combine_daily(inter, accuracy, list(methods), loop=loop)
    return {"daily.csv": daily, "interactions.csv": inter, "by_preference.csv": _by_preference(accuracy)}


def upload(tables: dict[str, pd.DataFrame]) -> dict:
    return uploaded_run.load_uploaded_tables([(name, records.csv_bytes(df)) for name, df in tables.items()])


def refused(tables: dict[str, pd.DataFrame]) -> str:
    with pytest.raises(CacasError) as err:
        upload(tables)
    return str(err.value)


@pytest.mark.parametrize("loop", ["first", "each"])
def test_the_tables_of_one_simulated_run_upload_without_checksums(loop):
    tables = _run(loop)
    assert list(upload(tables)) == ["daily", "by_preference", "interactions"]
    # design.md's columns alone (a daily.csv cut down in a spreadsheet) are checked as far as they go
    contract = {**tables, "daily.csv": tables["daily.csv"][records.DAILY_CONTRACT_COLUMNS]}
    assert list(upload(contract)) == ["daily", "by_preference", "interactions"]


def _human_study(path):
    """A human study's database at ``path``: a request while doing nothing, a proposal left unanswered, two
    methods in force on a participant's two days, a day begun with nothing recorded yet (scored for Fig. 4),
    and preferences sharing an activity (their accuracy is bounded, not exact)."""
    by_pref = [{"preference": 1, "label": "a", "activity": "cough", "action": "pain check", "states": 30,
                "correct": 12},
               {"preference": 2, "label": "b", "activity": "cough/sneeze", "action": "pain check", "states": 25,
                "correct": 10}]
    with StudyStore(path) as s:
        for code in ("P01", "P02"):
            s.add_participant(code)
            s.save_preferences(code, [{"activity": ["cough"], "action": "pain check"}])
        for code, methods in (("P01", ("orl", "cacas")), ("P02", ("cacas",))):  # adapted with orl: in force on day 2
            for day_number, method in enumerate(methods, 1):
                day = s.open_day(code)
                s.record_interaction(code, day, activity="cough", scene="kitchen", hour=8, interval_minutes=3,
                                     robot_action="pain check", response="accept")
                s.record_interaction(code, day, activity="cough", scene="kitchen", hour=8, interval_minutes=3,
                                     robot_action="chitchat", response="others")
                s.record_interaction(code, day, activity="do nothing", scene="kitchen", hour=9, interval_minutes=3,
                                     robot_action="do nothing", response="accept", type=T2,
                                     user_action="pain check")
                s.close_day(code, day)
                s.save_adapted_policy(code, day, method, f"{code} {day}".encode(), {}, 1.0,
                                      {"preference_accuracy": 22 / 55, "by_preference": by_pref})
        s.open_day("P02")  # begun, nothing recorded: its row counts nothing, and carries the feedback so far
    return path


def test_the_tables_of_a_study_databases_export_upload_without_checksums(tmp_path):
    with StudyStore(_human_study(tmp_path / "study.sqlite")) as s:
        tables = export_tables(s)
    uploaded = {f"{k}.csv": tables[k] for k in ("daily", "interactions", "by_preference")}
    assert set(tables["interactions"]["method"]) == {"cacas", "orl"} and len(tables["by_preference"])
    assert list(upload(uploaded)) == ["daily", "by_preference", "interactions"]


def test_interactions_of_a_run_of_fewer_days_are_refused():
    """With the same seed a run of fewer days has the same first days: each count of those matches."""
    tables = _run()
    inter = tables["interactions.csv"]
    message = refused({**tables, "interactions.csv": inter[inter["day"] == 1]})
    assert message == ("interactions.csv: P01 day 2 (cacas) has 0 recorded interactions, daily.csv says 4; upload "
                       "the tables of one study or run")


def test_interactions_cut_short_are_refused():
    tables = _run()
    assert "P02 day 2 (cacas) has 3 recorded interactions, daily.csv says 4" in \
        refused({**tables, "interactions.csv": tables["interactions.csv"].iloc[:-1]})


def test_another_runs_interactions_with_the_same_counts_are_refused_by_what_they_count():
    tables = _run()
    inter = tables["interactions.csv"].copy()
    first = inter.index[0]
    inter.loc[first, "response"] = "reject"  # the same recorded interactions, one success fewer
    assert refused({**tables, "interactions.csv": inter}) == (
        "interactions.csv: P01 day 1 (cacas): its interactions give successes 0, daily.csv says 1; upload the tables "
        "of one study or run")
    contract = tables["daily.csv"][records.DAILY_CONTRACT_COLUMNS]
    assert "its interactions give success_rate 0, daily.csv says 0.333333" in \
        refused({**tables, "daily.csv": contract, "interactions.csv": inter})
    # a rejected proposal that was a request instead: the same interactions and success rate, one more data point
    asked = tables["interactions.csv"].copy()
    rejected = asked.index[1]
    asked.loc[rejected, ["type", "robot_action", "response", "user_action"]] = [T2, "do nothing", "accept", "pain check"]
    assert "P01 day 1 (cacas): its interactions give cumulative_feedback 5, daily.csv says 4" in \
        refused({**tables, "daily.csv": contract, "interactions.csv": asked})


def test_a_by_preference_csv_of_another_run_is_refused():
    tables = _run()
    by_pref = tables["by_preference.csv"]
    other = by_pref.assign(correct=by_pref["correct"] + 1)
    assert refused({**tables, "by_preference.csv": other}) == (
        "by_preference.csv: P01 day 1 (cacas): its preferences' correct of states give a preference accuracy of 0.300, "
        "daily.csv says 0.250; upload the tables of one study or run")
    assert refused({**tables, "by_preference.csv": by_pref.assign(day=by_pref["day"] + 1)}) == (
        "by_preference.csv: P01 day 3 (cacas) is not in daily.csv; upload the tables of one study or run")
    # preferences sharing an activity count some states twice: the accuracy is bounded, and outside it refused
    shared = by_pref.assign(activity="cough")
    assert list(upload({**tables, "by_preference.csv": shared}))
    wrong = shared.assign(correct=20)
    assert "give a preference accuracy between 1.000 and 1.000 (preferences with activities in common), daily.csv " \
           "says 0.250" in refused({**tables, "by_preference.csv": wrong})


@pytest.mark.parametrize("table, change, message", [
    ("daily.csv", lambda df: pd.concat([df, df.iloc[[0]]]),
     "daily.csv: P01 day 1 (cacas) is listed twice (rows 2 and 14); valid: one row per participant, method and day"),
    ("interactions.csv", lambda df: df.assign(day=df["day"].astype(str).where(df.index > 0, "two")),
     "interactions.csv, row 2: day 'two' is invalid; valid: a whole number >= 1"),
    ("by_preference.csv", lambda df: df.assign(correct=df["correct"].where(df.index > 0, 21)),
     "by_preference.csv, row 2: correct 21 is more than states 20; valid: at most the test states"),
    ("by_preference.csv", lambda df: df.assign(states=df["states"].astype(str).where(df.index > 0, "many")),
     "by_preference.csv, row 2: states 'many' is invalid; valid: a whole number >= 0"),
])
def test_tables_that_cannot_be_of_one_run_are_refused_naming_the_row(table, change, message):
    tables = _run()
    assert refused({**tables, table: change(tables[table])}).startswith(message)


def test_the_page_says_whether_the_checksums_were_checked():
    assert uploaded_run.upload_caption(["daily", "interactions"], None) == (
        "Uploaded: daily.csv, interactions.csv, checked against each other (participants, methods, days and what "
        "they count).",
        "Checksums not checked: no checksums.sha256 was uploaded with them. Add the one beside the tables (cacas "
        "export and cacas simulate --out write it) to check that each file is whole and of that folder's run.")
    said, unchecked = uploaded_run.upload_caption(["daily"], None)
    assert said == "Uploaded: daily.csv." and unchecked.startswith("Checksums not checked: no checksums.sha256 was "
                                                                   "uploaded with it.")
    # tables read from a zip say so (a run's zip, as the Simulation lab downloads it)
    assert uploaded_run.upload_caption(["daily", "interactions"], "checksums.sha256", ["cacas-run-x.zip"])[0] == (
        "Uploaded from cacas-run-x.zip: daily.csv, interactions.csv, each matching its sha256 in checksums.sha256, "
        "and checked against each other (participants, methods, days and what they count).")
    # the lab's summary.csv beside a run's zip: neither in the zip nor in its checksums (it read as both)
    assert uploaded_run.upload_caption(["daily", "interactions", "summary"], "checksums.sha256",
                                       ["cacas-run-x.zip"])[0] == (
        "Uploaded from cacas-run-x.zip: daily.csv, interactions.csv, each matching its sha256 in checksums.sha256, "
        "and checked against each other (participants, methods, days and what they count). The summary.csv "
        "uploaded with them is checked to be daily.csv's means per method and day.")
    assert uploaded_run.upload_caption(["daily", "summary"], None)[0] == (
        "Uploaded: daily.csv. The summary.csv uploaded with it is checked to be daily.csv's means per method and "
        "day.")
    assert uploaded_run.upload_caption(["daily", "by_preference"], "checksums.sha256") == (
        "Uploaded: daily.csv, by_preference.csv, each matching its sha256 in checksums.sha256, and checked against "
        "each other (participants, methods, days and what they count).", None)


def _zip(members: dict[str, bytes]) -> bytes:
    import io
    import zipfile

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


def test_the_zip_of_a_simulated_run_uploads_checked_by_its_checksums(tmp_path):
    """The Simulation lab's 'Download the whole run' is a zip of the run's folder: uploaded as it is, its
    tables and checksums.sha256 are read (its settings.json is not a table), and a table changed in it is
    refused as the loose files are."""
    tables = _run()
    folder = saved_runs.save_run(tmp_path, "run1", tables["daily.csv"], tables["interactions.csv"], {"seed": 1},
                                 tables["by_preference.csv"])
    files = uploaded_run.unpacked_uploads([("cacas-run-run1.zip", saved_runs.run_zip(folder))])
    assert sorted(name for name, _ in files) == ["by_preference.csv", "checksums.sha256", "daily.csv",
                                                 "interactions.csv"]
    uploaded = uploaded_run.load_uploaded_tables(files)
    assert list(uploaded) == ["daily", "by_preference", "interactions"]
    pd.testing.assert_frame_equal(uploaded["daily"], saved_runs.load_run(folder).daily, check_dtype=False)
    # a CSV beside the zip goes through as it is
    assert uploaded_run.unpacked_uploads([("daily.csv", b"x"), ("r.zip", saved_runs.run_zip(folder))])[0] == \
        ("daily.csv", b"x")
    changed = _zip({"run1/daily.csv": records.csv_bytes(_run(methods=("cacas", "orl"))["daily.csv"]),
                    "run1/checksums.sha256": (folder / "checksums.sha256").read_bytes()})
    with pytest.raises(CacasError, match=r"^daily\.csv: does not match its sha256 in checksums\.sha256, so it is not"):
        uploaded_run.load_uploaded_tables(uploaded_run.unpacked_uploads([("run1.zip", changed)]))


def test_the_zip_of_a_study_uploads_its_daily_by_preference_and_interactions(tmp_path):
    from cacas.export import bundle_bytes

    with StudyStore(_human_study(tmp_path / "study.sqlite")) as s:
        bundle, exported = bundle_bytes(s), export_tables(s)
    files = uploaded_run.unpacked_uploads([("cacas-study-default.zip", bundle)])
    assert sorted(name for name, _ in files) == ["by_preference.csv", "daily.csv", "interactions.csv"]
    uploaded = uploaded_run.load_uploaded_tables(files)
    assert list(uploaded) == ["daily", "by_preference", "interactions"]
    pd.testing.assert_frame_equal(uploaded["daily"][records.DAILY_CONTRACT_COLUMNS],
                                  exported["daily"][records.DAILY_CONTRACT_COLUMNS], check_dtype=False)


@pytest.mark.parametrize("data, message", [
    (b"not a zip at all", r"^run\.zip: not a readable zip file \(File is not a zip file\); valid: the zip of a run"),
    (_zip({"run1/settings.json": b"{}", "run1/notes.txt": b"mine"}), r"^run\.zip: holds no daily\.csv; valid: the zip"),
    (_zip({"a/daily.csv": b"x", "b/daily.csv": b"y"}),
     r"^run\.zip: holds 2 daily\.csv files \(a/daily\.csv, b/daily\.csv\); upload the zip of one run or study$"),
], ids=["not a zip", "no daily.csv", "two daily.csv"])  # not the zips' bytes: they hold the time they were made
def test_a_zip_that_is_not_of_one_run_or_study_is_refused_by_name(data, message):
    with pytest.raises(CacasError, match=message):
        uploaded_run.unpacked_uploads([("run.zip", data)])


def test_a_runs_zip_cut_short_is_said_so():
    """Walkthrough: a zip cut short (a download that did not finish) was "not a readable zip file (File is
    not a zip file)"; it begins as a zip and lacks its end: said so."""
    data = _zip({"r/daily.csv": b"participant,method\n" * 50, "r/settings.json": b"{}"})
    with pytest.raises(CacasError, match=r"^run\.zip: is cut short: it begins as a zip, but the zip's end \(the list "
                                         r"of its files\) is missing, as when a download or a copy did not finish; "
                                         r"valid: the zip of a run"):
        uploaded_run.unpacked_uploads([("run.zip", data[: len(data) // 2])])


def test_a_zip_member_too_large_is_refused_before_it_is_read(monkeypatch):
    from cacas import export

    monkeypatch.setattr(export, "MAX_MEMBER_BYTES", 10)
    with pytest.raises(CacasError, match=r"^run\.zip: r/daily\.csv in the zip is 11 bytes uncompressed, over the "
                                         r"limit of 10 bytes for one file of a zip; valid: the zip of a run"):
        uploaded_run.unpacked_uploads([("run.zip", _zip({"r/daily.csv": b"01234567890", "r/settings.json": b"{}"}))])


def test_a_damaged_member_of_a_runs_zip_is_refused_naming_it_and_the_zip():
    """A run's zip whose daily.csv's bytes were changed (its CRC no longer matches): the message names the
    zip and the member, as a zip (it said "in the bundle", cacas import's word for a study's export)."""
    data = _zip({"r/daily.csv": b"participant,method\n", "r/settings.json": b"{}"})
    damaged = data.replace(b"participant,method", b"participant,METHOD", 1)
    with pytest.raises(CacasError, match=r"^run\.zip: r/daily\.csv in the zip is damaged \(Bad CRC-32.*\); valid: the "
                                         r"zip of a run"):
        uploaded_run.unpacked_uploads([("run.zip", damaged)])


def test_the_labs_summary_csv_uploads_beside_its_daily_csv_checked_against_it():
    """The Simulation lab's four downloads uploaded together: its summary.csv was refused as none of the
    tables, and nothing was shown. It is the means of daily.csv per method and day, and is checked to be."""
    from cacas.experiment import summary_table

    tables = _run()
    summary = summary_table(tables["daily.csv"])
    uploaded = upload({**tables, "summary-run1.csv": summary})
    assert list(uploaded) == ["daily", "by_preference", "interactions", "summary"]
    assert uploaded["summary"]["method"].tolist() == summary["method"].tolist()
    off = summary.assign(preference_accuracy=summary["preference_accuracy"].where(summary.index != 2, 0.9))
    assert refused({**tables, "summary-run1.csv": off}) == (
        f"summary-run1.csv: {summary['method'][2]} day {summary['day'][2]}: preference_accuracy 0.9, the mean of "
        f"daily.csv's rows is {summary['preference_accuracy'][2]:.6g}; upload the tables of one run")
    assert refused({**tables, "summary-run1.csv": summary.iloc[1:]}) == (
        f"summary-run1.csv: {summary['method'][0]} day {summary['day'][0]} is not in summary-run1.csv; upload the "
        "tables of one run")
    extra = pd.concat([summary, summary.iloc[[0]].assign(day=9)])  # a day daily.csv does not have
    assert refused({**tables, "summary-run1.csv": extra}) == (
        f"summary-run1.csv: {summary['method'][0]} day 9 is in it but not in daily.csv; upload the tables of one run")
    assert refused({"summary-run1.csv": summary}).startswith("summary-run1.csv: upload a daily.csv as well")


def test_the_labs_summary_csv_uploads_beside_the_zip_of_its_run_though_its_checksums_do_not_list_it(tmp_path):
    """The lab's 'Download the whole run' and its summary.csv uploaded together: the summary, which is not in
    the run's folder (the lab makes it from daily.csv), was refused as 'not one of the files checksums.sha256
    lists'. A summary is checked against daily.csv instead; any other file the checksums do not list still
    is refused."""
    from cacas.experiment import summary_table

    tables = _run()
    folder = saved_runs.save_run(tmp_path, "run1", tables["daily.csv"], tables["interactions.csv"], {"seed": 1},
                                 tables["by_preference.csv"])
    summary = records.csv_bytes(summary_table(saved_runs.load_run(folder).daily))
    files = uploaded_run.unpacked_uploads([("cacas-run-run1.zip", saved_runs.run_zip(folder)),
                                           ("summary-run1.csv", summary)])
    assert list(uploaded_run.load_uploaded_tables(files)) == ["daily", "by_preference", "interactions", "summary"]
    off = records.csv_bytes(summary_table(tables["daily.csv"]).assign(success_rate=0.5))
    with pytest.raises(CacasError, match=r"^summary-run1\.csv: cacas day 1: success_rate 0\.5, the mean of daily\.csv"):
        uploaded_run.load_uploaded_tables([*files[:-1], ("summary-run1.csv", off)])
    other = records.csv_bytes(tables["daily.csv"].assign(day=tables["daily.csv"]["day"] + 1))
    with pytest.raises(CacasError, match=r"^daily-other\.csv: is not one of the files checksums\.sha256 lists"):
        uploaded_run.load_uploaded_tables([*files, ("daily-other.csv", other)])


def _csv(df: pd.DataFrame) -> bytes:
    return df.to_csv(index=False).encode()


def test_uploaded_tables_are_recognised_by_their_columns():
    # one accepted proposal: its day's counts (user_initiated and unanswered 0)
    daily = pd.DataFrame({c: [1] for c in records.DAILY_COLUMNS}).assign(participant="P01", method="cacas",
                                                                         user_initiated=0, unanswered=0)
    by_pref = pd.DataFrame({c: [1] for c in records.BY_PREFERENCE_COLUMNS}).assign(participant="P01", method="cacas")
    inter = pd.DataFrame({c: ["x"] for c in records.INTERACTION_COLUMNS}).assign(
        participant="P01", method="cacas", day=1, type=records.ROBOT_INITIATED, robot_action="chitchat",
        response="accept")
    tables = uploaded_run.load_uploaded_tables([("b.csv", _csv(by_pref)), ("i.csv", _csv(inter)),
                                               ("d.csv", _csv(daily))])
    assert list(tables) == ["daily", "by_preference", "interactions"]
    assert list(tables["daily"].columns) == records.DAILY_COLUMNS
    assert tables["by_preference"]["participant"].tolist() == ["P01"]
    assert list(uploaded_run.load_uploaded_tables([("d.csv", _csv(daily))])) == ["daily"]
    # an interactions.csv of another run with the same codes: named, not shown beside it
    more = pd.concat([inter, inter.assign(response="reject")])
    with pytest.raises(CacasError, match=r"i\.csv: P01 day 1 \(cacas\) has 2 recorded interactions, d\.csv says 1; "
                                         r"upload the tables of one study or run"):
        uploaded_run.load_uploaded_tables([("i.csv", _csv(more)), ("d.csv", _csv(daily))])
    with pytest.raises(CacasError, match=r"i\.csv: P01 day 3 \(cacas\) is not in d\.csv"):
        uploaded_run.load_uploaded_tables([("i.csv", _csv(inter.assign(day=3))), ("d.csv", _csv(daily))])
    unanswered = pd.concat([inter, inter.assign(response="others")])  # saved, not recorded: daily.csv's count
    loaded = uploaded_run.load_uploaded_tables([("i.csv", _csv(unanswered)), ("d.csv", _csv(daily.assign(unanswered=1)))])
    assert len(loaded["interactions"]) == 2
    # a request made while doing nothing is not recorded now; tables exported before counted it (one
    # interaction, two data points): both upload
    idle = inter.assign(activity="do nothing", type=records.USER_INITIATED, user_action="chitchat")
    now = daily.assign(interactions=0, successes=0, success_rate=None, feedback=0, cumulative_feedback=0,
                       unanswered=1)
    before = daily.assign(interactions=1, successes=0, success_rate=0.0, user_initiated=1, feedback=2,
                          cumulative_feedback=2)
    for said in (now, before):
        tables = uploaded_run.load_uploaded_tables([("i.csv", _csv(idle)), ("d.csv", _csv(said))])
        assert len(tables["interactions"]) == 1
    with pytest.raises(CacasError, match=r"has 0 recorded interactions, d\.csv says 2"):
        uploaded_run.load_uploaded_tables([("i.csv", _csv(idle)), ("d.csv", _csv(now.assign(interactions=2)))])


def test_an_upload_near_a_table_names_the_columns_it_lacks():
    """Walkthrough: a daily.csv whose day column had been dropped (by hand, in a spreadsheet) was told it is "not a
    daily.csv, by_preference.csv or interactions.csv" and every column a daily.csv needs: which one lacked, it did
    not say. A file with most of a table's columns is told the ones it lacks; one near none, as before."""
    daily = pd.DataFrame({c: [1] for c in records.DAILY_CONTRACT_COLUMNS}).assign(participant="P01")
    with pytest.raises(CacasError) as err:
        uploaded_run.load_uploaded_tables([("daily.csv", _csv(daily.drop(columns="day")))])
    assert str(err.value).startswith("daily.csv: not a daily.csv, by_preference.csv or interactions.csv (as a "
                                     "daily.csv it lacks the column day); a daily.csv needs the columns participant, ")
    with pytest.raises(CacasError, match=r"\(as a daily.csv it lacks the columns day, interactions\)"):
        uploaded_run.load_uploaded_tables([("d.csv", _csv(daily.drop(columns=["day", "interactions"])))])
    with pytest.raises(CacasError) as err:
        uploaded_run.load_uploaded_tables([("notes.csv", b"a,b\n1,2\n")])
    assert "lacks" not in str(err.value)


@pytest.mark.parametrize("files, message", [
    ([("notes.csv", b"a,b\n1,2\n")], r"notes.csv: not a daily.csv, by_preference.csv or interactions.csv; "
                                     r"a daily.csv needs the columns participant, method, day"),
    ([("d1.csv", "daily"), ("d2.csv", "daily")], r"d2.csv and d1.csv are both a daily.csv; upload one of each kind"),
    # two files of one name (from two folders): "daily.csv and daily.csv are both ..." said which? (lab walkthrough)
    ([("daily.csv", "daily"), ("b.csv", "by_preference"), ("daily.csv", "daily")],
     r"^two files named daily.csv \(files 1 and 3 of those uploaded\) are both a daily.csv; upload one of each kind$"),
    ([("b.csv", "by_preference")], r"b.csv: upload a daily.csv as well"),
    ([], r"nothing uploaded: upload a daily.csv as well"),
    ([("d.csv", "daily"), ("b.csv", "stranger")], r"b.csv: participant\(s\) Q09 are not in d.csv"),
    ([("bin.csv", b"\xff\xfe\x00\x01\x02")], r"bin.csv: cannot be read as UTF-8 text \(it is UTF-16 text"),
    ([("photo.csv", b"\x89PNG\r\n\x1a\n\x00\x00")], r"^photo.csv: cannot be read as UTF-8 text \(it is not text\); valid: "
                                                     r"the file as cacas wrote it"),
    ([("d.csv", "daily_day_two")], r"d.csv, row 2: day 'two' is invalid; valid: a whole number >= 1"),
    ([("d.csv", "daily_rate_percent")], r"d.csv, row 2: success_rate 85.0 is invalid; valid: a share from 0 to 1"),
    ([("d.csv", "daily_ceiling_percent")], r"d.csv, row 2: success_ceiling 90.0 is invalid; valid: a share from 0 "),
    ([("d.csv", "daily_header_only")], r"d.csv: has the daily.csv columns but no rows; valid: a daily.csv with at "
                                       r"least one participant-day"),
])
def test_bad_uploads_name_the_file(files, message):
    daily = pd.DataFrame({c: [1] for c in records.DAILY_CONTRACT_COLUMNS}).assign(participant="P01")
    by_pref = pd.DataFrame({c: [1] for c in records.BY_PREFERENCE_COLUMNS}).assign(participant="P01")
    made = {"daily": _csv(daily), "by_preference": _csv(by_pref), "stranger": _csv(by_pref.assign(participant="Q09")),
            "daily_day_two": _csv(daily.assign(day="two")), "daily_rate_percent": _csv(daily.assign(success_rate=85.0)),
            "daily_ceiling_percent": _csv(daily.assign(success_rate=0.5, success_ceiling=90.0)),
            "daily_header_only": _csv(daily.iloc[:0])}
    files = [(name, made[data] if isinstance(data, str) else data) for name, data in files]
    with pytest.raises(CacasError, match=message):
        uploaded_run.load_uploaded_tables(files)


def test_a_table_from_another_runs_folder_is_said_to_be_one():
    """walk3: a daily.csv and checksums.sha256 of one run uploaded with another run's interactions.csv were
    refused as if a run had been killed ('the run that wrote that folder was stopped part-way ...; write the
    tables again'): picking a file from the wrong folder, the likelier cause, went unsaid."""
    from cacas.store import files

    one, other = _run(), _run(loop="each")  # another run: every method acted
    sums = "".join(f"{files.sha256(records.csv_bytes(df))}  {name}\n" for name, df in one.items())
    with pytest.raises(CacasError) as err:
        uploaded_run.load_uploaded_tables([("daily.csv", records.csv_bytes(one["daily.csv"])),
                                           ("interactions.csv", records.csv_bytes(other["interactions.csv"])),
                                           ("checksums.sha256", sums.encode())])
    assert str(err.value).startswith(
        "interactions.csv: does not match its sha256 in checksums.sha256, so it is not the interactions.csv written "
        "with it: one from another folder (upload the tables of one folder with that folder's checksums.sha256), or ")


def test_a_participant_coded_na_is_uploaded_as_a_participant_not_as_missing():
    """pandas' default NA strings made participant "NA" (a valid code) missing: the upload took it, and
    every figure dropped the participant from its means."""
    tables = _run()
    renamed = {name: df.replace({"participant": {"P01": "NA"}}) for name, df in tables.items()}
    daily = upload(renamed)["daily"]
    assert records.by_code(set(daily["participant"])) == ["NA", "P02"]


def test_a_table_a_spreadsheet_saved_again_in_another_language_says_so():
    """A lab in Germany opened daily.csv in a spreadsheet and saved it: ';' between the columns and '0,5' in the
    cells (Excel where the decimal mark is a comma), Windows-1252 or UTF-16 ('Unicode text'). The Results page said
    'not a daily.csv ...; a daily.csv needs the columns participant, method, day, ...', the very columns it has,
    or quoted Python's codec ("'utf-8' codec can't decode byte 0xff in position 0")."""
    daily = pd.DataFrame({c: [1] for c in records.DAILY_CONTRACT_COLUMNS}).assign(participant="DE01", success_rate=0.5)
    semicolons = daily.to_csv(sep=";", decimal=",", index=False)
    valid = r"; valid: the file as cacas wrote it \(comma-separated UTF-8; docs/tables.md\): upload it from the export"
    for data in (("\ufeff" + semicolons).encode("utf-8"), semicolons.encode("cp1252")):
        with pytest.raises(CacasError, match=r"^daily.csv: its columns are separated by ';', not ',', as a spreadsheet "
                                             r"saves a CSV where the decimal mark is a comma \(German, French, Turkish, "
                                             rf"...\){valid}"):
            uploaded_run.load_uploaded_tables([("daily.csv", data)])
    with pytest.raises(CacasError, match=r"^daily.csv: cannot be read as UTF-8 text \(it is UTF-16 text, as a "
                                         rf"spreadsheet saves 'Unicode text' and older Notepad 'Unicode'\){valid}"):
        uploaded_run.load_uploaded_tables([("daily.csv", daily.to_csv(sep="\t", index=False).encode("utf-16"))])
    words = daily.assign(participant="DE01", label="Küche").to_csv(index=False).encode("cp1252")
    with pytest.raises(CacasError, match=r"^daily.csv: cannot be read as UTF-8 text \(byte 0xfc on line 2 is not "
                                         rf"UTF-8: it was saved in another encoding, such as Windows-1252\){valid}"):
        uploaded_run.load_uploaded_tables([("daily.csv", words)])
    # a table with a ';' in a header's words is not taken for one (only a header of ';'-separated columns is)
    with pytest.raises(CacasError, match=r"^notes.csv: not a daily.csv"):
        uploaded_run.load_uploaded_tables([("notes.csv", b"a;b,c\n1,2\n")])
