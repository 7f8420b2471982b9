"""Draw a mel spectrogram of one library clip per activity into one PNG (a look at the library).

Usage: python3 scripts/sound_library_overview.py [OUT.png] [--clip K]
Default output: study_data/sounds/spectrograms.png (clip index 3 of each activity).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import librosa
import numpy as np
from PIL import Image, ImageDraw

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's cacas, not an installed one

from cacas import spaces  # noqa: E402
from cacas.audio import SAMPLE_RATE, load_clip  # noqa: E402
from cacas.audio.library import clip_paths, sounds_dir  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", type=Path, default=sounds_dir() / "spectrograms.png")
    ap.add_argument("--clip", type=int, default=3)
    args = ap.parse_args()
    tiles = []
    for name in spaces.ACTIVITIES:
        paths = clip_paths(name)
        tile = Image.new("L", (250, 110), 255)
        ImageDraw.Draw(tile).text((2, 1), name, fill=0)
        if paths:
            y = load_clip(paths[min(args.clip, len(paths) - 1)])
            mel = librosa.feature.melspectrogram(y=y, sr=SAMPLE_RATE, n_fft=2048, hop_length=512, n_mels=64)
            db = np.clip((librosa.power_to_db(mel, ref=1.0) + 90) / 90, 0, 1)[::-1]
            tile.paste(Image.fromarray((db * 255).astype(np.uint8)).resize((250, 96)), (0, 14))
        tiles.append(np.asarray(tile))
    blank = np.full_like(tiles[0], 255)
    rows = [np.concatenate((tiles[i:i + 6] + [blank] * 6)[:6], axis=1) for i in range(0, len(tiles), 6)]
    Image.fromarray(np.concatenate(rows, axis=0)).save(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
