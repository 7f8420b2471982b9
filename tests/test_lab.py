import inspect
import re

from cacas import lab


class _Result:
    def __init__(self, saved):
        self.recognizer = self
        self.saved = saved

    def save(self, path, keep_previous=False):
        self.saved.append((path, keep_previous))


def test_app_sound_training_uses_the_command_line_defaults(monkeypatch, tmp_path):
    import cacas.audio.model
    import cacas.audio.training
    from cacas.cli import sound as sound_cli

    default = inspect.signature(cacas.audio.training.train_sound_model).parameters["epochs"].default
    calls, saved = [], []
    monkeypatch.setattr(cacas.audio.training, "train_sound_model",
                        lambda **kw: calls.append(kw) or _Result(saved))
    monkeypatch.setattr(cacas.audio.model, "default_model_path", lambda: tmp_path / "sound_cnn.pt")
    lab.train_sound()
    assert "epochs" not in calls[0] and saved == [(tmp_path / "sound_cnn.pt", True)]  # the replaced one kept
    lab.train_sound(epochs=2, seed=5)
    assert calls[1]["epochs"] == 2 and calls[1]["seed"] == 5
    # the defaults the app now relies on are the ones `cacas sound train` uses
    import argparse

    parser = argparse.ArgumentParser()
    sound_cli.register(parser.add_subparsers())
    assert parser.parse_args(["sound", "train"]).epochs == default


def test_a_bad_upload_is_named_as_uploaded_not_by_its_temporary_file():
    import pytest

    from cacas import lab
    from cacas.audio.features import load_clip
    from cacas.errors import CacasError

    class Hears:
        def recognize(self, path):
            return load_clip(path)

    with pytest.raises(CacasError) as exc:
        lab.recognize_sound_bytes(Hears(), "notes.wav", b"these are notes, not sound")
    message = str(exc.value)
    assert message.startswith("notes.wav: ") and "/tmp" not in message and "tmp" not in message.split(":")[0]
    with pytest.raises(CacasError, match=r"^photo.jpg: is empty \(0 bytes\)$"):
        lab.recognize_scene_bytes(Hears(), "photo.jpg", b"")


def test_an_upload_without_a_file_type_is_read_as_the_default_type():
    """A recording or picture named without an extension ("recording", "camera") is written under
    the kind's default type, which the recognisers read (else: "unsupported file type '(none)'")."""
    class Named:
        def recognize(self, path):
            return path.name

    assert lab.recognize_sound_bytes(Named(), "recording", b"RIFF") == "recording.wav"
    assert lab.recognize_scene_bytes(Named(), "camera", b"\x89PNG") == "camera.jpg"
    assert lab.recognize_scene_bytes(Named(), "our sofa.png", b"\x89PNG") == "our_sofa.png"


# --- the saved models: stamp, loading by kind, training and evaluating in the app --------------------

import pytest  # noqa: E402

from cacas.errors import CacasError  # noqa: E402


@pytest.fixture
def study_data(tmp_path, monkeypatch):
    """An empty study data folder (no model saved, no library) in place of the shipped one."""
    monkeypatch.setenv("CACAS_STUDY_DATA", str(tmp_path))
    return tmp_path


def _saved_sound_model():
    from cacas.audio.model import SoundCNN, SoundRecognizer, default_model_path

    return SoundRecognizer(SoundCNN(), metadata={"accuracy": 0.5}).save(default_model_path())


def test_model_stamp_is_the_saved_model_file_time(study_data):
    import os

    assert lab.model_stamp("sound") is None and lab.model_stamp("scene") is None
    path = _saved_sound_model()
    os.utime(path, (1_700_000_000, 1_700_000_000))
    assert lab.model_stamp("sound") == 1_700_000_000 and lab.model_stamp("scene") is None
    with pytest.raises(CacasError, match=r"^unknown model kind 'speech'; valid: sound, scene$"):
        lab.model_stamp("speech")


def test_load_recognizer_by_kind(study_data):
    from cacas.audio.model import SoundRecognizer

    assert lab.load_recognizer("sound") is None and lab.load_recognizer("scene") is None  # none saved
    path = _saved_sound_model()
    rec = lab.load_recognizer("sound")
    assert isinstance(rec, SoundRecognizer) and rec.metadata["accuracy"] == 0.5
    with pytest.raises(CacasError, match="unknown model kind 'photo'"):
        lab.load_recognizer("photo")
    path.write_bytes(b"not a model")
    with pytest.raises(CacasError, match="sound_cnn"):
        lab.load_recognizer("sound")


def test_evaluate_sound_tests_the_saved_model_on_the_library(study_data):
    from cacas.audio.library import generate_library

    generate_library(2, seconds=1.0, root=study_data / "sounds", activities=["cough", "watch TV"])
    with pytest.raises(CacasError, match="no such sound model"):
        lab.evaluate_sound()
    _saved_sound_model()
    told = []
    metrics = lab.evaluate_sound(progress=lambda f, m: told.append(f))
    assert metrics.n == 4 and 0.0 <= metrics.accuracy <= 1.0 and metrics.extra["set"] == "all"
    assert told and told[-1] == 1.0


def test_train_scene_saves_the_model_evaluate_scene_tests_it(study_data, monkeypatch):
    """train_scene with the ResNet-18 training itself replaced by an untrained network (the
    training is tested in test_vision_model); what lab adds, passing the options and saving
    where the pages load the model, really runs, as does the evaluation."""
    import cacas.vision.training
    from cacas.vision.library import generate_scenes
    from cacas.vision.model import SceneRecognizer, build_resnet18

    generate_scenes(1, size=64, root=study_data / "scenes")
    calls = []

    def train_scene_model(**kw):
        calls.append(kw)
        model, _ = build_resnet18(weights="none")
        return cacas.vision.training.SceneTrainingResult(SceneRecognizer(model, metadata={"accuracy": 0.25}),
                                                         None, None, None, 0.0)

    monkeypatch.setattr(cacas.vision.training, "train_scene_model", train_scene_model)
    progress = lambda f, m: None  # noqa: E731
    result = lab.train_scene(progress, epochs=2, seed=7)
    assert calls == [{"epochs": 2, "seed": 7, "progress": progress}]
    assert lab.model_stamp("scene") is not None
    loaded = lab.load_recognizer("scene")
    assert isinstance(loaded, SceneRecognizer) and loaded.metadata["accuracy"] == 0.25
    assert result.recognizer.metadata["kind"] == "scene"
    metrics = lab.evaluate_scene()
    assert metrics.n == 6 and metrics.classes == list(loaded.classes) and metrics.extra["set"] == "all"
    assert lab.kept_model("scene") is None  # nothing was replaced
    lab.train_scene(progress, epochs=1, seed=8)  # the second training keeps the first's model
    assert lab.kept_model("scene")["model_id"] == loaded.model_id


def test_the_model_a_training_replaced_can_be_put_back_and_put_back_again(study_data):
    """Each training keeps the model it replaces; putting it back swaps the two (the tablets
    reload it: its file time changes), and a second put back returns to where one started."""
    import os

    from cacas.audio.model import SoundCNN, SoundRecognizer

    assert lab.kept_model("sound") is None
    with pytest.raises(CacasError, match=r"sound_cnn\.pt: no previous sound model is kept beside it "
                                         r"\(sound_cnn\.previous\.pt\); one is kept each time training replaces"):
        lab.put_back_previous_model("sound")
    first = _saved_sound_model()
    first_id = lab.load_recognizer("sound").model_id
    second = SoundRecognizer(SoundCNN(), metadata={"accuracy": 0.18}).save(first, keep_previous=True)
    second_id = lab.load_recognizer("sound").model_id
    assert second_id != first_id  # other weights (drawn anew)
    assert lab.kept_model("sound")["model_id"] == first_id and lab.kept_model("sound")["accuracy"] == 0.5
    os.utime(second, (1_700_000_000, 1_700_000_000))
    saved, kept = lab.put_back_previous_model("sound")
    assert (saved["model_id"], saved["accuracy"]) == (first_id, 0.5)
    assert (kept["model_id"], kept["accuracy"]) == (second_id, 0.18)
    rec = lab.load_recognizer("sound")
    assert (rec.model_id, rec.metadata["accuracy"]) == (first_id, 0.5)
    assert lab.model_stamp("sound") != 1_700_000_000  # the pages and tablets reload it
    assert lab.kept_model("sound")["model_id"] == second_id
    lab.put_back_previous_model("sound")  # again: the second model serves, the first is kept
    assert lab.load_recognizer("sound").model_id == second_id and lab.kept_model("sound")["model_id"] == first_id
    assert not list(study_data.glob("models/*.tmp"))
    with pytest.raises(CacasError, match=r"^unknown model kind 'speech'; valid: sound, scene$"):
        lab.put_back_previous_model("speech")


# --- adding photos of a room to the scene library -----------------------------------------------------

def _png(colour=(200, 120, 40)) -> bytes:
    import io

    from photos import photo

    buf = io.BytesIO()
    photo((40, 30), colour).save(buf, format="PNG")
    return buf.getvalue()


def test_add_photos_adds_checked_photos_all_or_nothing(tmp_path):
    from cacas.vision.library import image_paths

    root = tmp_path / "scenes"
    added = lab.add_photos("Living Room", [("our sofa.png", _png()), ("", _png((10, 20, 30)))], root)
    assert [(p.parent.name, p.name) for p in added] == [("living_room", "our_sofa.png"), ("living_room", "photo_2.jpg")]
    assert image_paths("living room", root) == sorted(added)
    for files, message in (([("notes.png", b"this is text")], r"^notes\.png: not a readable image"),
                           ([("empty.png", b"")], r"^empty\.png: is empty \(0 bytes\)$"),
                           ([("again.png", _png())], r"^again\.png: the same photo is already in the library as "
                                                     r"living_room/our_sofa\.png"),
                           ([], r"^no photo given; upload a JPEG or PNG photo or take one$")):
        new = [("good.png", _png((1, 2, 3)))] + files if files else files
        with pytest.raises(CacasError, match=message):
            lab.add_photos("living room", new, root)
    assert image_paths("living room", root) == sorted(added)  # nothing half-added
    # a name without a file type (a camera's "IMG_1234") gets the default one: the library takes it
    (camera,) = lab.add_photos("living room", [("IMG_1234", _png((40, 50, 60)))], root)
    assert (camera.parent.name, camera.name) == ("living_room", "IMG_1234.jpg")
    with pytest.raises(CacasError, match=r"attic.*valid.*kitchen"):
        lab.add_photos("attic", [("a.png", _png())], root)


def test_files_of_the_same_name_are_all_added_and_a_type_not_taken_is_refused(tmp_path):
    """Walkthrough: two photos called image.jpg (or "Küche Foto.jpg" and "Küche_Foto.jpg", the same file name once
    made safe) gave "Added 1": one overwrote the other; an MP3 among recordings was left out and the
    others added as if it had not been given."""
    from cacas.audio.library import clip_paths
    from cacas.vision.library import image_paths

    root = tmp_path / "scenes"
    added = lab.add_photos("kitchen", [("image.png", _png((1, 2, 3))), ("image.png", _png((90, 80, 70))),
                                       ("Küche Foto.png", _png((5, 50, 5))), ("Küche_Foto.png", _png((50, 5, 50)))],
                           root)
    assert [p.name for p in added] == ["image.png", "image-2.png", "Küche_Foto.png", "Küche_Foto-2.png"]  # as given
    assert len(image_paths("kitchen", root)) == 4
    sounds = tmp_path / "sounds"
    with pytest.raises(CacasError, match=r"^clip\.mp3: a \.mp3 file is not taken; valid: \.wav, \.flac, \.ogg "
                                         r"\(upload a WAV, FLAC or OGG file or record one\); nothing was added$"):
        lab.add_clips("cough", [("take.wav", b"RIFF...."), ("clip.mp3", b"ID3....")], sounds)
    assert clip_paths("cough", sounds) == []


def test_a_name_in_another_script_is_kept_with_its_file_type(tmp_path):
    """A lab outside the English-speaking world: only A-Z letters of an upload's name were kept, so "台所の写真.png"
    was stored as "png.jpg" (a PNG named JPEG, nothing of the name the researcher gave), "咳の録音.wav" as
    "wav.wav", "台所.gif" was added as "gif.jpg" where "kitchen.gif" is refused, and a name of more than 80
    characters lost its file type the same way. The letters of any script are kept, and the type as given."""
    from cacas.audio.library import clip_paths
    from cacas.vision.library import image_paths

    root = tmp_path / "scenes"
    added = lab.add_photos("kitchen", [("台所の写真.png", _png((5, 50, 5))), ("Küche Foto.png", _png((50, 5, 50))),
                                       ("مطبخ.png", _png((9, 90, 9))), ("🍳.png", _png((70, 7, 7))),
                                       ("Küche ☀️ hell.png", _png((7, 70, 7))), ("रसोई घर.png", _png((7, 7, 70)))], root)
    assert [p.name for p in added] == ["台所の写真.png", "Küche_Foto.png", "مطبخ.png", "photo_4.png", "Küche_hell.png",
                                       "रसोई_घर.png"]
    assert image_paths("kitchen", root) == sorted(added)
    with pytest.raises(CacasError, match=r"^台所\.gif: a \.gif file is not taken; valid: \.jpg"):
        lab.add_photos("kitchen", [("台所.gif", _png((1, 1, 90)))], root)
    long = "Aufnahme meiner Großmutter beim Husten in der Küche am Nachmittag, zweiter Versuch.png"
    (kept,) = lab.add_photos("kitchen", [(long, _png((30, 60, 90)))], root)
    assert kept.suffix == ".png" and kept.name.startswith("Aufnahme_meiner_Großmutter") and len(kept.stem) == 80
    (very,) = lab.add_photos("kitchen", [("写" * 100 + ".png", _png((90, 60, 30)))], root)
    assert very.name == "写" * 53 + ".png"  # 160 bytes of UTF-8: room for the library's "imported_<k>_"
    sounds = tmp_path / "sounds"
    with pytest.raises(CacasError, match=r"^咳\.mp3: a \.mp3 file is not taken; valid: \.wav, \.flac, \.ogg"):
        lab.add_clips("cough", [("咳.mp3", b"ID3....")], sounds)
    assert clip_paths("cough", sounds) == []


def test_a_refusal_names_each_file_as_uploaded_and_calls_photos_photos(tmp_path):
    """Walkthrough (Sounds and scenes): a refusal named an upload "my notes.png" by the name it would be stored
    under, "my_notes.png", and said "2 of the 3 images cannot be used" on a page that says photos. A file
    already in the library is named as stored there, where the researcher can find it."""
    import io

    from PIL import Image

    flat = io.BytesIO()
    Image.new("RGB", (40, 30), (10, 20, 30)).save(flat, format="PNG")
    root = tmp_path / "scenes"
    with pytest.raises(CacasError) as told:
        lab.add_photos("kitchen", [("my notes.png", b"text"), ("good.png", _png()),
                                   ("my flat photo.png", flat.getvalue())], root)
    lines = str(told.value).split("\n- ")
    assert lines[0] == "2 of the 3 photos cannot be used; nothing was added:"
    assert [line.split(": ")[0] for line in lines[1:]] == ["my flat photo.png", "my notes.png"]
    again = f"nothing was added (leave the copy out and press '{lab.ADD_BUTTON}' again)"
    with pytest.raises(CacasError, match=re.escape(f"our sofa again.png: the same photo is given twice (also as "
                                                   f"our sofa.png); {again}")):
        lab.add_photos("kitchen", [("our sofa.png", _png()), ("our sofa again.png", _png())], root)
    lab.add_photos("kitchen", [("our sofa.png", _png())], root)
    with pytest.raises(CacasError, match=re.escape(f"sofa copy.png: the same photo is already in the library as "
                                                   f"kitchen/our_sofa.png; {again}")):
        lab.add_photos("kitchen", [("sofa copy.png", _png())], root)
    # the sound library's files are "clips", as the page calls them ("Add clips"; it said "recordings")
    with pytest.raises(CacasError, match=r"^2 of the 2 clips cannot be used; nothing was added:\n- my notes\.wav: "):
        lab.add_clips("cough", [("my notes.wav", b"text"), ("my other notes.wav", b"more text")], tmp_path / "s")


def test_library_stamp_changes_when_a_folder_gains_a_file(study_data):
    (study_data / "sounds" / "cough").mkdir(parents=True)
    whole, cough, sneeze = lab.library_stamp("sound"), lab.library_stamp("sound", "cough"), \
        lab.library_stamp("sound", "sneeze")
    assert lab.library_stamp("sound") == whole  # nothing changed, same key
    (study_data / "sounds" / "cough" / "a.wav").write_bytes(b"x")
    assert lab.library_stamp("sound") != whole and lab.library_stamp("sound", "cough") != cough
    assert lab.library_stamp("sound", "sneeze") == sneeze  # another activity's folder keeps its key
    (study_data / "scenes").mkdir()
    assert lab.library_stamp("scene", "kitchen")[-1] == ("kitchen", None)  # no folder yet
    with pytest.raises(CacasError, match=r"^unknown library kind 'speech'; valid: sound, scene$"):
        lab.library_stamp("speech")


def test_a_photo_is_shown_as_the_model_sees_it():
    """Try a photo drew the upload's own bytes: a 16-bit grey PNG stopped the page with a traceback
    (Streamlit could not draw mode I;16); it is shown as the RGB image the model reads."""
    import io

    import numpy as np
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.tile(np.linspace(0, 65535, 64).astype(np.uint16), (48, 1))).save(buf, format="PNG")
    shown = lab.photo_to_show("deep.png", buf.getvalue())
    assert shown.mode == "RGB" and shown.size == (64, 48) and shown.getpixel((32, 10))[0] < 200
    with pytest.raises(CacasError, match=r"^notes\.png: not a readable image"):
        lab.photo_to_show("notes.png", b"text")


def test_every_bad_file_of_an_add_is_said_at_once(tmp_path):
    """Walkthrough: three bad clips added together were refused one at a time ('notes.wav: not a readable
    ...'; without it, 'silent.wav: is all silence'; without that, 'tiny.wav: is 0.20 s long'): three
    presses to learn what one could have said. Nothing is added while any is bad."""
    import io

    import numpy as np
    import soundfile as sf

    from cacas.audio.library import clip_paths

    def wav(seconds, amplitude=0.3):
        buf = io.BytesIO()
        t = np.arange(int(seconds * 16000)) / 16000
        sf.write(buf, amplitude * np.sin(2 * np.pi * 440 * t), 16000, format="WAV")
        return buf.getvalue()

    root = tmp_path / "sounds"
    files = [("good.wav", wav(1.0)), ("silent.wav", wav(1.0, 0.0)), ("notes.wav", b"this is not audio"),
             ("tiny.wav", wav(0.2))]
    with pytest.raises(CacasError) as told:
        lab.add_clips("cough", files, root)
    lines = str(told.value).split("\n- ")
    assert lines[0] == "3 of the 4 clips cannot be used; nothing was added:"
    assert [line.split(":")[0] for line in lines[1:]] == ["notes.wav", "silent.wav", "tiny.wav"]
    assert "is all silence" in lines[2] and "valid: a clip of at least 0.5 s" in lines[3]
    assert clip_paths("cough", root) == []
    # one bad file: said as before
    with pytest.raises(CacasError, match=r"^notes\.wav: not a readable WAV/FLAC/OGG audio file"):
        lab.add_clips("cough", files[:1] + files[2:3], root)


def test_an_upload_on_a_full_temporary_disk_is_one_message_and_adds_nothing(tmp_path, monkeypatch):
    """Adversarial audit: an upload is written to a temporary folder first; a full disk there (a
    small /tmp, a large upload) raised OSError, a traceback on the Sounds page."""
    import errno
    from pathlib import Path

    import pytest

    from cacas.errors import CacasError

    real = Path.write_bytes

    def full(self, data):
        if str(self).startswith(str(tmp_path / "temporary")):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, data)

    (tmp_path / "temporary").mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp_path / "temporary"))
    monkeypatch.setattr("tempfile.tempdir", None)
    monkeypatch.setattr(Path, "write_bytes", full)
    with pytest.raises(CacasError, match=rf"^my cough.wav: cannot be taken in: the temporary folder "
                                         rf"{tmp_path / 'temporary'} cannot be written \(No space left on device\); "
                                         r"nothing was added\. Free some disk space there"):
        lab.add_clips("cough", [("my cough.wav", b"RIFF....")], root=tmp_path / "library")
    assert not (tmp_path / "library").exists() or not any((tmp_path / "library").rglob("*.wav"))
    with pytest.raises(CacasError, match=r"^photo.jpg: cannot be taken in: .*; nothing was read\."):
        lab.recognize_scene_bytes(type("Sees", (), {"recognize": lambda self, path: path})(), "photo.jpg", b"\xff\xd8")


def test_an_upload_named_as_a_windows_device_is_kept_under_a_name_windows_can_hold(tmp_path):
    """"aux.wav" (a recording from the aux input), "CON.png": Windows opens the device for such a
    name (AUX, CON, NUL, PRN, COM1-9, LPT1-9, with any extension), so the library could not hold the
    file there, nor be copied to a Windows laptop; the stem gets a "_", on every system."""
    added = lab.add_photos("kitchen", [("CON.png", _png((1, 2, 3))), ("nul", _png((90, 80, 70))),
                                       ("icon.png", _png((5, 50, 5)))], tmp_path / "scenes")
    assert [p.name for p in added] == ["CON_.png", "nul_.jpg", "icon.png"]
