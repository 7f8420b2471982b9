"""Fine-tuning ResNet-18 to the 6 home scenes and testing it (Sections IV-A and V-A).

The images under ``<root>/<scene slug>/`` are split 9:1 (V-A's ratio), stratified by scene;
each image is its own source. Training uses random resized crops, horizontal flips and colour
jitter, AdamW, and keeps the epoch with the best accuracy on a ninth of the training images
(early stopping). The paper fine-tuned a pretrained ResNet for 3 epochs; without pretrained
weights (none are downloaded here) we train from scratch for more epochs.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pandas as pd
import torch
from torch import nn

from cacas import spaces
from cacas.errors import CacasError
from cacas.paths import study_data_dir
from cacas.recognition import Metrics, compute_metrics, restores_torch_threads, trains_alone
from cacas.recognition_training import TEST_FRACTION, EarlyStopping, Progress, evaluation_set, held_out_in, \
    held_out_sha256, relative_path, split_table, tell, training_split
from cacas.vision.library import load_image, scan, scenes_dir
from cacas.vision.model import IMAGE_SIZE, SceneRecognizer, build_resnet18, preprocess

@dataclass
class SceneTrainingResult:
    recognizer: SceneRecognizer
    metrics: Metrics
    history: pd.DataFrame
    split: pd.DataFrame
    seconds: float


def _augment(images, rng: np.random.Generator) -> torch.Tensor:
    """Random resized crop (60-100 % of the area), horizontal flip, brightness/contrast/colour jitter."""
    from PIL import Image, ImageEnhance

    out = []
    for im in images:
        w, h = im.size
        area = rng.uniform(0.6, 1.0) * w * h
        ratio = np.exp(rng.uniform(np.log(3 / 4), np.log(4 / 3)))
        cw, ch = int(min(w, np.sqrt(area * ratio))), int(min(h, np.sqrt(area / ratio)))
        x, y = int(rng.integers(0, w - cw + 1)), int(rng.integers(0, h - ch + 1))
        im = im.crop((x, y, x + cw, y + ch))
        if rng.random() < 0.5:
            im = im.transpose(Image.FLIP_LEFT_RIGHT)
        im = ImageEnhance.Brightness(im).enhance(rng.uniform(0.7, 1.3))
        im = ImageEnhance.Contrast(im).enhance(rng.uniform(0.7, 1.3))
        im = ImageEnhance.Color(im).enhance(rng.uniform(0.6, 1.4))
        out.append(im)
    return preprocess(out)


def evaluate_images(recognizer: SceneRecognizer, images, labels) -> Metrics:
    if not len(images):
        raise CacasError("no images to evaluate")
    idx = {c: i for i, c in enumerate(recognizer.classes)}
    y = np.array([idx[lab] for lab in labels])
    pred = recognizer.probabilities_of(list(images)).argmax(axis=1)
    return compute_metrics(y, pred, recognizer.classes, set="held-out")


@trains_alone
@restores_torch_threads
def train_scene_model(root: Path | str | None = None, *, epochs: int = 12, patience: int = 4, seed: int = 0,
                      weights: str | Path | None = "auto", batch_size: int = 32, lr: float | None = None,
                      test_fraction: float = TEST_FRACTION, threads: int | None = None,
                      progress: Progress = None) -> SceneTrainingResult:
    """Fine-tune (or train from scratch) ResNet-18 on the scene library at ``root``."""
    t0, c0 = time.perf_counter(), time.process_time()
    torch.set_num_threads(threads or min(2, os.cpu_count() or 1))
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    root = Path(root) if root is not None else scenes_dir()
    photos = scan(root)
    if not photos:
        raise CacasError(f"{root}: no images; generate them with `cacas scene generate`")
    classes = list(spaces.SCENES)
    labels = np.array([classes.index(p.scene) for p in photos])
    train, val, test = training_split(labels, classes, test_fraction, seed, root, "scenes", "image")
    tell(progress, 0.0, f"loading {len(photos)} images")
    images = [load_image(p.path) for p in photos]
    model, source = build_resnet18(len(classes), weights)
    pretrained = not source.startswith("none")
    lr = lr or (3e-4 if pretrained else 2e-3)
    opt = torch.optim.AdamW(model.parameters(), lr=lr, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=lr, total_steps=epochs * int(np.ceil(len(train) / batch_size)))
    loss_fn = nn.CrossEntropyLoss(label_smoothing=0.05)
    recognizer = SceneRecognizer(model, classes)
    val_x = preprocess([images[i] for i in val])
    yt = torch.from_numpy(labels).long()
    stopping, history = EarlyStopping(patience), []
    tell(progress, 0.05, f"training on {len(train)} images, initial weights: {source}")
    for epoch in range(1, epochs + 1):
        model.train()
        order = rng.permutation(train)
        total = 0.0
        for s in range(0, len(order), batch_size):
            b = order[s:s + batch_size]
            if len(b) < 2:
                continue
            x = _augment([images[i] for i in b], rng)
            opt.zero_grad()
            loss = loss_fn(model(x), yt[b])
            loss.backward()
            opt.step()
            sched.step()
            total += float(loss.detach()) * len(b)
            # a report a batch (one message an epoch, for the log): a Stop asked for ends the training here,
            # not at the end of a ResNet epoch of half a minute (review: 'Stopping...' for 35 s)
            tell(progress, 0.05 + 0.9 * (epoch - 1 + (s + len(b)) / len(order)) / epochs,
                 f"epoch {epoch}/{epochs}: training")
        model.eval()
        with torch.no_grad():
            logits = model(val_x)
        val_acc = float((logits.argmax(1).numpy() == labels[val]).mean())
        val_loss = float(nn.functional.cross_entropy(logits, yt[val]))
        history.append({"epoch": epoch, "train_loss": total / len(train), "val_accuracy": val_acc,
                        "val_loss": val_loss, "seconds": time.perf_counter() - t0})
        tell(progress, 0.05 + 0.9 * epoch / epochs,
              f"epoch {epoch}/{epochs}: loss {total / len(train):.3f}, validation accuracy {val_acc:.3f}")
        if stopping.step(epoch, val_acc, val_loss, model):
            break
    stopping.restore_best(model)
    recognizer.compact()  # test exactly what will be saved
    tell(progress, 0.96, f"testing on {len(test)} held-out images")
    metrics = evaluate_images(recognizer, [images[i] for i in test], [classes[labels[i]] for i in test])
    seconds = time.perf_counter() - t0
    split = split_table([relative_path(p.path, root) for p in photos], "scene", [p.scene for p in photos],
                        val, test)
    root_rel = relative_path(root, study_data_dir())
    recognizer.metadata = {
        "kind": "scene", "trained": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "accuracy": metrics.accuracy,
        "per_class_accuracy": dict(zip(metrics.per_class["label"], metrics.per_class["accuracy"].round(4))),
        "training_seconds": round(seconds, 1),
        "training_cpu_seconds": round(time.process_time() - c0, 1), "torch_threads": torch.get_num_threads(),
        "best_epoch": stopping.best_epoch, "epochs_run": len(history),
        "initial_weights": source, "image_size": IMAGE_SIZE,
        "training_data": {"root": root_rel, "images": len(photos), "train": int(len(train)),
                          "validation": int(len(val)), "test": int(len(test)), "seed": seed,
                          "synthetic": all(p.path.name.startswith("synthetic_") for p in photos),
                          "synthetic_items": sum(p.path.name.startswith("synthetic_") for p in photos)},
        "test_recordings": split.loc[split["side"] == "test", "path"].tolist(),
        "test_sha256": held_out_sha256([photos[i].path for i in test], root),  # taken for them only with these bytes
    }
    tell(progress, 1.0, f"done: test accuracy {metrics.accuracy:.3f} in {seconds:.0f} s")
    return SceneTrainingResult(recognizer, metrics, pd.DataFrame(history), split, seconds)


def evaluate_scene_model(recognizer: SceneRecognizer, root: Path | str | None = None, held_out: bool = True,
                         progress: Progress = None) -> Metrics:
    """Test on images under ``root``: the model's held-out test images when ``held_out`` and listed."""
    root = Path(root) if root is not None else scenes_dir()
    photos = scan(root)
    chosen, other_bytes = held_out_in(recognizer.metadata, [p.path for p in photos], root) if held_out else ([], 0)
    chosen = [photos[i] for i in chosen]
    which = evaluation_set(recognizer.metadata, root, len(chosen), held_out, other_bytes)  # said beside the accuracy
    if chosen:
        photos = chosen
    if not photos:
        raise CacasError(f"{root}: no images to evaluate")
    images = []
    for i, p in enumerate(photos):
        images.append(load_image(p.path))
        tell(progress, 0.9 * (i + 1) / len(photos), f"loading {p.path.name}")
    metrics = evaluate_images(recognizer, images, [p.scene for p in photos])
    metrics.extra.update(which)
    tell(progress, 1.0, f"accuracy {metrics.accuracy:.3f} on {len(photos)} images")
    return metrics
