"""Sound-based activity recognition (Section IV-A): MFCC features, the sound CNN, the sound library.

Public API:

* :func:`load_clip`, :func:`mfcc_windows`, :func:`mfcc_batch` (features, IV-A parameters);
* :class:`SoundRecognizer` (``load``, ``recognize``) and :class:`Recognition`;
* :func:`train_sound_model`, :func:`evaluate_sound_model` (with a ``progress(fraction, message)``
  callback) in :mod:`cacas.audio.training`;
* :mod:`cacas.audio.library`: ``clip_paths(activity)``, ``generate_library``, ``import_folder``.
"""

from cacas.audio.features import (FEATURE_PARAMS, FEATURE_SHAPE, SAMPLE_RATE, load_clip, mfcc_batch,
                                   mfcc_windows, windows)
from cacas.audio.model import SoundCNN, SoundRecognizer
from cacas.recognition import Recognition


def __getattr__(name):  # training pulls in more; import it on first use
    if name in ("train_sound_model", "evaluate_sound_model", "TrainingResult"):
        from cacas.audio import training

        return getattr(training, name)
    raise AttributeError(name)


__all__ = ["FEATURE_PARAMS", "FEATURE_SHAPE", "SAMPLE_RATE", "load_clip", "mfcc_batch", "mfcc_windows", "windows",
           "SoundCNN", "SoundRecognizer", "Recognition", "train_sound_model", "evaluate_sound_model",
           "TrainingResult"]
