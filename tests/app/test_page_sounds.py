import io

import numpy as np
import soundfile as sf

from apphelpers import no_exception, texts

PAGE = "app_pages/sounds.py"


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


def test_add_clips_valid_and_invalid(tmp_path, monkeypatch):
    from cacas import lab
    from cacas.audio.library import clip_paths
    from cacas.errors import CacasError

    root = tmp_path / "sounds"
    added = lab.add_clips("Cough", [("my cough.wav", _wav())], root)
    assert [p.parent.name for p in added] == ["cough"] and clip_paths("cough", root) == added
    for files, message in (([("silence.wav", _wav(silent=True))], "silen"),
                           ([("notes.wav", b"this is text")], "notes.wav"),
                           ([("empty.wav", b"")], "empty"),
                           ([], "no recording given")):
        try:
            lab.add_clips("cough", [("good.wav", _wav())] + files if files else files, root)
        except CacasError as exc:
            assert message in str(exc).lower() or message in str(exc)
        else:
            raise AssertionError(f"{files} was accepted")
    assert clip_paths("cough", root) == added  # nothing half-added
