"""Reading the project's policy files without running code from them.

A policy file (:meth:`cacas.policy.ReshapedPolicy.to_bytes`, the bandit's, and
:meth:`cacas.sac.DiscreteSAC.save`) is a dict of tensors, numbers, text and numpy arrays (the
replay memory ORL keeps, the bandit's counts). Such files come from elsewhere too: a study bundle
brings its participants' policies (``cacas import``), and a plain ``torch.load`` unpickles
whatever a crafted file names, including a call that runs code. :func:`load_checkpoint` uses
torch's weights-only unpickler, which builds tensors and plain containers only, with numpy's
array reconstruction and its numeric dtypes allowed (:data:`NUMPY_GLOBALS`): the files this
project writes load as before, anything else is refused.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import torch

_reconstruct = np._core.multiarray._reconstruct if hasattr(np, "_core") else np.core.multiarray._reconstruct
_scalar = np._core.multiarray.scalar if hasattr(np, "_core") else np.core.multiarray.scalar
_NUMERIC = (np.bool_, np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64,
            np.float16, np.float32, np.float64)

#: What a policy file may name besides torch's own: numpy arrays of numbers (under numpy 2's
#: module path and numpy 1's, whichever wrote the file), their dtypes and numpy number scalars.
#: Not object arrays: their elements would be arbitrary objects.
NUMPY_GLOBALS = [
    (_reconstruct, "numpy._core.multiarray._reconstruct"),
    (_reconstruct, "numpy.core.multiarray._reconstruct"),
    (_scalar, "numpy._core.multiarray.scalar"),
    (_scalar, "numpy.core.multiarray.scalar"),
    np.ndarray, np.dtype,
    *(type(np.dtype(t)) for t in _NUMERIC),
]
torch.serialization.add_safe_globals(NUMPY_GLOBALS)


def load_checkpoint(source: bytes | str | Path):
    """The object a torch file holds (bytes, or a path), read with ``weights_only=True`` and
    :data:`NUMPY_GLOBALS` allowed. A file naming anything else raises torch's
    ``UnpicklingError`` (the callers turn it into their "not a CACAS policy file")."""
    src = io.BytesIO(source) if isinstance(source, (bytes, bytearray)) else source
    return torch.load(src, map_location="cpu", weights_only=True)


__all__ = ["NUMPY_GLOBALS", "load_checkpoint"]
