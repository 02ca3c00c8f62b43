"""Masks for disparity evaluation (disparity maps themselves: products.disparity.read_disparity)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VoError
from ..io.files import read_image


def read_mask(path) -> np.ndarray:
    """Boolean (H, W) mask: True where the image (first channel) or .npy array is nonzero."""
    path = Path(path)
    if not path.is_file():
        raise VoError(f"{path}: no such mask file")
    if path.suffix.lower() == ".npy":
        try:
            m = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as e:
            raise VoError(f"{path}: not a readable .npy array ({e})") from None
    else:
        m = read_image(path)
    if m.ndim == 3:
        m = m[:, :, 0]
    return np.asarray(m) != 0
