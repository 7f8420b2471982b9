"""The model a training replaced, kept to be put back (cacas.previous_model)."""

import json

import pytest
import torch

from cacas import previous_model
from cacas.errors import CacasError
from cacas.recognition import load_model_file, model_id, save_model


def _save(path, n, keep=False, **meta):
    return save_model(path, {"w": torch.arange(float(n))}, {"kind": "sound", "classes": ["cough"], **meta},
                      keep_previous=keep)


def _files(folder):
    return sorted(p.name for p in folder.iterdir())


def test_the_kept_model_is_named_beside_the_saved_one(tmp_path):
    assert previous_model.previous_path(tmp_path / "sound_cnn.pt") == tmp_path / "sound_cnn.previous.pt"


def test_a_save_keeps_the_model_it_replaces_only_when_asked_and_only_a_whole_one(tmp_path):
    path = _save(tmp_path / "m.pt", 3)
    _save(path, 4)  # not asked: replaced for good (a model saved anywhere else than the app's)
    assert _files(tmp_path) == ["m.json", "m.pt"]
    first = model_id(path)
    _save(path, 5, keep=True)
    assert _files(tmp_path) == ["m.json", "m.previous.json", "m.previous.pt", "m.pt"]
    tensors, meta, kept_id = load_model_file(previous_model.previous_path(path), "sound")
    assert torch.equal(tensors["w"], torch.arange(4.0)) and kept_id == first == meta["model_id"]
    path.with_suffix(".json").unlink()  # weights without metadata are no model to keep
    assert previous_model.keep(path) is None
    assert model_id(previous_model.previous_path(path)) == first  # the kept one is left as it was


def test_a_model_saved_before_ids_were_recorded_is_kept_with_its_id(tmp_path):
    """The shipped models' metadata names no model_id: the kept copy's does (a pair swapped later
    can then be checked)."""
    path = _save(tmp_path / "m.pt", 3)
    meta = json.loads(path.with_suffix(".json").read_text())
    del meta["model_id"]
    path.with_suffix(".json").write_text(json.dumps(meta))
    kept = previous_model.keep(path)
    assert previous_model.previous_metadata(path)["model_id"] == model_id(path) == model_id(kept)


def test_a_mismatched_pair_is_kept_as_it_is_not_passed_off_as_whole(tmp_path):
    """Weights replaced without their metadata: keeping (or putting back) copies the pair with the
    metadata's own id, so loading the copy still refuses it."""
    path = _save(tmp_path / "m.pt", 3)
    path.write_bytes(_save(tmp_path / "o.pt", 4).read_bytes())
    kept = previous_model.keep(path)
    with pytest.raises(CacasError, match=r"m\.previous\.json belongs to other weights"):
        load_model_file(kept, "sound")


def test_putting_back_with_no_saved_model_moves_the_kept_one(tmp_path):
    path = _save(tmp_path / "m.pt", 3)
    _save(path, 4, keep=True)
    first = previous_model.previous_metadata(path)["model_id"]
    path.unlink()
    path.with_suffix(".json").unlink()
    saved, replaced = previous_model.put_back(path, "sound")
    assert replaced is None and saved["model_id"] == first == model_id(path)
    assert _files(tmp_path) == ["m.json", "m.pt"] and previous_model.previous_metadata(path) is None


def test_a_kept_model_that_cannot_serve_changes_nothing(tmp_path):
    path = _save(tmp_path / "m.pt", 3)
    _save(path, 4, keep=True)
    saved_bytes = path.read_bytes()
    kept_json = previous_model.previous_path(path).with_suffix(".json")
    meta = json.loads(kept_json.read_text())
    kept_json.write_text(json.dumps({**meta, "kind": "scene"}))
    with pytest.raises(CacasError, match=r"^the previous sound model kept beside m\.pt cannot be put back; nothing "
                                         r"was changed: .*m\.previous\.pt: not a sound model \(its metadata "
                                         r".*m\.previous\.json says it is a scene model\)"):
        previous_model.put_back(path, "sound")
    kept_json.write_text(json.dumps({**meta, "model_id": "0123456789ab"}))  # a swap caught half-way
    with pytest.raises(CacasError, match=r"nothing was changed: .*m\.previous\.pt: its metadata m\.previous\.json "
                                         r"belongs to other weights \(model id 0123456789ab"):
        previous_model.put_back(path, "sound")
    assert path.read_bytes() == saved_bytes and not list(tmp_path.glob("*.tmp"))


def test_a_model_is_described_by_what_its_metadata_records():
    assert previous_model.model_words({"model_id": "0123456789ab", "trained": "2026-11-20T09:00:00+00:00",
                                       "accuracy": 0.9854}) == (
        "model id 0123456789ab, trained 2026-11-20 09:00 UTC, test accuracy 98.5%")
    assert previous_model.model_words({"accuracy": None}) == "model id (not recorded)"
