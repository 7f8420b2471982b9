"""Image-based home-scene recognition (Section IV-A): torchvision's ResNet-18 over the 6 scenes.

Public API: :class:`SceneRecognizer` (``load``, ``recognize``), :func:`train_scene_model`,
:func:`evaluate_scene_model` (``progress(fraction, message)`` callback), and
:mod:`cacas.vision.library` (``image_paths(scene)``, ``generate_scenes``, ``import_folder``).
"""

from cacas.recognition import Recognition
from cacas.vision.model import SceneRecognizer, build_resnet18


def __getattr__(name):
    if name in ("train_scene_model", "evaluate_scene_model", "SceneTrainingResult"):
        from cacas.vision import training

        return getattr(training, name)
    raise AttributeError(name)


__all__ = ["Recognition", "SceneRecognizer", "build_resnet18", "train_scene_model", "evaluate_scene_model",
           "SceneTrainingResult"]
