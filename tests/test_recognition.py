"""Model files shared by sound and scene recognition (cacas.recognition): save_model / load_model_file."""

import json

import pytest
import torch

from cacas.audio import SoundRecognizer
from cacas.errors import CacasError
from cacas.recognition import load_model_file, save_model
from cacas.vision import SceneRecognizer


@pytest.fixture
def sound_file(tmp_path):
    """A model file written as a sound model (kind "sound")."""
    return save_model(tmp_path / "m.pt", {"w": torch.arange(3.0)}, {"kind": "sound", "classes": ["cough"]})


def test_save_then_load_gives_the_tensors_and_metadata(sound_file):
    tensors, meta = load_model_file(sound_file, "sound")
    assert torch.equal(tensors["w"], torch.arange(3.0))
    assert meta == {"kind": "sound", "classes": ["cough"]}
    assert sorted(p.name for p in sound_file.parent.iterdir()) == ["m.json", "m.pt"]  # no temporary left


def test_a_model_of_the_other_kind_is_refused(sound_file):
    with pytest.raises(CacasError, match=r"m\.pt: not a scene model \(metadata kind 'sound'\)"):
        load_model_file(sound_file, "scene")
    # the recognisers load through it: a sound model given as the scene model names the mix-up
    with pytest.raises(CacasError, match="not a scene model"):
        SceneRecognizer.load(sound_file)
    sound_file.with_suffix(".json").write_text(json.dumps({"classes": ["cough"]}))
    with pytest.raises(CacasError, match=r"not a sound model \(metadata kind None\)"):
        SoundRecognizer.load(sound_file)


def test_missing_or_unreadable_files_are_refused(sound_file, tmp_path):
    with pytest.raises(CacasError, match="is a folder; give the model's .pt file"):
        load_model_file(tmp_path, "sound")
    with pytest.raises(CacasError, match=r"absent\.pt: no such scene model; train one with `cacas scene train`"):
        load_model_file(tmp_path / "absent.pt", "scene")
    meta = sound_file.with_suffix(".json")
    text = meta.read_text()
    meta.unlink()
    with pytest.raises(CacasError, match=r"m\.json: the sound model's metadata file is missing"):
        load_model_file(sound_file, "sound")
    meta.write_text("{not json")
    with pytest.raises(CacasError, match=r"m\.json: not valid JSON metadata"):
        load_model_file(sound_file, "sound")
    meta.write_text('["sound"]')
    with pytest.raises(CacasError, match=r"m\.json: not a model's metadata; expected a JSON object"):
        load_model_file(sound_file, "sound")
    meta.write_text(text)
    sound_file.write_bytes(b"not tensors")
    with pytest.raises(CacasError, match=r"m\.pt: not a readable model file"):
        load_model_file(sound_file, "sound")
