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
