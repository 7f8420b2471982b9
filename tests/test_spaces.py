import numpy as np
import pytest

from cacas import spaces
from cacas.errors import CacasError


def test_table_one_sizes():
    assert (spaces.N_ACTIVITIES, spaces.N_SCENES, spaces.N_SLOTS, spaces.N_INTERVALS) == (33, 6, 12, 12)
    assert (spaces.N_ACTIONS, spaces.N_RESPONSES) == (14, 3)
    assert spaces.STATE_DIM == 94 and spaces.USER_INPUT_DIM == 91
    assert spaces.N_STATES == 16_765_056  # "The total number of state is 16,765,056" (IV-B.1)
    assert spaces.ACTIVITIES[-1] == "do nothing" and spaces.ACTIONS[0] == "do nothing"


def test_names_case_insensitive_and_unknown_named():
    assert spaces.activity_index("Watch tv") == spaces.ACTIVITIES.index("watch TV")
    assert spaces.canonical("action", "  Remind  to TURN off ") == "remind to turn off"
    with pytest.raises(CacasError) as err:
        spaces.action_index("make coffee")
    assert "'make coffee'" in str(err.value) and "remind to unplug" in str(err.value)
    assert "did you mean" not in str(err.value)  # nothing close to it: no guess


def test_an_unknown_name_close_to_a_valid_one_names_it_first():
    """The hint before the list (walkthrough: "unknown activity 'use scissors'" and 33 names); the name
    is still refused."""
    with pytest.raises(CacasError) as err:
        spaces.activity_index("use scissors")
    assert str(err.value).startswith("unknown activity 'use scissors'; did you mean 'use scissor'? valid: cough, ")
    with pytest.raises(CacasError, match="unknown action 'Remind to turn of'; did you mean 'remind to turn off'"):
        spaces.action_index("Remind to turn of")


@pytest.mark.parametrize("typed, meant", [("coughing", "cough"), ("Snoring", "snore"), ("cutting food", "cut food"),
                                          ("frying food", "fry food"), ("using blender", "use blender"),
                                          ("crying", "cry")])
def test_what_someone_is_doing_names_the_activity_meant(typed, meant):
    """A D4A row's 'snoring' and a sound folder named 'coughing' got no hint (difflib's ratio 0.67-0.77, under its
    0.8; walkthrough): the "-ing" form of an activity names it. Still refused."""
    with pytest.raises(CacasError) as err:
        spaces.activity_index(typed)
    assert str(err.value).startswith(f"unknown activity {typed!r}; did you mean {meant!r}? valid: cough, ")


def test_an_ing_word_that_is_no_activity_gets_no_guess():
    for typed in ("sing", "ringing", "cooking dinner"):
        with pytest.raises(CacasError) as err:
            spaces.activity_index(typed)
        assert "did you mean" not in str(err.value)


@pytest.mark.parametrize("minutes,expected", [(0, 0), (0.5, 0), (1, 1), (4, 2), (5, 3), (59, 7),
                                              (60, 8), (199, 10), (200, 11), (5000, 11)])
def test_interval_bins(minutes, expected):
    assert spaces.interval_bin(minutes) == expected


def test_time_slots():
    assert spaces.time_slot(0) == 0 and spaces.time_slot(1.99) == 0 and spaces.time_slot(23.5) == 11
    assert spaces.TIME_SLOTS[0] == (0, 2) and spaces.TIME_SLOTS[-1] == (22, 24)  # the paper prints [20, 24): a typo
    with pytest.raises(CacasError, match="hour 24 is outside the day; valid: 0 <= hour < 24"):
        spaces.time_slot(24)


def test_encode_decode_round_trip():
    rng = np.random.default_rng(0)
    sizes = [n for _, n in spaces.STATE_PARTS]
    states = [spaces.State(*(int(rng.integers(n)) for n in sizes)) for _ in range(50)]
    vecs = spaces.encode_states(states)
    assert vecs.shape == (50, 94) and np.all(vecs.sum(axis=1) == 7)
    assert spaces.decode_states(vecs) == states
    su = spaces.encode_states(states, parts=6)
    assert su.shape == (50, 91)
    assert [s.as_tuple()[:6] for s in spaces.decode_states(su)] == [s.as_tuple()[:6] for s in states]


def test_encode_user_input_replaces_judged_action():
    s = spaces.State.from_names("cough", "bedroom", 7, 12, action="chitchat")
    v = spaces.encode_user_input(s, judged_action=spaces.action_index("pain check"))
    assert spaces.decode_states(v)[0].action == spaces.action_index("pain check")


def test_names_decoding():
    s = spaces.State.from_names("use stove", "kitchen", 17.5, 45, task="set a timer")
    n = s.names()
    assert n["activity"] == "use stove" and n["time_slot"] == "16:00-18:00" and n["interval"] == "30-60 min"
    assert n["task"] == "set a timer"


def test_bad_vector_refused():
    with pytest.raises(CacasError, match="94 or 91"):
        spaces.decode_states(np.zeros((1, 10)))


def test_vector_that_is_not_one_hot_is_refused_naming_the_part():
    v = spaces.encode_states(np.array([[3, 1, 4, 2, 0, 5, 1], [0, 0, 0, 0, 0, 0, 0]]))
    v[1, spaces.OFFSETS[1] + 2] = 1.0  # two scenes at once in the second row
    with pytest.raises(CacasError, match="scene is not one-hot"):
        spaces.decode_states(v)


@pytest.mark.parametrize("row, message", [
    ([3, 6, 4, 2, 0, 5, 1], "state part scene has index 6; valid: 0..5"),  # would be S3's first slot
    ([3, 1, 4, 12, 0, 5, 1], "state part interval has index 12; valid: 0..11"),
    ([3, 1, 4, 2, 0, 5, -1], "state part response has index -1; valid: 0..2"),
])
def test_an_index_outside_its_part_is_refused_not_encoded_into_the_next(row, message):
    with pytest.raises(CacasError) as err:
        spaces.encode_states(np.array([row]))
    assert str(err.value) == message


def test_one_state_or_one_row_encodes_as_one_row():
    row = [3, 1, 4, 2, 0, 5, 1]
    one = spaces.encode_states(np.array([row]))
    assert np.array_equal(spaces.encode_states(spaces.State(*row)), one)
    assert np.array_equal(spaces.encode_states(np.array(row)), one)


def test_indices_from_onehot_inverts_encoding():
    rows = np.array([[3, 1, 4, 2, 0, 5, 1], [32, 5, 11, 11, 13, 13, 2]])
    assert np.array_equal(spaces.indices_from_onehot(spaces.encode_states(rows)), rows)
    assert np.array_equal(spaces.indices_from_onehot(spaces.encode_states(rows, parts=6), parts=6), rows[:, :6])


def test_a_scene_in_words():
    """The tablet said "in the others" for the sixth scene (walkthrough)."""
    assert spaces.in_scene("kitchen") == "in the kitchen"
    assert spaces.in_scene("Living Room") == "in the living room"
    assert spaces.in_scene("others") == "in another room"
    assert [spaces.scene_words(s) for s in spaces.SCENES] == ["bedroom", "living room", "kitchen", "bathroom",
                                                              "dining room", "another room"]
    with pytest.raises(CacasError, match="garden"):
        spaces.in_scene("garden")
