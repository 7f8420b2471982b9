"""What training the sound CNN and the scene ResNet share (Section V-A).

* :func:`training_split`: whole recordings (or images) split 9:1 into training and test, as V-A
  does, with a ninth of the training side kept for validation (early stopping).
* :class:`EarlyStopping`: keeps the weights of the best epoch (validation accuracy, then lower
  validation loss) and says when ``patience`` epochs have brought nothing better.
* :func:`split_table`: which item went to which side, as a tidy table (saved with the model).
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from cacas.errors import CacasError
from cacas.recognition import stratified_group_split
from cacas.store.files import file_sha256

Progress = Callable[[float, str], None] | None
TEST_FRACTION = 0.1  #: V-A: "divided into a training set and a testing set with a ratio of 9:1"


def tell(progress: Progress, fraction: float, message: str) -> None:
    """Report progress (clamped to 0..1) if anyone listens."""
    if progress:
        progress(float(min(1.0, max(0.0, fraction))), message)


def relative_path(path: Path, root: Path) -> str:
    """``path`` relative to ``root`` where it lies below it, else whole (resolved: a model's training
    folder given as ``--data ../lab/sounds`` was recorded so, which named nothing from another folder).
    Relative, with "/" between its parts on every system: a model's metadata names its held-out
    items so (``cough/rec5.wav``), and one trained on Windows named them ``cough\\rec5.wav``, which
    no other system's library matched (nor Windows' the shipped model's: :func:`held_out_in`)."""
    try:
        return Path(path).resolve().relative_to(Path(root).resolve()).as_posix()
    except ValueError:
        return str(Path(path).resolve())


def held_out_sha256(paths: Sequence[Path], root: Path) -> dict[str, str]:
    """The model's held-out items (files at ``paths`` below ``root``) by :func:`relative_path`, each
    with its sha256: the metadata's ``test_sha256``, so that an evaluation takes a file for a held-out
    one only when it holds the same bytes (:func:`held_out_in`)."""
    return {relative_path(p, root): file_sha256(p) for p in paths}


def held_out_in(metadata: dict, paths: Sequence[Path], root: Path) -> tuple[list[int], int]:
    """(indices of ``paths`` that are the model's held-out items, how many more bear a held-out
    item's name but hold other bytes). A file is one when its path relative to ``root`` is one of
    the metadata's ``test_recordings`` and, where the model records them (``test_sha256``), its
    sha256 is the one recorded: another library's ``cough/rec5.wav`` is not the model's (walk3; a
    model saved before sha256s were recorded matches by name alone, as it did)."""
    # "\\" between the parts: the metadata of a model trained on Windows before relative_path wrote "/"
    posix = lambda rel: str(rel).replace("\\", "/")  # noqa: E731
    wanted = {posix(rel) for rel in metadata.get("test_recordings") or ()}
    if not wanted:
        return [], 0
    hashes = metadata.get("test_sha256")
    if isinstance(hashes, dict):
        hashes = {posix(rel): digest for rel, digest in hashes.items()}
    chosen, other = [], 0
    for i, p in enumerate(paths):
        rel = relative_path(p, root)
        if rel not in wanted:
            continue
        if not isinstance(hashes, dict) or file_sha256(p) == hashes.get(rel):
            chosen.append(i)
        else:
            other += 1
    return chosen, other


def _trained_root(metadata: dict) -> Path | None:
    """The folder the model was trained on, as its metadata records it (None: not recorded)."""
    recorded = (metadata.get("training_data") or {}).get("root")
    if not recorded:
        return None
    from cacas.paths import study_data_dir

    # below the study data folder: relative to it; else absolute (a model saved before that: as given,
    # relative to the folder it was trained from, which is only known to be another)
    return Path(recorded) if Path(recorded).is_absolute() or Path(recorded).parts[:1] == ("..",) \
        else study_data_dir() / recorded


def evaluation_set(metadata: dict, root: Path, found: int, held_out: bool, other_bytes: int = 0) -> dict:
    """What an evaluation of a model (its ``metadata``) on the library at ``root`` was on, for
    ``Metrics.extra`` and :func:`cacas.recognition.evaluated_on`: ``set`` ("held-out" when ``found``
    of the model's held-out items are under ``root``, else "all"), ``held_out_missing``, and for an
    evaluation on every item, the folder the model was trained on when it is not ``root``
    (``trained_on``) and, when held-out items were asked for, how many the model has
    (``held_out_absent``): walkthrough, `cacas sound eval --model` of a model trained on the lab's
    own folder evaluated the shipped library and said "training ones included" of clips it never
    saw. ``other_bytes`` files bore held-out names with other bytes (:func:`held_out_in`):
    ``held_out_other_bytes``. Held-out items of a model that records no sha256s, found in another
    folder than its own, were matched by name alone: ``matched_by_name`` (the folder it was trained on)."""
    wanted = len(metadata.get("test_recordings") or ())
    trained = _trained_root(metadata)
    elsewhere = trained is not None and trained.resolve() != Path(root).resolve()
    out: dict = {"held_out_other_bytes": other_bytes} if held_out and other_bytes else {}
    if held_out and found:
        out.update({"set": "held-out", "held_out_missing": wanted - found})
        if elsewhere and not isinstance(metadata.get("test_sha256"), dict):
            out["matched_by_name"] = _said(trained)
        return out
    out["set"] = "all"
    if elsewhere:
        out["trained_on"] = _said(trained)
    if held_out and wanted:
        out["held_out_absent"] = wanted
    return out


def _said(trained: Path) -> str:
    """A model's training folder as an evaluation names it: whole, or as recorded when relative to an unknown one."""
    return str(trained) if trained.parts[:1] == ("..",) else str(trained.resolve())


def check_splittable(labels: np.ndarray, classes: Sequence[str], root: Path, what: str, item: str) -> None:
    """A CacasError naming ``root``, the classes with a single item and what is valid, if any class
    has one (:func:`training_split` cannot give it a training and a test item); the library tabs
    say it before a training is started."""
    counts = np.bincount(np.asarray(labels, dtype=int), minlength=len(classes))
    thin = [classes[i] for i in range(len(classes)) if 0 < counts[i] < 2]
    if thin:
        raise CacasError(f"{root}: {what} with a single {item} cannot be split 9:1 into training and test: "
                         f"{', '.join(thin)}; valid: 2 {item}s or more of each {what_one(what)} that has any "
                         "(add another, or remove the one)")


def what_one(what: str) -> str:
    """The singular of a class word: "activities" -> "activity", "scenes" -> "scene"."""
    return what[:-3] + "y" if what.endswith("ies") else what[:-1] if what.endswith("s") else what


def training_split(labels: np.ndarray, classes: Sequence[str], test_fraction: float, seed: int,
                   root: Path, what: str, item: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(train, validation, test) index arrays over the items. Every class with items needs two
    of them (one to train, one to test): otherwise one CacasError naming ``root`` and the
    classes (``what``, e.g. "activities"; ``item``, e.g. "recording"). With too few items for a
    validation side, validation falls back to the training items."""
    check_splittable(labels, classes, root, what, item)
    keep, test = stratified_group_split(labels, test_fraction, seed)
    tr_sub, val_sub = stratified_group_split(labels[keep], 1.0 / 9.0, seed + 1)
    train, val = keep[tr_sub], keep[val_sub]
    if len(val) == 0:  # tiny data: early-stop on the training items themselves
        val = train
    return train, val, test


def split_table(paths: Sequence[str], label_column: str, labels: Sequence[str], validation: np.ndarray,
                test: np.ndarray) -> pd.DataFrame:
    """path, <label_column>, side (train / validation / test): one row per item."""
    side = np.array(["train"] * len(paths), dtype=object)
    side[validation] = "validation"
    side[test] = "test"
    return pd.DataFrame({"path": list(paths), label_column: list(labels), "side": side})


class EarlyStopping:
    """Early stopping on the validation side: an epoch is better when its accuracy is higher, or
    equal with a lower loss; ``step`` returns True once ``patience`` epochs in a row were not."""

    def __init__(self, patience: int):
        self.patience = patience
        self.best = (-1.0, np.inf)
        self.best_epoch = 0
        self.best_state: dict | None = None
        self.stale = 0

    def step(self, epoch: int, accuracy: float, loss: float, model) -> bool:
        if (accuracy, -loss) > (self.best[0], -self.best[1]):
            self.best, self.best_epoch, self.stale = (accuracy, loss), epoch, 0
            self.best_state = {k: v.detach().clone() for k, v in model.state_dict().items()}
            return False
        self.stale += 1
        return self.stale >= self.patience

    def restore_best(self, model) -> None:
        """Load the best epoch's weights into ``model`` and put it in evaluation mode."""
        if self.best_state is not None:
            model.load_state_dict(self.best_state)
        model.eval()
