"""Scene recognition (Section IV-A): ResNet-18, weights handling, storage, training and recognition."""

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from PIL import Image

from cacas import spaces
from cacas.errors import CacasError
from cacas.recognition import Recognition, model_id
from cacas.vision import SceneRecognizer, build_resnet18, library, synth
from cacas.vision.model import default_model_path, dequantise_state, quantise_state
from cacas.vision.training import evaluate_scene_model, train_scene_model
from photos import photo


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    root = tmp_path_factory.mktemp("scenes")
    library.generate_scenes(4, size=64, seed=5, root=root)
    seen = []
    result = train_scene_model(root, epochs=1, patience=1, weights="none", progress=lambda f, m: seen.append(f))
    return root, result, seen


def test_scene_slugs_and_generator(tmp_path):
    assert library.scene_slug("Living Room") == "living_room"
    assert library.scene_of_folder("dining_room") == "dining room"
    for name in spaces.SCENES:
        img = synth.render(name, np.random.default_rng(0), 64)
        assert img.size == (64, 64) and img.mode == "RGB"
    paths = library.generate_scenes(1, size=48, root=tmp_path)
    assert len(paths) == 6 and library.image_paths("kitchen", tmp_path)[0].suffix == ".jpg"
    assert paths.written == 6 and paths.unchanged == []
    again = library.generate_scenes(2, size=48, root=tmp_path)  # the first image of each scene is there already
    assert again.written == 6 and again.unchanged == paths and again.replaced == []
    with pytest.raises(CacasError, match="^images per scene must be from 1 to 1000, got 0$"):
        library.generate_scenes(0, root=tmp_path / "none")
    for size in (31, 1025):
        with pytest.raises(CacasError, match=f"^image size must be between 32 and 1024 pixels, got {size}$"):
            library.generate_scenes(1, size=size, root=tmp_path / "none")
    assert not (tmp_path / "none").exists()


@pytest.fixture
def no_downloads(monkeypatch):
    """Fail the test on any attempt to fetch weights: torchvision looks the downloader up in its own
    module (torchvision.models._api), so it is patched there and in torch.hub, and any network
    connection is refused as well."""
    import socket

    import torchvision.models._api

    def refuse(*a, **k):
        pytest.fail("tried to download weights")

    monkeypatch.setattr(torchvision.models._api, "load_state_dict_from_url", refuse)
    monkeypatch.setattr(torch.hub, "load_state_dict_from_url", refuse)
    monkeypatch.setattr(torch.hub, "download_url_to_file", refuse)
    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket.socket, "connect_ex", refuse)


def test_resnet18_without_weights_never_downloads(no_downloads):
    model, source = build_resnet18(6, weights="none")
    assert source.startswith("none") and model.fc.out_features == 6
    model, source = build_resnet18(6, weights="auto")  # cache only
    assert model.fc.out_features == 6


def test_weights_file_is_used(tmp_path):
    donor, _ = build_resnet18(1000, weights="none")
    path = tmp_path / "r18.pth"
    torch.save(donor.state_dict(), path)
    model, source = build_resnet18(6, weights=path)
    assert source == "pretrained: r18.pth"
    assert torch.equal(model.conv1.weight, donor.conv1.weight)
    with pytest.raises(CacasError, match="no such weights file"):
        build_resnet18(6, weights=tmp_path / "absent.pth")
    (tmp_path / "junk.pth").write_text("junk")
    with pytest.raises(CacasError, match="junk.pth"):
        build_resnet18(6, weights=tmp_path / "junk.pth")


def test_weights_files_that_are_not_resnet18_say_what_they_are(tmp_path):
    """Each way a --weights file can be something else: one message naming the file, what it is not
    and what is expected (torch's own text, e.g. about weights_only, never reaches the researcher)."""
    from cacas.vision.model import WEIGHTS_EXPECTED, read_resnet18_weights

    donor, _ = build_resnet18(1000, weights="none")
    state = donor.state_dict()
    files = {
        "text.pth": lambda p: p.write_text("junk"),
        "whole_model.pth": lambda p: torch.save(donor, p),
        "tensor.pth": lambda p: torch.save(torch.zeros(3), p),
        "other_net.pth": lambda p: torch.save(torch.nn.Linear(2, 2).state_dict(), p),
        "resnet34_like.pth": lambda p: torch.save({**state, "layer1.0.conv1.weight": torch.zeros(64, 64, 5, 5)}, p),
    }
    for name, write in files.items():
        write(tmp_path / name)
    said = {}
    for name in files:
        with pytest.raises(CacasError) as err:
            build_resnet18(6, weights=tmp_path / name)
        message = str(err.value)
        assert message.startswith(f"{tmp_path / name}: ") and message.endswith(f"; {WEIGHTS_EXPECTED}"), message
        assert "weights_only" not in message and "\n" not in message
        said[name] = message[len(str(tmp_path / name)) + 2:-len(WEIGHTS_EXPECTED) - 2]
    assert said == {
        "text.pth": "not a PyTorch weights file",
        "whole_model.pth": "a PyTorch file that holds more than tensors (a whole model? save its state_dict() instead)",
        "tensor.pth": "holds Tensor, not a state dict",
        "other_net.pth": "the state dict of another network (100 of ResNet-18's 100 tensors missing, e.g. "
                         "'conv1.weight', 2 not ResNet-18's)",
        "resnet34_like.pth": "ResNet-18's tensors in other shapes (1, e.g. 'layer1.0.conv1.weight' is (64, 64, 5, 5), "
                             "not (64, 64, 3, 3))",
    }
    # a file without the batch-norm counters (torchvision's own resnet18-f37072fd.pth is one) is read
    torch.save({k: v for k, v in state.items() if not k.endswith("num_batches_tracked")}, tmp_path / "old.pth")
    model, source = build_resnet18(6, weights=tmp_path / "old.pth")
    assert source == "pretrained: old.pth" and torch.equal(model.conv1.weight, donor.conv1.weight)
    # a training checkpoint holding the state dict under "state_dict" is read
    torch.save({"state_dict": state, "epoch": 3}, tmp_path / "checkpoint.pth")
    assert torch.equal(read_resnet18_weights(tmp_path / "checkpoint.pth")["conv1.weight"], state["conv1.weight"])


def test_int8_storage_round_trip_is_close():
    model, _ = build_resnet18(6, weights="none")
    state = model.state_dict()
    back = dequantise_state(quantise_state(state))
    w, b = state["layer1.0.conv1.weight"], back["layer1.0.conv1.weight"]
    assert torch.max(torch.abs(w - b)) <= w.abs().max() / 127 / 2 + 1e-7
    assert set(back) == set(state)


def test_training_metrics_and_save_load(tiny, tmp_path):
    root, result, seen = tiny
    m = result.metrics
    assert m.n == 6 and m.confusion.shape == (6, 6) and m.confusion.sum() == 6
    assert seen[-1] == 1.0
    split = result.split
    assert split["path"].is_unique and (split.side == "test").sum() == 6
    path = result.recognizer.save(tmp_path / "scene.pt")
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta["classes"] == list(spaces.SCENES) and "accuracy" in meta and "trained" in meta
    data = meta["training_data"]  # the generated library: every image synthetic, and counted
    assert data["synthetic"] is True and data["synthetic_items"] == data["images"] > 0
    loaded = SceneRecognizer.load(path)
    assert loaded.model_id == result.recognizer.model_id == model_id(path)  # what interactions record
    img = library.image_paths("bathroom", root)[0]
    a = result.recognizer.recognize(img)
    b = loaded.recognize(img)
    assert a.label == b.label
    np.testing.assert_allclose(list(a.probabilities.values()), list(b.probabilities.values()), atol=1e-5)
    assert evaluate_scene_model(loaded, root).accuracy == pytest.approx(m.accuracy)


@pytest.mark.parametrize("change, message", [
    (lambda m: {**m, "classes": []}, "metadata lists no classes"),
    (lambda m: {**m, "classes": m["classes"] + ["garage"]}, "weights do not fit ResNet-18 (Error(s) in loading"),
])
def test_a_model_whose_metadata_does_not_fit_its_weights_is_refused(tiny, tmp_path, change, message):
    _, result, _ = tiny
    path = result.recognizer.save(tmp_path / "scene.pt")
    meta = path.with_suffix(".json")
    meta.write_text(json.dumps(change(json.loads(meta.read_text()))))
    with pytest.raises(CacasError) as err:
        SceneRecognizer.load(path)
    assert str(err.value).startswith(f"{path}: {message}")


def test_recognize_image_and_bad_files(tiny, tmp_path):
    _, result, _ = tiny
    r = result.recognizer.recognize(Image.new("RGB", (80, 60), (200, 200, 200)))
    assert isinstance(r, Recognition) and r.label in spaces.SCENES and len(r.top3) == 3
    assert sum(r.probabilities.values()) == pytest.approx(1.0, abs=1e-4)
    empty = tmp_path / "e.jpg"
    empty.write_bytes(b"")
    with pytest.raises(CacasError, match="empty"):
        result.recognizer.recognize(empty)
    text = tmp_path / "t.png"
    text.write_text("no image here")
    with pytest.raises(CacasError, match="not a readable image"):
        result.recognizer.recognize(text)
    with pytest.raises(CacasError, match="no such file"):
        result.recognizer.recognize(tmp_path / "absent.jpg")


def test_a_folder_without_images_is_refused_for_training_and_evaluation(tiny, tmp_path):
    _, result, _ = tiny
    (tmp_path / "kitchen").mkdir()
    with pytest.raises(CacasError, match=f"^{tmp_path}: no images; generate them with `cacas scene generate`$"):
        train_scene_model(tmp_path, epochs=1, weights="none")
    with pytest.raises(CacasError, match=f"^{tmp_path}: no images to evaluate$"):
        evaluate_scene_model(result.recognizer, tmp_path)
    with pytest.raises(CacasError, match=f"^{tmp_path}: is a folder, not an image$"):
        result.recognizer.recognize(tmp_path)


def test_import_scene_folder(tmp_path):
    src = tmp_path / "photos" / "Living Room"
    src.mkdir(parents=True)
    photo((40, 30), (10, 20, 30)).save(src / "a.png")
    copied = library.import_folder(tmp_path / "photos", root=tmp_path / "lib")
    assert [p.relative_to(tmp_path / "lib").as_posix() for p in copied] == ["living_room/a.png"]
    (tmp_path / "photos" / "garage").mkdir()
    with pytest.raises(CacasError, match="garage"):
        library.import_folder(tmp_path / "photos", root=tmp_path / "lib2")


def test_shipped_scene_model_and_images():
    rec = SceneRecognizer.load()
    assert default_model_path().exists() and rec.classes == list(spaces.SCENES)
    assert default_model_path().stat().st_size < 15_000_000
    for name in spaces.SCENES:
        assert len(library.image_paths(name)) >= 10
    m = evaluate_scene_model(rec)
    assert m.accuracy == pytest.approx(rec.metadata["accuracy"], abs=1e-6)


def test_auto_weights_use_the_local_torchvision_cache(tmp_path, monkeypatch):
    from torchvision.models import ResNet18_Weights

    donor, _ = build_resnet18(1000, weights="none")
    cache = tmp_path / "hub" / "checkpoints"
    cache.mkdir(parents=True)
    torch.save(donor.state_dict(), cache / ResNet18_Weights.IMAGENET1K_V1.url.rsplit("/", 1)[-1])
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path / "hub"))
    model, source = build_resnet18(6, weights="auto")
    assert source.startswith("pretrained:") and torch.equal(model.conv1.weight, donor.conv1.weight)
    monkeypatch.setattr(torch.hub, "get_dir", lambda: str(tmp_path / "empty"))
    assert build_resnet18(6, weights="auto")[1].startswith("none")


@pytest.mark.parametrize("size", [32, 33, 47, 128])
def test_every_scene_renders_at_the_sizes_generate_scenes_accepts(size):
    """generate_scenes accepts 32-1024 pixels; small rooms crashed (the furniture had no room)."""
    for scene in spaces.SCENES:
        for seed in range(5):
            img = synth.render(scene, np.random.default_rng(seed), size)
            assert img.size == (size, size) and img.mode == "RGB"


def test_a_stop_asked_for_during_an_epoch_ends_the_training_within_a_batch(tmp_path):
    """Review: 'Stopping...' showed for 35 s, the rest of a ResNet epoch: progress is reported (so a
    Stop can be raised) after every batch, with one message an epoch for the log."""
    from cacas.jobs import Stopped

    root = tmp_path / "scenes"
    library.generate_scenes(6, size=64, seed=5, root=root)
    messages = []

    def progress(fraction, message):
        messages.append(message)
        if message == "epoch 1/3: training":  # after the first batch of epoch 1
            raise Stopped("stopped on request")
    with pytest.raises(Stopped):
        train_scene_model(root, epochs=3, patience=3, weights="none", progress=progress)
    assert not any(m.startswith("epoch 1/3: loss") for m in messages)  # epoch 1 never finished


def test_another_library_s_images_of_the_held_out_names_are_not_taken_for_them(tiny, tmp_path):
    """walk3: held-out images were matched by their path alone; the model records each one's sha256 (as
    the sound model's held-out clips: test_audio_model), and an image of that name with other bytes is not one."""
    import shutil

    from cacas.store.files import file_sha256

    root, result, _ = tiny
    held = result.recognizer.metadata["test_recordings"]
    assert result.recognizer.metadata["test_sha256"] == {rel: file_sha256(root / rel) for rel in held}
    other = tmp_path / "other"
    shutil.copytree(root, other)
    for rel in held[1:]:  # the same names, another image of the same scene in each but the first
        same_scene = sorted(p for p in (other / rel).parent.iterdir() if p.name != Path(rel).name)
        shutil.copy(same_scene[0], other / rel)
    m = evaluate_scene_model(result.recognizer, other)
    assert (m.n, m.extra["set"], m.extra["held_out_missing"]) == (1, "held-out", len(held) - 1)
    assert m.extra["held_out_other_bytes"] == len(held) - 1
