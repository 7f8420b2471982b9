"""The sound CNN (Section IV-A): shape, grouped 9:1 split, training metrics, save/load, recognition."""

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from cacas import spaces
from cacas.audio import SoundRecognizer, library
from cacas.audio.model import SoundCNN, default_model_path
from cacas.audio.training import evaluate_sound_model, train_sound_model
from cacas.errors import CacasError
from cacas.recognition import Recognition, model_id, stratified_group_split

TINY = ["cough", "use blender", "type keyboard", "do nothing"]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    root = tmp_path_factory.mktemp("sounds")
    library.generate_library(5, seconds=2.0, root=root, activities=TINY, seed=3)
    seen = []
    result = train_sound_model(root, epochs=2, patience=2, seed=0, augment_copies=1,
                               progress=lambda f, m: seen.append((f, m)))
    return root, result, seen


def test_architecture_is_the_papers():
    m = SoundCNN()
    convs = [l for l in m.modules() if isinstance(l, torch.nn.Conv2d)]
    assert [c.out_channels for c in convs] == [64, 128, 256] and all(c.kernel_size == (3, 3) for c in convs)
    assert m.dense[0].out_features == 128 and m.out.out_features == 33
    assert m(torch.zeros(2, 64, 32)).shape == (2, 33)


def test_grouped_split_never_puts_a_recording_on_both_sides():
    labels = np.repeat(np.arange(33), 24)
    keep, held = stratified_group_split(labels, 0.1, seed=0)
    assert set(keep).isdisjoint(held) and len(keep) + len(held) == len(labels)
    assert len(held) == 33 * 2  # round(0.1 * 24) per activity
    assert set(labels[held]) == set(range(33))


def test_training_split_is_by_recording(tiny):
    root, result, _ = tiny
    split = result.split
    assert split["path"].is_unique  # each recording has exactly one side
    assert set(split["side"]) == {"train", "validation", "test"}
    test_paths = set(split.loc[split.side == "test", "path"])
    assert test_paths == set(result.recognizer.metadata["test_recordings"])
    for act in TINY:  # every activity on the test side
        assert (split[(split.activity == act)].side == "test").sum() >= 1


def test_training_reports_metrics_and_progress(tiny):
    _, result, seen = tiny
    m = result.metrics
    assert m.n == result.split.side.eq("test").sum()
    assert m.confusion.shape == (33, 33) and m.confusion.sum() == m.n
    assert list(m.per_class.columns) == ["label", "n", "correct", "accuracy"]
    assert m.per_class.set_index("label").loc[TINY, "n"].sum() == m.n
    # accuracy: the confusion matrix's diagonal (each class's correct) over the test recordings
    assert m.accuracy == pytest.approx(np.trace(m.confusion) / m.n)
    assert m.per_class["correct"].sum() == np.trace(m.confusion) and m.extra["windows"] == 2 * m.n
    assert seen[-1][0] == 1.0 and all(0 <= f <= 1 for f, _ in seen)
    assert [f for f, _ in seen] == sorted(f for f, _ in seen)


def test_save_load_same_predictions(tiny, tmp_path):
    root, result, _ = tiny
    path = result.recognizer.save(tmp_path / "m.pt")
    # strict JSON (walk3: NaN for the 29 activities with no test clip, which jq and JSON.parse refuse)
    meta = json.loads(path.with_suffix(".json").read_text(), parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    for key in ("classes", "features", "accuracy", "trained", "training_data"):
        assert key in meta
    assert meta["per_class_accuracy"]["cry"] is None and meta["per_class_accuracy"]["cough"] >= 0  # cry: untested
    assert meta["features"]["n_fft"] == 2048 and meta["classes"] == list(spaces.ACTIVITIES)
    data = meta["training_data"]  # the generated library: every recording synthetic, and counted
    assert data["synthetic"] is True and data["synthetic_items"] == data["recordings"] > 0
    loaded = SoundRecognizer.load(path)
    assert loaded.model_id == result.recognizer.model_id == model_id(path)  # what interactions record
    clip = library.clip_paths("cough", root)[0]
    a, b = result.recognizer.probabilities(clip), loaded.probabilities(clip)
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)
    m = evaluate_sound_model(loaded, root)
    assert m.accuracy == pytest.approx(result.metrics.accuracy)


def test_recognize_returns_label_probabilities_top3(tiny):
    root, result, _ = tiny
    r = result.recognizer.recognize(library.clip_paths("use blender", root)[0])
    assert isinstance(r, Recognition) and r.label in spaces.ACTIVITIES
    assert list(r.probabilities) == list(spaces.ACTIVITIES)
    assert sum(r.probabilities.values()) == pytest.approx(1.0, abs=1e-4)
    assert r.top3[0] == (r.label, r.probabilities[r.label]) and len(r.top3) == 3
    assert r.top3[0][1] >= r.top3[1][1] >= r.top3[2][1]
    noise = np.random.default_rng(0).standard_normal(48000).astype(np.float32) * 0.1
    arr = result.recognizer.recognize(noise)  # a signal, not a file: the most probable class
    probs = result.recognizer.probabilities(noise)
    assert arr.label == spaces.ACTIVITIES[int(np.argmax(probs))]
    np.testing.assert_allclose(list(arr.probabilities.values()), probs)
    assert arr.seconds == pytest.approx(1.5) and not arr.short  # 48,000 samples at 32 kHz
    click = result.recognizer.recognize(noise[:800])
    assert click.seconds == pytest.approx(0.025) and click.short


def test_recognize_refuses_bad_input(tiny, tmp_path):
    _, result, _ = tiny
    with pytest.raises(CacasError, match="silence"):
        result.recognizer.recognize(np.zeros(32000, dtype=np.float32))
    bad = tmp_path / "x.wav"
    bad.write_text("hello")
    with pytest.raises(CacasError, match="x.wav"):
        result.recognizer.recognize(bad)


def test_training_refuses_thin_or_missing_data(tmp_path):
    with pytest.raises(CacasError, match="no such sound folder"):
        train_sound_model(tmp_path / "absent")
    library.generate_library(1, seconds=1.0, root=tmp_path, activities=["cough", "cry"])
    with pytest.raises(CacasError, match="single clip"):
        train_sound_model(tmp_path, epochs=1)


def test_a_folder_without_recordings_is_refused_for_training_and_evaluation(tiny, tmp_path):
    _, result, _ = tiny
    (tmp_path / "cough").mkdir()
    with pytest.raises(CacasError, match=f"^{tmp_path}: no clips; generate the library with `cacas sound generate`$"):
        train_sound_model(tmp_path, epochs=1)
    with pytest.raises(CacasError, match=f"^{tmp_path}: no clips to evaluate$"):
        evaluate_sound_model(result.recognizer, tmp_path)
    # a model of fewer classes than the library's activities (one trained on a subset, or older)
    unknown = [a for a in spaces.ACTIVITIES if a not in TINY][:2]
    library.generate_library(1, seconds=1.0, root=tmp_path, activities=unknown)
    with pytest.raises(CacasError, match=f"^the model does not know the activities {', '.join(sorted(unknown))}$"):
        evaluate_sound_model(SoundRecognizer(SoundCNN(len(TINY)), TINY), tmp_path)


@pytest.mark.parametrize("change, message", [
    (lambda m: {**m, "classes": []}, "metadata lists no classes"),
    (lambda m: {**m, "features": {**m["features"], "shape": [40, 32]}}, "trained on features {"),
    (lambda m: {**m, "classes": m["classes"] + ["snore"]},
     "weights do not fit the sound CNN (Error(s) in loading state_dict for SoundCNN:"),
])
def test_a_model_whose_metadata_does_not_fit_its_weights_is_refused(tiny, tmp_path, change, message):
    """A model's .json edited by hand, or from another model: said, not a traceback or a model
    that answers with the wrong activity names."""
    _, result, _ = tiny
    path = result.recognizer.save(tmp_path / "m.pt")
    meta = path.with_suffix(".json")
    meta.write_text(json.dumps(change(json.loads(meta.read_text()))))
    with pytest.raises(CacasError) as err:
        SoundRecognizer.load(path)
    assert str(err.value).startswith(f"{path}: {message}")


def test_load_refuses_missing_or_wrong_model(tmp_path):
    with pytest.raises(CacasError, match="no such sound model"):
        SoundRecognizer.load(tmp_path / "none.pt")
    (tmp_path / "bad.pt").write_text("nonsense")
    (tmp_path / "bad.json").write_text(json.dumps({"kind": "sound", "classes": ["a"], "features": {"shape": [64, 32]}}))
    with pytest.raises(CacasError, match="bad.pt"):
        SoundRecognizer.load(tmp_path / "bad.pt")
    (tmp_path / "notes.json").write_text("{}")  # no model beside it
    with pytest.raises(CacasError, match=r"notes.json: a JSON file, not a sound model; expected a model saved by "
                                         r"`cacas sound train` \(.pt, with its .json beside it\)$"):
        SoundRecognizer.load(tmp_path / "notes.json")


def test_shipped_model_recognises_its_held_out_recordings():
    rec = SoundRecognizer.load()  # study_data/models/sound_cnn.pt
    assert default_model_path().exists() and rec.classes == list(spaces.ACTIVITIES)
    meta = rec.metadata
    assert meta["accuracy"] >= 0.9 and len(meta["test_recordings"]) >= 33
    m = evaluate_sound_model(rec)  # the held-out recordings named in its metadata
    assert m.n == len(meta["test_recordings"])
    assert m.accuracy == pytest.approx(meta["accuracy"], abs=1e-6)
    assert (m.extra["set"], m.extra["held_out_missing"]) == ("held-out", 0)


def test_an_evaluation_on_part_of_the_held_out_recordings_says_how_many_are_missing(tmp_path):
    """Lab walkthrough: on a library holding 10 of the model's 66 held-out recordings, the accuracy was
    'on 10 held-out recordings' and the 56 missing went unsaid."""
    import shutil

    rec = SoundRecognizer.load()
    kept = rec.metadata["test_recordings"][:3]
    for rel in kept:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(library.sounds_dir() / rel, tmp_path / rel)
    m = evaluate_sound_model(rec, tmp_path)
    assert m.n == 3 and m.extra["set"] == "held-out"
    assert m.extra["held_out_missing"] == len(rec.metadata["test_recordings"]) - 3


def test_confusion_figure_and_png(tiny, tmp_path):
    from cacas.plots_recognition import confusion_figure, confusion_png, per_class_figure

    _, result, _ = tiny
    m = result.metrics
    fig = confusion_figure(m)
    heat = fig.data[0]
    assert list(heat.x) == list(spaces.ACTIVITIES) and np.asarray(heat.z).shape == (33, 33)
    rows = np.asarray(heat.z).sum(axis=1)
    assert np.allclose(rows[m.confusion.sum(axis=1) > 0], 1.0)
    counts = confusion_figure(m, normalise=False).data[0].z
    assert np.array_equal(np.asarray(counts), m.confusion)
    assert len(per_class_figure(m).data[0].x) == len(TINY)
    confusion_png(m, tmp_path / "cm.png")
    assert (tmp_path / "cm.png").stat().st_size > 1000
    tidy = m.confusion_frame()
    assert list(tidy.columns) == ["true", "predicted", "count"] and tidy["count"].sum() == m.n


def test_training_restores_the_callers_thread_count(tmp_path):
    library.generate_library(2, seconds=1.0, root=tmp_path, activities=["cough", "cry"])
    before = torch.get_num_threads()
    train_sound_model(tmp_path, epochs=1, threads=2 if before != 2 else 1)
    assert torch.get_num_threads() == before


def test_an_evaluation_on_another_library_names_the_one_the_model_was_trained_on(tiny, tmp_path, monkeypatch):
    """walk3: `cacas sound eval --model lab.pt` (no --data) of a model trained on the lab's own folder
    tested the shipped library and said "on all 792 clips (training ones included)": none of them was a
    training clip, and its held-out clips were elsewhere. The model's folder is recorded whole (it was as
    given, "../lab/sounds", which names nothing from another folder), and the evaluation says it."""
    from cacas.recognition import evaluated_on

    root, result, _ = tiny
    monkeypatch.chdir(root.parent)
    again = train_sound_model(Path(root.name), epochs=1, patience=1, seed=0, augment_copies=1)  # --data sounds0
    assert again.recognizer.metadata["training_data"]["root"] == str(root.resolve())
    other = tmp_path / "other"
    library.generate_library(1, seconds=1.0, root=other, activities=TINY, seed=5)
    held = len(result.recognizer.metadata["test_recordings"])
    m = evaluate_sound_model(result.recognizer, other)
    assert m.n == len(TINY) and m.extra["set"] == "all"
    assert evaluated_on(m, "clips") == (f"on all {len(TINY)} clips of another library: the model was trained on "
                                        f"{root.resolve()}, where its {held} held-out clips are")
    m = evaluate_sound_model(result.recognizer, other, held_out=False)  # --all
    assert evaluated_on(m, "clips") == f"on all {len(TINY)} clips of another library: the model was trained on " \
                                       f"{root.resolve()}"
    m = evaluate_sound_model(result.recognizer, root, held_out=False)  # --all on its own library
    assert evaluated_on(m, "clips") == f"on all {m.n} clips (training ones included)"


def test_another_library_s_files_of_the_held_out_names_are_not_taken_for_them(tiny, tmp_path):
    """walk3: held-out clips were matched by their path alone (`cough/rec5.wav`), so another library with
    the same file names was evaluated as the model's held-out clips. The model records each one's sha256;
    a file of a held-out name but other bytes is not one, and is said."""
    import shutil

    from cacas.recognition import evaluated_on
    from cacas.store.files import file_sha256

    root, result, _ = tiny
    meta = result.recognizer.metadata
    held = meta["test_recordings"]
    assert meta["test_sha256"] == {rel: file_sha256(root / rel) for rel in held}
    other = tmp_path / "other"
    shutil.copytree(root, other)
    for rel in held:  # the same names, another clip of the same activity in each
        same_activity = sorted(p for p in (other / rel).parent.iterdir() if p.name != Path(rel).name)
        shutil.copy(same_activity[0], other / rel)
    m = evaluate_sound_model(result.recognizer, other)
    assert m.extra["set"] == "all" and m.n == len(result.split)
    assert evaluated_on(m, "clips") == (f"on all {m.n} clips of another library: the model was trained on "
                                        f"{root.resolve()}, where its {len(held)} held-out clips are "
                                        f"({len(held)} clips of their names hold other contents here)")
    shutil.copy(root / held[0], other / held[0])  # one of them the model's own again: taken, the others said
    m = evaluate_sound_model(result.recognizer, other)
    assert (m.n, m.extra["set"], m.extra["held_out_missing"]) == (1, "held-out", len(held) - 1)
    assert evaluated_on(m, "clips") == (f"on 1 held-out clips ({len(held) - 1} of the model's {len(held)} held-out "
                                        f"ones are not in the library; {len(held) - 1} clips of their names hold "
                                        "other contents)")
    # a model saved before sha256s were recorded: by name, as before, and said where it matters (another folder)
    old = SoundRecognizer(result.recognizer.model, result.recognizer.classes,
                          {k: v for k, v in meta.items() if k != "test_sha256"})
    m = evaluate_sound_model(old, other)
    assert (m.n, m.extra["set"], m.extra["held_out_missing"]) == (len(held), "held-out", 0)
    assert evaluated_on(m, "clips") == (f"on {len(held)} held-out clips (taken by their names only: the model "
                                        f"records no sha256 of its held-out clips and was trained on "
                                        f"{root.resolve()})")
    assert evaluated_on(evaluate_sound_model(old, root), "clips") == f"on {len(held)} held-out clips"  # its own
