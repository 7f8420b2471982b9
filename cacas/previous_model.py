"""The sound or scene model a training replaced, kept so that it can be put back.

Training saves its model over the one the tablets use (``study_data/models/sound_cnn.pt``), whatever
its accuracy: one click in the lab once replaced a 98.5 % model with an 18 % one, and a study's
next interactions were recognised by it. So each save that replaces a model first keeps the
replaced one beside it (``sound_cnn.previous.pt`` and its ``.json``), and :func:`put_back` swaps the
two: the kept model serves again and the replaced one is kept in its place (putting back twice is
where one started). One previous model is kept, not a history.

Each file pair is written under temporary names and renamed; the metadata names the weights it
belongs to (``model_id``, :func:`cacas.recognition.model_id`), so a pair left mismatched by an
interrupted swap is refused on loading (:func:`cacas.recognition.load_model_file`), never used.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from cacas.errors import CacasError

#: What a kept model's file names add to the model's: sound_cnn.pt -> sound_cnn.previous.pt.
SUFFIX = ".previous"


def previous_path(path: Path | str) -> Path:
    """Where the model that ``path`` replaced is kept: ``sound_cnn.pt`` -> ``sound_cnn.previous.pt``
    (its metadata beside it, ``sound_cnn.previous.json``)."""
    path = Path(path)
    return path.with_name(f"{path.stem}{SUFFIX}{path.suffix}")


def writing(path: Path | str):
    """An exclusive lock (``flock``, :func:`cacas.store.recovery.busy`) on the model saved at
    ``path`` and its kept one, for a save (keep, then the renames) or a put-back: a training's save
    in the app's thread, a put-back from another browser and a command-line training take turns,
    rather than renaming each other's temporary files (they share names). The lock file
    (``.<name>.lock`` beside the model) stays."""
    from cacas.store.recovery import busy

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return busy(path.with_name(f".{path.stem}.lock"))


def _pair(path: Path) -> tuple[Path, Path]:
    return path, path.with_suffix(".json")


def _recorded(meta_bytes: bytes) -> dict | None:
    """The metadata as a dict, or None when it is not a JSON object (loading says what is wrong)."""
    try:
        meta = json.loads(meta_bytes)
    except ValueError:
        return None
    return meta if isinstance(meta, dict) else None


def _stamped(meta_bytes: bytes, weights: bytes) -> bytes:
    """The metadata (JSON bytes) naming the weights it belongs to (``model_id``) where it names
    none (a model saved before ids were recorded, as the shipped ones). Metadata that names other
    weights keeps its id, and metadata that is not a JSON object is kept as it is: loading either
    says what is wrong, rather than the copy passing for a whole model."""
    from cacas.recognition import metadata_bytes, model_id

    meta = _recorded(meta_bytes)
    if meta is None or meta.get("model_id") is not None:
        return meta_bytes
    meta["model_id"] = model_id(weights)
    return metadata_bytes(meta)  # strict JSON: an old file's NaN written null


def _write_pairs(*pairs: tuple[Path, bytes, bytes]) -> None:
    """Each (path, weights, metadata) written as ``path`` and its .json: every file under a
    temporary name first, then each renamed, metadata before weights (the metadata names its
    weights: a pair caught between the two is refused on loading as mismatched, never used)."""
    moves = []
    for path, weights, meta in pairs:
        for target, data in zip(reversed(_pair(path)), (meta, weights)):
            tmp = target.with_name(target.name + ".tmp")
            tmp.write_bytes(data)
            moves.append((tmp, target))
    for tmp, target in moves:
        os.replace(tmp, target)


def _belongs(meta_bytes: bytes, weights: bytes) -> bool:
    """False when the metadata names weights other than these (a torn save); True otherwise (no
    id recorded, as the shipped models', or metadata load_model_file refuses for its own reason)."""
    from cacas.recognition import model_id

    meta = _recorded(meta_bytes)
    return meta is None or meta.get("model_id") in (None, model_id(weights))


def _meta_id(js: Path) -> str | None:
    """The model id a metadata file records (None: none, or no readable metadata)."""
    try:
        meta = _recorded(js.read_bytes())
    except OSError:
        return None
    return meta.get("model_id") if meta is not None else None


def _file_id(pt: Path) -> str | None:
    from cacas.recognition import model_id

    return model_id(pt) if pt.is_file() else None


def finish_put_back(path: Path | str) -> None:
    """Finish a put-back killed between its renames (:func:`put_back` renames the saved pair, then
    the kept one, metadata before weights), or drop its temporary files when it had renamed nothing:
    called under :func:`writing` before a keep or a put-back overwrites them. A put-back killed
    after the saved pair was renamed held the model it put aside only in the kept slot's ``.tmp``
    files (the kept slot then held a copy of the saved model): that model is kept again."""
    pt, js = _pair(Path(path))
    tmp = lambda f: f.with_name(f.name + ".tmp")  # noqa: E731
    # the saved pair: its metadata renamed, its weights not (the metadata names the waiting weights)
    if tmp(pt).is_file() and not tmp(js).is_file() and _meta_id(js) not in (None, _file_id(pt)) \
            and _meta_id(js) == _file_id(tmp(pt)):
        os.replace(tmp(pt), pt)
    kpt, kjs = _pair(previous_path(path))
    if not (tmp(kpt).is_file() or tmp(kjs).is_file()):
        return
    # the model waiting to be kept: its files not yet renamed, or renamed already
    wpt, wjs = (tmp(kpt) if tmp(kpt).is_file() else kpt), (tmp(kjs) if tmp(kjs).is_file() else kjs)
    waiting = _meta_id(wjs) if wpt.is_file() and _meta_id(wjs) == _file_id(wpt) else None
    kept_now = _meta_id(kjs) if kpt.is_file() and _meta_id(kjs) == _file_id(kpt) else None
    saved_now = _file_id(pt)
    if waiting is not None and waiting != saved_now and kept_now in (None, saved_now):  # nowhere else: keep it
        for f, target in ((tmp(kjs), kjs), (tmp(kpt), kpt)):
            if f.is_file():
                os.replace(f, target)
        return
    for f in (tmp(kjs), tmp(kpt)):  # a copy of a model that is whole elsewhere, or a part written
        f.unlink(missing_ok=True)


def keep(path: Path | str) -> Path | None:
    """Copy the model saved at ``path`` (weights and metadata) to :func:`previous_path`, replacing
    the model kept before; the path of the kept copy, or None when there is no whole model at
    ``path`` to keep (no weights, no metadata beside them, or metadata naming other weights: a torn
    save is not kept over the last good model)."""
    finish_put_back(path)
    pt, js = _pair(Path(path))
    if not (pt.is_file() and js.is_file()):
        return None
    weights, meta = pt.read_bytes(), js.read_bytes()
    if not _belongs(meta, weights):
        return None
    target = previous_path(pt)
    _write_pairs((target, weights, _stamped(meta, weights)))
    return target


def previous_metadata(path: Path | str) -> dict | None:
    """The kept previous model's metadata (what a page shows before putting it back: when it was
    trained, its accuracy, ``model_id``), or None when none is kept or its metadata is unreadable
    (:func:`put_back` then says why)."""
    pt, js = _pair(previous_path(path))
    if not (pt.is_file() and js.is_file()):
        return None
    try:
        meta = json.loads(js.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return meta if isinstance(meta, dict) else None


def model_words(meta: dict) -> str:
    """A saved model for a person, from its metadata: "model id 3f2a9c01d4e5, trained 2026-11-26
    18:40 UTC, test accuracy 94.7%" (what is not recorded is left out)."""
    from cacas.app_support import short_time

    words = [f"model id {meta.get('model_id') or '(not recorded)'}"]
    if meta.get("trained"):
        words.append(f"trained {short_time(meta['trained'])}")
    if isinstance(meta.get("accuracy"), (int, float)) and not isinstance(meta.get("accuracy"), bool):
        words.append(f"test accuracy {100 * meta['accuracy']:.1f}%")
    return ", ".join(words)


def put_back(path: Path | str, kind: str, expected: str | None = None) -> tuple[dict, dict | None]:
    """Swap the model at ``path`` with the kept previous one: the kept model is checked first
    (:func:`cacas.recognition.load_model_file`: a kept file that is not a ``kind`` model, or whose
    metadata names other weights, changes nothing) and becomes the saved model; the model it
    replaces is kept in its place. Returns (the model now saved's metadata, the now kept one's, or
    None when there was no model at ``path``). The saved model's file time is now, so the app's
    pages and tablets, which reload a model when its file time changes, use it from their next
    recognition. No kept model: a CacasError saying when one is kept. ``expected``: the kept
    model's id as the caller showed it; another kept model (a second press, or another browser's
    put-back since) is refused, not swapped back. Killed between its renames, the next keep or
    put-back finishes it (:func:`finish_put_back`)."""
    with writing(path):
        return _put_back(path, kind, expected)


def _put_back(path, kind: str, expected: str | None) -> tuple[dict, dict | None]:
    from cacas.recognition import load_model_file, model_weights_path

    path = model_weights_path(path, f"{kind} model")
    if path.is_dir():
        raise CacasError(f"{path}: is a folder; give the saved {kind} model's .pt file")
    finish_put_back(path)
    kept = previous_path(path)
    if not kept.is_file():
        raise CacasError(f"{path}: no previous {kind} model is kept beside it ({kept.name}); one is kept "
                         f"each time training replaces the saved model")
    try:  # a kept file that is not a model of this kind, or whose metadata names other weights
        load_model_file(kept, kind)
    except CacasError as exc:
        raise CacasError(f"the previous {kind} model kept beside {path.name} cannot be put back; nothing was "
                         f"changed: {exc}") from None
    weights = kept.read_bytes()
    meta = _stamped(kept.with_suffix(".json").read_bytes(), weights)
    if expected is not None and json.loads(meta).get("model_id") != expected:
        raise CacasError(f"the previous {kind} model kept beside {path.name} is no longer model {expected} (it was "
                         "put back already, or a training replaced the model since); nothing was changed")
    pt, js = _pair(path)
    if pt.is_file() and js.is_file():  # the model put aside is kept in turn (putting back twice undoes it)
        replaced_weights = pt.read_bytes()
        replaced_meta = _stamped(js.read_bytes(), replaced_weights)
        _write_pairs((path, weights, meta), (kept, replaced_weights, replaced_meta))
        return json.loads(meta), json.loads(replaced_meta)
    _write_pairs((path, weights, meta))  # nothing to keep in turn: the kept files become the saved model's
    kept.unlink()
    kept.with_suffix(".json").unlink()
    return json.loads(meta), None
