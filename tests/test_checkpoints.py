"""checkpoints: policy files are read with torch's weights-only unpickler, so a crafted file (a
study bundle from elsewhere) cannot run code, while every policy this project writes still loads."""

import io
import pathlib

import numpy as np
import pytest
import torch

from cacas.checkpoints import load_checkpoint
from cacas.errors import CacasError
from cacas.policy import BanditPolicy, MLPPolicy, ReshapedPolicy, policy_from_bytes
from cacas.sac import DiscreteSAC, SACConfig
from cacas import spaces


class _TouchesAFile:
    """What a crafted policy file can hold: unpickling it calls Path.touch(marker)."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return pathlib.Path.touch, (self.marker,)


def _crafted(marker) -> bytes:
    buf = io.BytesIO()
    torch.save({"kind": "reshaped", "sac": _TouchesAFile(marker)}, buf)
    return buf.getvalue()


def test_a_crafted_policy_file_is_refused_without_running_its_code(tmp_path):
    marker = tmp_path / "ran"
    torch.load(io.BytesIO(_crafted(marker)), weights_only=False)  # the payload is live: a plain load runs it
    assert marker.exists()
    marker.unlink()
    with pytest.raises(CacasError, match=r"^not a CACAS policy file \(UnpicklingError\)$"):
        policy_from_bytes(_crafted(marker))
    path = tmp_path / "agent.pt"
    path.write_bytes(_crafted(marker))
    with pytest.raises(Exception, match="Weights only load failed"):
        DiscreteSAC.load(path)
    assert not marker.exists()


def test_every_kind_of_policy_this_project_writes_still_loads(tmp_path):
    sac = DiscreteSAC(SACConfig(hidden=16), seed=0)
    s = np.zeros((3, 7), np.int64)
    sac.memory = {"s": np.zeros((2, 7), np.int8), "a": np.zeros(2, np.int64), "r": np.zeros(2, np.float32),
                  "s2": np.zeros((2, 7), np.int8)}  # ORL's replay memory: numpy arrays
    reshaped = ReshapedPolicy(sac, MLPPolicy(hidden=8, epochs=2).fit(s, np.array([1, 2, 3])), 0.7, "cacas")
    back = policy_from_bytes(reshaped.to_bytes())
    assert np.allclose(back.action_probabilities(s), reshaped.action_probabilities(s))
    assert {k: v.dtype for k, v in back.sac.memory.items()} == {k: v.dtype for k, v in sac.memory.items()}
    bandit = BanditPolicy(np.zeros((spaces.N_ACTIVITIES, spaces.N_ACTIONS), np.int64))
    assert np.array_equal(policy_from_bytes(bandit.to_bytes()).wins, bandit.wins)
    sac.save(tmp_path / "agent.pt")
    assert DiscreteSAC.load(tmp_path / "agent.pt").config == sac.config
    buf = io.BytesIO()
    torch.save({"rate": np.float64(0.5), "counts": np.arange(3, dtype=np.uint8)}, buf)  # numpy numbers
    loaded = load_checkpoint(buf.getvalue())
    assert loaded["rate"] == 0.5 and loaded["counts"].tolist() == [0, 1, 2]
    buf = io.BytesIO()
    torch.save({"objects": np.array([{"a": 1}], dtype=object)}, buf)  # not numbers: refused
    with pytest.raises(Exception, match="Weights only load failed"):
        load_checkpoint(buf.getvalue())
