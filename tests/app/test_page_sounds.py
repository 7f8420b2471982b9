import io
import json

import numpy as np
import pytest
import soundfile as sf

from apphelpers import cache_of, no_exception, open_expander, texts
from pages import ui

PAGE = "pages/sounds.py"


def _wav(seconds=1.0, rate=16000, silent=False) -> bytes:
    t = np.arange(int(seconds * rate)) / rate
    y = np.zeros_like(t) if silent else 0.3 * np.sin(2 * np.pi * 440 * t) * np.exp(-3 * t)
    buf = io.BytesIO()
    sf.write(buf, y, rate, format="WAV")
    return buf.getvalue()


def test_sounds_page_opens(app):
    at = app(PAGE)
    no_exception(at)
    assert "activities" in texts(at)
    assert any("a sure answer is not proof" in c.value for c in at.caption)  # closed-set models, said on Try


def test_training_says_how_long_the_saved_model_took(app, monkeypatch):
    from types import SimpleNamespace

    import cacas.lab

    took = {"sound": 74.7, "scene": 424.1}  # the shipped models' training times
    monkeypatch.setattr(cacas.lab, "model_stamp", lambda kind: 1.0 if kind == "scene" else None)
    monkeypatch.setattr(cacas.lab, "load_recognizer", lambda kind: SimpleNamespace(model_id="0123456789ab", metadata={
        "trained": "2026-11-21T10:34:00Z", "accuracy": 0.9, "training_seconds": took[kind]}))
    at = app(PAGE)
    no_exception(at)
    replaces = (" The new model replaces the saved one when it is done, whatever its accuracy, and the tablets use it "
                "from their next interaction; the replaced one is kept, and 'Put back the previous scene model' returns "
                "to it.")
    assert at.button(key="btn-train-scene").help == ("Runs in the background; the saved model took 7 min to train."
                                                     + replaces)
    # no saved model: no time to go by
    assert at.button(key="btn-train-sound").help == ("Runs in the background; several minutes on 2 CPU cores."
                                                     + replaces.replace("scene", "sound"))


def test_add_clips_valid_and_invalid(tmp_path, monkeypatch):
    from cacas import lab
    from cacas.audio.library import clip_paths
    from cacas.errors import CacasError

    root = tmp_path / "sounds"
    added = lab.add_clips("Cough", [("my cough.wav", _wav())], root)
    assert [p.parent.name for p in added] == ["cough"] and clip_paths("cough", root) == added
    # the reason, not only the file's name (which holds "silence", "empty")
    for files, message in (([("silence.wav", _wav(silent=True))], "silence.wav: is all silence"),
                           ([("notes.wav", b"this is text")], "notes.wav: not a readable WAV/FLAC/OGG audio file"),
                           ([("empty.wav", b"")], "empty.wav: is empty (0 bytes)"),
                           ([], "no clip given")):
        try:
            lab.add_clips("cough", [("good.wav", _wav())] + files if files else files, root)
        except CacasError as exc:
            assert message in str(exc)
            assert "/tmp" not in str(exc)  # the name given, not our temporary copy
        else:
            raise AssertionError(f"{files} was accepted")
    assert clip_paths("cough", root) == added  # nothing half-added


def test_evaluate_a_model_in_the_background_shows_accuracy_and_confusion(app, monkeypatch):
    import cacas.audio
    import cacas.lab
    from cacas.audio.model import SoundCNN, SoundRecognizer
    from cacas.jobs import RUNNER
    from cacas.recognition import compute_metrics

    recognizer = SoundRecognizer(SoundCNN(), metadata={"accuracy": 0.5, "trained": "2026-11-21T10:00:00+00:00"})
    metrics = compute_metrics([0, 1, 2, 2], [0, 1, 2, 1], ["cough", "cry", "sneeze"])

    def evaluate(progress=None):
        progress(0.5, "recognising held-out recordings")
        return metrics

    monkeypatch.setattr(cacas.lab, "model_stamp", lambda kind: 1.0 if kind == "sound" else None)
    monkeypatch.setattr(cacas.audio.SoundRecognizer, "load", classmethod(lambda cls, path=None: recognizer))
    monkeypatch.setattr(cacas.lab, "evaluate_sound", evaluate)
    at = app(PAGE)
    no_exception(at)
    assert "Trained 2026-11-21 10:00 UTC · test accuracy 50.0%" in texts(at)
    next(b for b in at.button if b.label == "Evaluate the saved sound model").click().run()
    job = RUNNER.get("eval-sound")
    assert job is not None and job.wait(30) and job.status == "done"
    at.run()
    no_exception(at)
    assert any(m.label == "Sound test accuracy" and m.value == "75.0%" for m in at.metric)
    assert len(at.get("plotly_chart")) == 1
    per_class = next(d.value for d in at.dataframe if "class" in d.value.columns)  # whole percentages (was 66.67%)
    assert dict(zip(per_class["class"], per_class["accuracy"])) == {"cough": 100.0, "cry": 100.0, "sneeze": 50.0}
    assert next(d for d in at.dataframe if "class" in d.value.columns).proto.placeholder == "–"  # not "None"
    RUNNER.forget("eval-sound")
    # the model's held-out recordings not found: every recording, training ones included, and said so
    # (lab walkthrough: the page called it "test accuracy ... on 4 held-out items")
    metrics.extra["set"] = "all"
    next(b for b in at.button if b.label == "Evaluate the saved sound model").click().run()
    assert RUNNER.get("eval-sound").wait(30)
    at.run()
    no_exception(at)
    shown = next(m for m in at.metric if m.label.startswith("Sound"))
    assert (shown.label, shown.help) == ("Sound accuracy", "on all 4 clips (training ones included)")
    assert "Accuracy on all 4 clips (training ones included)." in texts(at)
    RUNNER.forget("eval-sound")
    # held-out clips found in another folder by a model that records no sha256 of them: said under the figure
    metrics.extra = {"set": "held-out", "held_out_missing": 0, "matched_by_name": "/lab/sounds"}
    next(b for b in at.button if b.label == "Evaluate the saved sound model").click().run()
    assert RUNNER.get("eval-sound").wait(30)
    at.run()
    no_exception(at)
    assert ("Accuracy on 4 held-out clips (taken by their names only: the model records no sha256 of its held-out "
            "clips and was trained on /lab/sounds).") in texts(at)
    RUNNER.forget("eval-sound")


def test_a_training_can_be_stopped_and_saves_nothing(app, monkeypatch):
    import threading

    import cacas.lab
    from cacas.jobs import RUNNER

    saved, reported = [], threading.Event()

    def train(progress=None):
        for epoch in range(100_000):
            progress(epoch / 100_000, f"epoch {epoch}")
            reported.set()
            threading.Event().wait(0.01)
        saved.append("model")  # the real trainers save only at the end

    monkeypatch.setattr(cacas.lab, "train_sound", train)
    at = app(PAGE)
    next(b for b in at.button if b.label == "Train the sound model").click().run()
    job = RUNNER.get("train-sound")
    assert job is not None and reported.wait(30)
    at.run()
    stop = next(b for b in at.button if b.label == "Stop")  # under the running job's progress bar
    stop.click().run()
    assert job.wait(30) and job.status == "stopped"
    at.run()
    no_exception(at)
    assert saved == []
    assert any("Training the sound model was stopped" in i.value and "nothing was saved" in i.value for i in at.info)
    assert any(b.label == "Train the sound model" and not b.disabled for b in at.button)  # it can start again
    RUNNER.forget("train-sound")


def test_a_model_trained_on_another_library_says_so(app, monkeypatch):
    from types import SimpleNamespace

    import cacas.lab
    from cacas.audio.library import clip_paths
    from cacas.spaces import ACTIVITIES

    clips = sum(len(clip_paths(a)) for a in ACTIVITIES)
    trained_on = {"now": clips, "before": clips - 2}
    for stamp, (when, n) in enumerate(trained_on.items(), 1):  # a model file of its own each (cached by it)
        monkeypatch.setattr(cacas.lab, "model_stamp", lambda kind, t=stamp: float(t) if kind == "sound" else None)
        monkeypatch.setattr(cacas.lab, "load_recognizer", lambda kind, n=n: SimpleNamespace(model_id="0123456789ab", metadata={
            "trained": "2026-11-21T10:34:00Z", "accuracy": 0.9, "training_seconds": 70,
            "training_data": {"recordings": n}}))
        at = app(PAGE)
        no_exception(at)
        stale = [c.value for c in at.caption if "train it again" in c.value]
        assert stale == ([] if when == "now" else [
            f"{ui.icon('update')} The sound library holds {clips} clips now ({clips - 2} when this model was "
            "trained): train it again to use them."])


def test_the_scene_library_counts_each_room_and_a_stale_scene_model_says_so(app, monkeypatch):
    from types import SimpleNamespace

    import cacas.lab
    from cacas.spaces import SCENES
    from cacas.vision.library import image_paths

    photos = {s: len(image_paths(s)) for s in SCENES}
    monkeypatch.setattr(cacas.lab, "model_stamp", lambda kind: 7.0 if kind == "scene" else None)
    monkeypatch.setattr(cacas.lab, "load_recognizer", lambda kind: SimpleNamespace(model_id="0123456789ab", metadata={
        "trained": "2026-11-21T10:34:00Z", "accuracy": 0.9, "training_seconds": 400,
        "training_data": {"images": sum(photos.values()) - 5}}))
    at = app(PAGE)
    no_exception(at)
    assert f"**{sum(photos.values())} photos** for **6 of 6** rooms." in [m.value.split(" In a study")[0]
                                                                          for m in at.markdown]
    for i, scene in enumerate(SCENES, 1):
        assert f"**{i}. {scene}** · {photos[scene]} photo{'s' if photos[scene] != 1 else ''}" in [m.value for m in at.markdown]
    assert [c.value for c in at.caption if "train it again" in c.value] == [
        f"{ui.icon('update')} The scene library holds {sum(photos.values())} photos now ({sum(photos.values()) - 5} "
        "when this model was trained): train it again to use them."]
    # the id the study's interactions record for this model (interactions.csv's scene_model)
    assert [c.value.split(" · ")[-1] for c in at.caption if c.value.startswith("Trained ")] == ["model id 0123456789ab"]
    assert [s.label for s in at.selectbox if s.key in ("sound-add-name", "scene-add-name")] == ["Activity", "Room"]
    # nothing preset: a clip added without a choice went to "cough", the first activity in the list
    assert [s.value for s in at.selectbox if s.key in ("sound-add-name", "scene-add-name")] == [None, None]
    next(b for b in at.button if b.key == "sound-add").click().run()
    assert [e.value for e in at.error] == ["Choose the activity the clips are of; nothing was added."]


def test_training_while_a_study_day_is_open_is_warned(app, store):
    """A model trained mid-day changes what the tablet's robot hears from the next interaction on, and
    training slows the tablet: the Train tab names the open days."""
    at = app(PAGE)
    assert not [w for w in at.warning if "Study days are open" in w.value]
    store.add_participant("P01")
    store.create_study("pilot")
    store.add_participant("Q01", study="pilot")
    store.open_day("P01")
    store.close_day("Q01", store.open_day("Q01"))
    store.open_day("Q01")
    at = app(PAGE)
    no_exception(at)
    assert [w.value.split(".")[0] for w in at.warning if "Study days are open" in w.value] == [
        "Study days are open: P01 (day 1), Q01 (day 2)"]


def test_clips_added_outside_the_page_are_counted_without_a_restart(app, tmp_path, monkeypatch):
    """`cacas sound import` (or a copy) while the app runs: the library stayed at its old count
    until the server restarted, and the tablet played no clip of the new folder (walkthrough)."""
    import shutil

    from cacas.paths import PROJECT_ROOT

    data = tmp_path / "data"
    shutil.copytree(PROJECT_ROOT / "study_data" / "scenes", data / "scenes")
    (data / "sounds" / "cough").mkdir(parents=True)
    (data / "sounds" / "cough" / "a.wav").write_bytes(_wav())
    monkeypatch.setenv("CACAS_STUDY_DATA", str(data))
    at = app(PAGE)
    no_exception(at)
    summary = lambda: [m.value for m in at.markdown if m.value.endswith(" activities.")]  # noqa: E731
    assert summary() == ["**1 clips** for **1 of 33** activities."]
    (data / "sounds" / "cough" / "b.wav").write_bytes(_wav())
    (data / "sounds" / "sneeze").mkdir()
    (data / "sounds" / "sneeze" / "c.wav").write_bytes(_wav())
    at.run()
    assert summary() == ["**3 clips** for **2 of 33** activities."]


def test_every_clip_of_an_activity_says_when_it_shows_the_first_40(app, tmp_path, monkeypatch):
    """Walkthrough: "Every clip of one activity" showed 40 of cry's 41 clips without a word (the photos
    said "The first 48 of N")."""
    import shutil

    from cacas.paths import PROJECT_ROOT

    data = tmp_path / "data"
    shutil.copytree(PROJECT_ROOT / "study_data" / "scenes", data / "scenes")
    (data / "sounds" / "cough").mkdir(parents=True)
    for i in range(41):
        (data / "sounds" / "cough" / f"c{i:02d}.wav").write_bytes(_wav())
    monkeypatch.setenv("CACAS_STUDY_DATA", str(data))
    at = open_expander(app(PAGE), "lib-every-clip")
    no_exception(at)
    assert "The first 40 of 41 clips, by file name." in [c.value for c in at.caption]
    assert len(at.get("audio")) >= 40


def test_every_clip_and_every_photo_are_drawn_only_once_opened(app, tmp_path, monkeypatch):
    """Helper's profile: the closed "Every clip of one activity" and "Every photo of one room" expanders
    sent their 40 audio players and 48 photos on every run of the page. They are drawn once opened, the
    activity and the room chosen there kept while closed."""
    import shutil

    from cacas.paths import PROJECT_ROOT

    data = tmp_path / "data"
    shutil.copytree(PROJECT_ROOT / "study_data" / "scenes", data / "scenes")
    for activity in ("cough", "sneeze"):
        (data / "sounds" / activity).mkdir(parents=True)
        for i in range(3):
            (data / "sounds" / activity / f"{activity}{i}.wav").write_bytes(_wav(0.6))
    monkeypatch.setenv("CACAS_STUDY_DATA", str(data))
    at = app(PAGE)
    no_exception(at)
    grid = lambda: (len(at.get("audio")), len(at.get("image")))  # noqa: E731
    assert grid() == (2, 6)  # the libraries' cards: a clip of each of 2 activities, a photo of each of 6 rooms
    # each photo named for a screen reader, by its room and file (they had no alt text: accessibility walkthrough)
    alts = [i.alt for e in at.get("image") for i in e.proto.imgs]
    assert len(alts) == 6 and all(a.startswith("A photo in ") for a in alts)
    assert any(a.startswith("A photo in the dining room: ") for a in alts)
    assert any(a.startswith("A photo in another room: ") for a in alts)
    assert not [s for s in at.selectbox if s.key in ("lib-activity", "lib-room")]
    at = open_expander(at, "lib-every-clip")
    no_exception(at)
    at.selectbox(key="lib-activity").set_value("sneeze").run()
    assert grid() == (2 + 3, 6) and [c.value for c in at.caption if c.value.startswith("sneeze")] == \
        ["sneeze0.wav", "sneeze1.wav", "sneeze2.wav"]
    at = open_expander(at, "lib-every-photo")
    photos = len(at.get("image")) - 6
    assert photos == min(48, len(list((data / "scenes" / "bedroom").iterdir()))) and photos > 6
    at = open_expander(at, "lib-every-clip", False)
    at = open_expander(at, "lib-every-photo", False)
    assert grid() == (2, 6)
    assert open_expander(at, "lib-every-clip").selectbox(key="lib-activity").value == "sneeze"


def _library_app(app, tmp_path, monkeypatch):
    """The page over a study data folder of its own (the shipped scenes, one cough clip)."""
    import shutil

    from cacas.paths import PROJECT_ROOT

    data = tmp_path / "data"
    shutil.copytree(PROJECT_ROOT / "study_data" / "scenes", data / "scenes")
    (data / "sounds" / "cough").mkdir(parents=True)
    (data / "sounds" / "cough" / "a.wav").write_bytes(_wav())
    monkeypatch.setenv("CACAS_STUDY_DATA", str(data))
    return app(PAGE), data


def _add_clips(at, *files, activity="cough"):
    """Choose ``activity`` (None: none) and the (name, bytes) files, then press Add."""
    at.selectbox(key="sound-add-name").set_value(activity)
    uploader = next(u for u in at.get("file_uploader") if u.key.startswith("sound-upload-"))
    uploader.set_value([(name, data, "audio/wav") for name, data in files])
    at.button(key="sound-add").click().run()
    no_exception(at)


def _errors(at) -> list[str]:
    return [e.value for e in at.error if not e.value.startswith("Set-up:")]  # a folder without the D4A pairs


def test_the_page_calls_sound_files_clips_in_its_messages_too(app, tmp_path, monkeypatch):
    """The page calls them clips ("Add clips", "Sound library": "No clips yet."), but its messages, from the
    library and the lab, said "recordings": "2 of the 2 recordings cannot be used", "the same recording is given
    twice", "Add recordings of one activity". The page's word now, in the messages too."""
    at, data = _library_app(app, tmp_path, monkeypatch)
    assert "Add clips of one activity:" in texts(at)
    _add_clips(at, ("my notes.wav", b"text"), ("my other notes.wav", b"more text"))
    assert _errors(at)[0].startswith("2 of the 2 clips cannot be used; nothing was added:"), _errors(at)
    _add_clips(at, ("a.wav", _wav(0.8)), ("a again.wav", _wav(0.8)))
    assert _errors(at) and _errors(at)[0].startswith("a again.wav: the same clip is given twice"), _errors(at)
    # the page's caption keeps "real (household) recordings": the paper's sounds, not the library's files
    assert "recording" not in texts(at).replace("real household recordings", "").replace("real recordings", "")


def test_a_refused_add_is_said_until_the_files_or_the_activity_change(app, tmp_path, monkeypatch):
    """Review: the refusal stayed on the Add tab after the researcher had chosen other files (until the
    next Add), as if the new files had been refused too."""
    at, data = _library_app(app, tmp_path, monkeypatch)
    _add_clips(at, ("b.wav", _wav(0.8)))
    assert "Added 1 clip to 'cough'." in texts(at)
    _add_clips(at, ("b2.wav", _wav(0.8)))  # the same bytes: refused, in the words of the page's button
    assert _errors(at) == ["b2.wav: the same clip is already in the library as cough/b.wav; nothing was added "
                           "(leave the copy out and press 'Add to the library' again)"]
    at.run()  # anything else on the page: the same files are still the ones refused
    assert any("already in the library" in e for e in _errors(at))
    uploader = next(u for u in at.get("file_uploader") if u.key.startswith("sound-upload-"))
    uploader.set_value([("c.wav", _wav(0.9), "audio/wav")]).run()  # other files chosen: not refused (yet)
    no_exception(at)
    assert not _errors(at)
    assert sorted(p.name for p in (data / "sounds" / "cough").iterdir()) == ["a.wav", "b.wav"]

    _add_clips(at, ("d.wav", _wav(0.7)), activity=None)  # no activity chosen
    assert _errors(at) == ["Choose the activity the clips are of; nothing was added."]
    at.selectbox(key="sound-add-name").set_value("sneeze").run()
    assert not _errors(at)


def test_a_copy_is_refused_in_the_words_of_the_add_button(tmp_path):
    """Review: a clip or photo already in the library was refused with "nothing was imported (leave the copy
    out and import again)", beside a button called "Add to the library"; `cacas sound import` keeps its words."""
    import io

    import pytest
    from photos import photo

    from cacas import lab
    from cacas.audio import library
    from cacas.errors import CacasError

    jpeg = io.BytesIO()
    photo().save(jpeg, format="JPEG")
    for add, name, data, root in ((lab.add_clips, "a.wav", _wav(), tmp_path / "sounds"),
                                  (lab.add_photos, "a.jpg", jpeg.getvalue(), tmp_path / "scenes")):
        where = add("kitchen" if add is lab.add_photos else "cough", [(name, data)], root)[0]
        for files in ([("again" + name[1:], data)], [("b" + name[1:], data), ("c" + name[1:], data)]):
            with pytest.raises(CacasError) as refused:
                add("kitchen" if add is lab.add_photos else "cough", files, root)
            said = str(refused.value)
            assert said.endswith("nothing was added (leave the copy out and press 'Add to the library' again)")
            assert "import" not in said and lab.ADD_BUTTON == "Add to the library"
        assert list(where.parent.iterdir()) == [where]
    src = tmp_path / "mine" / "cough"
    src.mkdir(parents=True)
    (src / "a.wav").write_bytes(_wav())
    with pytest.raises(CacasError, match=r"nothing was imported \(leave the copy out and import again\)$"):
        library.import_folder(tmp_path / "mine", root=tmp_path / "sounds")  # the command's words


def test_a_long_clip_is_said_to_weigh_its_activity(app, tmp_path, monkeypatch):
    """Review: a 60-s clip was added without a word, though the model learns from it as from as many
    windows as seconds, more than a whole activity of the library holds: the page says so (the window
    length taken from the features), and says nothing of a clip of usual length. The clip is named as
    uploaded, with the name it is stored under (walkthrough: "my_long_take.wav" for "my long take.wav")."""
    from cacas.audio.features import WINDOW_SECONDS

    at, data = _library_app(app, tmp_path, monkeypatch)  # cough: one 1-s clip
    (data / "sounds" / "sneeze").mkdir()
    for name in ("s1.wav", "s2.wav"):  # sneeze: 2 windows; the median of the activities other than cough
        (data / "sounds" / "sneeze" / name).write_bytes(_wav(1.0 + len(name) / 100))
    _add_clips(at, ("usual.wav", _wav(2.0, rate=8000)))
    assert "Added 1 clip to 'cough'." in texts(at) and not [w for w in at.warning if "s long" in w.value]
    seconds = 12 * WINDOW_SECONDS
    n = round(seconds / WINDOW_SECONDS)
    _add_clips(at, ("my long take.wav", _wav(seconds, rate=8000)))  # named as uploaded, and as stored
    notes = [w.value for w in at.warning if "s long" in w.value]
    assert notes == [f"my long take.wav (in the library as my_long_take.wav) is {seconds:.0f} s long: the sound model learns from {WINDOW_SECONDS:g}-s windows, "
                     f"so this one clip gives 'cough' {n} windows, more than a whole activity has (the other "
                     f"activities' median: 2). 'cough' has {1 + 2 + n} now and weighs more than the others in training: "
                     "clips of a few seconds, or more clips of the other activities, keep them even."]
    at.selectbox(key="sound-add-name").set_value("sneeze").run()  # said until the next Add
    assert [w.value for w in at.warning if "s long" in w.value] == notes


def test_the_model_a_training_replaced_is_shown_and_put_back(app, tmp_path, monkeypatch):
    """A training replaced a 98.5 % model with an 18 % one, unsaid and for good (lab walkthrough):
    the replaced model is kept and shown, 'Put back the previous sound model' swaps the two (a second
    press undoes it), and a kept model that cannot be read is said, with nothing changed."""
    import cacas.lab
    from cacas.audio.model import SoundCNN, SoundRecognizer

    monkeypatch.setenv("CACAS_STUDY_DATA", str(tmp_path))
    monkeypatch.setattr(cacas.lab, "model_stamp", lambda kind: (  # the real stamp: the file's time
        cacas.lab.model_path(kind).stat().st_mtime_ns if cacas.lab.model_path(kind).exists() else None))
    path = cacas.lab.model_path("sound")
    SoundRecognizer(SoundCNN(), metadata={"accuracy": 0.985, "trained": "2026-11-20T09:00:00+00:00"}).save(path)
    good = cacas.lab.load_recognizer("sound").model_id
    at = app(PAGE)
    no_exception(at)
    assert not [b for b in at.button if b.key == "btn-put-back-sound"]  # nothing kept yet
    SoundRecognizer(SoundCNN(), metadata={"accuracy": 0.18, "trained": "2026-11-26T18:00:00+00:00"}).save(
        path, keep_previous=True)
    poor = cacas.lab.load_recognizer("sound").model_id
    at.run()
    kept = [c.value for c in at.caption if c.value.startswith(f"{ui.icon('history')} Kept")]
    assert kept == [f"{ui.icon('history')} Kept beside it, to put back: model id {good}, trained "
                    "2026-11-20 09:00 UTC, test accuracy 98.5%."]
    assert f"test accuracy 18.0% · ? items · ? s · model id {poor}" in texts(at)  # the saved one, as before
    assert at.button(key="btn-put-back-sound").label == "Put back the previous sound model"
    from cacas.jobs import RUNNER  # the last training's results, of the model about to be put aside

    RUNNER.start("train-sound", lambda progress=None: None, label="Training the sound model")
    assert RUNNER.get("train-sound").wait(30)
    at.run()
    assert any(c.value.startswith("Training the sound model: finished") for c in at.caption)
    at.button(key="btn-put-back-sound").click().run()
    assert not any(c.value.startswith("Training the sound model: finished") for c in at.caption)  # not shown
    assert RUNNER.get("train-sound") is None  # under the model put back
    no_exception(at)
    assert cacas.lab.load_recognizer("sound").model_id == good
    assert [s.value for s in at.success] == [
        f"The previous sound model is back (model id {good}, trained 2026-11-20 09:00 UTC, test accuracy 98.5%); "
        f"the one it replaced is kept (model id {poor}, trained 2026-11-26 18:00 UTC, test accuracy 18.0%)."]
    assert f"model id {good}" in [c.value for c in at.caption if c.value.startswith("Trained")][0]  # reloaded
    at.button(key="btn-put-back-sound").click().run()  # again: back to where it started
    assert cacas.lab.load_recognizer("sound").model_id == poor and cacas.lab.kept_model("sound")["model_id"] == good
    kept_file = cacas.lab.model_path("sound").with_name("sound_cnn.previous.pt")
    kept_file.write_bytes(b"damaged")
    at.button(key="btn-put-back-sound").click().run()
    no_exception(at)
    assert [e.value for e in at.error if not e.value.startswith("Set-up:")] == [  # (the empty folder's set-up note)
        f"the previous sound model kept beside sound_cnn.pt cannot be put back; nothing was changed: {kept_file}: "
        "not a sound model (not a PyTorch file); expected a model saved by `cacas sound train` (.pt, with its .json "
        "beside it)"]
    assert cacas.lab.load_recognizer("sound").model_id == poor


def test_a_put_back_pressed_while_a_training_runs_is_refused(app, tmp_path, monkeypatch):
    """A page drawn before a training started (another browser) still shows the button: pressed,
    nothing is put back (the training's save would undo the swap and lose the model put aside): the
    press's run draws it disabled, and a disabled button reports no press. A model saved but
    unreadable is said, not shown as 'No trained model saved yet'."""
    import threading

    import cacas.lab
    from cacas.audio.model import SoundCNN, SoundRecognizer
    from cacas.jobs import RUNNER

    monkeypatch.setenv("CACAS_STUDY_DATA", str(tmp_path))
    monkeypatch.setattr(cacas.lab, "model_stamp", lambda kind: (  # the file's time, as the real stamp
        cacas.lab.model_path(kind).stat().st_mtime_ns if cacas.lab.model_path(kind).exists() else None))
    path = cacas.lab.model_path("sound")
    SoundRecognizer(SoundCNN(), metadata={"accuracy": 0.9}).save(path)
    SoundRecognizer(SoundCNN(), metadata={"accuracy": 0.2}).save(path, keep_previous=True)
    serving = cacas.lab.load_recognizer("sound").model_id
    at = app(PAGE)
    assert not at.button(key="btn-put-back-sound").disabled
    release = threading.Event()
    RUNNER.start("train-sound", lambda progress=None: release.wait(30), label="Training the sound model")
    try:
        at.button(key="btn-put-back-sound").click().run()
        no_exception(at)
        assert cacas.lab.load_recognizer("sound").model_id == serving and not at.success
        assert at.button(key="btn-put-back-sound").disabled  # and drawn disabled meanwhile
    finally:
        release.set()
        assert RUNNER.get("train-sound").wait(30)
        RUNNER.forget("train-sound")
    path.write_bytes(b"damaged")
    at.run()
    assert f"{path}: not a sound model (not a PyTorch file)" in " ".join(e.value for e in at.error)
    assert [c.value for c in at.caption].count("No trained model saved yet.") == 1  # the scene model's alone


def test_the_library_tabs_say_what_training_would_refuse(app, tmp_path, monkeypatch):
    """Walkthrough: a folder 'coughing' (not an activity) and a notes.txt in cry/ were passed over on the
    Sound library tab ("48 clips for 2 of 33 activities", all well), and training then failed on them
    after it had started; the tab says it, naming the folder and what is valid. The same for the scenes."""
    import shutil

    from cacas.paths import PROJECT_ROOT

    data = tmp_path / "data"
    shutil.copytree(PROJECT_ROOT / "study_data" / "scenes", data / "scenes")
    (data / "sounds" / "cry").mkdir(parents=True)
    (data / "sounds" / "cry" / "a.wav").write_bytes(_wav())
    (data / "sounds" / "cry" / "b.wav").write_bytes(_wav(0.8))
    monkeypatch.setenv("CACAS_STUDY_DATA", str(data))
    at = app(PAGE)
    no_exception(at)
    assert not [w.value for w in at.warning if "would refuse" in w.value]  # a library training takes
    (data / "sounds" / "coughing").mkdir()
    (data / "sounds" / "coughing" / "b.wav").write_bytes(_wav(0.9))
    (data / "scenes" / "bedroom" / "notes.txt").write_text("camera settings")
    at.run()
    no_exception(at)
    said = [w.value for w in at.warning if "would refuse" in w.value]
    assert len(said) == 2, said
    assert said[0].startswith("Training the sound model would refuse this library: ")
    assert "folder name 'coughing' is not an activity; did you mean 'cough'? valid: cough, cry" in said[0]
    assert said[1].startswith("Training the scene model would refuse this library: ")
    assert "notes.txt: unsupported file type '.txt'; valid: " in said[1]


def test_the_sound_library_tab_says_an_activity_with_a_single_clip(app, tmp_path, monkeypatch):
    """Walkthrough: an activity with one clip was counted like any other ("1 clip"), and training failed on
    it once started ("cannot be split 9:1"); the tab says it first, with what is valid."""
    at, data = _library_app(app, tmp_path, monkeypatch)  # cough: one clip
    no_exception(at)
    said = [w.value for w in at.warning if "would refuse" in w.value]
    assert len(said) == 1 and said[0].endswith(
        "activities with a single clip cannot be split 9:1 into training and test: cough; valid: 2 clips "
        "or more of each activity that has any (add another, or remove the one)"), said
    (data / "sounds" / "cough" / "b.wav").write_bytes(_wav(0.9))
    at.run()
    assert not [w.value for w in at.warning if "would refuse" in w.value]


def test_training_is_not_offered_on_a_library_it_would_refuse(app, tmp_path, monkeypatch):
    """Walkthrough: "Train the sound model" started on a library with no sounds folder (or an activity of one
    clip) and failed a moment later; the Train tab says why first, and the button waits until it is fixed."""
    at, data = _library_app(app, tmp_path, monkeypatch)  # cough: one clip
    no_exception(at)
    assert at.button(key="btn-train-sound").disabled
    assert not at.button(key="btn-train-scene").disabled  # the shipped scenes: fine
    said = [e.value for e in at.warning if e.value.startswith("Cannot train the sound model on this library: ")]
    assert len(said) == 1 and "cough; valid: 2 clips or more" in said[0], said
    (data / "sounds" / "cough" / "b.wav").write_bytes(_wav(0.9))
    at.run()
    assert not at.button(key="btn-train-sound").disabled
    assert not [e.value for e in at.warning if e.value.startswith("Cannot train")]


def test_every_photo_of_a_room_stands_in_a_row_that_wraps_each_as_wide_as_its_name(app, monkeypatch):
    """The ui helpers saw the shipped photos' captions break mid-name at 1280 px ("synthetic_0_000.jp" / "g", six
    columns) and, with five columns fitted to 1280 px, at 1024 ("synthetic_0_00" / "0.jpg"): the page cannot know
    the window's width. The photos stand in a row that wraps (st.container(horizontal=True)), each as wide as keeps
    the longest name on one line (table_layouts.photo_width), as many side by side as the window holds (the
    browser test measures the captions at 1024, 1280 and 1440 px)."""
    import streamlit as st

    from cacas import table_layouts
    from cacas.paths import PROJECT_ROOT

    drawn = []
    real = st.image

    def image(picture, caption=None, width="content", **kwargs):
        drawn.append((caption, width))
        return real(picture, caption=caption, width=width, **kwargs)
    monkeypatch.setattr(st, "image", image)
    at = open_expander(app(PAGE), "lib-every-photo")
    no_exception(at)
    grid = next(b for b in _blocks(at.main) if "every-photo-grid" in str(getattr(getattr(b, "proto", None), "id", "")))
    assert grid.proto.flex_container.wrap and grid.proto.flex_container.direction == 2  # HORIZONTAL
    names = sorted(p.name for p in (PROJECT_ROOT / "study_data" / "scenes" / "bedroom").glob("*.jpg"))[:48]
    assert [c for k in grid.children.values() for c in k.captions] == names  # every photo, by name
    widths = {w for c, w in drawn if c in names}
    # "synthetic_0_000.jpg" is 117.7 px in the caption's 14-px Source Sans (Chromium), 2 px of padding a side
    assert widths == {table_layouts.PHOTO_WIDTH} and table_layouts.PHOTO_WIDTH >= 117.7 + 4
    # a study's own photos, named by a phone (176.0 px): wider photos, each name whole
    assert table_layouts.photo_width(["PXL_20260301_101500123.jpg", "IMG_20260301_101500.jpg"]) >= 176.0 + 4
    assert table_layouts.photo_width(["a.jpg"]) == table_layouts.PHOTO_WIDTH


def _blocks(node):
    """``node`` and every block under it (AppTest's element tree)."""
    yield node
    for child in (getattr(node, "children", None) or {}).values():
        yield from _blocks(child)


def _try_a_photo(monkeypatch, shares, labels):
    """The Try tab given a kitchen photo to recognise (AppTest cannot upload: the uploader is given the photo)
    and a scene model whose recognition has ``shares`` of ``labels``."""
    from types import SimpleNamespace

    import streamlit as st

    from cacas import lab
    from cacas.paths import PROJECT_ROOT
    from cacas.recognition import make_recognition
    from pages import ui

    photo = sorted((PROJECT_ROOT / "study_data" / "scenes" / "kitchen").glob("*.jpg"))[0]
    real = st.file_uploader

    def uploader(label, *args, **kwargs):
        if kwargs.get("key") == "try-photo":
            return SimpleNamespace(name=photo.name, getvalue=photo.read_bytes)
        return real(label, *args, **kwargs)
    monkeypatch.setattr(st, "file_uploader", uploader)
    monkeypatch.setattr(ui, "recognizer", lambda kind: SimpleNamespace(metadata={}, model_id="m1"))
    monkeypatch.setattr(lab, "recognize_scene_bytes", lambda model, name, data: make_recognition(shares, labels))


def test_the_top_3_says_shares_as_the_unsure_warning_does(app, monkeypatch):
    """A photo recognised at 0.4996: the warning said "Unsure: 49%" and the top 3 beside it "49.96%" (Streamlit's
    "percent" format, two decimals). The top 3 now says whole percents by the warning's rule
    (Recognition.top3_words): 49, 40; a share of 0.4 % "<1%" (a progress column's "%d%%" said "0%"), each beside
    an unlabelled bar of its exact share."""
    from cacas import spaces

    _try_a_photo(monkeypatch, [0.4996, 0.4964, 0.004] + [0.0] * (len(spaces.SCENES) - 3), spaces.SCENES)
    at = app(PAGE)
    no_exception(at)
    assert any(w.value.startswith(f"Unsure: 49% for {spaces.SCENES[0]}.") for w in at.warning)
    top3 = next(d for d in at.dataframe if "scene" in d.value.columns)
    assert list(top3.value["probability"]) == ["49%", "49%", "<1%"]
    assert list(top3.value["bar"]) == pytest.approx([49.96, 49.64, 0.4])
    bar = json.loads(top3.proto.columns)["bar"]
    assert bar["type_config"]["format"] == " " and bar["label"] == " "


def test_the_recognised_label_has_no_anchor_link_icon(app, monkeypatch):
    """The Try tab's result ("### kitchen") kept Streamlit's anchor-link icon beside it, of no use there (the
    tablet's headings dropped theirs)."""
    _try_a_photo(monkeypatch, [0.8, 0.15, 0.05], ["kitchen", "living room", "others"])
    at = app(PAGE)
    no_exception(at)
    headings = [m for m in at.main.markdown if m.value.startswith("#")]
    assert [m.value for m in headings] == ["### kitchen"]
    assert all(m.proto.hide_anchors for m in headings)


def test_a_retrained_model_is_not_kept_in_memory_beside_the_one_it_replaced(db, monkeypatch):
    """The saved models are cached by their file's time, so that a retrained one is loaded: every model a page had
    loaded stayed in the server's memory until it stopped (the scene model, a ResNet-18, is 43 MB in memory), one
    more each training. The cache keeps the two in use, the sound and the scene model."""
    import cacas.lab

    stamps = {"sound": 1.0, "scene": 1.0}
    monkeypatch.setattr(cacas.lab, "model_stamp", lambda kind: stamps[kind])
    monkeypatch.setattr(cacas.lab, "load_recognizer", lambda kind: object())  # a model loaded afresh each time
    for training in range(5):  # the scene model retrained five times; the tablet uses both models meanwhile
        stamps["scene"] += 1
        sound, scene = ui.recognizer("sound"), ui.recognizer("scene")
    assert ui.recognizer("sound") is sound and ui.recognizer("scene") is scene  # the models in use stay loaded
    assert len(cache_of("pages.ui._saved_recognizer")._mem_cache) == 2
