"""scripts/accuracy_by_preference.py: a day's accuracy per described preference, from the
by_preference.csv of a simulated study."""


import pandas as pd
import pytest

from cacas import records
from cacas.experiment import simulate_study
from cacas.preferences import parse_personas
from script_module import load_script

PERSONAS = {"participants": [{"id": "Q1", "preferences": [
    {"activity": ["use stove"], "scene": ["kitchen"], "action": "set a timer"},
    {"activity": ["watch TV"], "action": "do nothing"}]}]}


@pytest.fixture(scope="module")
def script():
    return load_script("accuracy_by_preference")


def test_all_equals_the_studys_preference_accuracy(script, tmp_path, capsys, small_config, small_initial):
    # 15 a day, the paper's: with 6, day 1 had no accepted action, and NN kept the initial policy in force
    res = simulate_study(parse_personas(PERSONAS), days=2, interactions=15, methods=["cacas", "nn"], seed=0,
                         config=small_config, initial_policy=small_initial)
    path = tmp_path / "by_preference.csv"
    records.write_csv(res.by_preference, path)
    table = script.summary(script.load(str(path)).query("day == 2"))
    daily = res.daily[res.daily["day"] == 2].set_index("method")["preference_accuracy"]
    assert table["all"].to_dict() == pytest.approx(daily.to_dict())
    assert table.loc["nn", "do nothing"] == 0  # NN never learns to stay quiet
    assert script.main([str(path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("day 2: mean over 1 participants") and "| nn | 0.000 |" in out


def test_summary_weights_each_participants_states(script):
    rows = pd.DataFrame([
        {"participant": "A", "method": "cacas", "action": "do nothing", "states": 10, "correct": 5},
        {"participant": "A", "method": "cacas", "action": "chitchat", "states": 30, "correct": 30},
        {"participant": "B", "method": "cacas", "action": "pain check", "states": 20, "correct": 10}])
    table = script.summary(rows)
    assert table.loc["cacas", "do nothing"] == 0.5  # only A has one
    assert table.loc["cacas", "other actions"] == pytest.approx((1.0 + 0.5) / 2)
    assert table.loc["cacas", "all"] == pytest.approx((35 / 40 + 0.5) / 2)


def test_bad_file_and_day(script, tmp_path, capsys):
    daily = tmp_path / "daily.csv"
    daily.write_text("participant,method,day,success_rate\nP01,cacas,1,0.5\n")
    assert script.main([str(daily)]) == 2
    assert "not a by_preference.csv; missing columns: action, states, correct" in capsys.readouterr().err
    good = tmp_path / "by_preference.csv"
    pd.DataFrame([{"participant": "A", "method": "nn", "day": 1, "action": "chitchat", "states": 3,
                   "correct": 1}]).to_csv(good, index=False)
    assert script.main([str(good), "--day", "7"]) == 2
    err = capsys.readouterr().err
    assert "--day 7 is not in" in err and err.strip().endswith("valid: 1")


def test_a_participant_coded_na_counts_in_the_mean(script, tmp_path):
    """pandas read participant "NA" (a valid code) as missing, and the mean over participants left them out."""
    path = tmp_path / "by_preference.csv"
    pd.DataFrame([{"participant": who, "method": "cacas", "day": 1, "action": "chitchat", "states": 10,
                   "correct": correct} for who, correct in (("NA", 0), ("P02", 10))]).to_csv(path, index=False)
    assert script.summary(script.load(str(path)))["all"].to_dict() == {"cacas": 0.5}
