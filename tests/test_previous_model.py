"""The model a training replaced, kept to be put back (cacas.previous_model)."""

import json
import os

import pytest
import torch

from cacas import previous_model
from cacas.errors import CacasError
from cacas.recognition import load_model_file, model_id, save_model


def _save(path, n, keep=False, **meta):
    return save_model(path, {"w": torch.arange(float(n))}, {"kind": "sound", "classes": ["cough"], **meta},
                      keep_previous=keep)


def _files(folder):
    """The folder's files but the hidden lock file that saves and put-backs take turns on."""
    return sorted(p.name for p in folder.iterdir() if not (p.name.startswith(".") and p.name.endswith(".lock")))


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


def test_a_torn_save_is_not_kept_over_the_last_good_model(tmp_path):
    """Weights replaced without their metadata (a save killed between its renames, one file copied
    over): the refusal's advice was to train again, whose keep() then copied the torn pair over the
    kept model, the only good one left (review). A torn pair is not kept."""
    path = _save(tmp_path / "m.pt", 3)
    good = model_id(path)
    _save(path, 4, keep=True)
    path.write_bytes(_save(tmp_path / "o.pt", 5).read_bytes())  # torn
    assert previous_model.keep(path) is None
    _save(path, 6, keep=True)  # the training that the refusal asked for
    assert previous_model.previous_metadata(path)["model_id"] == good
    load_model_file(previous_model.previous_path(path), "sound")  # whole: it loads


def test_a_save_cut_between_its_renames_is_refused_even_over_metadata_with_no_id(tmp_path, monkeypatch):
    """The shipped models' metadata records no id: a save whose weights were renamed before its
    metadata, cut between the two, loaded the new weights with the old classes and accuracy. The
    metadata goes first, and it names its weights: the cut pair is refused."""
    path = _save(tmp_path / "m.pt", 3)
    meta = json.loads(path.with_suffix(".json").read_text())
    del meta["model_id"]
    path.with_suffix(".json").write_text(json.dumps(meta))
    real, calls = os.replace, []

    def replace_once(src, dst):
        if calls:  # killed before the second rename: nothing after it runs, the put-back neither
            raise KeyboardInterrupt
        calls.append(dst)
        return real(src, dst)
    monkeypatch.setattr(os, "replace", replace_once)
    with pytest.raises(KeyboardInterrupt):
        _save(path, 4)
    monkeypatch.undo()
    with pytest.raises(CacasError, match="belongs to other weights"):
        load_model_file(path, "sound")


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


def test_a_put_back_of_a_kept_model_other_than_the_one_shown_is_refused(tmp_path):
    """A second press (or another browser's put-back since the page was drawn) would swap back:
    the page passes the kept model's id it showed, and another is refused, nothing changed."""
    path = _save(tmp_path / "m.pt", 3)
    _save(path, 4, keep=True)
    shown = previous_model.previous_metadata(path)["model_id"]
    previous_model.put_back(path, "sound", expected=shown)
    serving = model_id(path)
    with pytest.raises(CacasError, match=rf"^the previous sound model kept beside m\.pt is no longer model {shown} "
                                         r"\(it was put back already, or a training replaced the model since\); "
                                         r"nothing was changed$"):
        previous_model.put_back(path, "sound", expected=shown)
    assert model_id(path) == serving == shown


def test_saves_and_put_backs_of_one_model_take_turns(tmp_path):
    """The app's training thread, a put-back from another browser and a command-line training
    share temporary names: a save waits while a put-back (or another save) holds the model."""
    import threading

    path = _save(tmp_path / "m.pt", 3)
    order, holding = [], threading.Event()

    def hold():
        with previous_model.writing(path):
            holding.set()
            threading.Event().wait(0.5)  # time for the save to try
            order.append("put-back done")

    other = threading.Thread(target=hold)
    other.start()
    holding.wait(10)
    _save(path, 4, keep=True)
    order.append("save done")
    other.join(10)
    assert order == ["put-back done", "save done"]


@pytest.mark.parametrize("renames_done", [0, 1, 2, 3])
def test_a_put_back_killed_between_its_renames_loses_neither_model(tmp_path, monkeypatch, renames_done):
    """Review: killed after the saved pair was renamed and before the kept one, both slots held the
    model put back, and the one put aside was only in .tmp files that the next keep overwrote. The
    next keep or put-back finishes a put-back that had begun, and drops one that had not."""
    path = _save(tmp_path / "m.pt", 3)
    _save(path, 4, keep=True)
    kept_id, saved_id = previous_model.previous_metadata(path)["model_id"], model_id(path)
    real, done = os.replace, []

    def replace(src, dst):
        if len(done) == renames_done:
            raise KeyboardInterrupt  # killed here
        done.append(dst)
        return real(src, dst)
    monkeypatch.setattr(previous_model.os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        previous_model.put_back(path, "sound")
    monkeypatch.undo()
    previous_model.finish_put_back(path)  # as the next keep or put-back does first
    kept = previous_model.previous_path(path)
    state = (load_model_file(path, "sound")[2], load_model_file(kept, "sound")[2])  # both whole
    assert state == ((saved_id, kept_id) if renames_done == 0 else (kept_id, saved_id))
    # (the saved slot's temporary files of a put-back that renamed nothing stay until the next save's
    # overwrite them: a save writes its own there before it takes the lock, so they are not removed)
    assert not list(tmp_path.glob("m.previous.*.tmp"))
