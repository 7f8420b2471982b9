"""What sound and scene recognition share (Section IV-A, V-A): results, metrics, model files.

* :class:`Recognition`: a label, the probability of every class, and the top 3.
* :class:`Metrics`: accuracy, a tidy per-class accuracy table and the confusion matrix, as the
  paper reports them in V-A ("most of sound activities can be recognized at an accuracy of 100%").
* :func:`save_model` / :func:`load_model_file`: a ``.pt`` file of tensors (loaded with
  ``weights_only=True``) beside a ``.json`` metadata file (classes, feature parameters, accuracy,
  date, training data); :func:`model_id` names a saved model in the study records.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from cacas.errors import CacasError


#: Below this top-class probability a recognition is flagged as unsure (:attr:`Recognition.unsure`).
UNSURE_BELOW = 0.5
#: A sound clip shorter than this (seconds) is mostly the silence that pads it to the model's 1-s
#: window (Section IV-A: "The duration of the sound sample is set to 1 second"); a longer clip's
#: last partial window is kept from this length on (cacas.audio.features.windows).
SHORT_CLIP_SECONDS = 0.5


def clip_length(seconds: float) -> str:
    """A clip's length for a person: "25 ms" under a tenth of a second (a 3-ms clip read "0.00 s"),
    else "0.45 s"."""
    return f"{seconds * 1000:.0f} ms" if seconds < 0.1 else f"{seconds:.2f} s"


def short_clip_warning(seconds: float) -> str:
    """What the app's "Try a clip" and ``cacas sound recognize`` say of a clip shorter than
    :data:`SHORT_CLIP_SECONDS` (:attr:`Recognition.short`), after the subject ("The clip", the
    file): one rule and one wording for both. The sound library refuses such a clip
    (:func:`cacas.audio.library.library_clip`)."""
    return (f"is {clip_length(seconds)} long: the model hears 1-s windows, so it heard mostly the silence that pads "
            f"it, and the result says little; record at least {SHORT_CLIP_SECONDS:g} s (1 s or more is best)")


def evaluated_on(metrics: "Metrics", what: str) -> str:
    """What an evaluation's accuracy is on, for ``cacas sound/scene eval`` and the app's "Evaluate
    the saved ... model" alike: "on 10 held-out clips (56 of the model's 66 held-out ones are
    not in the library)", or "on all 33 clips (training ones included)" when the model's
    held-out ones were not found (``metrics.extra["set"]``), or "on all 33 clips of another library: the model
    was trained on /lab/sounds, where its 2 held-out clips are"
    (:func:`cacas.recognition_training.evaluation_set`). The page said "held-out" of both. Files bearing
    held-out names but other contents (another library's ``cough/rec5.wav``, walk3) are said, and held-out
    ones found in another library by a model that records no sha256 of them are said to be taken by name."""
    other = int(metrics.extra.get("held_out_other_bytes") or 0)
    others = [f"{other} {what if other != 1 else what[:-1]} of their names {'hold' if other != 1 else 'holds'} "
              "other contents"] if other else []
    if metrics.extra.get("set", "held-out") != "held-out":
        trained, absent = metrics.extra.get("trained_on"), metrics.extra.get("held_out_absent")
        if trained:  # another library than the model's: its clips may be none of the training ones
            held = f", where its {absent} held-out {what} are" if absent else ""
            return (f"on all {metrics.n} {what} of another library: the model was trained on {trained}{held}"
                    + "".join(f" ({o} here)" for o in others))
        return f"on all {metrics.n} {what} (training ones included" + "".join(
            f"; {s}" for s in ([f"none of the model's {absent} held-out ones is in the library"] if absent else [])
            + others) + ")"
    missing = int(metrics.extra.get("held_out_missing") or 0)
    notes = ([f"{missing} of the model's {metrics.n + missing} held-out ones are not in the library"] if missing
             else []) + others
    if metrics.extra.get("matched_by_name"):
        notes.append(f"taken by their names only: the model records no sha256 of its held-out {what} and was "
                     f"trained on {metrics.extra['matched_by_name']}")
    return f"on {metrics.n} held-out {what}" + (f" ({'; '.join(notes)})" if notes else "")


def whole_percent(share: float) -> int:
    """A class's share of a recognition (0-1) as a whole percentage, as the pages and the CLI say every share:
    rounded, halves up (as :func:`cacas.app_support.percent`), but rounded down under :data:`UNSURE_BELOW`
    (after rounding to 6 places: 100 x 0.29 is 28.999...), so that a share just under half never reads as 50 %
    beside "not sure" (0.4996: "49%")."""
    share = round(100 * share, 6)
    return math.floor(share) if share < 100 * UNSURE_BELOW else math.floor(share + 0.5)


def share_words(share: float) -> str:
    """A class's share as the top 3 says it: :func:`whole_percent` with "%", but "<1%" for a share above
    0 that rounds to 0 ("clear throat 0%" read as never, for a share of 0.3 %)."""
    whole = whole_percent(share)
    return "<1%" if whole == 0 and share > 0 else f"{whole}%"


#: What a recogniser's classes are called, by kind ("sound", "scene").
CLASS_WORDS = {"sound": "sound activities", "scene": "home scenes"}


def unsure_words(recognition: "Recognition", kind: str) -> str:
    """What the app's "Try a clip or a photo" and ``cacas sound/scene recognize`` say of an unsure
    recognition (:attr:`Recognition.unsure`) of a ``kind`` ("sound", "scene") recogniser: one rule
    and one wording for both (the share as :attr:`Recognition.percent` gives it)."""
    return (f"{recognition.percent}% for {recognition.label}. It may be none of the "
            f"{len(recognition.probabilities)} {CLASS_WORDS[kind]} the model knows")


@dataclass(frozen=True)
class Recognition:
    """One recognition: ``label``, ``probabilities`` (class -> p, in class order), ``top3``;
    for a sound, ``seconds``, the length of the clip heard (None for a photo); ``model``, the
    :func:`model_id` of the saved model that recognised it (None for a model not saved)."""

    label: str
    probabilities: dict[str, float]
    top3: list[tuple[str, float]]
    seconds: float | None = None
    model: str | None = None

    @property
    def short(self) -> bool:
        """A sound clip shorter than :data:`SHORT_CLIP_SECONDS`: the model heard mostly padding."""
        return self.seconds is not None and self.seconds < SHORT_CLIP_SECONDS

    @property
    def confidence(self) -> float:
        return self.probabilities[self.label]

    @property
    def percent(self) -> int:
        """The confidence as a whole percentage, as the pages and the CLI show it (:func:`whole_percent`:
        rounded down where :attr:`unsure`)."""
        return whole_percent(self.confidence)

    @property
    def top3_words(self) -> list[tuple[str, str]]:
        """:attr:`top3` with each share in words (:func:`share_words`: "49%", "<1%"), as the Sounds page's top 3,
        the researcher's "Also possible" and ``cacas sound/scene recognize`` say them."""
        return [(label, share_words(p)) for label, p in self.top3]

    @property
    def unsure(self) -> bool:
        """The top class has less than :data:`UNSURE_BELOW` of the probability: the input may be
        none of the classes (a photo of no home scene, a sound of no listed activity)."""
        return self.confidence < UNSURE_BELOW


def make_recognition(probs: np.ndarray, classes: Sequence[str], seconds: float | None = None,
                     model: str | None = None) -> Recognition:
    """A :class:`Recognition` from a probability vector over ``classes`` (``seconds``: a sound's
    length; ``model``: the recognising model's id)."""
    probs = np.asarray(probs, dtype=float)
    order = np.argsort(-probs, kind="stable")
    return Recognition(
        label=classes[int(order[0])],
        probabilities={c: float(p) for c, p in zip(classes, probs)},
        top3=[(classes[int(i)], float(probs[i])) for i in order[:3]],
        seconds=seconds,
        model=model,
    )


@dataclass
class Metrics:
    """Test results: ``accuracy``, ``per_class`` (tidy: label, n, correct, accuracy), ``confusion``.

    ``confusion[i, j]`` counts items of true class i predicted as class j (rows: truth).
    ``extra`` holds further figures (e.g. window-level accuracy for sound).
    """

    accuracy: float
    per_class: pd.DataFrame
    confusion: np.ndarray
    classes: list[str]
    n: int
    extra: dict = field(default_factory=dict)

    def confusion_frame(self) -> pd.DataFrame:
        """The confusion matrix as a tidy table: true, predicted, count."""
        rows = [(t, p, int(self.confusion[i, j])) for i, t in enumerate(self.classes)
                for j, p in enumerate(self.classes)]
        return pd.DataFrame(rows, columns=["true", "predicted", "count"])

    def to_json(self) -> dict:
        return {
            "accuracy": self.accuracy, "n": self.n, "classes": self.classes,
            "per_class": self.per_class.to_dict(orient="records"),
            "confusion": self.confusion.tolist(), **self.extra,
        }


def compute_metrics(y_true: Sequence[int], y_pred: Sequence[int], classes: Sequence[str], **extra) -> Metrics:
    """Accuracy, per-class accuracy and confusion matrix of integer labels over ``classes``."""
    y_true = np.asarray(y_true, dtype=int)
    y_pred = np.asarray(y_pred, dtype=int)
    k = len(classes)
    cm = np.zeros((k, k), dtype=int)
    np.add.at(cm, (y_true, y_pred), 1)
    n_cls = cm.sum(axis=1)
    correct = np.diag(cm)
    per_class = pd.DataFrame({
        "label": list(classes), "n": n_cls.astype(int), "correct": correct.astype(int),
        "accuracy": np.where(n_cls > 0, correct / np.maximum(n_cls, 1), np.nan),
    })
    acc = float(correct.sum() / max(1, len(y_true)))
    return Metrics(accuracy=acc, per_class=per_class, confusion=cm, classes=list(classes), n=int(len(y_true)),
                   extra=dict(extra))


def stratified_group_split(labels: Sequence[int], fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Split items (each one source recording / image) into (keep, held_out) index arrays.

    Per class, ``round(fraction * n)`` items (at least 1 when a class has 2 or more) are held
    out, so every class is represented on both sides when it can be. Because the items are whole
    recordings, their windows never sit on both sides.
    """
    labels = np.asarray(labels, dtype=int)
    rng = np.random.default_rng(seed)
    held = []
    for c in np.unique(labels):
        idx = np.flatnonzero(labels == c)
        if len(idx) < 2:
            continue
        k = min(len(idx) - 1, max(1, int(round(fraction * len(idx)))))
        held += list(rng.choice(idx, size=k, replace=False))
    held = np.array(sorted(held), dtype=int)
    keep = np.setdiff1d(np.arange(len(labels)), held)
    return keep, held


def model_weights_path(path: Path | str, what: str = "model file") -> Path:
    """``path`` as a model's weights file: a .json name is refused, as the metadata written beside
    the weights (``path.with_suffix('.json')``) is that same file: `--model m.json` left the
    metadata alone, the trained weights overwritten, and said "saved" (CLI review)."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        raise CacasError(f"{what} {path}: a .json file is where a model's metadata goes, beside its weights; valid: "
                         f"a .pt file, e.g. {path.with_suffix('.pt')}")
    return path


def model_save_path(path: Path | str, what: str) -> Path:
    """``path`` checked, before a training, as where :func:`save_model` with ``keep_previous`` will
    write: a weights file (:func:`model_weights_path`) that can be written there
    (:func:`cacas.store.files.writable_file`), and no folder where its metadata or the kept previous
    model's two files go (CLI audit: a folder named m.json was refused after the whole training,
    and one named m.previous.pt left a 2-MB temporary file and metadata without weights). Else a
    CacasError naming ``what`` (the option, e.g. "--model") and the folder."""
    from cacas.previous_model import previous_path
    from cacas.store.files import writable_file

    path = writable_file(model_weights_path(path, what), what)
    kept = previous_path(path)
    files = {path.with_suffix(".json"): "its metadata", kept: "the model it replaces, kept",
             kept.with_suffix(".json"): "the kept model's metadata"}
    for target, role in files.items():
        if target.is_dir():
            raise CacasError(f"{what} {path}: {target} is a folder, where the save writes a file ({role}); valid: "
                             f"move or rename that folder, or another {what} path")
    return path


def save_model(path: Path | str, tensors: dict, metadata: dict, keep_previous: bool = False) -> Path:
    """Write ``path`` (.pt, tensors only) and ``path.with_suffix('.json')`` (metadata, with the
    ``model_id`` of the weights it belongs to: :func:`load_model_file` refuses a pair that does not
    belong together). With ``keep_previous``, a model saved at ``path`` before is kept beside it
    first (:func:`cacas.previous_model.keep`), to be put back if the new one serves worse.

    Both are written as one change (:func:`cacas.store.files.write_all`, inside the model's lock
    that saves and put-backs take turns on): each to a temporary file of this process, fsynced, then
    renamed, the metadata first and the weights (whose file time is the app's cache key) last. A
    failure (disk full, a folder that cannot be written) is a CacasError naming the file, with the
    model saved before as it was and no temporary file left (safety round: fixed temporary names,
    written before the lock and never synced, let two trainings at once rename each other's files,
    and a full disk left a bare OSError and a 45-MB temporary file).
    """
    import torch

    from cacas import previous_model
    from cacas.store.files import write_all

    path = model_weights_path(path)
    buffer = io.BytesIO()
    torch.save(tensors, buffer)
    weights = buffer.getvalue()
    metadata = {**metadata, "model_id": model_id(weights)}
    meta_bytes = metadata_bytes(metadata)
    with previous_model.writing(path):  # a put-back or another save meanwhile waits
        if keep_previous:
            previous_model.keep(path)
        # metadata first: it names its weights, so until they follow the pair is refused, never used
        # (weights first left new weights beside the old, id-less metadata of the shipped models: loaded)
        write_all(path.parent, {path.with_suffix(".json").name: meta_bytes, path.name: weights})
    return path


def metadata_bytes(metadata: dict) -> bytes:
    """A model's metadata as strict JSON (UTF-8, indented, a newline at the end): a number that is
    not one (NaN, e.g. ``per_class_accuracy`` of a class with no test items, or an infinity) is
    written ``null``. Python's json wrote NaN, which jq and a browser's JSON.parse refuse (walk3);
    metadata saved so still loads (:func:`load_model_file` reads NaN and null alike)."""
    return (json.dumps(_finite(metadata), indent=1, allow_nan=False, default=_json_default) + "\n").encode()


def _finite(obj):
    """``obj`` with every float that is NaN or infinite (numpy's too) replaced by None."""
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _finite(obj.tolist())
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


def _json_default(obj):
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj)}")


#: Hex digits of a model file's sha256 that name the model (:func:`model_id`).
MODEL_ID_DIGITS = 12


def model_id(data: bytes | Path | str) -> str:
    """The name under which the study records a saved model (the bytes of its ``.pt`` file, or
    the file): the first :data:`MODEL_ID_DIGITS` hex digits of their sha256. Each interaction
    recorded on the tablet keeps the ids of the sound and scene models that recognised its
    context, so a study can tell which model served which day after a retraining."""
    if not isinstance(data, bytes):
        data = Path(data).read_bytes()
    return hashlib.sha256(data).hexdigest()[:MODEL_ID_DIGITS]


def load_model_file(path: Path | str, kind: str) -> tuple[dict, dict, str]:
    """Read a model written by :func:`save_model`: (tensors, metadata, :func:`model_id`), from one
    read of the file. A file that is not one is a CacasError saying what it is not and what is
    expected (the app and the command line alike): the metadata .json given for the model, a file
    that is not a PyTorch archive, metadata of another kind or none, tensors torch cannot read."""
    import zipfile

    import torch

    path = Path(path)
    expected = f"expected a model saved by `cacas {kind} train` (.pt, with its .json beside it)"
    if path.is_dir():
        raise CacasError(f"{path}: is a folder; give the model's .pt file")
    if not path.exists():
        raise CacasError(f"{path}: no such {kind} model; train one with `cacas {kind} train`")
    if path.suffix.lower() == ".json":
        pt = path.with_suffix(".pt")
        if pt.is_file():
            raise CacasError(f"{path}: a model's JSON metadata, not the {kind} model; give {pt}, "
                             "the model saved beside it")
        raise CacasError(f"{path}: a JSON file, not a {kind} model; {expected}")
    data = path.read_bytes()  # one read: the id names exactly the tensors loaded
    if not zipfile.is_zipfile(io.BytesIO(data)):  # torch.save writes a zip archive
        raise CacasError(f"{path}: not a {kind} model (not a PyTorch file); {expected}")
    meta_path = path.with_suffix(".json")
    if not meta_path.exists():
        raise CacasError(f"{meta_path}: the {kind} model's metadata file is missing")
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise CacasError(f"{meta_path}: not valid JSON metadata ({exc})") from None
    if not isinstance(meta, dict):
        raise CacasError(f"{meta_path}: not a model's metadata; expected a JSON object with its kind and classes")
    found = meta.get("kind")
    if found != kind:
        what = f"says it is a {found} model" if found in ("sound", "scene") else "names no model kind"
        raise CacasError(f"{path}: not a {kind} model (its metadata {meta_path} {what}); {expected}")
    try:
        tensors = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as exc:
        raise CacasError(f"{path}: not a readable {kind} model ({' '.join(str(exc).split())[:120]}); "
                         f"{expected}") from None
    file_id = model_id(data)  # hashed once (the shipped scene model, 11 MB: ~10 ms a hash)
    if meta.get("model_id") not in (None, file_id):  # written by save_model since ids were recorded
        raise CacasError(f"{path}: its metadata {meta_path.name} belongs to other weights (model id "
                         f"{meta['model_id']}; this file's is {file_id}): a save was interrupted or one "
                         f"of the two files was copied without the other; put back the previous {kind} model "
                         f"if one is kept (`cacas {kind} put-back`), or train it again")
    return tensors, meta, file_id


_TRAINING = threading.Lock()


def trains_alone(fn):
    """Decorator for the recognisers' training functions: one training at a time in a process.
    They seed torch's global random stream and draw from it (layer initialisation, dropout), so
    two trainings in threads of one process (the app's background jobs: the sound CNN and the
    scene ResNet at once) would draw each other's numbers and neither would be reproducible; the
    second waits for the first. (The policy's networks draw from generators of their own and do
    not wait: ``cacas.nets``.)"""
    import functools

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        if not _TRAINING.acquire(blocking=False):
            if kwargs.get("progress"):
                kwargs["progress"](0.0, "waiting for the other model's training to finish")
            _TRAINING.acquire()
        try:
            return fn(*args, **kwargs)
        finally:
            _TRAINING.release()

    wrapper.trains_alone = True
    return wrapper


def restores_torch_threads(fn):
    """Decorator: whatever thread count ``fn`` sets with ``torch.set_num_threads``, the caller's
    count is restored afterwards (training picks its own; the app or the test suite keeps theirs)."""
    import functools

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        import torch

        before = torch.get_num_threads()
        try:
            return fn(*args, **kwargs)
        finally:
            torch.set_num_threads(before)

    return wrapper
