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

Progress = Callable[[float, str], None] | None
TEST_FRACTION = 0.1  #: V-A: "divided into a training set and a testing set with a ratio of 9:1"


def tell(progress: Progress, fraction: float, message: str) -> None:
    """Report progress (clamped to 0..1) if anyone listens."""
    if progress:
        progress(float(min(1.0, max(0.0, fraction))), message)


def relative_path(path: Path, root: Path) -> str:
    """``path`` relative to ``root`` where it lies below it, else as given."""
    try:
        return str(Path(path).resolve().relative_to(Path(root).resolve()))
    except ValueError:
        return str(path)


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
