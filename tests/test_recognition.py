"""Model files shared by sound and scene recognition (cacas.recognition): save_model / load_model_file."""

import hashlib
import json

import pytest
import torch

from cacas.audio import SoundRecognizer
from cacas.errors import CacasError
from cacas.recognition import load_model_file, model_id, save_model
from cacas.vision import SceneRecognizer


@pytest.fixture
def sound_file(tmp_path):
    """A model file written as a sound model (kind "sound")."""
    return save_model(tmp_path / "m.pt", {"w": torch.arange(3.0)}, {"kind": "sound", "classes": ["cough"]})


def test_save_then_load_gives_the_tensors_and_metadata(sound_file):
    tensors, meta, file_id = load_model_file(sound_file, "sound")
    assert torch.equal(tensors["w"], torch.arange(3.0))
    assert meta == {"kind": "sound", "classes": ["cough"], "model_id": file_id}  # the weights it belongs to
    assert sorted(p.name for p in sound_file.parent.iterdir()) == [".m.lock", "m.json", "m.pt"]  # no temporary
    # left (the lock file saves and put-backs take turns on stays: cacas.previous_model.writing)
    assert file_id == hashlib.sha256(sound_file.read_bytes()).hexdigest()[:12] == model_id(sound_file)



def test_loading_a_model_hashes_its_file_once(sound_file, monkeypatch):
    """Helper's profile: the model id was computed twice per load (the check against the metadata
    and the value returned), each a sha256 of the whole file (~10 ms for the shipped scene model)."""
    data = sound_file.read_bytes()
    hashed = []
    real = hashlib.sha256

    def counting(*args, **kwargs):
        if args and bytes(args[0]) == data:
            hashed.append(1)
        return real(*args, **kwargs)
    monkeypatch.setattr(hashlib, "sha256", counting)
    assert load_model_file(sound_file, "sound")[2] == real(data).hexdigest()[:12]
    assert len(hashed) == 1

def test_metadata_is_strict_json_and_metadata_holding_nan_still_loads(tmp_path):
    """walk3: per_class_accuracy held NaN for a class with no test items (and Python's json writes it),
    which is not JSON to jq or a browser's JSON.parse. It is written null; a model saved before, its
    metadata holding NaN, loads and is kept (its copy stamped with its id) as before, the copy strict."""
    import numpy as np

    from cacas import previous_model

    def strict(text):
        return json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in the metadata"))

    per_class = {"cough": np.float64(0.5), "cry": np.float64("nan"), "sneeze": np.float32("inf")}
    path = save_model(tmp_path / "m.pt", {"w": torch.arange(3.0)},
                      {"kind": "sound", "classes": list(per_class), "per_class_accuracy": per_class,
                       "window_accuracy": float("nan"), "curve": np.array([0.25, np.nan])})
    meta = strict(path.with_suffix(".json").read_text())
    assert meta["per_class_accuracy"] == {"cough": 0.5, "cry": None, "sneeze": None}
    assert meta["window_accuracy"] is None and meta["curve"] == [0.25, None]
    assert load_model_file(path, "sound")[1] == meta
    old = path.with_suffix(".json").read_text().replace("null", "NaN")  # as saved before
    old = json.loads(old)
    del old["model_id"]  # and before ids were recorded (the shipped models'): a keep rewrites it
    path.with_suffix(".json").write_text(json.dumps(old))
    assert "NaN" in path.with_suffix(".json").read_text()
    loaded = load_model_file(path, "sound")[1]
    assert loaded["per_class_accuracy"]["cough"] == 0.5 and loaded["per_class_accuracy"]["cry"] != \
        loaded["per_class_accuracy"]["cry"]  # NaN, read as before
    kept = previous_model.keep(path)
    assert strict(kept.with_suffix(".json").read_text())["per_class_accuracy"]["cry"] is None


def test_metadata_that_names_other_weights_is_refused(sound_file, tmp_path):
    """Weights replaced without their metadata (an interrupted save, one file copied over): the
    pair is refused, naming both ids, not loaded with another model's classes and accuracy."""
    other = save_model(tmp_path / "o.pt", {"w": torch.arange(4.0)}, {"kind": "sound", "classes": ["cough"]})
    sound_file.write_bytes(other.read_bytes())
    with pytest.raises(CacasError, match=rf"m\.pt: its metadata m\.json belongs to other weights \(model id "
                                         rf"[0-9a-f]{{12}}; this file's is {model_id(other)}\): a save was interrupted "
                                         r"or one of the two files was copied without the other; put back the "
                                         r"previous sound model if one is kept \(`cacas sound put-back`\), or "
                                         r"train it again$"):
        load_model_file(sound_file, "sound")
    meta = json.loads(sound_file.with_suffix(".json").read_text())
    del meta["model_id"]  # metadata from before ids were recorded (the shipped models') is not checked
    sound_file.with_suffix(".json").write_text(json.dumps(meta))
    assert load_model_file(sound_file, "sound")[2] == model_id(other)


def test_a_model_id_names_the_file_s_bytes(sound_file, tmp_path):
    """Two saves of other weights are two models; the metadata alone does not change the id."""
    other = save_model(tmp_path / "o.pt", {"w": torch.arange(4.0)}, {"kind": "sound", "classes": ["cough"]})
    assert model_id(other) != model_id(sound_file)
    assert len(model_id(other)) == 12 and all(c in "0123456789abcdef" for c in model_id(other))
    before = model_id(sound_file)
    sound_file.with_suffix(".json").write_text(json.dumps({"kind": "sound", "classes": ["cough"], "note": "x"}))
    assert load_model_file(sound_file, "sound")[2] == before


def test_a_model_of_the_other_kind_is_refused(sound_file):
    with pytest.raises(CacasError, match=r"m\.pt: not a scene model \(its metadata .*m\.json says it is a sound "
                                         r"model\); expected a model saved by `cacas scene train`"):
        load_model_file(sound_file, "scene")
    # the recognisers load through it: a sound model given as the scene model names the mix-up
    with pytest.raises(CacasError, match="not a scene model"):
        SceneRecognizer.load(sound_file)
    sound_file.with_suffix(".json").write_text(json.dumps({"classes": ["cough"]}))
    with pytest.raises(CacasError, match=r"not a sound model \(its metadata .*m\.json names no model kind\)"):
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
    with pytest.raises(CacasError, match=r"m\.json: a model's JSON metadata, not the sound model; give .*m\.pt"):
        load_model_file(meta, "sound")
    tensors = sound_file.read_bytes()
    sound_file.write_bytes(b"not tensors")
    with pytest.raises(CacasError, match=r"m\.pt: not a sound model \(not a PyTorch file\); expected a model saved "
                                         r"by `cacas sound train`"):
        load_model_file(sound_file, "sound")
    import zipfile

    with zipfile.ZipFile(sound_file, "w") as z:  # an archive, but not of tensors torch can read
        z.writestr("notes.txt", "hello")
    with pytest.raises(CacasError, match=r"m\.pt: not a readable sound model \(.*\); expected a model saved"):
        load_model_file(sound_file, "sound")
    sound_file.write_bytes(tensors)
    assert load_model_file(sound_file, "sound")[1]["kind"] == "sound"


def test_trainings_take_turns_so_each_draws_only_its_own_seeds_numbers():
    import threading
    import time

    import torch

    from cacas.audio.training import train_sound_model
    from cacas.recognition import trains_alone
    from cacas.vision.training import train_scene_model

    @trains_alone
    def training(seed):  # seeds the global stream and draws from it along the way, as training does
        torch.manual_seed(seed)
        drawn = []
        for _ in range(5):
            drawn.append(torch.rand(1).item())
            time.sleep(0.01)  # the other thread runs meanwhile
        return drawn

    alone = {seed: training(seed) for seed in (1, 2)}
    together = {}
    threads = [threading.Thread(target=lambda s=seed: together.__setitem__(s, training(s))) for seed in (1, 2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert together == alone
    assert train_sound_model.trains_alone and train_scene_model.trains_alone


def test_a_training_that_waits_says_so():
    import threading

    from cacas.recognition import _TRAINING, trains_alone

    said = []
    trained = trains_alone(lambda progress=None: "trained")
    _TRAINING.acquire()  # another training is running
    t = threading.Thread(target=lambda: said.append(trained(progress=lambda f, m: said.append((f, m)))))
    t.start()
    t.join(0.2)
    assert t.is_alive() and said == [(0.0, "waiting for the other model's training to finish")]
    _TRAINING.release()
    t.join(5)
    assert said[-1] == "trained"


def test_a_recognition_below_half_the_probability_is_unsure():
    from cacas.recognition import UNSURE_BELOW, make_recognition

    sure = make_recognition([0.1, 0.8, 0.1], ["bedroom", "kitchen", "bathroom"])
    assert sure.label == "kitchen" and sure.top3[0] == ("kitchen", 0.8) and not sure.unsure
    unsure = make_recognition([0.3, 0.35, 0.35], ["bedroom", "kitchen", "bathroom"])
    assert unsure.label == "kitchen" and unsure.unsure  # ties go to the first class
    assert make_recognition([1 - UNSURE_BELOW, UNSURE_BELOW], ["a", "b"]).unsure is False


def test_an_unsure_recognition_never_reads_as_half_or_more():
    """README audit: `cacas sound recognize` on a 0.25-s clip said "unsure: 50% for eat chips" of a
    0.495 top probability, unsure because under 50 %. The share is rounded down where it is unsure."""
    from cacas.recognition import make_recognition, unsure_words

    rec = make_recognition([0.495, 0.385, 0.12], ["eat chips", "do nothing", "drink soup"])
    assert rec.unsure and unsure_words(rec, "sound").startswith("49% for eat chips. ")
    assert unsure_words(make_recognition([0.29, 0.71 / 3, 0.71 / 3, 0.71 / 3], list("abcd")), "scene").startswith("29% for a")


def test_every_share_of_a_recognition_reads_as_a_whole_percent_by_one_rule():
    """The Sounds page's top 3 showed "49.96%" (Streamlit's "percent" format) beside "Unsure: 49%", and
    `cacas sound recognize` "0.500": each share is now a whole percent as Recognition.percent gives the
    top one (recognition.whole_percent): under half rounded down, else halves up as app_support.percent."""
    from cacas.recognition import make_recognition, whole_percent

    rec = make_recognition([0.4004, 0.4996, 0.1], ["cry", "cough", "sneeze"])
    assert rec.top3_words == [("cough", "49%"), ("cry", "40%"), ("sneeze", "10%")] and rec.percent == 49
    sure = make_recognition([0.5004, 0.4996], ["cough", "cry"])
    assert sure.top3_words == [("cough", "50%"), ("cry", "49%")] and sure.percent == 50
    assert [whole_percent(p) for p in (0.0, 0.29, 0.4999, 0.5, 0.725, 0.9996, 1.0)] == [0, 29, 49, 50, 73, 100, 100]


def test_a_share_under_one_percent_reads_under_one_percent_not_zero():
    """A top 3's third share of 0.3 % read "clear throat 0%" (as if never); it reads "<1%". A share of exactly 0
    still reads "0%", and every other share as whole_percent says it."""
    from cacas.recognition import make_recognition, share_words

    assert [share_words(p) for p in (0.0, 0.001, 0.0099, 0.01, 0.4999, 0.725)] == [
        "0%", "<1%", "<1%", "1%", "49%", "73%"]
    rec = make_recognition([0.6, 0.397, 0.003], ["cough", "cry", "clear throat"])
    assert rec.top3_words == [("cough", "60%"), ("cry", "39%"), ("clear throat", "<1%")]


def test_a_sound_shorter_than_half_a_second_is_short():
    from cacas.recognition import SHORT_CLIP_SECONDS, make_recognition

    assert SHORT_CLIP_SECONDS == 0.5
    assert make_recognition([0.9, 0.1], ["a", "b"], seconds=0.025).short
    assert not make_recognition([0.9, 0.1], ["a", "b"], seconds=0.5).short
    assert not make_recognition([0.9, 0.1], ["a", "b"]).short  # a photo has no length


def test_a_short_clips_length_is_said_in_ms_under_a_tenth_of_a_second():
    """A 3-ms clip read "0.00 s long"."""
    from cacas.recognition import clip_length, short_clip_warning

    assert [clip_length(s) for s in (0.003, 0.025, 0.2, 0.456)] == ["3 ms", "25 ms", "0.20 s", "0.46 s"]
    assert short_clip_warning(0.003).startswith("is 3 ms long: the model hears 1-s windows")


def test_what_an_evaluation_is_on_is_said_as_it_was_made():
    """Lab walkthrough: the page called an evaluation on every recording (the model's held-out ones not
    found, training ones included) 'held-out', and one on 10 of 66 held-out recordings said nothing of
    the 56 missing."""
    from cacas.recognition import compute_metrics, evaluated_on

    m = compute_metrics([0, 1], [0, 1], ["cough", "cry"])
    assert evaluated_on(m, "recordings") == "on 2 held-out recordings"  # as older metrics, with no set named
    m.extra.update({"set": "held-out", "held_out_missing": 5})
    assert evaluated_on(m, "recordings") == ("on 2 held-out recordings (5 of the model's 7 held-out ones are not "
                                             "in the library)")
    m.extra = {"set": "all"}
    assert evaluated_on(m, "images") == "on all 2 images (training ones included)"
    # the model's library, its held-out ones gone; another library (walk3)
    m.extra = {"set": "all", "held_out_absent": 4}
    assert evaluated_on(m, "images") == ("on all 2 images (training ones included; none of the model's 4 held-out "
                                         "ones is in the library)")
    m.extra = {"set": "all", "held_out_absent": 4, "trained_on": "/lab/scenes"}
    assert evaluated_on(m, "images") == ("on all 2 images of another library: the model was trained on /lab/scenes, "
                                         "where its 4 held-out images are")
    # files of held-out names with other bytes (walk3: another library's cough/rec5.wav was taken for the model's)
    m.extra = {"set": "all", "held_out_absent": 4, "held_out_other_bytes": 1}
    assert evaluated_on(m, "images") == ("on all 2 images (training ones included; none of the model's 4 held-out "
                                         "ones is in the library; 1 image of their names holds other contents)")


def test_a_save_writes_nothing_before_it_holds_the_model_s_lock(sound_file, monkeypatch):
    """Safety round: the temporary files had fixed names (m.pt.tmp, m.json.tmp) and were written
    before the lock that saves and put-backs take turns on, so two trainings at once (the app's and
    `cacas sound train`) wrote and renamed each other's. What the folder holds as the lock is taken
    is what an earlier save left: the model, its metadata and the lock file."""
    from contextlib import contextmanager

    from cacas import previous_model

    real = previous_model.writing
    seen = []

    @contextmanager
    def watching(path):
        seen.append(sorted(p.name for p in sound_file.parent.iterdir()))
        with real(path):
            yield
    monkeypatch.setattr(previous_model, "writing", watching)
    save_model(sound_file, {"w": torch.arange(5.0)}, {"kind": "sound", "classes": ["cough"]})
    assert seen == [[".m.lock", "m.json", "m.pt"]]
    assert torch.equal(load_model_file(sound_file, "sound")[0]["w"], torch.arange(5.0))


def test_a_save_on_a_full_disk_says_so_and_keeps_the_model_saved_before(sound_file, monkeypatch, fail_on_call):
    """Safety round: a full disk raised a bare OSError and left a 45-MB temporary file. Now one
    message names the file, and the model saved before loads as it did, nothing left beside it."""
    import os

    before = sound_file.read_bytes(), sound_file.with_suffix(".json").read_bytes()
    monkeypatch.setattr(os, "fsync", fail_on_call(os.fsync, 1))
    with pytest.raises(CacasError, match=rf"^{sound_file.with_suffix('.json')}: cannot be written \(No space left on "
                                         r"device\); the folder's files are unchanged$"):
        save_model(sound_file, {"w": torch.arange(5.0)}, {"kind": "sound", "classes": ["cough"]})
    monkeypatch.undo()
    assert (sound_file.read_bytes(), sound_file.with_suffix(".json").read_bytes()) == before
    assert sorted(p.name for p in sound_file.parent.iterdir()) == [".m.lock", "m.json", "m.pt"]
    assert torch.equal(load_model_file(sound_file, "sound")[0]["w"], torch.arange(3.0))
