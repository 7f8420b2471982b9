"""Benchmark: how long recognising one 1-s clip (load + MFCC + CNN) and one photo take after warm-up.

Usage: python3 scripts/bench_recognition.py [--repeats 200] [--threads 1]

Prints a table of median / 95th percentile / mean milliseconds per step. Uses the shipped models
and library clips (study_data/). Timings on a shared machine are noisy: run it on a quiet one.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import soundfile as sf
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one


def _time(fn, repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        out.append((time.perf_counter() - t) * 1000)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=200)
    ap.add_argument("--threads", type=int, default=1, help="torch threads (default 1: a tablet-like setting)")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)

    from cacas.audio import SoundRecognizer, load_clip, mfcc_batch, mfcc_windows
    from cacas.audio.library import clip_paths
    from cacas.vision import SceneRecognizer
    from cacas.vision.library import image_paths, load_image

    rec = SoundRecognizer.load()
    src = load_clip(clip_paths("use blender")[0])
    tmp = Path(tempfile.mkdtemp())
    one_s_wav = tmp / "one_second.wav"  # a 1-s 16-bit WAV at 32 kHz: no resampling
    sf.write(one_s_wav, src[:32000], 32000, subtype="PCM_16")
    one_s_ogg = clip_paths("cough")[0]  # a shipped 2-s OGG clip (decode + 2 windows)
    one_s_44 = tmp / "one_second_44k.wav"
    import librosa
    sf.write(one_s_44, librosa.resample(src[:32000], orig_sr=32000, target_sr=44100), 44100, subtype="PCM_16")
    y = load_clip(one_s_wav)
    feats = mfcc_windows(y)
    scenes = SceneRecognizer.load()
    photo_path = image_paths("kitchen")[0]
    photo = load_image(photo_path)
    for _ in range(10):  # warm-up
        rec.recognize(one_s_wav)
        scenes.recognize(photo)

    rows = [
        ("load 1-s WAV (32 kHz)", _time(lambda: load_clip(one_s_wav), args.repeats)),
        ("MFCC 64x32 of one window", _time(lambda: mfcc_windows(y), args.repeats)),
        ("CNN on one window", _time(lambda: rec.window_probabilities(feats), args.repeats)),
        ("recognize 1-s WAV (load+MFCC+CNN)", _time(lambda: rec.recognize(one_s_wav), args.repeats)),
        ("recognize 1-s WAV at 44.1 kHz (+resample)", _time(lambda: rec.recognize(one_s_44), args.repeats)),
        ("recognize shipped 2-s OGG (2 windows)", _time(lambda: rec.recognize(one_s_ogg), args.repeats)),
        ("recognize photo (ResNet-18, 112 px)", _time(lambda: scenes.recognize(photo), max(20, args.repeats // 4))),
        ("recognize photo file", _time(lambda: scenes.recognize(photo_path), max(20, args.repeats // 4))),
    ]
    batch = [np.roll(y, k * 997) for k in range(200)]
    t = time.perf_counter()
    mfcc_batch(batch)
    per_clip = (time.perf_counter() - t) * 1000 / len(batch)

    print(f"torch threads: {args.threads}; repeats: {args.repeats}; after 10 warm-up calls")
    print(f"| {'step':44s} | median ms | p95 ms | mean ms |")
    print(f"|{'-' * 46}|----------:|-------:|--------:|")
    for name, ms in rows:
        p95 = float(np.percentile(ms, 95))
        print(f"| {name:44s} | {statistics.median(ms):9.2f} | {p95:6.2f} | {statistics.mean(ms):7.2f} |")
    print(f"| {'mfcc_batch, per 1-s clip (200 clips)':44s} | {per_clip:9.2f} |        |         |")


if __name__ == "__main__":
    main()
