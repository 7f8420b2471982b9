"""The scene image library: ``study_data/scenes/<scene slug>/<image>`` (Section III's 6 scenes).

Folder names are slugs of the Table I names ("living room" -> ``living_room``). The shipped
images are SYNTHETIC (:mod:`cacas.vision.synth`); :func:`generate_scenes` makes more and
:func:`import_folder` copies a researcher's own photos (same layout) in after checking each one.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from cacas import media_library, spaces
from cacas.errors import CacasError
from cacas.media_library import files_with_extensions, slug
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
    """Open an image file as RGB, upright as a photo viewer shows it (a camera's EXIF orientation
    applied); a missing, empty or unreadable file raises CacasError naming it."""
    from PIL import Image, ImageOps, UnidentifiedImageError

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
            # a phone stores a portrait photo sideways with an orientation tag: the model and the
            # pages got it on its side (helper's bug hunt)
            return _eight_bit(ImageOps.exif_transpose(im)).convert("RGB")
    except Image.DecompressionBombError:  # not an OSError: it ended the page with a traceback
        raise CacasError(f"{path}: is too large to read safely (more than {2 * Image.MAX_IMAGE_PIXELS:,} pixels); "
                         f"valid: a photo of at most {Image.MAX_IMAGE_PIXELS:,} pixels, e.g. 6000 x 4000") from None
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise CacasError(f"{path}: not a readable image ({' '.join(str(exc).split())[:160]}); "
                         f"valid: {', '.join(IMAGE_EXTENSIONS)}") from None


#: Pillow's modes of one channel of more than 8 bits (a 16-bit grey PNG is "I;16" or "I").
_DEEP_GREY = ("I", "I;16", "I;16B", "I;16L", "I;16N", "F")


def _eight_bit(im):
    """``im`` with 8 bits a channel: a 16-bit (or 32-bit, or float) grey image scaled to 0-255.
    Pillow's own conversion clips every level above 255 to white: a 16-bit grey photo reached the
    scene model 99.97 % white (walkthrough)."""
    if im.mode not in _DEEP_GREY:
        return im
    from PIL import Image

    levels = np.asarray(im, dtype=np.float64)
    if im.mode.startswith("I;16") or (im.mode == "I" and levels.max(initial=0) > 255):
        levels = levels / 257.0  # 0-65535 onto 0-255
    return Image.fromarray(np.clip(np.rint(levels), 0, 255).astype(np.uint8), "L")


#: The smallest side of a photo the scene library takes: below it there is nothing of a room to see.
MIN_PHOTO_SIDE = 16

#: A photo whose every colour channel varies less than this (standard deviation over its pixels, in
#: 0-255 levels) is one flat colour: a covered lens, a blank or fully transparent image, not a room.
#: A dim room in the evening still varies by tens of levels; a JPEG of one colour by under one.
MIN_PHOTO_SPREAD = 2.0


def library_photo(path):
    """:func:`load_image`, refusing what shows no room, or what a page cannot show (a grey image of
    more than 8 bits): a photo smaller than
    :data:`MIN_PHOTO_SIDE` pixels a side (review: a 1 x 1 pixel image was added to the library),
    a fully transparent image, and one flat colour (:data:`MIN_PHOTO_SPREAD`; a walkthrough added
    a blank frame). Each would be a training example of a room with nothing of the room in it."""
    from PIL import Image, ImageStat

    image = load_image(path)
    if min(image.size) < MIN_PHOTO_SIDE:
        raise CacasError(f"{path}: is {image.size[0]} x {image.size[1]} pixels; valid: a photo at least "
                         f"{MIN_PHOTO_SIDE} pixels a side")
    with Image.open(path) as raw:  # load_image has read it whole: it opens
        if raw.mode in _DEEP_GREY:  # the model reads it (load_image), but a page cannot draw it: the Sounds
            # and scenes page stopped with a traceback at the library's grid, its other tabs gone (walkthrough)
            raise CacasError(f"{path}: is a {'16' if raw.mode.startswith('I;16') else 'more than 8'}-bit grey image "
                             f"(mode {raw.mode}), which the pages cannot show; valid: a photo of 8 bits a channel "
                             "(a camera's JPEG, or a PNG saved at 8 bits)")
        if "A" in raw.getbands() and raw.getchannel("A").getextrema()[1] == 0:
            raise CacasError(f"{path}: is fully transparent, nothing of a room shows; valid: a photo of the room")
    if max(ImageStat.Stat(image).stddev) < MIN_PHOTO_SPREAD:
        colour = tuple(round(c) for c in ImageStat.Stat(image).mean)
        raise CacasError(f"{path}: is one flat colour (RGB {colour}), a covered lens or a blank image; "
                         "valid: a photo of the room")
    return image


#: The scene library's kind for :mod:`cacas.media_library`.
SCENE_IMAGES = media_library.MediaKind(what="scene", label="scene", item="image", names=spaces.SCENES,
                                       extensions=IMAGE_EXTENSIONS, name_of_folder=scene_of_folder,
                                       check=library_photo)


@dataclass(frozen=True)
class Photo:
    path: Path
    scene: str


def scan(root: Path | str | None = None) -> list[Photo]:
    """Every image under ``root`` (default: the library), ordered by scene then name
    (:func:`cacas.media_library.scan`: a folder that is not a scene, or a file that is not an
    image type, is refused with a message naming it)."""
    root = Path(root) if root is not None else scenes_dir()
    return [Photo(path, name) for path, name in media_library.scan(root, SCENE_IMAGES)]


def generate_scenes(images_per_scene: int = 40, size: int = 128, seed: int = 0, root: Path | str | None = None,
                    progress: Progress = None, replace: bool = False) -> media_library.Generated:
    """Write SYNTHETIC scene images to ``root/<slug>/synthetic_<seed>_<k>.jpg``, under temporary
    names first, renamed into place when all are written (:class:`cacas.media_library.Staging`):
    a run stopped before (Ctrl-C) adds none. A file of the same name holding the same picture is
    left as it is; one holding another (the shipped 128-px images, asked for 64-px ones of the same
    seed; an unreadable file) is replaced only with ``replace``, otherwise the run is refused
    (:func:`cacas.media_library.refuse_replacing`) and nothing is written. Returns the images'
    paths, with those replaced and those left as they were (:class:`cacas.media_library.Generated`)."""
    from cacas.vision import synth

    if not media_library.SYNTHETIC_PER_CLASS[0] <= images_per_scene <= media_library.SYNTHETIC_PER_CLASS[1]:
        raise CacasError("images per scene must be from {} to {}, got {}".format(*media_library.SYNTHETIC_PER_CLASS,
                                                                                images_per_scene))
    low, high = media_library.SYNTHETIC_IMAGE_SIDE
    if not low <= size <= high:
        raise CacasError(f"image size must be between {low} and {high} pixels, got {size}")
    root = Path(root) if root is not None else scenes_dir()
    written, replaced, unchanged = [], [], []
    total = len(spaces.SCENES) * images_per_scene
    # all placed at the end: stopped before, nothing is added
    with media_library.Staging(root, IMAGE_EXTENSIONS) as staging:
        for j, name in enumerate(spaces.SCENES):
            folder = root / slug(name)
            for k in range(images_per_scene):
                img = synth.render(name, np.random.default_rng([seed, j, k]), size)
                path = folder / f"synthetic_{seed}_{k:03d}.jpg"
                media_library.no_folder_at(path, "image")
                encoded = io.BytesIO()
                img.save(encoded, format="JPEG", quality=85)
                if _same_picture(path, encoded.getvalue()):
                    unchanged.append(path)
                else:
                    if path.exists():
                        if not replace:
                            raise media_library.refuse_replacing(
                                path, f"another picture than this run draws there ({_picture_words(path)}; this "
                                      f"run's: {size} x {size} pixels)", seed, root, IMAGE_EXTENSIONS, "image")
                        replaced.append(path)
                    staging.path(path).write_bytes(encoded.getvalue())
                written.append(path)
                if progress:
                    progress(len(written) / total, f"{name}: image {k + 1}/{images_per_scene}")
        staging.place()
    return media_library.Generated(written, replaced, unchanged=unchanged)


def _same_picture(path: Path, encoded: bytes) -> bool:
    """``path`` exists and holds ``encoded``'s bytes, or decodes to the same pixels (a JPEG
    library of another version may encode the same picture in other bytes)."""
    from PIL import Image

    if not path.is_file():
        return False
    old = path.read_bytes()
    if old == encoded:
        return True
    try:
        with Image.open(io.BytesIO(old)) as a, Image.open(io.BytesIO(encoded)) as b:
            return a.size == b.size and np.array_equal(np.asarray(a.convert("RGB")), np.asarray(b.convert("RGB")))
    except (OSError, ValueError, Image.DecompressionBombError):
        return False


def _picture_words(path: Path) -> str:
    """An image's size, for a message; what it is when it cannot be read as one."""
    from PIL import Image

    try:
        with Image.open(path) as img:
            return f"{img.size[0]} x {img.size[1]} pixels"
    except (OSError, ValueError, Image.DecompressionBombError):
        return "a file that cannot be read as an image"


def import_folder(source: Path | str, root: Path | str | None = None, progress: Progress = None,
                  **wording) -> list[Path]:
    """Copy a researcher's photos (``source/<scene slug or name>/<image>``) into the library, all
    or nothing: every file is checked first (:func:`load_image`), and a bad folder or file is a
    CacasError naming it (:func:`cacas.media_library.import_folder`, shared with the sound
    library). A name already in the library gets an ``imported_`` prefix and a number.
    ``wording``: ``done``, ``again`` and ``item`` of a refusal's message (``cacas.media_library.import_folder``)."""
    root = Path(root) if root is not None else scenes_dir()
    return media_library.import_folder(source, root, SCENE_IMAGES, progress, **wording)
