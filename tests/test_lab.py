import inspect

from cacas import lab


class _Result:
    def __init__(self, saved):
        self.recognizer = self
        self.saved = saved

    def save(self, path):
        self.saved.append(path)


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
    assert "epochs" not in calls[0] and saved == [tmp_path / "sound_cnn.pt"]
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
