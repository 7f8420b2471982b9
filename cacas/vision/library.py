"""The scene image library: ``study_data/scenes/<scene slug>/<image>`` (Section III's 6 scenes).

Folder names are slugs of the Table I names ("living room" -> ``living_room``). The shipped
images are SYNTHETIC (:mod:`cacas.vision.synth`); :func:`generate_scenes` makes more and
:func:`import_folder` copies a researcher's own photos (same layout) in after checking each one.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from cacas import spaces
from cacas.audio.library import files_with_extensions, slug
from cacas.errors import CacasError
from cacas.paths import study_data_dir

Progress = Callable[[float, str], None] | None
IMAGE_EXTENSIONS = (".jpg", ".jpeg", ".png", ".bmp", ".webp")


def scenes_dir() -> Path:
    return study_data_dir() / "scenes"


def scene_slug(scene: str) -> str:
    return slug(spaces.canonical("scene", scene))


def scene_of_folder(folder: str) -> str:
    """The Table I scene of a folder name (``living_room`` -> "living room")."""
    return spaces.canonical("scene", str(folder).replace("_", " "))


def _images(folder: Path) -> list[Path]:
    return files_with_extensions(folder, IMAGE_EXTENSIONS)


def image_paths(scene: str, root: Path | str | None = None) -> list[Path]:
    """The library's images of ``scene`` (Table I name, any case), sorted by name."""
    root = Path(root) if root is not None else scenes_dir()
    return _images(root / scene_slug(scene))


def load_image(path):
    """Open an image file as RGB; a missing, empty or unreadable file raises CacasError naming it."""
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if not path.exists():
        raise CacasError(f"{path}: no such file")
    if path.is_dir():
        raise CacasError(f"{path}: is a folder, not an image")
    if path.stat().st_size == 0:
        raise CacasError(f"{path}: is empty (0 bytes)")
    try:
        with Image.open(path) as im:
            im.load()
            return im.convert("RGB")
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise CacasError(f"{path}: not a readable image ({' '.join(str(exc).split())[:160]}); "
                         f"valid: {', '.join(IMAGE_EXTENSIONS)}") from None


@dataclass(frozen=True)
class Photo:
    path: Path
    scene: str


def scan(root: Path | str | None = None) -> list[Photo]:
    """Every image under ``root`` (default: the library), ordered by scene then name."""
    root = Path(root) if root is not None else scenes_dir()
    if not root.is_dir():
        raise CacasError(f"{root}: no such scene folder; expected <folder>/<scene>/<image>.jpg|png")
    out = []
    for sub in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        try:
            name = scene_of_folder(sub.name)
        except CacasError:
            valid = ", ".join(slug(s) for s in spaces.SCENES)
            raise CacasError(f"{sub}: folder name {sub.name!r} is not a scene; valid: {valid}") from None
        out += [Photo(p, name) for p in _images(sub)]
    out.sort(key=lambda p: (spaces.scene_index(p.scene), p.path.name))
    return out


def generate_scenes(images_per_scene: int = 40, size: int = 128, seed: int = 0, root: Path | str | None = None,
                    progress: Progress = None) -> list[Path]:
    """Write SYNTHETIC scene images to ``root/<slug>/synthetic_<seed>_<k>.jpg``."""
    from cacas.vision import synth

    if images_per_scene < 1:
        raise CacasError(f"images per scene must be at least 1, got {images_per_scene}")
    if not 32 <= size <= 1024:
        raise CacasError(f"image size must be between 32 and 1024 pixels, got {size}")
    root = Path(root) if root is not None else scenes_dir()
    written = []
    total = len(spaces.SCENES) * images_per_scene
    for j, name in enumerate(spaces.SCENES):
        folder = root / slug(name)
        folder.mkdir(parents=True, exist_ok=True)
        for k in range(images_per_scene):
            img = synth.render(name, np.random.default_rng([seed, j, k]), size)
            path = folder / f"synthetic_{seed}_{k:03d}.jpg"
            img.save(path, quality=85)
            written.append(path)
            if progress:
                progress(len(written) / total, f"{name}: image {k + 1}/{images_per_scene}")
    return written


def import_folder(source: Path | str, root: Path | str | None = None, progress: Progress = None) -> list[Path]:
    """Copy a researcher's photos (``source/<scene>/<image>``) into the library, all checked first."""
    source = Path(source)
    if not source.is_dir():
        raise CacasError(f"{source}: no such folder; expected <folder>/<scene>/<image>.jpg|png")
    plan = [(p.path, p.scene) for p in scan(source)]
    if not plan:
        raise CacasError(f"{source}: no images found; expected <folder>/<scene>/<image>.jpg|png")
    for f, _ in plan:
        load_image(f)
    root = Path(root) if root is not None else scenes_dir()
    copied = []
    for i, (f, name) in enumerate(plan):
        folder = root / slug(name)
        folder.mkdir(parents=True, exist_ok=True)
        target, k = folder / f.name, 1
        while target.exists():
            target, k = folder / f"imported_{k}_{f.name}", k + 1
        shutil.copy2(f, target)
        copied.append(target)
        if progress:
            progress((i + 1) / len(plan), f"copied {f.name}")
    return copied
