"""Masks for disparity evaluation (disparity maps themselves: groundtruth.disparity.read_disparity)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VoError
from ..io.files import load_npy, read_image


def read_mask(path) -> np.ndarray:
    """Boolean (H, W) mask: True where the image (first channel) or .npy array is nonzero."""
    path = Path(path)
    if not path.is_file():
        raise VoError(f"{path}: no such mask file")
    if path.suffix.lower() == ".npy":
        m = load_npy(path)
    else:
        m = read_image(path)
    if m.ndim == 3:
        m = m[:, :, 0]
    if m.ndim != 2 or m.dtype.kind not in "biuf":
        raise VoError(f"{path}: a mask is a 2-D array of numbers, got shape {m.shape} dtype {m.dtype}")
    return np.asarray(m) != 0
