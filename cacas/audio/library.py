"""The sound library: ``study_data/sounds/<activity slug>/<clip>`` (Section III's 33 activities).

* A folder is named by a filesystem-safe slug of the Table I name ("watch TV" -> ``watch_tv``);
  :func:`activity_of_folder` maps it back through :mod:`cacas.spaces`.
* The shipped clips are SYNTHETIC (:mod:`cacas.audio.synth`); :func:`generate_library` makes more.
* :func:`import_folder` copies a researcher's own recordings (same layout, WAV/FLAC/OGG at any
  rate) into the library after checking every file with :func:`cacas.audio.features.load_clip`;
  a bad folder name or file is refused with one line naming it, and nothing is copied then.
"""

from __future__ import annotations

import functools
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from cacas import media_library, spaces
from cacas.audio.features import SAMPLE_RATE, SUPPORTED_EXTENSIONS, libsndfile_path, load_clip
from cacas.errors import CacasError
from cacas.media_library import files_with_extensions, slug
from cacas.paths import study_data_dir

Progress = Callable[[float, str], None] | None


def sounds_dir() -> Path:
    """The library folder: ``<study data>/sounds``."""
    return study_data_dir() / "sounds"


def activity_slug(activity: str) -> str:
    return slug(spaces.canonical("activity", activity))


def activity_of_folder(folder: str) -> str:
    """The Table I activity name of a library folder name (``watch_tv`` -> "watch TV")."""
    return spaces.canonical("activity", str(folder).replace("_", " "))


#: The sound library's kind for :mod:`cacas.media_library`.
def library_clip(path) -> np.ndarray:
    """:func:`load_clip`, refusing a clip shorter than :data:`cacas.recognition.SHORT_CLIP_SECONDS`:
    the model hears 1-s windows, so such a clip would train it on the silence that pads it (review:
    a 0.2-s clip was added to the library without a word, while "Try a clip" flags one)."""
    from cacas.recognition import SHORT_CLIP_SECONDS, clip_length

    y = load_clip(path)
    if len(y) < SHORT_CLIP_SECONDS * SAMPLE_RATE:
        raise CacasError(f"{path}: is {clip_length(len(y) / SAMPLE_RATE)} long, mostly the silence that pads it to the "
                         f"model's 1-s window; valid: a clip of at least {SHORT_CLIP_SECONDS:g} s (1 s or more "
                         "is best)")
    return y


SOUNDS = media_library.MediaKind(what="sound", label="activity", item="clip", names=spaces.ACTIVITIES,
                                 extensions=SUPPORTED_EXTENSIONS, name_of_folder=activity_of_folder,
                                 check=library_clip)


def _audio_files(folder: Path) -> list[Path]:
    return files_with_extensions(folder, SUPPORTED_EXTENSIONS)


def clip_paths(activity: str, root: Path | str | None = None) -> list[Path]:
    """The library's clips for ``activity`` (a Table I name, any case), sorted by name."""
    root = Path(root) if root is not None else sounds_dir()
    return _audio_files(root / activity_slug(activity))


@dataclass(frozen=True)
class Clip:
    """One recording of the library: its file and its activity (Table I name)."""

    path: Path
    activity: str


def scan(root: Path | str | None = None) -> list[Clip]:
    """Every clip under ``root`` (default: the library), one per file, ordered by activity then
    name (:func:`cacas.media_library.scan`: a folder that is not an activity, or a file that is
    not WAV/FLAC/OGG, is refused with a message naming it)."""
    root = Path(root) if root is not None else sounds_dir()
    return [Clip(path, name) for path, name in media_library.scan(root, SOUNDS)]


def generate_library(clips_per_activity: int = 24, seconds: float = 2.0, seed: int = 0,
                     root: Path | str | None = None, activities=None, progress: Progress = None,
                     fmt: str = "ogg", replace: bool = False) -> media_library.Generated:
    """Write SYNTHETIC clips (:mod:`cacas.audio.synth`) into ``root/<slug>/synthetic_<seed>_<k>.<fmt>``.

    A file of the same name that already holds the same audio is left as it is: an OGG encoder
    stamps each file with a random stream serial number, so rewriting the shipped clips with their
    own seed would change their bytes (and show them modified in git) for nothing. One that holds
    other audio (the shipped 2-s clips, asked for 1-s ones of the same seed; an unreadable file),
    or the same clip in another format (``synthetic_0_000.ogg`` beside a ``--format flac`` run's
    ``.flac``: the library would hold it twice), is replaced (the other format's removed) only with
    ``replace``; otherwise the run is refused (:func:`cacas.media_library.refuse_replacing`: a
    CacasError naming the file, what it holds and what to do) and nothing is written (CLI audit: it
    replaced the shipped clips without a word). Other files are left alone, so a new seed adds
    clips. The clips are written under temporary names and renamed into place when all are
    written (:class:`cacas.media_library.Staging`): a run stopped before (Ctrl-C) adds none.
    Returns the clips' paths, with those replaced, removed and left as they were
    (:class:`cacas.media_library.Generated`).
    """
    import soundfile as sf

    from cacas.audio import synth

    if not media_library.SYNTHETIC_PER_CLASS[0] <= clips_per_activity <= media_library.SYNTHETIC_PER_CLASS[1]:
        raise CacasError("clips per activity must be from {} to {}, got {}".format(*media_library.SYNTHETIC_PER_CLASS,
                                                                                  clips_per_activity))
    low, high = media_library.SYNTHETIC_CLIP_SECONDS
    if not low <= seconds <= high:
        raise CacasError(f"clip length must be between {low:g} and {high:g} seconds, got {seconds}")
    fmt = fmt.lower()
    subtypes = {"ogg": "VORBIS", "flac": "PCM_16", "wav": "PCM_16"}
    if fmt not in subtypes:
        raise CacasError(f"unknown clip format {fmt!r}; valid: {', '.join(subtypes)}")
    root = Path(root) if root is not None else sounds_dir()
    names = [spaces.canonical("activity", a) for a in (activities or spaces.ACTIVITIES)]
    written, replaced, twins, unchanged = [], [], [], []
    total = len(names) * clips_per_activity

    def refuse(path: Path, holds: str) -> CacasError:
        return media_library.refuse_replacing(path, holds, seed, root, SUPPORTED_EXTENSIONS, "clip")

    # all placed at the end: stopped before, nothing is added. Each clip is encoded into a file, not a BytesIO:
    # soundfile writes a file object through cffi callbacks, and cffi swallows an exception raised in one (a Ctrl-C
    # there was printed as "Exception ignored from cffi callback" and the run went on to place its clips: CLI audit);
    # a path libsndfile writes itself, and a Ctrl-C is raised when it returns
    with tempfile.TemporaryDirectory(prefix="cacas-clip-") as scratch, \
            media_library.Staging(root, SUPPORTED_EXTENSIONS) as staging:
        encoded = Path(scratch) / f"clip.{fmt}"
        for i, name in enumerate(names):
            folder = root / slug(name)
            # one independent stream per (seed, activity, clip): adding activities changes nothing else
            for k in range(clips_per_activity):
                rng = np.random.default_rng([seed, spaces.activity_index(name), k])
                y = synth.render(name, rng, seconds)
                path = folder / f"synthetic_{seed}_{k:03d}.{fmt}"
                media_library.no_folder_at(path, "clip")
                for other in (folder / f"{path.stem}.{ext}" for ext in subtypes if ext != fmt):
                    if other.is_file():
                        if not replace:
                            raise refuse(other, f"the clip this run writes as {path.name}, in another format (the "
                                                "library would hold it twice)")
                        twins.append(other)
                sf.write(str(encoded), y, SAMPLE_RATE, format=fmt.upper(), subtype=subtypes[fmt])
                if _same_audio(path, encoded):
                    unchanged.append(path)
                else:
                    if path.exists():
                        if not replace:
                            raise refuse(path, f"other audio than this run writes there ({_audio_words(path)}; "
                                               f"this run's: {seconds:g} s)")
                        replaced.append(path)
                    staging.path(path).write_bytes(encoded.read_bytes())
                written.append(path)
                if progress:
                    progress(len(written) / total, f"{name}: clip {k + 1}/{clips_per_activity}")
        staging.place()
    for twin in twins:  # after the new clips are in place: stopped before, the library keeps the clip
        twin.unlink(missing_ok=True)
    return media_library.Generated(written, replaced, twins, unchanged)


def _audio_words(path: Path) -> str:
    """A clip's length, for a message: "a 2-s clip"; what it is when it cannot be read as audio."""
    import soundfile as sf

    try:
        return f"a {round(sf.info(libsndfile_path(path)).duration, 2):g}-s clip"
    except (RuntimeError, sf.LibsndfileError):
        return "a file that cannot be read as audio"


def _same_audio(path: Path, encoded: Path) -> bool:
    """``path`` exists and decodes to the same samples as the clip file ``encoded``."""
    import soundfile as sf

    if not path.is_file():
        return False
    try:
        old, old_rate = sf.read(libsndfile_path(path), dtype="float32")
    except (RuntimeError, sf.LibsndfileError):  # unreadable: rewrite it
        return False
    new, new_rate = sf.read(str(encoded), dtype="float32")
    return old_rate == new_rate and old.shape == new.shape and bool(np.array_equal(old, new))


def import_folder(source: Path | str, root: Path | str | None = None, progress: Progress = None,
                  **wording) -> list[Path]:
    """Copy a researcher's recordings (``source/<activity slug or name>/<clip>``) into the library.

    Sub-folders may be named by slug ("watch_tv") or Table I name ("watch TV"). Every file is
    checked first (:func:`library_clip`: readable WAV/FLAC/OGG, not empty, not silent, no NaN, at
    least half a second);
    if any folder or file is bad, :class:`CacasError` names it and nothing is copied
    (:func:`cacas.media_library.import_folder`, shared with the scene library). Files keep
    their format; a name already in the library gets an ``imported_`` prefix and a number.
    ``wording``: ``done``, ``again`` and ``item`` of a refusal's message (``cacas.media_library.import_folder``).
    Returns the new paths.
    """
    root = Path(root) if root is not None else sounds_dir()
    return media_library.import_folder(source, root, SOUNDS, progress, **wording)


def clip_seconds(path) -> float:
    """The length of a library clip from its header (nothing decoded); 0 for a file libsndfile
    cannot read or that is gone. Remembered per file version (path, inode, modification time, size):
    every Add in the app weighs the new clips against the whole library's lengths, and reading
    ~800 headers took 0.3-0.4 s each time (library files are written whole and renamed, so a
    changed clip has a new version)."""
    try:
        st = Path(path).stat()
    except OSError:
        return 0.0
    return _header_seconds(str(path), st.st_ino, st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=16384)
def _header_seconds(path: str, inode: int, mtime_ns: int, size: int) -> float:
    import soundfile as sf

    try:
        info = sf.info(path)
    except (RuntimeError, sf.LibsndfileError):
        return 0.0
    return info.frames / info.samplerate if info.samplerate else 0.0


def clip_windows(path) -> int:
    """How many windows of :data:`cacas.audio.features.WINDOW_SECONDS` the sound model cuts the clip
    into (:func:`cacas.audio.features.window_count`; training draws about as many augmented ones per
    epoch); 0 for a file that cannot be read."""
    from cacas.audio.features import window_count

    seconds = clip_seconds(path)
    return window_count(round(seconds * SAMPLE_RATE)) if seconds else 0


def library_clips(root: Path | str | None = None) -> tuple[int, int]:
    """(number, total bytes) of the clips in the library's activity folders: the recordings only,
    not a picture or notes kept beside them (study_data/sounds/spectrograms.png)."""
    clips = [p for activity in spaces.ACTIVITIES for p in clip_paths(activity, root)]
    return len(clips), sum(p.stat().st_size for p in clips)
