"""scripts/accuracy_by_preference.py: the last day's accuracy per described preference, for the
same study `cacas simulate` runs."""

import importlib.util
import json

import pandas as pd
import pytest
import torch

from cacas.experiment import simulate_study
from cacas.paths import PROJECT_ROOT
from cacas.preferences import parse_personas

PERSONAS = {"participants": [{"id": "Q1", "preferences": [
    {"activity": ["use stove"], "scene": ["kitchen"], "action": "set a timer"},
    {"activity": ["watch TV"], "action": "do nothing"}]}]}


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("accuracy_by_preference",
                                                  PROJECT_ROOT / "scripts" / "accuracy_by_preference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_rows_add_up_to_the_studys_preference_accuracy(script, tmp_path):
    path = tmp_path / "personas.json"
    path.write_text(json.dumps(PERSONAS))
    threads = torch.get_num_threads()
    try:
        rows = script.participant_rows(0, str(path), ("nn",), 2, 6, 0)
    finally:
        torch.set_num_threads(threads)
    daily = simulate_study(parse_personas(PERSONAS), days=2, interactions=6, methods=["nn"], seed=0).daily
    day2 = daily[daily["day"] == 2]["preference_accuracy"].iloc[0]
    assert list(rows["action"]) == ["set a timer", "do nothing"]
    assert rows["correct"].sum() / rows["states"].sum() == pytest.approx(day2)
    assert rows.loc[rows["action"] == "do nothing", "correct"].item() == 0  # NN never learns to stay quiet


def test_summary_weights_each_participants_states(script):
    rows = pd.DataFrame([
        {"participant": "A", "method": "cacas", "action": "do nothing", "states": 10, "correct": 5},
        {"participant": "A", "method": "cacas", "action": "chitchat", "states": 30, "correct": 30},
        {"participant": "B", "method": "cacas", "action": "pain check", "states": 20, "correct": 10}])
    table = script.summary(rows)
    assert table.loc["cacas", "do nothing"] == 0.5  # only A has one
    assert table.loc["cacas", "other actions"] == pytest.approx((1.0 + 0.5) / 2)
    assert table.loc["cacas", "all"] == pytest.approx((35 / 40 + 0.5) / 2)
