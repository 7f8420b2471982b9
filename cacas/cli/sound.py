"""``cacas sound generate|import|train|eval|recognize``: the sound library and the sound CNN (IV-A)."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

from cacas.cli import types
from cacas.cli.progress import ProgressBar
from cacas.media_library import SYNTHETIC_CLIP_SECONDS, SYNTHETIC_PER_CLASS
from cacas.recognition import SHORT_CLIP_SECONDS, UNSURE_BELOW


def count(n: int, noun: str) -> str:
    """'1 epoch', '2 epochs'."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def print_metrics(metrics, what: str = "clips") -> None:
    """Accuracy, the per-class table and the confusion pairs that are off the diagonal."""
    from cacas.recognition import evaluated_on

    print(f"accuracy: {metrics.accuracy:.3f} {evaluated_on(metrics, what)}")
    if "window_accuracy" in metrics.extra:
        print(f"window accuracy: {metrics.extra['window_accuracy']:.3f} on {metrics.extra['windows']} 1-s windows")
    pc = metrics.per_class.dropna(subset=["accuracy"])
    print(pc.to_string(index=False, formatters={"accuracy": "{:.2f}".format}))
    cf = metrics.confusion_frame()
    off = cf[(cf["true"] != cf["predicted"]) & (cf["count"] > 0)]
    if len(off):
        print("confusions (true -> predicted: count):")
        for r in off.itertuples():
            print(f"  {r.true} -> {r.predicted}: {r.count}")


def print_recognition(path, rec, kind: str) -> None:
    """``rec``'s label and top 3 on stdout; on stderr, as warnings, what the app's "Try a clip or a
    photo" warns of: a clip too short to say much, a recognition the ``kind`` ("sound", "scene")
    model is unsure of."""
    from cacas.errors import visible
    from cacas.recognition import short_clip_warning, unsure_words

    path = visible(path)  # one line each, whatever the file's name holds (CLI audit: a line break split them)
    print(f"{path}: {rec.label}")
    for label, share in rec.top3_words:  # whole percents ("<1%" under 1), as the app and the warning below say them
        print(f"  {label:24s} {share:>4s}")
    if rec.short:
        print(f"cacas {kind} recognize: warning: {path}: {short_clip_warning(rec.seconds)}", file=sys.stderr)
    if rec.unsure:
        print(f"cacas {kind} recognize: warning: {path}: unsure: {unsure_words(rec, kind)}", file=sys.stderr)


@contextlib.contextmanager
def library_out(out, default: Path):
    """The library folder a ``generate`` or ``import`` writes into (``--out``, else ``default``),
    checked before any work (:func:`cacas.store.files.writable_folder`: one line naming the path
    and what is wrong, not the OS's "afile/cough: Not a directory"); created if missing, and the
    folders it created removed again if the command fails or is stopped."""
    from cacas.store import files

    root = Path(out) if out is not None else default
    made = files.missing_folders(root)
    try:
        yield files.writable_folder(root, f"--out {root}" if out is not None else f"the library folder {root}")
    except BaseException:
        files.remove_empty(made)
        raise


def add_training_options(t, epochs: int, patience: int, augment: int | None = None) -> None:
    """The options ``sound train`` and ``scene train`` share (``--augment``: sound only), with
    their defaults and valid values in the help."""
    t.add_argument("--epochs", type=types.count, default=epochs,
                   help=types.described("at most this many epochs", types.count, epochs))
    t.add_argument("--patience", type=types.count, default=patience,
                   help=types.described("early stopping: epochs without improvement", types.count, patience))
    if augment is not None:
        t.add_argument("--augment", type=types.count, default=augment,
                       help=types.described("augmented copies per training window", types.count, augment))
    t.add_argument("--seed", type=types.seed, default=0,
                   help=types.described("seed of the held-out split and the training", types.seed, 0))
    t.add_argument("--quiet", action="store_true", help="no progress bar")


def register(subparsers) -> None:
    p = subparsers.add_parser("sound", help="sound library and sound-activity CNN (generate, import, train, put-back, eval, recognize)",
                              description="Sound-based activity recognition (paper Section IV-A).")
    sub = p.add_subparsers(dest="sound_command", metavar="ACTION")
    sub.required = True
    g = sub.add_parser("generate", help="write SYNTHETIC clips into the sound library",
                       description="Write SYNTHETIC clips (one folder per activity, Table I's 33 activities) into "
                                   "the sound library, named synthetic_<seed>_<k>; a clip already holding the same "
                                   "audio is left as it is. A clip of the same name holding other audio (the shipped "
                                   "2-s clips of seed 0, asked for --seconds 1) or in another format is replaced only "
                                   "with --replace; otherwise nothing is written, and the message says what to do. "
                                   "The clips are placed when all are written: stopped before, none is added.")
    clips = types.at_least(*SYNTHETIC_PER_CLASS)
    g.add_argument("--clips", type=clips, default=24, help=types.described("clips per activity", clips, 24))
    seconds = types.between(*SYNTHETIC_CLIP_SECONDS)
    g.add_argument("--seconds", type=seconds, default=2.0, help=types.described("clip length in seconds", seconds, 2))
    g.add_argument("--seed", type=types.seed, default=0,
                   help=types.described("seed (a new seed adds new clips)", types.seed, 0))
    g.add_argument("--format", default="ogg", choices=["ogg", "flac", "wav"], help="clip file format (default ogg)")
    g.add_argument("--out", type=types.path, default=None, metavar="DIR", help="library folder (default study_data/sounds)")
    g.add_argument("--replace", action="store_true",
                   help="replace clips of the same names that hold other audio or another format")
    g.set_defaults(func=run_generate)
    i = sub.add_parser("import", help="copy your own clips (FOLDER/<activity>/<clip>) into the library",
                       description="Copy your own clips (FOLDER/<activity>/<clip>) into the sound library; "
                                   "if any folder or file is bad, nothing is copied.")
    i.add_argument("folder", type=types.path, metavar="FOLDER",
                   help="your clips as FOLDER/<activity>/<clip>: a sub-folder per activity, named as in "
                        "Table I (use_stove or 'use stove'), holding .wav, .flac or .ogg clips")
    i.add_argument("--out", type=types.path, default=None, metavar="DIR", help="library folder (default study_data/sounds)")
    i.set_defaults(func=run_import)
    t = sub.add_parser("train", help="train the sound CNN on the library and save it",
                       description="Train the sound CNN (MFCC of 1-s windows, Section IV-A) on the library, "
                                   "holding out clips for the test, and save it.")
    t.add_argument("--data", type=types.path, default=None, metavar="DIR", help="library folder (default study_data/sounds)")
    t.add_argument("--model", type=types.path, default=None, metavar="FILE", help="where to save (default study_data/models/sound_cnn.pt)")
    add_training_options(t, epochs=8, patience=3, augment=1)
    t.set_defaults(func=run_train)
    e = sub.add_parser("eval", help="test a sound model (default: on its held-out clips)",
                       description="Test a sound model: accuracy, per-activity accuracy and confusions, by "
                                   "default on the clips held out when it was trained.")
    e.add_argument("--model", type=types.path, default=None, metavar="FILE", help="the model (default study_data/models/sound_cnn.pt)")
    e.add_argument("--data", type=types.path, default=None, metavar="DIR", help="clips folder (default study_data/sounds)")
    e.add_argument("--all", action="store_true", help="use every clip under --data, not only the held-out ones")
    e.add_argument("--confusion-png", type=types.png, default=None, metavar="FILE", help="also draw the confusion matrix")
    e.add_argument("--quiet", action="store_true", help="no progress bar")
    e.set_defaults(func=run_eval)
    r = sub.add_parser("recognize", help="recognise the activity in sound files (prints label and top 3)",
                       description="Recognise the activity in sound files: prints each file's label and its "
                                   "top 3 with their probabilities, and warns of a clip shorter than "
                                   f"{SHORT_CLIP_SECONDS:g} s (mostly the silence that pads it to the model's 1-s "
                                   f"window) and of a label under {UNSURE_BELOW:.0%} (the sound may be none of the "
                                   "33 activities), on stderr.")
    r.add_argument("files", nargs="+", type=types.path, metavar="FILE", help="sound files: .wav, .flac or .ogg")
    r.add_argument("--model", type=types.path, default=None, metavar="FILE", help="the model (default study_data/models/sound_cnn.pt)")
    r.set_defaults(func=run_recognize)
    add_put_back(sub, "sound", "study_data/models/sound_cnn.pt")


def add_put_back(sub, kind: str, default: str) -> None:
    """``cacas sound|scene put-back``: the model the last training replaced serves again."""
    b = sub.add_parser("put-back", help=f"put back the {kind} model the last training replaced",
                       description=f"Put back the {kind} model the last training replaced (each training keeps the "
                                   "model it replaces beside the new one, as <name>.previous.pt); the model it "
                                   "replaces is kept in its place, so putting back again undoes it.")
    b.add_argument("--model", type=types.path, default=None, metavar="FILE", help=f"the saved model (default {default})")
    b.set_defaults(func=lambda args: run_put_back(args, kind))


def run_put_back(args, kind: str) -> int:
    from cacas import lab, previous_model
    from cacas.previous_model import model_words

    path = args.model or lab.model_path(kind)
    saved, kept = previous_model.put_back(path, kind)
    print(f"{kind} model put back: {path} ({model_words(saved)})")
    if kept is not None:
        print(f"the model it replaced ({model_words(kept)}) is kept as {previous_model.previous_path(path)}; "
              f"`cacas {kind} put-back` again puts that one back")
    return 0


def run_generate(args) -> int:
    from cacas.audio.library import generate_library, library_clips, sounds_dir

    with library_out(args.out, sounds_dir()) as root, ProgressBar() as bar:
        paths = generate_library(args.clips, args.seconds, args.seed, root, progress=bar, fmt=args.format,
                                 replace=args.replace)
    n, size = library_clips(root)
    say_generated(paths, "clip", args.seed, root, "audio", f"; library now {n} clips, {size / 1e6:.1f} MB")
    say_replaced(paths, "clip", "held other audio")
    return 0


def say_generated(paths, item: str, seed: int, root, same: str, after: str = "") -> None:
    """What a generate did, in one line: the files it wrote and those it left as they were, which already held
    the ``same`` content (:class:`cacas.media_library.Generated`), then ``after``. The shipped library generated
    again wrote nothing, and the line said "wrote 240 synthetic scene images" (docs run)."""
    what = f"synthetic {item}"
    kept = len(paths.unchanged)
    if not kept:
        line = f"wrote {count(paths.written, what)} of seed {seed} to {root}"
    elif not paths.written:
        line = (f"wrote no {item}: the {count(kept, what)} of seed {seed} {'is' if kept == 1 else 'are'} in {root} "
                f"already, holding the same {same} (left as {'it is' if kept == 1 else 'they are'})")
    else:
        line = (f"wrote {count(paths.written, what)} of seed {seed} to {root}; {kept} more "
                f"{'was' if kept == 1 else 'were'} there already, holding the same {same} "
                f"(left as {'it is' if kept == 1 else 'they are'})")
    print(line + after)


def say_replaced(paths, item: str, other: str) -> None:
    """What a generate's ``--replace`` replaced and removed (:class:`cacas.media_library.Generated`)."""
    if paths.replaced:
        print(f"replaced {count(len(paths.replaced), item)} of the same name that {other}")
    if paths.removed:
        print(f"removed {count(len(paths.removed), item)} of the same name in another format (each is in the library "
              "once, in the format asked for)")


def run_import(args) -> int:
    from cacas.audio.library import import_folder, sounds_dir

    with library_out(args.out, sounds_dir()) as root, ProgressBar() as bar:
        paths = import_folder(args.folder, root, progress=bar)
    print(f"imported {count(len(paths), 'clip')} into {root}")
    return 0


def run_train(args) -> int:
    from cacas.audio.model import default_model_path
    from cacas.audio.training import train_sound_model
    from cacas.recognition import model_save_path

    model_path = model_save_path(args.model or default_model_path(), "--model")
    with ProgressBar(quiet=args.quiet) as bar:
        result = train_sound_model(args.data, epochs=args.epochs, patience=args.patience, seed=args.seed,
                                   augment_copies=args.augment, progress=bar)
    from cacas.cli import signals_held

    with signals_held():  # Ctrl-C while the model is saved: after the save (a torn one is refused), and said
        replaced = saved_model_id(model_path)
        path = result.recognizer.save(model_path, keep_previous=True)
        print(f"trained in {result.seconds:.0f} s ({count(len(result.history), 'epoch')}); saved {path}")
        print_metrics(result.metrics)
        say_kept(path, "sound", replaced)
    return 0


def saved_model_id(path) -> str | None:
    """The model id of the weights saved at ``path`` (None: none), read before a training saves."""
    from pathlib import Path

    from cacas.recognition import model_id

    return model_id(path) if Path(path).is_file() else None


def say_kept(path, kind: str, replaced: str | None) -> None:
    """After a training: where the model it replaced (``replaced``, its id) is kept, and how to put
    it back; nothing when it replaced none, or the one there was not kept (a torn save)."""
    from cacas import previous_model
    from cacas.previous_model import model_words

    kept = previous_model.previous_metadata(path)
    if replaced is not None and kept is not None and kept.get("model_id") == replaced:
        print(f"the model it replaced ({model_words(kept)}) is kept as {previous_model.previous_path(path)}; "
              f"`cacas {kind} put-back` puts it back")


def run_eval(args) -> int:
    from cacas.audio.model import SoundRecognizer
    from cacas.audio.training import evaluate_sound_model

    rec = SoundRecognizer.load(args.model)
    check_confusion_png(args.confusion_png)  # before the evaluation, not after it
    with ProgressBar(quiet=args.quiet) as bar:
        metrics = evaluate_sound_model(rec, args.data, held_out=not args.all, progress=bar)
    print_metrics(metrics)
    save_confusion(metrics, args.confusion_png)
    return 0


def check_confusion_png(path) -> None:
    """--confusion-png (a .png path, :func:`cacas.cli.types.png`) can be written there."""
    if path is not None:
        from cacas.store.files import writable_file

        writable_file(path, "--confusion-png")


def save_confusion(metrics, path) -> None:
    if path is not None:
        from pathlib import Path

        from cacas.plots_recognition import confusion_png

        Path(path).parent.mkdir(parents=True, exist_ok=True)  # as --model: missing folders are made

        confusion_png(metrics, path)
        print(f"confusion matrix drawn to {path}")


def run_recognize(args) -> int:
    from cacas.audio.model import SoundRecognizer

    return recognize_each(args.files, SoundRecognizer.load(args.model), "sound")


def recognize_each(files, recognizer, kind: str) -> int:
    """Every file recognised and printed (:func:`print_recognition`); a file that cannot be read is
    one error line, and the others are still recognised (lab walkthrough: `recognize bad.wav good.ogg`
    stopped at the first): exit 2 if any could not be, else 0."""
    from cacas.errors import CacasError, visible

    failed = 0
    for f in files:
        try:
            result = recognizer.recognize(f)
        except CacasError as exc:
            print(f"cacas: error: {visible(exc)}", file=sys.stderr)
            failed += 1
            continue
        print_recognition(f, result, kind)
    return 2 if failed else 0
