"""The sound and scene library in the app (Sections IV-A, V-A): add clips and photos, train,
evaluate, try.

Thin wrappers over :mod:`cacas.audio` and :mod:`cacas.vision` so that a page (or a background
job) does one call: add validated clips to the library (all or nothing, through the libraries'
importers), train a model and save it where the study page loads it, evaluate the saved model.
"""

from __future__ import annotations

import os
import re
import tempfile
import unicodedata
from pathlib import Path
from typing import Callable, Sequence

from cacas import spaces
from cacas.errors import CacasError
from cacas.store.files import windows_device_name

Progress = Callable[[float, str], None] | None
#: A file type at the end of an upload's name (".jpg", ".flac"), kept as given.
_FILE_TYPE = re.compile(r"\.[A-Za-z0-9]{1,8}$")
#: An upload's stem is cut to this many characters, and to this many bytes in UTF-8 (a file name may hold 255
#: bytes, and the library may put "imported_<k>_" before it; a character of Japanese is 3 bytes).
STEM_CHARS, STEM_BYTES = 80, 160


def _safe_name(name: str, fallback: str) -> str:
    """The name an upload is stored under: its letters, digits and their marks, in any script, kept
    ("Küche Foto.png" -> "Küche_Foto.png", "台所の写真.png" as given), each run of anything else (spaces,
    emoji, punctuation) one "_", the stem cut to :data:`STEM_CHARS` / :data:`STEM_BYTES`, and its file type
    kept as given; ``fallback``'s stem where nothing of the name's is left ("🍳.png" -> "photo_1.png"). Only
    A-Z letters were kept: "台所の写真.png" came out "png", taken for a name without a type, and was stored as
    "png.jpg" (a PNG named JPEG, not the researcher's name), "録音.flac" as "flac.wav", and "台所.gif" was added
    as "gif.jpg" where "kitchen.gif" is refused; a name over 80 characters lost its type the same way. A stem
    Windows keeps for a device ("aux.wav", "CON.jpg": :func:`cacas.store.files.windows_device_name`) gets a
    "_" ("aux_.wav"): a library copied to, or run on, a Windows computer could not hold it."""
    given = Path(unicodedata.normalize("NFC", str(name or "")).replace("\\", "/")).name
    found = _FILE_TYPE.search(given)
    stem, suffix = (given[:found.start()], found.group()) if found else (given, "")
    kept = ""
    for c in stem:  # a mark after a letter it belongs to (Hindi's vowel signs), not an emoji's (☀️'s U+FE0F)
        word = c.isalnum() or c in "._-" or (unicodedata.category(c).startswith("M") and kept[-1:].strip() != "")
        kept += c if word else " "
    stem = "_".join(kept.split()).strip("._")[:STEM_CHARS]
    while len(stem.encode("utf-8")) > STEM_BYTES:
        stem = stem[:-1]
    stem = stem.strip("._")
    if windows_device_name(stem):  # "aux.wav" opens a device on Windows: kept as "aux_.wav" on every system
        stem += "_"
    return fallback if not stem and not suffix else (stem or Path(fallback).stem) + suffix


#: The Sounds and scenes page's button that adds files to a library: its refusals name it.
ADD_BUTTON = "Add to the library"


def add_clips(activity: str, files: Sequence[tuple[str, bytes]], root: Path | str | None = None) -> list[Path]:
    """Add clips of ``activity`` to the sound library (the page's word, in its messages too): ``files`` are (file name, bytes) from an
    upload or a microphone recording. Every file is checked first (WAV / FLAC / OGG, not empty,
    not silent, no NaN, at least half a second: :func:`cacas.audio.library.library_clip`); one bad file
    and nothing is added."""
    from cacas.audio.features import SUPPORTED_EXTENSIONS
    from cacas.audio.library import import_folder

    return _add_files("activity", activity, files, import_folder, root, what="clip",
                      how="upload a WAV, FLAC or OGG file or record one", default_name="recording_{}.wav",
                      extensions=SUPPORTED_EXTENSIONS)


def long_clip_notes(activity: str, added: Sequence[Path], root: Path | str | None = None,
                    given: Sequence[str] | None = None) -> list[str]:
    """A note for each clip of ``added`` (just added to ``activity``) that gives the sound model more
    training windows than the library's other activities hold each (their median): the model
    learns from windows of :data:`cacas.audio.features.WINDOW_SECONDS`, so one long recording
    weighs its activity more than the others, and the model leans toward it. [] when the clips
    are of a usual length, or no other activity has clips to compare with. ``given``: each clip's
    name as the researcher gave it (``added``'s order, as :func:`add_clips` returns them): a note
    names a clip so, and the name it is stored under where that differs ("my cough.wav (in the
    library as my_cough.wav)"), to find it there."""
    from statistics import median

    from cacas.audio.features import WINDOW_SECONDS
    from cacas.audio.library import clip_paths, clip_seconds, clip_windows

    activity = spaces.canonical("activity", activity)
    others = [n for n in (sum(clip_windows(p) for p in clip_paths(a, root))
                          for a in spaces.ACTIVITIES if a != activity) if n]
    if not others:
        return []
    typical = median(others)
    total = sum(clip_windows(p) for p in clip_paths(activity, root))
    notes = []
    for i, path in enumerate(added):
        n = clip_windows(path)
        if n > typical:
            stored = Path(path).name
            name = stored if given is None or given[i] == stored else f"{given[i]} (in the library as {stored})"
            notes.append(f"{name} is {clip_seconds(path):.0f} s long: the sound model learns from "
                         f"{WINDOW_SECONDS:g}-s windows, so this one clip gives '{activity}' {n} windows, more "
                         f"than a whole activity has (the other activities' median: {typical:g}). '{activity}' "
                         f"has {total} now and weighs more than the others in training: clips of a few seconds, "
                         "or more clips of the other activities, keep them even.")
    return notes


def add_photos(scene: str, files: Sequence[tuple[str, bytes]], root: Path | str | None = None) -> list[Path]:
    """Add photos of the room ``scene`` to the scene library (what the robot's camera sees in a
    study, Section IV-A): ``files`` are (file name, bytes) from an upload or the camera. Every file
    is checked first (a readable JPEG / PNG / BMP / WebP image, at least 16 pixels a side, neither
    fully transparent nor one flat colour:
    :func:`cacas.vision.library.library_photo`);
    one bad file and nothing is added."""
    from cacas.vision.library import IMAGE_EXTENSIONS, import_folder

    return _add_files("scene", scene, files, import_folder, root, what="photo",
                      how="upload a JPEG or PNG photo or take one", default_name="photo_{}.jpg",
                      extensions=IMAGE_EXTENSIONS)


def _add_files(kind: str, name: str, files: Sequence[tuple[str, bytes]], import_folder, root, what: str,
               how: str, default_name: str, extensions: Sequence[str]) -> list[Path]:
    """Write ``files`` into a temporary ``<slug>/`` folder and import it into the library, all or
    nothing (the library's ``import_folder`` checks every file and refuses copies of files already
    there, saying to press :data:`ADD_BUTTON` again without the copy, as the page's button is
    called); an error names each file as the researcher gave it ("my cough.wav"), never our
    temporary copy nor the name it would be stored under ("my_cough.wav"), and calls the files by
    ``what`` ("photos": the scene library's own word, "images", is not the page's). A file whose
    type the library does not take is refused, not left out (the folder's import skipped it, and
    the others were added as if it had not been given); files of the same name (from two folders,
    or names that differ only in letters a file name cannot hold) are all kept, numbered (one
    overwrote the other: "Added 1"). Returns the library's new files in the order ``files`` gave
    them (:func:`long_clip_notes` names them as given)."""
    from cacas.media_library import slug

    name = spaces.canonical(kind, name)
    if not files:
        raise CacasError(f"no {what} given; {how}")
    given: dict[Path, str] = {}  # our temporary copy -> the file's name as the researcher gave it
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / slug(name)
        folder.mkdir()
        for i, (fname, data) in enumerate(files):
            if not data:
                raise CacasError(f"{fname or what}: is empty (0 bytes)")
            target = folder / _safe_name(fname, default_name.format(i + 1))
            if target.suffix == "":
                target = target.with_suffix(Path(default_name).suffix)
            if target.suffix.lower() not in extensions:
                raise CacasError(f"{fname}: a {target.suffix} file is not taken; valid: {', '.join(extensions)} "
                                 f"({how}); nothing was added")
            base, n = target, 1
            while target.exists():  # another file of the same name in this upload: take-2.wav, take-3.wav
                n += 1
                target = base.with_name(f"{base.stem}-{n}{base.suffix}")
            _write_temporary(target, data, fname or target.name, "nothing was added")
            given[target] = fname or target.name
        try:
            added = import_folder(tmp, root, done="added", again=f"press '{ADD_BUTTON}' again", item=what)
        except CacasError as exc:  # name the file as the researcher gave it, not our temporary copy
            said = str(exc)
            for copy in sorted(given, key=lambda c: len(str(c)), reverse=True):  # "a.wav.wav" before "a.wav"
                said = said.replace(str(copy), given[copy]).replace(f"(also as {copy.name})",
                                                                    f"(also as {given[copy]})")
            raise CacasError(said.replace(str(folder) + os.sep, "")) from None
    # the import adds them in file-name order (``media_library.import_folder``); given back in the order given
    by_copy = dict(zip(sorted(given, key=lambda c: c.name), added))
    return [by_copy[copy] for copy in given]


def train_sound(progress: Progress = None, **options):
    """Train the sound CNN on the library and save it as the model the study page uses.
    ``options`` go to :func:`train_sound_model`; its defaults (those of ``cacas sound train``,
    with which the shipped model was trained) apply otherwise."""
    from cacas.audio.training import train_sound_model

    result = train_sound_model(progress=progress, **options)
    result.recognizer.save(model_path("sound"), keep_previous=True)  # the replaced model can be put back
    return result


def evaluate_sound(progress: Progress = None):
    """The saved sound model on its held-out recordings (or the whole library)."""
    from cacas.audio.model import SoundRecognizer
    from cacas.audio.training import evaluate_sound_model

    return evaluate_sound_model(SoundRecognizer.load(), progress=progress)


def train_scene(progress: Progress = None, epochs: int = 12, seed: int = 0):
    """Fine-tune (or train) the scene ResNet-18 on the scene library and save it."""
    from cacas.vision.training import train_scene_model

    result = train_scene_model(epochs=epochs, seed=seed, progress=progress)
    result.recognizer.save(model_path("scene"), keep_previous=True)  # the replaced model can be put back
    return result


def evaluate_scene(progress: Progress = None):
    from cacas.vision.model import SceneRecognizer
    from cacas.vision.training import evaluate_scene_model

    return evaluate_scene_model(SceneRecognizer.load(), progress=progress)


def recognize_sound_bytes(recognizer, name: str, data: bytes):
    """Recognise an uploaded or recorded clip (bytes); a bad file raises CacasError naming it."""
    return _recognize_bytes(recognizer, name, data, "recording.wav")


def recognize_scene_bytes(recognizer, name: str, data: bytes):
    """Recognise an uploaded photo or a camera picture (bytes); a bad file raises CacasError naming it."""
    return _recognize_bytes(recognizer, name, data, "photo.jpg")


def photo_to_show(name: str, data: bytes):
    """An uploaded photo as the RGB image the scene model sees (:func:`cacas.vision.library.load_image`),
    to show on a page: the upload's own bytes could not be drawn for every image the model reads (a
    16-bit PNG stopped the page with a traceback)."""
    from cacas.vision.library import load_image

    return _on_upload(name, data, "photo.jpg", load_image)


def _write_temporary(path: Path, data: bytes, name: str, outcome: str) -> None:
    """An upload's bytes written to our temporary copy ``path``; a full disk (or a temporary folder
    that cannot be written) is a CacasError naming the upload, not a traceback on the page."""
    try:
        path.write_bytes(data)
    except OSError as exc:
        raise CacasError(f"{name}: cannot be taken in: the temporary folder {tempfile.gettempdir()} cannot be written "
                         f"({exc.strerror or exc}); {outcome}. Free some disk space there (or set TMPDIR to a "
                         "folder with room) and try again") from None


def _recognize_bytes(recognizer, name: str, data: bytes, default_name: str):
    """The recognizer on ``data`` written to a temporary file named like the upload; its
    messages name the upload, not the temporary file."""
    return _on_upload(name, data, default_name, recognizer.recognize)


def _on_upload(name: str, data: bytes, default_name: str, read):
    """``read(path)`` of ``data`` written to a temporary file named like the upload; its messages
    name the upload, not the temporary file."""
    if not data:
        raise CacasError(f"{name}: is empty (0 bytes)")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / _safe_name(name, default_name)
        if path.suffix == "":
            path = path.with_suffix(Path(default_name).suffix)
        _write_temporary(path, data, name, "nothing was read")
        try:
            return read(path)
        except CacasError as exc:
            raise CacasError(str(exc).replace(str(path), name)) from None


def library_stamp(kind: str, name: str | None = None) -> tuple:
    """The sound or scene library's folder times (``name``'s folder alone when given): a cache
    key, so that a page lists and plays what the library holds now, whoever added to it (the
    page, ``cacas sound import``, a copy). A folder's time changes when a file is added or
    removed in it."""
    if kind == "sound":
        from cacas.audio.library import activity_slug as folder_of, sounds_dir as root_of
    elif kind == "scene":
        from cacas.vision.library import scene_slug as folder_of, scenes_dir as root_of
    else:
        raise CacasError(f"unknown library kind {kind!r}; valid: sound, scene")
    root = root_of()
    if name is not None:
        folders = [root / folder_of(name)]
    else:
        folders = [root] + (sorted(p for p in root.iterdir() if p.is_dir()) if root.is_dir() else [])
    return (str(root),) + tuple((f.name, f.stat().st_mtime_ns if f.exists() else None) for f in folders)


def library_problem(kind: str) -> str | None:
    """What training would refuse in the sound or scene library as it is now (a folder that is not
    an activity or a room, a file of a type the library does not read, no library folder at all, an
    activity or room with a single file),
    in the words the training would fail with; None when the library's layout is fine. The library
    tabs say it before a training is started on it (the folders are listed, no file is read)."""
    from cacas.recognition_training import check_splittable

    if kind == "sound":
        from cacas.audio.library import scan, sounds_dir as root_of
        names, what, item, name_of = spaces.ACTIVITIES, "activities", "clip", lambda clip: clip.activity
    elif kind == "scene":
        from cacas.vision.library import scan, scenes_dir as root_of
        names, what, item, name_of = spaces.SCENES, "scenes", "image", lambda photo: photo.scene
    else:
        raise CacasError(f"unknown library kind {kind!r}; valid: sound, scene")
    try:  # in training's own words (train_sound_model, train_scene_model)
        labels = [list(names).index(name_of(f)) for f in scan()]
        check_splittable(labels, list(names), root_of(), what, item)
    except CacasError as exc:
        return str(exc)
    return None


def model_path(kind: str) -> Path:
    """Where the saved sound or scene model is (the one the study page and the tablets load)."""
    if kind == "sound":
        from cacas.audio.model import default_model_path
    elif kind == "scene":
        from cacas.vision.model import default_model_path
    else:
        raise CacasError(f"unknown model kind {kind!r}; valid: sound, scene")
    return default_model_path()


def model_stamp(kind: str) -> float | None:
    """The saved sound or scene model's modification time (None: no model saved): a cache key, so
    that a page reloads a model that was retrained."""
    path = model_path(kind)
    return path.stat().st_mtime if path.exists() else None


def kept_model(kind: str) -> dict | None:
    """The metadata of the sound or scene model the last training replaced, kept to be put back
    (:mod:`cacas.previous_model`), or None when none is kept."""
    from cacas import previous_model as kept

    return kept.previous_metadata(model_path(kind))


def put_back_previous_model(kind: str, expected: str | None = None) -> tuple[dict, dict | None]:
    """Put the kept previous sound or scene model back as the saved one; the model it replaces is
    kept in its place. (metadata now saved, metadata now kept); a CacasError when none is kept, it
    cannot be read, or it is not model ``expected`` (the one the page showed): nothing changed."""
    from cacas import previous_model as kept

    return kept.put_back(model_path(kind), kind, expected)


def load_recognizer(kind: str):
    """The saved sound (:class:`~cacas.audio.model.SoundRecognizer`) or scene
    (:class:`~cacas.vision.model.SceneRecognizer`) model, or None when none is saved. An unknown
    kind, or a saved model that cannot be read, raises CacasError naming it."""
    if model_stamp(kind) is None:
        return None
    if kind == "sound":
        from cacas.audio.model import SoundRecognizer as Recognizer
    else:
        from cacas.vision.model import SceneRecognizer as Recognizer
    return Recognizer.load()


AUDIO_MIME = {".wav": "audio/wav", ".ogg": "audio/ogg", ".flac": "audio/flac"}


def audio_mime(path) -> str:
    """The MIME type a browser needs to play a library clip."""
    return AUDIO_MIME.get(Path(path).suffix.lower(), "audio/wav")
