"""Sound features as in Section IV-A of the paper: 1-s mono windows at 32,000 Hz and their MFCC.

Paper, IV-A: "The duration of the sound sample is set to 1 second. The sample rate is 32,000 Hz.
The window size of the fast Fourier transform is set to 2,048 and the step size is 1,024. The
number of the Mel band is set to 64. For each sound sample, the generated feature shape is 64x32."

The paper names 64 Mel bands and a 64 x 32 feature, not the number of cepstral coefficients; we
keep all 64 of the 64 bands (``N_MFCC``; librosa keeps 20 unless told), which gives its shape.

* :func:`load_clip` reads WAV, FLAC or OGG (any sample rate, mono or multi-channel, 8/16/24-bit
  integer or float) and returns mono float32 at 32 kHz. A file that is missing, empty, not audio,
  corrupt, truncated (a WAV or FLAC; an OGG records no total length and reads as the shorter clip
  it holds), all silence or contains NaN/inf is refused with one :class:`CacasError` naming it.
* :func:`windows` cuts a signal into 1-s windows (a short one is zero-padded to 1 s; a long one
  is cut into consecutive 1-s windows, the last partial window kept when at least half a second).
* :func:`mfcc_windows` gives the (n_windows, 64, 32) MFCC of one signal; :func:`mfcc_batch` the
  same for many signals at once (one librosa call over a 2-D array, much faster than a loop).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

import numpy as np

from cacas.errors import CacasError

SAMPLE_RATE = 32_000  #: Hz (IV-A)
WINDOW_SECONDS = 1.0  #: one sound sample is 1 s (IV-A)
WINDOW_SAMPLES = int(SAMPLE_RATE * WINDOW_SECONDS)
N_FFT = 2_048  #: FFT window (IV-A)
HOP_LENGTH = 1_024  #: FFT step (IV-A)
N_MELS = 64  #: Mel bands (IV-A)
N_MFCC = 64  #: coefficients kept: the feature is 64 x 32 (IV-A)
TOP_DB = 80.0  #: dynamic range of the log-mel spectrogram, per 1-s window (librosa's default)
N_FRAMES = 1 + WINDOW_SAMPLES // HOP_LENGTH  # 32 frames with librosa's centred framing
FEATURE_SHAPE = (N_MFCC, N_FRAMES)  # (64, 32)

#: File types the loader accepts (libsndfile reads them; the extension is only a first check).
SUPPORTED_EXTENSIONS = (".wav", ".flac", ".ogg")
#: A clip whose peak is below this (under one 16-bit step) is "all silence" and refused.
SILENCE_PEAK = 1.0 / 32768.0

#: The feature parameters, written into every model's metadata.
FEATURE_PARAMS = {
    "sample_rate": SAMPLE_RATE, "window_seconds": WINDOW_SECONDS, "n_fft": N_FFT,
    "hop_length": HOP_LENGTH, "n_mels": N_MELS, "n_mfcc": N_MFCC, "shape": list(FEATURE_SHAPE),
}


def _refuse(path, problem: str) -> CacasError:
    return CacasError(f"{path}: {problem}")


def check_signal(signal: np.ndarray, name: str = "signal") -> np.ndarray:
    """Mono float32 copy of ``signal`` (integer PCM scaled to [-1, 1]); refuse an empty, non-finite
    or all-silent one."""
    y = np.asarray(signal)
    if y.ndim not in (1, 2):
        raise _refuse(name, f"expected a 1-D (mono) or 2-D (multi-channel) signal, got shape {y.shape}")
    if y.size == 0:
        raise _refuse(name, "contains no samples")
    if not np.issubdtype(y.dtype, np.number):
        raise _refuse(name, f"is not numeric audio (dtype {y.dtype})")
    if np.issubdtype(y.dtype, np.integer):  # PCM samples: scale to [-1, 1] (before a mix-down makes them floats)
        info = np.iinfo(y.dtype)
        y = (y.astype(np.float64) - (info.max + info.min + 1) / 2) / (info.max - info.min + 1) * 2
    if y.ndim == 2:  # (samples, channels) or (channels, samples): mix down the short axis
        y = y.mean(axis=1 if y.shape[0] >= y.shape[1] else 0)
    y = y.astype(np.float32, copy=True)
    if not np.all(np.isfinite(y)):
        raise _refuse(name, "contains NaN or infinite samples; not usable audio")
    if float(np.max(np.abs(y))) < SILENCE_PEAK:
        raise _refuse(name, "is all silence (peak below one 16-bit step); nothing to recognise")
    return y


def wav_truncation(path) -> tuple[float, float] | None:
    """(seconds the header announces, seconds the file holds) of a RIFF WAV file cut inside its
    audio data, else None. libsndfile reads such a file without complaint and reports the shorter
    length as the clip's, so the data chunk's size in the header is compared with the bytes that
    follow it. Sizes a recorder left unwritten (0, 0xFFFFFFFF) and files that are not plain RIFF
    (RF64, ...) are not judged."""
    import struct

    path = Path(path)
    try:
        with open(path, "rb") as fh:
            head = fh.read(12)
            if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WAVE":
                return None
            size = path.stat().st_size
            block_align = rate = 0
            offset = 12
            while offset + 8 <= size:
                fh.seek(offset)
                chunk, length = struct.unpack("<4sI", fh.read(8))
                if chunk == b"fmt ":
                    fmt = fh.read(16)
                    if len(fmt) < 16:
                        return None
                    _, _, rate, _, block_align = struct.unpack("<HHIIH", fmt[:14])
                elif chunk == b"data":
                    held = size - (offset + 8)
                    if length in (0, 0xFFFFFFFF) or not block_align or not rate or held >= length:
                        return None
                    if (length - held) < block_align:  # less than one sample frame missing
                        return None
                    return length / block_align / rate, held // block_align / rate
                offset += 8 + length + (length & 1)  # chunks are padded to an even size
    except (OSError, struct.error):
        return None
    return None


def libsndfile_path(path) -> str | bytes:
    """``path`` as libsndfile should be given it: on Windows the text (soundfile opens it with the
    wide-character call), elsewhere the file system's own bytes (soundfile encodes text as UTF-8,
    which a name that is not UTF-8, read back with surrogate escapes, cannot be: a valid WAV was
    refused as "not a readable WAV/FLAC/OGG audio file ('utf-8' codec can't encode ...)", CLI audit)."""
    return str(path) if os.name == "nt" else os.fsencode(path)


def load_clip(path) -> np.ndarray:
    """Read an audio file as mono float32 at 32 kHz (Section IV-A).

    Accepts WAV, FLAC and OGG at any sample rate (resampled with librosa), any channel count
    (mixed down), 8/16/24/32-bit integer or float samples. Raises :class:`CacasError` with one
    line naming the file and the problem when it is missing, empty, not audio, corrupt, all
    silence or contains NaN.
    """
    import soundfile as sf

    path = Path(path)
    if not path.exists():
        raise _refuse(path, "no such file")
    if path.is_dir():
        raise _refuse(path, "is a folder, not an audio file")
    if path.stat().st_size == 0:
        raise _refuse(path, "is empty (0 bytes)")
    if path.suffix.lower() not in SUPPORTED_EXTENSIONS:
        raise _refuse(path, f"unsupported file type {path.suffix or '(none)'!r}; "
                            f"valid: {', '.join(SUPPORTED_EXTENSIONS)}")
    try:
        data, rate = sf.read(libsndfile_path(path), dtype="float32", always_2d=True)
    except Exception as exc:  # libsndfile: not audio / corrupt / truncated
        detail = " ".join(str(exc).split())
        raise _refuse(path, f"not a readable WAV/FLAC/OGG audio file ({detail})") from None
    if data.shape[0] == 0:
        raise _refuse(path, "contains no audio samples")
    cut = wav_truncation(path)
    if cut is not None:
        raise _refuse(path, f"is truncated: its header announces {cut[0]:.2f} s of audio but the file holds "
                            f"{cut[1]:.2f} s; valid: a complete WAV/FLAC/OGG file")
    y = check_signal(data.mean(axis=1), str(path))
    if rate != SAMPLE_RATE:
        import librosa

        y = librosa.resample(y, orig_sr=rate, target_sr=SAMPLE_RATE, res_type="soxr_hq").astype(np.float32)
    return y


def window_count(samples: int) -> int:
    """How many 1-s windows :func:`windows` cuts a 32-kHz signal of ``samples`` samples into."""
    if samples <= WINDOW_SAMPLES:
        return 1
    count = samples // WINDOW_SAMPLES
    return count + (samples - count * WINDOW_SAMPLES >= WINDOW_SAMPLES // 2)


def windows(signal: np.ndarray) -> np.ndarray:
    """Cut a 32-kHz mono signal into 1-s windows: (n_windows, 32000) float32.

    Shorter than 1 s: zero-padded at the end to one window. Longer: consecutive 1-s windows; a
    final partial window is kept (zero-padded) when it holds at least half a second.
    """
    y = np.asarray(signal, dtype=np.float32)
    n = len(y)
    if n <= WINDOW_SAMPLES:
        return np.pad(y, (0, WINDOW_SAMPLES - n))[None, :]
    count = window_count(n)
    y = np.pad(y, (0, max(0, count * WINDOW_SAMPLES - n)))
    return y[: count * WINDOW_SAMPLES].reshape(count, WINDOW_SAMPLES)


def mfcc_of_windows(frames: np.ndarray) -> np.ndarray:
    """MFCC (IV-A parameters) of an array of 1-s windows (n, 32000) -> (n, 64, 32) float32."""
    import librosa

    frames = np.asarray(frames, dtype=np.float32)
    if frames.ndim != 2 or frames.shape[1] != WINDOW_SAMPLES:
        raise CacasError(f"expected windows of shape (n, {WINDOW_SAMPLES}), got {frames.shape}")
    if len(frames) == 0:
        return np.zeros((0, *FEATURE_SHAPE), dtype=np.float32)
    mel = librosa.feature.melspectrogram(y=frames, sr=SAMPLE_RATE, n_fft=N_FFT, hop_length=HOP_LENGTH,
                                         n_mels=N_MELS)
    # log-mel per window: power_to_db's 80 dB floor is taken from the loudest bin of the array it
    # is given, so one call over the batch would make a clip's features depend on its batch-mates
    log_mel = np.stack([librosa.power_to_db(window_mel, top_db=TOP_DB) for window_mel in mel])
    m = librosa.feature.mfcc(S=log_mel, n_mfcc=N_MFCC)
    return m.astype(np.float32)


def mfcc_windows(signal: np.ndarray) -> np.ndarray:
    """MFCC of every 1-s window of one 32-kHz mono signal: (n_windows, 64, 32)."""
    return mfcc_of_windows(windows(signal))


def mfcc_batch(signals: Sequence[np.ndarray], return_groups: bool = False):
    """MFCC of many signals in one librosa call: (total_windows, 64, 32).

    Each signal is cut into 1-s windows (:func:`windows`). With ``return_groups=True`` also
    returns an int array giving, for every window, the index of the signal it came from.
    """
    parts = [windows(s) for s in signals]
    groups = np.concatenate([np.full(len(p), i) for i, p in enumerate(parts)]) if parts else np.zeros(0, int)
    frames = np.concatenate(parts) if parts else np.zeros((0, WINDOW_SAMPLES), np.float32)
    feats = mfcc_of_windows(frames)
    return (feats, groups.astype(int)) if return_groups else feats
