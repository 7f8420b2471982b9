"""Home-scene recognition with torchvision's ResNet-18 (Section IV-A: "For home scene
recognition, we used the Residual neural network (ResNet)"; V-A: fine-tuned from a pre-trained
ResNet for 3 epochs).

* :func:`build_resnet18` makes a ResNet-18 with a 6-way head. Pretrained ImageNet weights are used
  only when they are already on this machine: a weights file path, or torchvision's
  ``ResNet18_Weights.IMAGENET1K_V1`` file in the local torch hub cache. Nothing is downloaded; without
  weights the network trains from scratch.
* Saved models store conv / linear weights as int8 with one scale per output channel (about a
  quarter of the float32 size, ~11 MB instead of 45 MB); training dequantises the weights before
  the final test, so the tested model is exactly the saved one.
* :class:`SceneRecognizer` loads a saved model (default ``study_data/models/scene_resnet18.pt``)
  and recognises an image file or a PIL image.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
import torch
from torch import nn

from cacas import spaces
from cacas.errors import CacasError
from cacas.paths import study_data_dir
from cacas.recognition import Recognition, load_model_file, make_recognition, model_id, save_model

MODEL_FILE = "scene_resnet18.pt"
IMAGE_SIZE = 112  #: network input (pixels, square); the shipped images are 128 x 128
MEAN = (0.485, 0.456, 0.406)  # ImageNet statistics (the pretrained weights expect them)
STD = (0.229, 0.224, 0.225)


def default_model_path() -> Path:
    return study_data_dir() / "models" / MODEL_FILE


def cached_imagenet_weights() -> Path | None:
    """torchvision's ResNet-18 ImageNet weights file if it is in the local torch hub cache."""
    from torchvision.models import ResNet18_Weights

    url = ResNet18_Weights.IMAGENET1K_V1.url
    path = Path(torch.hub.get_dir()) / "checkpoints" / url.rsplit("/", 1)[-1]
    return path if path.is_file() else None


#: what a weights file must be, said after each reason a file is refused
WEIGHTS_EXPECTED = ("expected a ResNet-18 state dict saved with torch.save (.pth), such as torchvision's "
                    "resnet18-*.pth, or 'none'")


def read_resnet18_weights(path: str | Path) -> dict[str, torch.Tensor]:
    """The tensors of a ResNet-18 weights file, without its ``fc`` head (the 6-way head is new).

    Every way a file can be something else is one CacasError naming the file, what it is not and
    :data:`WEIGHTS_EXPECTED`: no such file, not a PyTorch file, a PyTorch file holding more than
    tensors (a whole pickled model), something other than a state dict, the state dict of another
    network, or ResNet-18's tensors in other shapes. Never runs code from the file
    (``weights_only=True``).
    """
    import zipfile

    from torchvision.models import resnet18

    path = Path(path)
    if not path.is_file():
        raise CacasError(f"{path}: no such weights file; {WEIGHTS_EXPECTED}")
    torch_archive = False  # torch.save's format: a zip archive holding a data.pkl
    if zipfile.is_zipfile(path):
        with zipfile.ZipFile(path) as archive:
            torch_archive = any(n == "data.pkl" or n.endswith("/data.pkl") for n in archive.namelist())
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception:
        if not torch_archive:
            raise CacasError(f"{path}: not a PyTorch weights file; {WEIGHTS_EXPECTED}") from None
        raise CacasError(f"{path}: a PyTorch file that holds more than tensors (a whole model? save its "
                         f"state_dict() instead); {WEIGHTS_EXPECTED}") from None
    if isinstance(state, dict) and isinstance(state.get("state_dict"), dict):  # a training checkpoint
        state = state["state_dict"]
    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        held = "a dict of other things than tensors" if isinstance(state, dict) else type(state).__name__
        raise CacasError(f"{path}: holds {held}, not a state dict; {WEIGHTS_EXPECTED}")
    reference = {k: v.shape for k, v in resnet18(weights=None).state_dict().items() if not k.startswith("fc.")}
    state = {k: v for k, v in state.items() if not k.startswith("fc.")}
    # files older than PyTorch 0.4.1 (torchvision's own resnet18-f37072fd.pth) lack the batch-norm counters;
    # the batch-norm layers fill them in as they load
    needed = [k for k in reference if not k.endswith("num_batches_tracked")]
    missing = [k for k in needed if k not in state]
    if missing or set(state) - set(reference):
        raise CacasError(f"{path}: the state dict of another network ({len(missing)} of ResNet-18's "
                         f"{len(needed)} tensors missing" + (f", e.g. '{missing[0]}'" if missing else "") +
                         f", {len(set(state) - set(reference))} not ResNet-18's); {WEIGHTS_EXPECTED}")
    wrong = [k for k in reference if k in state and tuple(state[k].shape) != tuple(reference[k])]
    if wrong:
        raise CacasError(f"{path}: ResNet-18's tensors in other shapes ({len(wrong)}, e.g. '{wrong[0]}' is "
                         f"{tuple(state[wrong[0]].shape)}, not {tuple(reference[wrong[0]])}); {WEIGHTS_EXPECTED}")
    return state


def build_resnet18(n_classes: int = spaces.N_SCENES, weights: str | Path | None = "auto") -> tuple[nn.Module, str]:
    """A ResNet-18 with an ``n_classes`` head, and where its starting weights came from.

    ``weights``: "auto" (the local torchvision cache if present, else none), "none", or a path
    to a ResNet-18 state dict (:func:`read_resnet18_weights`; its ``fc`` layer is replaced). Never
    downloads.
    """
    from torchvision.models import resnet18

    model = resnet18(weights=None)
    source = "none (trained from scratch)"
    path = None
    if weights == "auto":
        path = cached_imagenet_weights()
    elif weights not in (None, "none"):
        path = Path(weights)
    if path is not None:
        model.load_state_dict(read_resnet18_weights(path), strict=False)
        source = f"pretrained: {path.name}"
    model.fc = nn.Linear(model.fc.in_features, n_classes)
    return model, source


# ----------------------------------------------------------------------------- compact storage
def quantise_state(state: dict) -> dict:
    """int8 per-output-channel weights for tensors of 2+ dimensions; other tensors as they are."""
    out = {}
    for k, v in state.items():
        v = v.detach().cpu()
        if v.is_floating_point() and v.ndim >= 2:
            scale = v.abs().amax(dim=tuple(range(1, v.ndim)), keepdim=True).clamp_min(1e-12) / 127.0
            out[k + "::q"] = torch.round(v / scale).to(torch.int8)
            out[k + "::scale"] = scale.float()
        else:
            out[k] = v
    return out


def dequantise_state(tensors: dict) -> dict:
    out = {}
    for k, v in tensors.items():
        if k.endswith("::q"):
            base = k[:-3]
            out[base] = v.float() * tensors[base + "::scale"]
        elif not k.endswith("::scale"):
            out[k] = v
    return out


def preprocess(images) -> torch.Tensor:
    """PIL images -> normalised tensor batch (n, 3, IMAGE_SIZE, IMAGE_SIZE)."""
    from PIL import Image

    arrs = []
    for im in images:
        im = im.convert("RGB").resize((IMAGE_SIZE, IMAGE_SIZE), Image.BILINEAR)
        arrs.append(np.asarray(im, dtype=np.float32) / 255.0)
    x = torch.from_numpy(np.stack(arrs)).permute(0, 3, 1, 2)
    return (x - torch.tensor(MEAN)[:, None, None]) / torch.tensor(STD)[:, None, None]


class SceneRecognizer:
    """Recognises the home scene of a photo (Section IV-A) with a fine-tuned ResNet-18."""

    def __init__(self, model: nn.Module, classes: Sequence[str] = spaces.SCENES, metadata: dict | None = None):
        self.model = model.eval()
        self.classes = list(classes)
        self.metadata = dict(metadata or {})
        self.model_id: str | None = None  # the saved file's id (recognition.model_id); None until saved

    @classmethod
    def load(cls, path: Path | str | None = None) -> "SceneRecognizer":
        """Load a model saved by :meth:`save` (default: ``study_data/models/scene_resnet18.pt``)."""
        path = Path(path) if path is not None else default_model_path()
        tensors, meta, file_id = load_model_file(path, "scene")
        classes = meta.get("classes")
        if not classes:
            raise CacasError(f"{path}: metadata lists no classes")
        model, _ = build_resnet18(len(classes), weights="none")
        try:
            model.load_state_dict(dequantise_state(tensors))
        except (RuntimeError, KeyError) as exc:
            raise CacasError(f"{path}: weights do not fit ResNet-18 ({str(exc).splitlines()[0]})") from None
        recognizer = cls(model, classes, meta)
        recognizer.model_id = file_id
        return recognizer

    def compact(self) -> None:
        """Round the weights to what :meth:`save` stores (int8 per channel), in place."""
        self.model.load_state_dict(dequantise_state(quantise_state(self.model.state_dict())))

    def save(self, path: Path | str | None = None, *, keep_previous: bool = False, **metadata) -> Path:
        """Write int8-per-channel weights (.pt) and metadata (.json). Calls :meth:`compact` first.
        With ``keep_previous``, a model saved at ``path`` before is kept to be put back
        (:mod:`cacas.previous_model`)."""
        path = Path(path) if path is not None else default_model_path()
        self.compact()
        meta = {**self.metadata, **metadata, "kind": "scene", "classes": self.classes,
                "features": {"image_size": IMAGE_SIZE, "mean": MEAN, "std": STD},
                "architecture": f"torchvision resnet18, fc -> {len(self.classes)}",
                "storage": "int8 per output channel for conv/linear weights, float32 otherwise"}
        self.metadata = meta
        path = save_model(path, quantise_state(self.model.state_dict()), meta, keep_previous=keep_previous)
        self.model_id = model_id(path)
        return path

    @torch.no_grad()
    def probabilities_of(self, images) -> np.ndarray:
        """Class probabilities of PIL images: (n, n_classes)."""
        out = []
        for i in range(0, len(images), 32):
            out.append(torch.softmax(self.model(preprocess(images[i:i + 32])), dim=1).numpy())
        return np.concatenate(out) if out else np.zeros((0, len(self.classes)))

    def recognize(self, image) -> Recognition:
        """The scene of an image file path or a PIL image, with the top 3."""
        from PIL import Image

        from cacas.vision.library import load_image

        if isinstance(image, (str, Path)):
            image = load_image(image)
        elif not isinstance(image, Image.Image):
            raise CacasError(f"expected an image file path or a PIL image, got {type(image).__name__}")
        return make_recognition(self.probabilities_of([image])[0], self.classes, model=self.model_id)
