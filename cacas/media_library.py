"""What the sound and the scene libraries share: one folder per Table I name, of media files.

A library is ``<root>/<slug>/<file>``, where the slug is a filesystem-safe form of an activity
(``watch_tv``) or a scene (``living_room``) name. :class:`MediaKind` says which (its names, file
types and checker), and the same two functions serve both libraries:

* :func:`scan`: every media file of a library, by Table I order then name. A sub-folder that is
  not a name, or a file of a type the kind cannot read, is refused with one message naming it
  and what is valid; files beside the sub-folders (a README, a figure) are left alone.
* :func:`import_folder`: a researcher's folder of the same layout copied into a library. Every
  file is checked first (type, then readable by the kind's checker); one bad folder or file and
  nothing is copied. The copies are staged under temporary names and renamed into place only
  when all are written (:class:`Staging`, which the synthetic generators use too): stopped
  before, the library is as it was.
"""

from __future__ import annotations

import os
import re
import shutil
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Sequence

from cacas.errors import CacasError, closest_name, visible

Progress = Callable[[float, str], None] | None

#: What the SYNTHETIC generators take, from..to (both valid): a clip's length in seconds
#: (:func:`cacas.audio.library.generate_library`) and an image's side in pixels
#: (:func:`cacas.vision.library.generate_scenes`); here, where the command line's help reads them
#: without loading torch.
SYNTHETIC_CLIP_SECONDS = (1.0, 10.0)
SYNTHETIC_IMAGE_SIDE = (32, 1024)
#: How many clips per activity, or images per scene, one generate writes: 33,000 clips of 2 s are
#: ~2 GB (CLI audit: --clips 99999999999999999999999 was taken, and ran until stopped)
SYNTHETIC_PER_CLASS = (1, 1000)


class Generated(list):
    """The files a SYNTHETIC generator's run stands for (a list of paths, as before), with those of
    them it left as they were (``unchanged``: the file already held the same content), those it
    wrote in place of a file of the same name holding other content (``replaced``: the generator's
    ``replace=True``; without it such a run is refused, :func:`refuse_replacing`), and the files
    it removed (``removed``: the same clip in another format, which would have been in the library
    twice)."""

    def __init__(self, paths=(), replaced=(), removed=(), unchanged=()):
        super().__init__(paths)
        self.replaced = list(replaced)
        self.removed = list(removed)
        self.unchanged = list(unchanged)

    @property
    def written(self) -> int:
        """How many files the run wrote (new ones and replaced ones)."""
        return len(self) - len(self.unchanged)


_SYNTHETIC = re.compile(r"synthetic_(\d+)_\d+\.[^.]+")


def refuse_replacing(path: Path, holds: str, seed: int, root: Path, extensions, item: str) -> CacasError:
    """The refusal of a SYNTHETIC generator's run that would replace ``path`` (a file of the name
    it writes, which ``holds`` other content: a shipped clip or image, or an earlier run's) without
    ``replace``: what it holds, and the ways on (a seed the library has no files of yet, another
    library, or ``--replace``). Nothing is written then (the generator raises it before placing)."""
    seeds = {int(m[1]) for f in Path(root).glob("*/synthetic_*")
             if (m := _SYNTHETIC.fullmatch(f.name)) and f.suffix.lower() in extensions}
    free = next(n for n in range(seed + 1, seed + len(seeds) + 2) if n not in seeds)
    return CacasError(f"{path}: holds {holds}; a run of seed {seed} writes its {item}s under these names and would "
                      f"replace the library's (the shipped ones, or an earlier run's); valid: --seed {free} for new "
                      f"{item}s beside them, --out DIR for a library of its own, or --replace to replace them; "
                      "nothing was written")


def no_folder_at(path: Path, item: str) -> None:
    """A SYNTHETIC generator's refusal (CacasError) of a folder where it writes ``item`` (a clip, an
    image): no ``replace`` can replace a folder (CLI audit: one was said to hold "a file that cannot
    be read as audio", and --replace was offered). Raised before anything is placed."""
    if path.is_dir():
        raise CacasError(f"{path}: a folder, where this run writes {_a(item)}; valid: move or rename that folder, "
                         "or --out DIR for a library of its own; nothing was written")


def slug(name: str) -> str:
    """Filesystem-safe folder name of a Table I name: "watch TV" -> "watch_tv"."""
    return re.sub(r"[^a-z0-9]+", "_", name.strip().lower()).strip("_")


def files_with_extensions(folder: Path, extensions) -> list[Path]:
    """The files of ``folder`` (not below it) whose extension is one of ``extensions``, sorted;
    none if the folder does not exist."""
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in extensions)


@dataclass(frozen=True)
class MediaKind:
    """One kind of library: ``what`` ("sound"), its ``label`` ("activity") and ``item``
    ("recording") words for messages, the Table I ``names``, the file ``extensions`` it reads,
    ``name_of_folder`` (folder name -> Table I name, CacasError if none) and ``check`` (raises
    CacasError naming a file it cannot use)."""

    what: str
    label: str
    item: str
    names: Sequence[str]
    extensions: Sequence[str]
    name_of_folder: Callable[[str], str]
    check: Callable[[Path], object]

    @property
    def layout(self) -> str:
        return f"<folder>/<{self.label}>/<{self.item}>{'|'.join(self.extensions)}"

    def folder_name(self, sub: Path) -> str:
        """The Table I name of a sub-folder; CacasError naming it and the valid folder names."""
        try:
            return self.name_of_folder(sub.name)
        except CacasError:
            valid = ", ".join(slug(n) for n in self.names)
            # the hint as a folder is named ('coughing' -> 'cough', 'cutting_food' -> 'cut_food'; walkthrough)
            close = closest_name(sub.name.replace("_", " "), [slug(n).replace("_", " ") for n in self.names])
            near = "" if close is None else f"did you mean {close.replace(' ', '_')!r}? "
            raise CacasError(f"{sub}: folder name {sub.name!r} is not {_a(self.label)}; {near}valid: {valid}") from None

    def supported(self, path: Path) -> Path:
        """``path`` if its type is one the kind reads; else CacasError naming it and what is valid."""
        if path.suffix.lower() not in self.extensions:
            raise CacasError(f"{path}: unsupported file type {path.suffix or '(none)'!r}; "
                             f"valid: {', '.join(self.extensions)}")
        return path


def _a(word: str) -> str:
    return ("an " if word[:1] in "aeiou" else "a ") + word


def _visible(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if not p.name.startswith("."))


def _entries(folder: Path, kind: MediaKind) -> list[tuple[Path, str]]:
    """(file, Table I name) of every visible file in the name folders of ``folder``, every
    folder name and file type checked."""
    out = []
    for sub in (p for p in _visible(folder) if p.is_dir()):
        name = kind.folder_name(sub)
        out += [(kind.supported(f), name) for f in _visible(sub) if f.is_file()]
    return out


def _refuse_copies(plan: list[tuple[Path, str]], root: Path, kind: MediaKind, done: str = "imported",
                   again: str = "import again") -> None:
    """A file whose bytes are already in the library (under any name), or twice in ``plan``, is
    refused: a copy could fall into both the training and the test split of a model and flatter
    its accuracy (or, under another name, teach it two answers for one clip). The message says
    "nothing was <done> (leave the copy out and <again>)"."""
    from cacas.store.files import file_sha256

    seen: dict[str, Path] = {}
    if root.is_dir():
        for sub in (p for p in _visible(root) if p.is_dir()):
            for f in _visible(sub):
                if f.is_file() and f.suffix.lower() in kind.extensions:
                    seen.setdefault(file_sha256(f), f)
    for f, _ in plan:
        digest = file_sha256(f)
        if digest in seen:
            where = seen[digest]
            place = (f"already in the library as {where.relative_to(root)}" if where.is_relative_to(root)
                     else f"given twice (also as {where.name})")
            raise CacasError(f"{f}: the same {kind.item} is {place}; nothing was {done} (leave the copy out "
                             f"and {again})")
        seen[digest] = f


class Staging:
    """Files written to temporary names beside their targets (``.<name>.<pid>.tmp``, which no
    scan reads) and renamed into place together by :meth:`place`: until then the library is as it
    was. As a context manager: if the work fails or is stopped (Ctrl-C, SIGTERM) before
    :meth:`place` is done, the temporary files, the new files already placed and the folders made
    for them are removed (a file it replaced with other content stays replaced)."""

    def __init__(self, root: Path | str | None = None, extensions: Sequence[str] = ()):
        """``root``: the library written into (its files end in one of ``extensions``); the
        temporary files that a writer killed outright (kill -9, a power cut) left in its folders
        are removed on entering (:func:`remove_leftovers`)."""
        self.root = Path(root) if root is not None else None
        self.extensions = tuple(extensions)
        self.staged: list[tuple[Path, Path, bool]] = []  # (temporary, target, target existed)
        self.made: list[Path] = []
        self.placed: list[Path] = []  # new files renamed into place so far
        self.done = False

    def path(self, target: Path) -> Path:
        """Where to write ``target``'s content (a temporary name beside it; its folder is made)."""
        from cacas.store import files

        self.made += files.missing_folders(target.parent)
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
        self.staged.append((tmp, target, target.exists()))
        return tmp

    def place(self) -> None:
        """Rename every staged file into place: each fsynced first and the folders after, so a
        power cut soon after cannot leave empty or cut files under the new names (safety round:
        the copies were renamed unsynced)."""
        from cacas.store import files

        for tmp, _, _ in self.staged:
            files.fsync_file(tmp)
        for tmp, target, existed in self.staged:
            os.replace(tmp, target)
            if not existed:
                self.placed.append(target)
        for folder in dict.fromkeys(target.parent for _, target, _ in self.staged):
            files.fsync_folder(folder)
        self.done = True

    def discard(self) -> None:
        from cacas.store import files

        for path in [tmp for tmp, _, _ in self.staged] + self.placed:
            try:
                path.unlink(missing_ok=True)
            except OSError:  # pragma: no cover - the folder went away meanwhile
                pass
        files.remove_empty(self.made)

    def __enter__(self) -> "Staging":
        if self.root is not None:
            remove_leftovers(self.root, self.extensions)
        return self

    def __exit__(self, kind, exc, tb) -> None:
        if kind is not None and not self.done:
            self.discard()


_LEFTOVER = re.compile(r"^\.(.+)\.(\d{1,9})\.tmp$")
#: A leftover is removed only when older than this (seconds) as well: a process id alone does not
#: tell that its writer is gone (in another container a running process looks gone; the store's
#: recovery says the same), and no generate or import writes a file for that long.
LEFTOVER_AGE = 3600


def remove_leftovers(root: Path | str, extensions: Sequence[str]) -> list[Path]:
    """Remove the temporary files that :class:`Staging` writes (``.<name>.<pid>.tmp``, ``name``
    ending in one of the library's ``extensions``) in the library folders of ``root``, whose
    process is gone and that are older than :data:`LEFTOVER_AGE`: a generate or import killed
    outright leaves them (a Ctrl-C or SIGTERM is cleaned up at once). Anything else is left.
    Returns the removed files."""
    import time

    from cacas.store import files

    root = Path(root)
    removed = []
    if not root.is_dir():
        return removed
    now = time.time()
    for folder in (p for p in root.iterdir() if p.is_dir()):
        for f in folder.iterdir():
            m = _LEFTOVER.match(f.name)
            if not (m and Path(m.group(1)).suffix.lower() in extensions and f.is_file()):
                continue
            try:
                if now - f.stat().st_mtime > LEFTOVER_AGE and not files.process_running(int(m.group(2))):
                    f.unlink()
                    removed.append(f)
            except OSError:  # pragma: no cover - removed meanwhile, or not ours to remove
                pass
    return removed


def scan(root: Path, kind: MediaKind) -> list[tuple[Path, str]]:
    """Every file of the library at ``root`` as (path, Table I name), by Table I order then file
    name; [] for a library with none. A missing ``root``, a sub-folder that is not a name or a
    file of another type is a CacasError naming it."""
    root = Path(root)
    if not root.is_dir():
        raise CacasError(f"{root}: no such {kind.what} folder; expected {kind.layout}")
    order = {n: i for i, n in enumerate(kind.names)}
    return sorted(_entries(root, kind), key=lambda e: (order[e[1]], e[0].name))


def import_folder(source: Path | str, root: Path, kind: MediaKind, progress: Progress = None, *,
                  done: str = "imported", again: str = "import again", item: str | None = None) -> list[Path]:
    """Copy ``source/<name or slug>/<file>`` into the library at ``root`` (``root/<slug>/<file>``),
    all or nothing. Refused, with nothing copied: a missing folder, a file beside the name
    folders, a folder that is not a name, a file of another type or one ``kind.check`` refuses,
    and a folder with no file at all, and a file already in the library (the same bytes, under any
    name) or given twice; the folders not named as a name, the files of another type and those
    ``kind.check`` refuses are all said at once, one a line ("- <file>: ..."), in the folder's order. A name already in the library gets an ``imported_<k>_`` prefix.
    A refusal that nothing was copied says "nothing was <done>", and a copy to leave out, to do it
    "<again>" (the app's page adds files with a button of its own), and calls a file ``item``
    (default ``kind.item``: the app's page says "photos" where the scene library says "images").
    Returns the new paths."""
    if item is not None:
        kind = replace(kind, item=item)
    source, root = Path(source), Path(root)
    if not source.is_dir():  # a file given for the folder is said as one (CLI audit: "no such folder")
        raise CacasError(f"{source}: {'a file, not a folder' if source.exists() else 'no such folder'}; "
                         f"expected {kind.layout}")
    stray = [p for p in _visible(source) if p.is_file()]
    if stray:
        raise CacasError(f"{stray[0]}: not in {_a(kind.label)} folder; expected {kind.layout}")
    # every folder name, file type and file checked before anything is copied, every bad one said: one at a
    # time took a try for each (walkthrough: three bad clips, three presses; then a folder named 'coughing',
    # a notes.txt and an .mp3 beside a short clip, four tries)
    # bad: (path, message, how many items (files of the kind's types) and other files it makes unusable)
    plan, bad, items_in, others_in = [], [], 0, 0
    for sub in (p for p in _visible(source) if p.is_dir()):
        inside = [f for f in _visible(sub) if f.is_file()]
        items = sum(f.suffix.lower() in kind.extensions for f in inside)
        items_in, others_in = items_in + items, others_in + len(inside) - items
        try:
            name = kind.folder_name(sub)
        except CacasError as exc:
            bad.append((sub, str(exc), items, len(inside) - items))
            continue
        for f in inside:
            try:
                plan.append((kind.supported(f), name))
            except CacasError as exc:
                bad.append((f, str(exc), 0, 1))
    if not items_in + others_in and not bad:
        raise CacasError(f"{source}: no {kind.item}s found; expected {kind.layout}")
    for i, (f, _) in enumerate(plan):
        try:
            kind.check(f)
        except CacasError as exc:
            bad.append((f, str(exc), 1, 0))
        if progress:
            progress(0.5 * (i + 1) / len(plan), f"checked {f.name}")
    bad.sort(key=lambda b: b[0])  # in the folder's order
    # each problem on its line: a line break in a folder's or a file's name written \n (CLI audit: 'cou<break>gh'
    # split the message)
    if len(bad) == 1:
        raise CacasError(visible(bad[0][1]))
    if bad:
        raise CacasError(f"{_unusable(bad, items_in, kind.item)} cannot be used; nothing was {done}:"
                         + "".join(f"\n- {visible(b[1])}" for b in bad))
    try:
        with adding(root):  # two adds at once take turns: the copy check sees what the other placed
            _refuse_copies(plan, root, kind, done, again)
            targets, taken = [], set()
            for f, name in plan:
                folder = root / slug(name)
                target, k = folder / f.name, 1
                while target.exists() or target in taken:
                    target, k = folder / f"imported_{k}_{f.name}", k + 1
                taken.add(target)
                targets.append(target)
            # new names only (taken ones get a prefix), so removing them undoes the import
            with Staging(root, kind.extensions) as staging:
                for i, ((f, _), target) in enumerate(zip(plan, targets)):
                    # the bytes alone: a read-only source's mode (a DVD's, a write-protected stick's files) made
                    # read-only library files, which Windows neither syncs through a descriptor that may write
                    # (files.fsync_file) nor deletes
                    shutil.copyfile(f, staging.path(target))
                    if progress:
                        progress(0.5 + 0.5 * (i + 1) / len(plan), f"copied {f.name}")
                staging.place()
    except OSError as exc:
        raise CacasError(f"{root}: cannot copy into the {kind.what} library ({exc.strerror or exc}); "
                         f"nothing was {done}") from None
    return targets


def _unusable(bad: list[tuple], items_in: int, item: str) -> str:
    """What a refused import could not use, items and other files apart: "2 of the 3 clips and 2 files
    that are not clips" (walk3: notes.txt and an .mp3 were counted as clips, "4 of the 5 clips")."""
    items, others = sum(b[2] for b in bad), sum(b[3] for b in bad)
    words = [f"{items} of the {items_in} {item}s"] if items else []
    if others:
        words.append(f"1 file that is not {_a(item)}" if others == 1 else f"{others} files that are not {item}s")
    return " and ".join(words)


def adding_lock(root: Path) -> Path:
    """The lock file of adding to the library at ``root``: hidden, beside it."""
    return root.with_name(f".{root.name}.adding.lock")


def adding(root: Path):
    """An exclusive lock (``flock``) for adding files to the library at ``root``, from the check
    for copies to the last rename: two researchers adding the same clip at one moment (two
    browsers, or the app and `cacas sound import`) each found it new and both copies went in,
    counted twice in training (safety round). The lock file stays."""
    from cacas.store.recovery import busy

    root.parent.mkdir(parents=True, exist_ok=True)
    return busy(adding_lock(root))
