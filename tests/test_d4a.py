import numpy as np
import pytest

from cacas import spaces
from cacas.d4a import D4A, default_d4a_path, load_d4a, save_d4a
from cacas.errors import CacasError

A, R, O = spaces.ACCEPT, spaces.REJECT, spaces.OTHERS


@pytest.fixture(scope="module")
def d4a():
    return load_d4a()


def act(name):
    return spaces.activity_index(name)


def acts(name):
    return spaces.action_index(name)


def shipped_lines():
    return default_d4a_path().read_text(encoding="utf-8").splitlines()


def write(tmp_path, lines, name="mine.csv"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def error_of(path):
    with pytest.raises(CacasError) as err:
        load_d4a(path)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg
    return msg


# --- the loader ------------------------------------------------------------------------------------

def test_shipped_table_loads(d4a):
    assert d4a.table.shape == (33, 14) and d4a.table.dtype == np.int8
    assert set(np.unique(d4a.table)) <= {A, R, O}
    assert d4a.source == str(default_d4a_path())
    assert not d4a.table.flags.writeable


def test_response_reward_and_accepted(d4a):
    fall = act("fall down")
    assert d4a.response(fall, acts("call someone for help")) == A
    assert d4a.reward(fall, acts("call someone for help")) == 1.0
    assert d4a.reward(fall, acts("chitchat")) == -1.0
    assert d4a.reward(fall, acts("do nothing")) == 0.0
    assert d4a.accepted_actions(fall) == sorted(
        acts(n) for n in ("ask to offer help", "call someone for help", "pain check"))
    assert d4a.accepted_actions(act("snore")) == []
    assert d4a.generic_actions(act("snore")) == [spaces.DO_NOTHING_ACTION]
    assert d4a.generic_actions(fall) == d4a.accepted_actions(fall)


def test_to_frame_is_tidy_and_round_trips(d4a, tmp_path):
    frame = d4a.to_frame()
    assert list(frame.columns) == ["activity", "action", "response"] and len(frame) == 33 * 14
    row = frame[(frame.activity == "use stove") & (frame.action == "remind to turn off")]
    assert row.response.tolist() == ["accept"]
    path = tmp_path / "copy.csv"
    save_d4a(d4a, path)
    assert np.array_equal(load_d4a(path).table, d4a.table)
    assert path.read_text() == default_d4a_path().read_text()


def test_a_save_on_a_full_disk_says_so_and_keeps_the_file(d4a, tmp_path, monkeypatch, fail_on_call):
    """Safety round: a fixed '.tmp' name, no fsync, and a bare OSError on a full disk."""
    import os

    path = tmp_path / "d4a.csv"
    path.write_text("earlier\n")
    monkeypatch.setattr(os, "fsync", fail_on_call(os.fsync, 1))
    with pytest.raises(CacasError, match=rf"^{path}: cannot be written \(No space left on device\); nothing was saved"):
        save_d4a(d4a, path)
    assert path.read_text() == "earlier\n" and os.listdir(tmp_path) == ["d4a.csv"]


def test_default_path_follows_study_data_env(tmp_path, monkeypatch, d4a):
    table = d4a.table.copy()
    table[act("cough"), acts("chitchat")] = A
    save_d4a(D4A(table), tmp_path / "d4a.csv")
    monkeypatch.setenv("CACAS_STUDY_DATA", str(tmp_path))
    assert load_d4a().response(act("cough"), acts("chitchat")) == A


def test_own_file_any_order_and_case(tmp_path, d4a):
    lines = shipped_lines()
    header = lines[0].split(",")
    order = [0] + list(range(len(header) - 1, 0, -1))  # actions reversed
    out = [",".join(h.upper() for h in (header[i] for i in order))]
    for line in reversed(lines[1:]):  # activities reversed
        cells = line.split(",")
        out.append(",".join(cells[i].title() for i in order))
    out.insert(3, "")  # a blank line is ignored
    assert np.array_equal(load_d4a(write(tmp_path, out)).table, d4a.table)


def test_utf8_bom_and_crlf_accepted(tmp_path, d4a):
    path = tmp_path / "bom.csv"
    path.write_bytes(("\ufeff" + "\r\n".join(shipped_lines()) + "\r\n").encode("utf-8"))
    assert np.array_equal(load_d4a(path).table, d4a.table)


# --- every error path ----------------------------------------------------------------------------

def test_missing_file(tmp_path):
    assert "no such D4A file" in error_of(tmp_path / "nope.csv")


def test_folder_not_file(tmp_path):
    assert "is a folder" in error_of(tmp_path)


def test_binary_file_is_not_csv(tmp_path):
    path = tmp_path / "x.csv"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe")
    assert "not a CSV text file" in error_of(path)


def test_a_file_saved_as_utf16_says_so(tmp_path):
    """A spreadsheet's "Unicode text" is UTF-16: it said only "not UTF-8 text"."""
    path = tmp_path / "d4a.csv"
    path.write_bytes("\n".join(shipped_lines()).encode("utf-16"))
    assert error_of(path) == (f"{path}: is not a CSV text file (not UTF-8 text: it is UTF-16 text, as a spreadsheet saves "
                              "'Unicode text' and older Notepad 'Unicode'); valid: a D4A CSV file saved as UTF-8")


def test_text_with_nul_bytes_is_not_csv(tmp_path):
    path = tmp_path / "x.csv"
    path.write_bytes("\n".join(shipped_lines()).replace("accept", "acc\x00ept", 1).encode())
    assert error_of(path) == f"{path}: is not a CSV text file (it contains NUL bytes)"


def test_json_file_is_not_csv(tmp_path):
    path = tmp_path / "d4a.json"
    path.write_text('{"cough": {"pain check": "accept"}}', encoding="utf-8")
    msg = error_of(path)
    assert "line 1" in msg and "not a D4A CSV header" in msg


def test_tab_separated_is_not_this_csv(tmp_path):
    path = write(tmp_path, [line.replace(",", "\t") for line in shipped_lines()])
    assert "not a D4A CSV header" in error_of(path)


def test_empty_file(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("\n\n", encoding="utf-8")
    assert "is empty" in error_of(path)


def test_malformed_quoting(tmp_path):
    lines = shipped_lines()
    lines[5] = lines[5].replace("others", '"others"x', 1)
    msg = error_of(write(tmp_path, lines))
    assert "line 6" in msg and "not valid CSV" in msg


def test_unknown_action_column(tmp_path):
    lines = shipped_lines()
    lines[0] = lines[0].replace("pain check", "make coffee")
    msg = error_of(write(tmp_path, lines))
    assert "line 1, column 9" in msg and "'make coffee'" in msg and "pain check" in msg


def test_missing_action_column(tmp_path):
    lines = [",".join(line.split(",")[:-1]) for line in shipped_lines()]
    msg = error_of(write(tmp_path, lines))
    assert "missing action column" in msg and "remind to unplug" in msg


def test_duplicate_action_column(tmp_path):
    lines = [line + "," + line.split(",")[3] for line in shipped_lines()]  # chitchat again
    msg = error_of(write(tmp_path, lines))
    assert "column 16" in msg and "'chitchat' appears twice" in msg


def test_row_with_wrong_number_of_fields(tmp_path):
    lines = shipped_lines()
    lines[3] += ",accept"
    msg = error_of(write(tmp_path, lines))
    assert "line 4" in msg and "16 fields" in msg and "15" in msg


def test_unknown_activity_row(tmp_path):
    lines = shipped_lines()
    lines.append("juggle," + ",".join(["others"] * 14))
    msg = error_of(write(tmp_path, lines))
    assert "line 35, column 1" in msg and "unknown activity 'juggle'" in msg and "flush toilet" in msg


def test_duplicate_activity_row(tmp_path):
    lines = shipped_lines()
    lines.append(lines[1].replace("cough", "COUGH"))
    msg = error_of(write(tmp_path, lines))
    assert "line 35" in msg and "'cough' appears twice (also line 2)" in msg


def test_missing_activity_rows(tmp_path):
    lines = [line for line in shipped_lines() if not line.startswith(("snore,", "shave,"))]
    msg = error_of(write(tmp_path, lines))
    assert "missing activity row(s): snore, shave" in msg


def test_bad_cell(tmp_path):
    lines = shipped_lines()
    cells = lines[6].split(",")  # fall down
    assert cells[0] == "fall down"
    cells[6] = "yes"  # column 7 (1-based): call someone for help
    lines[6] = ",".join(cells)
    msg = error_of(write(tmp_path, lines))
    assert "line 7, column 7 (fall down / call someone for help)" in msg
    assert "'yes' is not a response" in msg and "accept, reject, others" in msg


def test_empty_cell(tmp_path):
    lines = shipped_lines()
    """An empty cell is said to be empty, not "'' is not a response" (walk3), with its activity and action."""
    lines = shipped_lines()
    lines[2] = lines[2][: lines[2].rindex(",") + 1]  # cry: last cell empty
    msg = error_of(write(tmp_path, lines))
    assert msg.endswith(", line 3, column 15 (cry / remind to unplug): the cell is empty; valid: accept, reject, others")
    lines[2] = lines[2] + "  "  # blanks only: empty too
    assert error_of(write(tmp_path, lines)).endswith("(cry / remind to unplug): the cell is empty; valid: accept, "
                                                     "reject, others")


def test_do_nothing_cell_other_than_others_is_refused(tmp_path):
    lines = shipped_lines()
    cells = lines[6].split(",")  # fall down; column 2 (1-based) is "do nothing"
    assert cells[0] == "fall down" and lines[0].split(",")[1] == "do nothing"
    cells[1] = "Accept"
    lines[6] = ",".join(cells)
    msg = error_of(write(tmp_path, lines))
    assert "line 7, column 2 (fall down / do nothing): 'Accept'" in msg  # as written, as other cells' messages
    assert "valid: 'others' only: the robot doing nothing gets no response" in msg


def test_table_object_refuses_an_answered_do_nothing(d4a):
    table = d4a.table.copy()
    table[act("snore"), acts("do nothing")] = spaces.REJECT
    with pytest.raises(CacasError, match=r"'do nothing' column holds 'reject' for 'snore'; valid: 'others' only"):
        D4A(table)
    table[act("cough"), acts("do nothing")] = spaces.ACCEPT
    with pytest.raises(CacasError, match=r"^mine\.csv: a D4A table's 'do nothing' column holds 'accept' for 'cough' "
                                          r"\(and 1 more activity\); valid"):
        D4A(table, source="mine.csv")
    table[act("yawn"), acts("do nothing")] = spaces.ACCEPT
    with pytest.raises(CacasError, match=r"\(and 2 more activities\); valid"):
        D4A(table)


def test_table_object_validates_shape_and_values():
    with pytest.raises(CacasError, match=r"has shape \(33, 13\); valid: \(33, 14\)"):
        D4A(np.zeros((33, 13), dtype=np.int8))
    with pytest.raises(CacasError, match=r"value other than ACCEPT, REJECT or OTHERS \(0, 1, 2\)"):
        D4A(np.full((33, 14), 3, dtype=np.int8))


# --- the common-sense content ----------------------------------------------------------------------

@pytest.mark.parametrize("activity, action, response", [
    ("fall down", "call someone for help", A),
    ("fall down", "ask to offer help", A),
    ("fall down", "pain check", A),
    ("fall down", "chitchat", R),
    ("use stove", "remind to turn off", A),
    ("fry food", "remind to turn off", A),
    ("cough", "show compassion", A),
    ("cough", "pain check", A),
    ("cough", "remind to unplug", R),
    ("use hair dryer", "remind to unplug", A),
    ("use blender", "remind to be careful", A),
    ("use scissor", "remind to be careful", A),
    ("cut food", "remind to be careful", A),
    ("cut food", "chitchat", R),
    ("drink milk", "remind to put back", A),
    ("snore", "chitchat", R),
    ("snore", "call someone for help", R),
    ("watch TV", "chitchat", A),
    ("cry", "show compassion", A),
    ("cry", "ask to offer help", A),
    ("sneeze", "show compassion", A),
    ("sniff", "remind to take medicine", A),
    ("eat apple", "call someone for help", R),
    ("flush toilet", "chitchat", R),
    ("wash hands", "call someone for help", R),
])
def test_common_sense(d4a, activity, action, response):
    assert d4a.response(act(activity), acts(action)) == response


def test_do_nothing_column_is_others_everywhere(d4a):
    assert (d4a.table[:, spaces.DO_NOTHING_ACTION] == O).all()


def test_quiet_activities_are_exactly_the_documented_ones(d4a):
    quiet = {spaces.ACTIVITIES[i] for i in range(33) if not d4a.accepted_actions(i)}
    assert quiet == {"clear throat", "burp", "yawn", "snore", "wash hands", "type keyboard",
                     "pour water into glass", "flush toilet", "do nothing"}
    # there doing nothing is the best response: nothing is accepted (above), and doing nothing is
    # not rejected
    nothing = spaces.ACTIONS.index("do nothing")
    assert {spaces.ACTIVITIES[i]: int(d4a.table[i, nothing]) for i in range(33) if spaces.ACTIVITIES[i] in quiet} \
        == {activity: O for activity in quiet}


def test_snore_rejects_every_spoken_action(d4a):
    row = d4a.table[act("snore")]
    spoken = [a for a in range(14) if spaces.ACTIONS[a] not in ("do nothing", "record sound")]
    assert (row[spoken] == R).all()


def test_d4a_md_names_every_activity_that_rejects_confirm_or_record_sound(d4a):
    """study_data/d4a.md's last paragraph lists where `confirm sound` and `record sound` are not
    neutral; every activity whose table rejects one of them is named there (clear throat, which
    rejects a recording, was not)."""
    text = (default_d4a_path().parent / "d4a.md").read_text(encoding="utf-8")
    paragraph = " ".join(text.split("Across all actions", 1)[1].split())
    for action in ("confirm sound", "record sound"):
        rejecting = [a for a in spaces.ACTIVITIES if d4a.response(act(a), spaces.action_index(action)) == R]
        assert rejecting and all(a in paragraph for a in rejecting), (action, rejecting)
