"""Sound features (Section IV-A): the loader's inputs and refusals, windows and the 64 x 32 MFCC."""

import os

import numpy as np
import pytest
import soundfile as sf

from cacas.audio import features
from cacas.audio.features import FEATURE_SHAPE, SAMPLE_RATE, load_clip, mfcc_batch, mfcc_windows, windows
from cacas.errors import CacasError


def _tone(seconds, rate, channels=1, amp=0.3, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * rate)) / rate
    y = amp * np.sin(2 * np.pi * 440 * t) + 0.01 * rng.standard_normal(len(t))
    return np.stack([y] * channels, axis=1) if channels > 1 else y


def test_parameters_are_the_papers():
    assert (features.SAMPLE_RATE, features.N_FFT, features.HOP_LENGTH, features.N_MELS) == (32000, 2048, 1024, 64)
    assert FEATURE_SHAPE == (64, 32)


def test_stereo_48k_is_mixed_down_and_resampled(tmp_path):
    y = _tone(1.0, 48000, channels=2)
    y[:, 1] *= 0  # one channel silent: the mix is half the other
    p = tmp_path / "stereo.wav"
    sf.write(p, y, 48000, subtype="PCM_16")
    out = load_clip(p)
    assert out.dtype == np.float32 and out.ndim == 1
    assert abs(len(out) - SAMPLE_RATE) <= 2
    assert 0.1 < np.max(np.abs(out)) < 0.2  # (0.3 + 0) / 2


def test_8bit_16k_wav(tmp_path):
    p = tmp_path / "u8.wav"
    sf.write(p, _tone(1.0, 16000), 16000, subtype="PCM_U8")
    out = load_clip(p)
    assert abs(len(out) - SAMPLE_RATE) <= 2 and np.max(np.abs(out)) > 0.2


@pytest.mark.parametrize("fmt,subtype,ext", [("WAV", "PCM_24", "wav"), ("WAV", "FLOAT", "wav"),
                                             ("FLAC", "PCM_16", "flac"), ("OGG", "VORBIS", "ogg")])
def test_formats_and_depths(tmp_path, fmt, subtype, ext):
    p = tmp_path / f"clip.{ext}"
    sf.write(p, _tone(1.0, 22050), 22050, format=fmt, subtype=subtype)
    out = load_clip(p)
    assert abs(len(out) - SAMPLE_RATE) <= 40 and np.max(np.abs(out)) > 0.2


@pytest.mark.skipif(os.name == "nt", reason="Windows names files in UTF-16: no name is other bytes there")
def test_a_clip_whose_name_is_not_utf8_is_read(tmp_path):
    """CLI audit: a WAV named in another encoding (b'caf\\xe9.wav', Latin-1: Python reads the name back
    with a surrogate escape) was refused as "not a readable WAV/FLAC/OGG audio file ('utf-8' codec
    can't encode ...)": soundfile encoded the name as UTF-8; it is given the file system's bytes."""
    name = os.path.join(os.fsencode(tmp_path), b"caf\xe9.wav")
    sf.write(name, 0.3 * np.sin(2 * np.pi * 300 * np.arange(16000) / 16000), 16000)
    path = tmp_path / os.listdir(tmp_path)[0]
    assert "\udce9" in str(path)  # the name as Python reads it back
    y = load_clip(path)
    assert y.shape == (2 * 16000,) and np.abs(y).max() > 0.2  # 1 s at 32 kHz, the tone kept


def test_short_clip_padded_to_one_window(tmp_path):
    p = tmp_path / "short.wav"
    sf.write(p, _tone(0.4, SAMPLE_RATE), SAMPLE_RATE)
    y = load_clip(p)
    w = windows(y)
    assert w.shape == (1, SAMPLE_RATE)
    assert np.all(w[0, int(0.41 * SAMPLE_RATE):] == 0)
    assert mfcc_windows(y).shape == (1, 64, 32)


def test_long_clip_cut_into_windows(tmp_path):
    p = tmp_path / "long.wav"
    sf.write(p, _tone(3.0, SAMPLE_RATE), SAMPLE_RATE)
    assert mfcc_windows(load_clip(p)).shape == (3, 64, 32)
    assert windows(np.ones(int(2.6 * SAMPLE_RATE))).shape[0] == 3  # >= 0.5 s tail kept
    assert windows(np.ones(int(2.3 * SAMPLE_RATE))).shape[0] == 2  # shorter tail dropped


def test_window_count_is_what_windows_cuts():
    """The Sounds and scenes page counts a new clip's windows from its length (nothing decoded)."""
    for seconds in (0.2, 1.0, 1.4, 1.5, 2.6, 60.0):
        n = int(seconds * SAMPLE_RATE)
        assert features.window_count(n) == windows(np.ones(n)).shape[0], seconds


def _refused(path, *words):
    """The clip is refused in one line naming it, for the reason ``words`` say: looked for in the
    message without the path (a reason found in the file's own name, "empty.wav", proved nothing)."""
    with pytest.raises(CacasError) as err:
        load_clip(path)
    msg = str(err.value)
    assert str(path) in msg and "\n" not in msg
    reason = msg.replace(str(path), "")
    for w in words:
        assert w in reason
    return msg


def test_zero_byte_file(tmp_path):
    p = tmp_path / "empty.wav"
    p.write_bytes(b"")
    _refused(p, "is empty (0 bytes)")


def test_text_named_wav(tmp_path):
    p = tmp_path / "notes.wav"
    p.write_text("this is not audio\n" * 20)
    _refused(p, "not a readable")


def test_truncated_wav(tmp_path):
    good = tmp_path / "good.wav"
    sf.write(good, _tone(1.0, SAMPLE_RATE), SAMPLE_RATE)
    bad = tmp_path / "cut.wav"
    bad.write_bytes(good.read_bytes()[:30])
    _refused(bad, "not a readable WAV/FLAC/OGG audio file")


def test_missing_file(tmp_path):
    _refused(tmp_path / "nowhere.wav", "no such file")


def test_unsupported_extension(tmp_path):
    p = tmp_path / "clip.mp4"
    p.write_bytes(b"\x00" * 100)
    _refused(p, "unsupported", ".wav")


def test_a_folder_and_a_wav_with_no_samples(tmp_path):
    (tmp_path / "cough.wav").mkdir()
    with pytest.raises(CacasError, match=f"^{tmp_path / 'cough.wav'}: is a folder, not an audio file$"):
        load_clip(tmp_path / "cough.wav")
    p = tmp_path / "nothing.wav"
    sf.write(p, np.zeros(0), SAMPLE_RATE)
    with pytest.raises(CacasError, match=f"^{p}: contains no audio samples$"):
        load_clip(p)


@pytest.mark.parametrize("signal, problem", [
    (np.zeros((2, 2, 800)), "expected a 1-D (mono) or 2-D (multi-channel) signal, got shape (2, 2, 800)"),
    (np.zeros(0), "contains no samples"),
    (np.zeros((2, 0), np.int16), "contains no samples"),
    (np.array(list("noise")), "is not numeric audio (dtype <U1)"),
    (np.array([[True, False]] * 800), "is not numeric audio (dtype bool)"),
])
def test_arrays_that_are_not_a_signal_are_refused(signal, problem):
    with pytest.raises(CacasError) as err:
        features.check_signal(signal, "array")
    assert str(err.value) == f"array: {problem}"


def test_silence(tmp_path):
    p = tmp_path / "silence.wav"
    sf.write(p, np.zeros(SAMPLE_RATE), SAMPLE_RATE)
    _refused(p, "is all silence")


def test_nan(tmp_path):
    p = tmp_path / "nan.wav"
    y = _tone(1.0, SAMPLE_RATE).astype(np.float32)
    y[100:200] = np.nan
    sf.write(p, y, SAMPLE_RATE, subtype="FLOAT")
    _refused(p, "NaN")


def test_quiet_room_tone_is_not_silence():
    y = (0.002 * np.random.default_rng(0).standard_normal(SAMPLE_RATE)).astype(np.float32)
    assert features.check_signal(y).shape == (SAMPLE_RATE,)


def test_batch_matches_single_and_groups():
    rng = np.random.default_rng(1)
    sigs = [rng.standard_normal(n).astype(np.float32) * 0.1 for n in (SAMPLE_RATE, 2 * SAMPLE_RATE, 5000)]
    feats, groups = mfcc_batch(sigs, return_groups=True)
    assert feats.shape == (4, 64, 32) and list(groups) == [0, 1, 1, 2]
    np.testing.assert_allclose(feats[1:3], mfcc_windows(sigs[1]), rtol=1e-4, atol=1e-3)


def test_integer_pcm_arrays_are_scaled():
    y = (_tone(0.5, SAMPLE_RATE) * 32767).astype(np.int16)
    out = features.check_signal(y)
    assert out.dtype == np.float32 and 0.25 < np.max(np.abs(out)) < 0.35
    u8 = (_tone(0.5, SAMPLE_RATE) * 127 + 128).astype(np.uint8)
    assert 0.25 < np.max(np.abs(features.check_signal(u8))) < 0.35
    with pytest.raises(CacasError, match="silence"):
        features.check_signal(np.full(1000, 128, dtype=np.uint8))


def test_integer_pcm_with_several_channels_is_scaled_as_mono_is():
    """A 2-D integer array (scipy.io.wavfile.read of a stereo file) was mixed down to floats before
    the PCM scaling, so it reached the model 32768 times too loud (the shipped model heard a cough
    given as int16 stereo as "pour water into glass")."""
    y = (_tone(0.5, SAMPLE_RATE) * 32767).astype(np.int16)
    mono = features.check_signal(y)
    for stereo in (np.stack([y, y], axis=1), np.stack([y, y])):  # (samples, channels), (channels, samples)
        out = features.check_signal(stereo)
        assert out.dtype == np.float32 and np.allclose(out, mono, atol=1e-6)


def test_a_clips_features_do_not_depend_on_the_clips_beside_it():
    """The robot hears one clip at a time; training and evaluation take many at once. A clip's
    MFCC must be the same both ways (power_to_db's 80 dB floor is per window, not per batch)."""
    import librosa

    rng = np.random.default_rng(0)
    quiet = (0.001 * rng.standard_normal(features.WINDOW_SAMPLES)).astype(np.float32)
    loud = rng.standard_normal(features.WINDOW_SAMPLES).astype(np.float32)
    alone = features.mfcc_windows(quiet)[0]
    in_a_batch = features.mfcc_batch([loud, quiet])[1]
    assert np.array_equal(alone, in_a_batch)
    # and it is librosa's MFCC of that 1-s window with the paper's parameters
    expected = librosa.feature.mfcc(y=quiet, sr=features.SAMPLE_RATE, n_mfcc=64, n_fft=2048, hop_length=1024, n_mels=64)
    np.testing.assert_allclose(alone, expected, rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize("subtype, width", [("PCM_16", 2), ("FLOAT", 4)])
def test_a_wav_cut_inside_its_audio_data_is_refused(tmp_path, subtype, width):
    """0.31 s left of a 1-s clip: libsndfile reads what is there (and reports that length as the
    clip's), but the header's data size says 1 s: refused as truncated, naming both lengths."""
    good = tmp_path / "good.wav"
    sf.write(good, _tone(1.0, SAMPLE_RATE), SAMPLE_RATE, subtype=subtype)
    data = good.read_bytes()
    start = data.index(b"data") + 8
    bad = tmp_path / "cut.wav"
    bad.write_bytes(data[:start + int(0.31 * SAMPLE_RATE) * width])
    with pytest.raises(CacasError) as err:
        load_clip(bad)
    msg = str(err.value)
    assert msg.startswith(f"{bad}: is truncated") and "1.00 s" in msg and "0.31 s" in msg, msg
    assert len(load_clip(good)) == SAMPLE_RATE  # the whole file is read as before


def test_a_wav_with_a_chunk_after_its_audio_and_one_of_unknown_length_are_read(tmp_path):
    import struct

    good = tmp_path / "good.wav"
    sf.write(good, _tone(1.0, SAMPLE_RATE), SAMPLE_RATE, subtype="PCM_16")
    data = good.read_bytes()
    tail = b"LIST" + struct.pack("<I", 4) + b"INFO"
    extra = tmp_path / "extra.wav"
    extra.write_bytes(data[:4] + struct.pack("<I", len(data) - 8 + len(tail)) + data[8:] + tail)
    assert len(load_clip(extra)) == SAMPLE_RATE
    at = data.index(b"data") + 4
    streamed = tmp_path / "streamed.wav"  # a recorder that never wrote the sizes: 0xFFFFFFFF
    streamed.write_bytes(data[:at] + b"\xff\xff\xff\xff" + data[at + 4:])
    assert len(load_clip(streamed)) == SAMPLE_RATE
