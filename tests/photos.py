"""Test photos for the scene library, which refuses one flat colour (cacas.vision.library.library_photo):
``photo(size, colour)`` is that colour with a gradient across it, so two colours give two photos.
Import it into a test module: ``from photos import photo``."""

import numpy as np
from PIL import Image


def photo(size=(40, 30), colour=(200, 120, 40)) -> Image.Image:
    """An RGB image of ``size`` (width, height): ``colour`` brightened left to right by up to 40 levels."""
    w, h = size
    ramp = np.linspace(0, 40, w)[None, :, None]
    pixels = np.clip(np.array(colour, dtype=float)[None, None, :] + ramp, 0, 255)
    return Image.fromarray(np.broadcast_to(pixels, (h, w, 3)).astype(np.uint8), "RGB")
