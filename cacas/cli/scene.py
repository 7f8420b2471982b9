"""``cacas scene generate|import|train|eval|recognize``: the scene images and ResNet-18 (IV-A)."""

from __future__ import annotations

from cacas.cli import types
from cacas.cli.progress import ProgressBar
from cacas.cli.sound import (add_put_back, add_training_options, check_confusion_png, count, library_out,
                             print_metrics, recognize_each, save_confusion, saved_model_id, say_generated, say_kept,
                             say_replaced)
from cacas.errors import CacasError
from cacas.media_library import SYNTHETIC_IMAGE_SIDE, SYNTHETIC_PER_CLASS
from cacas.recognition import UNSURE_BELOW


def register(subparsers) -> None:
    p = subparsers.add_parser("scene", help="scene images and the ResNet-18 scene model (generate, import, train, put-back, eval, recognize)",
                              description="Image-based home-scene recognition (paper Section IV-A).")
    sub = p.add_subparsers(dest="scene_command", metavar="ACTION")
    sub.required = True
    g = sub.add_parser("generate", help="write SYNTHETIC scene images into the library",
                       description="Write SYNTHETIC images of the 6 home scenes (Table I), one folder per scene, "
                                   "into the scene library, named synthetic_<seed>_<k>.jpg; an image already holding "
                                   "the same picture is left as it is. One of the same name holding another (the "
                                   "shipped 128-px images of seed 0, asked for --size 64) is replaced only with "
                                   "--replace; otherwise nothing is written, and the message says what to do. The "
                                   "images are placed when all are written: stopped before, none is added.")
    images = types.at_least(*SYNTHETIC_PER_CLASS)
    g.add_argument("--images", type=images, default=40, help=types.described("images per scene", images, 40))
    size = types.at_least(*SYNTHETIC_IMAGE_SIDE)
    g.add_argument("--size", type=size, default=128, help=types.described("image side in pixels", size, 128))
    g.add_argument("--seed", type=types.seed, default=0,
                   help=types.described("seed (a new seed draws new images)", types.seed, 0))
    g.add_argument("--out", type=types.path, default=None, metavar="DIR", help="library folder (default study_data/scenes)")
    g.add_argument("--replace", action="store_true", help="replace images of the same names that hold other pictures")
    g.set_defaults(func=run_generate)
    i = sub.add_parser("import", help="copy your own photos (FOLDER/<scene>/<image>) into the library",
                       description="Copy your own photos (FOLDER/<scene>/<image>) into the scene library; if any "
                                   "folder or file is bad, nothing is copied.")
    i.add_argument("folder", type=types.path, metavar="FOLDER",
                   help="your photos as FOLDER/<scene>/<image>: a sub-folder per scene, named as in Table I "
                        "(living_room or 'living room'), holding .jpg, .jpeg, .png, .bmp or .webp images")
    i.add_argument("--out", type=types.path, default=None, metavar="DIR", help="library folder (default study_data/scenes)")
    i.set_defaults(func=run_import)
    t = sub.add_parser("train", help="fine-tune ResNet-18 on the scene library and save it",
                       description="Fine-tune ResNet-18 (Section IV-A) on the scene library, holding out images "
                                   "for the test, and save it. Never downloads weights.")
    t.add_argument("--data", type=types.path, default=None, metavar="DIR", help="images folder (default study_data/scenes)")
    t.add_argument("--model", type=types.path, default=None, metavar="FILE", help="where to save (default study_data/models/scene_resnet18.pt)")
    t.add_argument("--weights", default="auto", metavar="auto|none|FILE",
                   help="initial weights: 'auto' (torchvision's local cache if present), 'none', or a .pth file "
                        "(default auto)")
    add_training_options(t, epochs=12, patience=4)
    t.set_defaults(func=run_train)
    e = sub.add_parser("eval", help="test a scene model (default: on its held-out images)",
                       description="Test a scene model: accuracy, per-scene accuracy and confusions, by default on "
                                   "the images held out when it was trained.")
    e.add_argument("--model", type=types.path, default=None, metavar="FILE",
                   help="the model (default study_data/models/scene_resnet18.pt)")
    e.add_argument("--data", type=types.path, default=None, metavar="DIR", help="images folder (default study_data/scenes)")
    e.add_argument("--all", action="store_true", help="use every image under --data")
    e.add_argument("--confusion-png", type=types.png, default=None, metavar="FILE", help="also draw the confusion matrix")
    e.add_argument("--quiet", action="store_true", help="no progress bar")
    e.set_defaults(func=run_eval)
    r = sub.add_parser("recognize", help="recognise the scene of image files (prints label and top 3)",
                       description="Recognise the scene of image files: prints each file's label and its top 3 "
                                   f"with their probabilities, and warns of a label under {UNSURE_BELOW:.0%} (the photo "
                                   "may be of none of the 6 home scenes), on stderr.")
    r.add_argument("files", nargs="+", type=types.path, metavar="FILE",
                   help="image files: .jpg, .jpeg, .png, .bmp or .webp")
    r.add_argument("--model", type=types.path, default=None, metavar="FILE",
                   help="the model (default study_data/models/scene_resnet18.pt)")
    r.set_defaults(func=run_recognize)
    add_put_back(sub, "scene", "study_data/models/scene_resnet18.pt")


def run_generate(args) -> int:
    from cacas.vision.library import generate_scenes, scenes_dir

    with library_out(args.out, scenes_dir()) as root, ProgressBar() as bar:
        paths = generate_scenes(args.images, args.size, args.seed, root, progress=bar, replace=args.replace)
    say_generated(paths, "scene image", args.seed, root, "picture")
    say_replaced(paths, "image", "held another picture")
    return 0


def run_import(args) -> int:
    from cacas.vision.library import import_folder, scenes_dir

    with library_out(args.out, scenes_dir()) as root:
        paths = import_folder(args.folder, root)
    print(f"imported {count(len(paths), 'image')} into {root}")
    return 0


def run_train(args) -> int:
    from cacas.vision.model import default_model_path
    from cacas.vision.training import train_scene_model
    from cacas.recognition import model_save_path

    model_path = model_save_path(args.model or default_model_path(), "--model")
    check_weights_file(args.weights)
    with ProgressBar(quiet=args.quiet) as bar:
        result = train_scene_model(args.data, epochs=args.epochs, patience=args.patience, seed=args.seed,
                                   weights=args.weights, progress=bar)
    from cacas.cli import signals_held

    with signals_held():  # Ctrl-C while the model is saved: after the save (a torn one is refused), and said
        replaced = saved_model_id(model_path)
        path = result.recognizer.save(model_path, keep_previous=True)
        print(f"trained in {result.seconds:.0f} s ({count(len(result.history), 'epoch')}, initial weights: "
              f"{result.recognizer.metadata['initial_weights']}); saved {path}")
        print_metrics(result.metrics, "images")
        say_kept(path, "scene", replaced)
    return 0


def check_weights_file(weights: str) -> None:
    """--weights: 'auto', 'none', or a ResNet-18 weights file, checked before the images are read and
    minutes of training begin (the model builder's own rules: :func:`read_resnet18_weights`)."""
    from cacas.vision.model import read_resnet18_weights

    if weights not in ("auto", "none"):
        try:
            read_resnet18_weights(weights)
        except CacasError as exc:
            raise CacasError(f"--weights {exc}") from None


def run_eval(args) -> int:
    from cacas.vision.model import SceneRecognizer
    from cacas.vision.training import evaluate_scene_model

    rec = SceneRecognizer.load(args.model)
    check_confusion_png(args.confusion_png)  # before the evaluation, not after it
    with ProgressBar(quiet=args.quiet) as bar:
        metrics = evaluate_scene_model(rec, args.data, held_out=not args.all, progress=bar)
    print_metrics(metrics, "images")
    save_confusion(metrics, args.confusion_png)
    return 0


def run_recognize(args) -> int:
    from cacas.vision.model import SceneRecognizer

    return recognize_each(args.files, SceneRecognizer.load(args.model), "scene")
