"""The sound-activity CNN of Section IV-A and the recognizer that wraps it.

Paper, IV-A: "We built a CNN network that has 3 convolutional layers (kernel size: 3 x 3,
dimension: 64, 128, 256) and 1 dense layer (dimension: 128) to recognize the sound activity."
Our reading: each convolution is followed by batch normalisation, ReLU and max pooling (4 x 2
after the first, over coefficients x frames, then 2 x 2; the coarser first pooling halves the
cost so that training fits in minutes on 2 CPU cores); the 256 x 4 x 4 map is average-pooled to
256 x 2 x 2 and flattened into the dense layer of 128 (ReLU, dropout), then a linear layer to
the 33 activities. The input MFCC (64 x 32) is
standardised per coefficient with the training set's mean and standard deviation, stored in
the model.

:class:`SoundRecognizer` loads a saved model (by default the shipped one in
``study_data/models/sound_cnn.pt``) and recognises a file or a signal: it cuts it into 1-s
windows, computes the MFCC, and averages the class probabilities over the windows.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
import torch
from torch import nn

from cacas import spaces
from cacas.audio.features import FEATURE_PARAMS, FEATURE_SHAPE, SAMPLE_RATE, check_signal, load_clip, mfcc_windows
from cacas.errors import CacasError
from cacas.paths import study_data_dir
from cacas.recognition import Recognition, load_model_file, make_recognition, model_id, save_model

MODEL_FILE = "sound_cnn.pt"


def default_model_path() -> Path:
    return study_data_dir() / "models" / MODEL_FILE


class SoundCNN(nn.Module):
    """3 conv layers (3 x 3; 64, 128, 256) and a dense layer of 128 (Section IV-A)."""

    def __init__(self, n_classes: int = spaces.N_ACTIVITIES, dropout: float = 0.3):
        super().__init__()
        blocks = []
        c_in = 1
        for c_out, pool in ((64, (4, 2)), (128, 2), (256, 2)):
            blocks += [nn.Conv2d(c_in, c_out, 3, padding=1), nn.BatchNorm2d(c_out), nn.ReLU(), nn.MaxPool2d(pool)]
            c_in = c_out
        self.features = nn.Sequential(*blocks, nn.AdaptiveAvgPool2d((2, 2)), nn.Flatten())
        self.dense = nn.Sequential(nn.Linear(256 * 4, 128), nn.ReLU(), nn.Dropout(dropout))
        self.out = nn.Linear(128, n_classes)
        self.register_buffer("mean", torch.zeros(FEATURE_SHAPE[0], 1))
        self.register_buffer("std", torch.ones(FEATURE_SHAPE[0], 1))

    def set_normalisation(self, feats: np.ndarray) -> None:
        """Per-coefficient mean / std of training MFCC (n, 64, 32)."""
        self.mean.copy_(torch.from_numpy(feats.mean(axis=(0, 2))[:, None].astype(np.float32)))
        self.std.copy_(torch.from_numpy(feats.std(axis=(0, 2))[:, None].astype(np.float32) + 1e-3))

    def normalise(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.mean) / self.std

    def forward(self, x: torch.Tensor, normalised: bool = False) -> torch.Tensor:
        """Logits for MFCC ``x`` of shape (batch, 64, 32)."""
        if not normalised:
            x = self.normalise(x)
        return self.out(self.dense(self.features(x.unsqueeze(1))))


class SoundRecognizer:
    """Recognises the activity of a sound (Section IV-A) with a trained :class:`SoundCNN`."""

    def __init__(self, model: SoundCNN, classes: Sequence[str] = spaces.ACTIVITIES, metadata: dict | None = None):
        self.model = model.eval()
        self.classes = list(classes)
        self.metadata = dict(metadata or {})
        self.model_id: str | None = None  # the saved file's id (recognition.model_id); None until saved

    # ---------------------------------------------------------------- files
    @classmethod
    def load(cls, path: Path | str | None = None) -> "SoundRecognizer":
        """Load a model saved by :meth:`save` (default: ``study_data/models/sound_cnn.pt``)."""
        path = Path(path) if path is not None else default_model_path()
        tensors, meta, file_id = load_model_file(path, "sound")
        classes = meta.get("classes")
        if not classes:
            raise CacasError(f"{path}: metadata lists no classes")
        if list(meta.get("features", {}).get("shape", [])) != list(FEATURE_SHAPE):
            raise CacasError(f"{path}: trained on features {meta.get('features')}, expected shape {FEATURE_SHAPE}")
        model = SoundCNN(len(classes))
        try:
            model.load_state_dict(tensors)
        except (RuntimeError, KeyError) as exc:
            raise CacasError(f"{path}: weights do not fit the sound CNN ({str(exc).splitlines()[0]})") from None
        recognizer = cls(model, classes, meta)
        recognizer.model_id = file_id
        return recognizer

    def save(self, path: Path | str | None = None, *, keep_previous: bool = False, **metadata) -> Path:
        """Write the weights (.pt) and metadata (.json: classes, feature parameters, ...).
        With ``keep_previous``, a model saved at ``path`` before is kept to be put back
        (:mod:`cacas.previous_model`)."""
        path = Path(path) if path is not None else default_model_path()
        meta = {**self.metadata, **metadata, "kind": "sound", "classes": self.classes, "features": FEATURE_PARAMS,
                "architecture": "SoundCNN: conv3x3 64-128-256 (BN, ReLU, maxpool 4x2/2x2/2x2), avgpool 2x2, dense 128, "
                                f"linear {len(self.classes)}"}
        self.metadata = meta
        path = save_model(path, {k: v.detach().cpu() for k, v in self.model.state_dict().items()}, meta,
                          keep_previous=keep_previous)
        self.model_id = model_id(path)
        return path

    # ---------------------------------------------------------------- recognition
    @torch.no_grad()
    def window_probabilities(self, feats: np.ndarray) -> np.ndarray:
        """Class probabilities of each MFCC window (n, 64, 32) -> (n, n_classes)."""
        x = torch.from_numpy(np.ascontiguousarray(feats, dtype=np.float32))
        return torch.softmax(self.model(x), dim=1).numpy()

    def probabilities(self, clip) -> np.ndarray:
        """Pooled (mean over 1-s windows) class probabilities of a file path or 32-kHz signal."""
        return self._pooled(self._signal(clip))

    @staticmethod
    def _signal(clip) -> np.ndarray:
        return load_clip(clip) if isinstance(clip, (str, Path)) else check_signal(clip)

    def _pooled(self, y: np.ndarray) -> np.ndarray:
        return self.window_probabilities(mfcc_windows(y)).mean(axis=0)

    def recognize(self, clip) -> Recognition:
        """The activity of a sound file (WAV/FLAC/OGG) or a mono 32-kHz signal, with the top 3
        and the clip's length (:attr:`Recognition.short` flags one mostly padding)."""
        y = self._signal(clip)
        return make_recognition(self._pooled(y), self.classes, seconds=len(y) / SAMPLE_RATE, model=self.model_id)
