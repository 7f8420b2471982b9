from pathlib import Path, PureWindowsPath

import numpy as np
import pytest
import torch

from cacas.errors import CacasError
from cacas.recognition_training import EarlyStopping, relative_path, split_table, tell, training_split


def test_early_stopping_keeps_the_best_epoch_and_stops_after_patience():
    model = torch.nn.Linear(2, 2)
    stopping = EarlyStopping(patience=2)
    weights = {}
    # accuracy, loss per epoch: epoch 2 is best (equal accuracy to 3, lower loss); 3 and 4 are not better
    for epoch, (acc, loss) in enumerate([(0.5, 1.0), (0.8, 0.4), (0.8, 0.6), (0.7, 0.3)], start=1):
        with torch.no_grad():
            model.weight.fill_(float(epoch))
        weights[epoch] = model.weight.clone()
        stop = stopping.step(epoch, acc, loss, model)
        assert stop == (epoch == 4)
    assert stopping.best_epoch == 2
    stopping.restore_best(model)
    assert torch.equal(model.weight, weights[2])
    assert not model.training


def test_early_stopping_prefers_lower_loss_at_equal_accuracy():
    model = torch.nn.Linear(1, 1)
    stopping = EarlyStopping(patience=5)
    stopping.step(1, 0.9, 0.5, model)
    stopping.step(2, 0.9, 0.2, model)
    assert stopping.best_epoch == 2 and stopping.best == (0.9, 0.2)


def test_training_split_is_disjoint_and_covers_every_item():
    labels = np.repeat(np.arange(3), 20)
    train, val, test = training_split(labels, ["a", "b", "c"], 0.1, seed=0, root=Path("lib"),
                                      what="activities", item="recording")
    assert set(train).isdisjoint(val) and set(train).isdisjoint(test) and set(val).isdisjoint(test)
    assert sorted(np.concatenate([train, val, test])) == list(range(60))
    assert all(np.isin(np.arange(3), labels[test]))  # every class is tested


def test_training_split_names_classes_with_a_single_item():
    labels = np.array([0, 0, 1, 2, 2])
    # what is valid, said (walkthrough: "cannot be split 9:1: b" left the researcher to work out the fix)
    told = (r"^lib: scenes with a single image cannot be split 9:1 into training and test: b; valid: 2 images or "
            r"more of each scene that has any \(add another, or remove the one\)$")
    with pytest.raises(CacasError, match=told):
        training_split(labels, ["a", "b", "c"], 0.1, seed=0, root=Path("lib"), what="scenes", item="image")


def test_training_split_validates_on_training_items_when_data_is_tiny():
    train, val, test = training_split(np.array([0, 0, 1, 1]), ["a", "b"], 0.1, seed=0, root=Path("x"),
                                      what="activities", item="recording")
    assert len(test) == 2 and list(val) == list(train)


def test_split_table_marks_each_side():
    table = split_table(["p0", "p1", "p2"], "scene", ["kitchen", "bedroom", "kitchen"], np.array([1]), np.array([2]))
    assert table.to_dict("list") == {"path": ["p0", "p1", "p2"], "scene": ["kitchen", "bedroom", "kitchen"],
                                     "side": ["train", "validation", "test"]}


def test_relative_path_and_tell(tmp_path):
    assert relative_path(tmp_path / "a" / "b.wav", tmp_path) == "a/b.wav"
    assert relative_path(Path("/elsewhere/b.wav"), tmp_path) == "/elsewhere/b.wav"
    heard = []
    tell(lambda f, m: heard.append((f, m)), 1.7, "done")
    tell(None, 0.5, "nobody listens")
    assert heard == [(1.0, "done")]


class WindowsPath(PureWindowsPath):
    """A Windows path (backslashes, a drive) as relative_path sees one there."""

    def resolve(self):
        return self


def test_a_models_items_are_named_with_slashes_on_windows_too(monkeypatch):
    """A model's metadata names its held-out items relative to the library; trained on Windows they
    were "cough\\rec5.wav", which no other system's library matched (an evaluation of the published
    held-out set took every clip, training ones included, and said the held-out ones were absent)."""
    from cacas import recognition_training

    monkeypatch.setattr(recognition_training, "Path", WindowsPath)
    assert relative_path(WindowsPath(r"C:\lab\sounds\cough\rec5.wav"), WindowsPath(r"C:\lab\sounds")) == "cough/rec5.wav"


def test_held_out_items_a_model_named_with_backslashes_are_found(tmp_path):
    """The metadata of a model trained on Windows before its items were named with "/" (and the
    shipped model's, "cough/...", on Windows, where relative paths had "\\"): its held-out items
    are found in the library, by name and bytes."""
    from cacas.recognition_training import held_out_in
    from cacas.store.files import file_sha256

    clips = [tmp_path / "cough" / "rec5.wav", tmp_path / "cough" / "rec6.wav", tmp_path / "cry" / "rec1.wav"]
    for k, clip in enumerate(clips):
        clip.parent.mkdir(exist_ok=True)
        clip.write_bytes(b"RIFF" + bytes([k]))
    metadata = {"test_recordings": ["cough\\rec5.wav", "cry\\rec1.wav"],
                "test_sha256": {"cough\\rec5.wav": file_sha256(clips[0]), "cry\\rec1.wav": "0" * 64}}
    assert held_out_in(metadata, clips, tmp_path) == ([0], 1)  # cry/rec1.wav: the name, other bytes
