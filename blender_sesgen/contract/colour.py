"""Colour encodings: scene-linear float <-> sRGB (IEC 61966-2-1, not a plain 2.2 gamma)."""
from __future__ import annotations

import numpy as np


def linear_to_srgb(rgb_linear: np.ndarray) -> np.ndarray:
    """Scene-linear values (clipped to [0, 1]; NaN as 0) -> sRGB-encoded float32 in [0, 1]."""
    c = np.clip(np.nan_to_num(np.asarray(rgb_linear, dtype=np.float32)), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055).astype(np.float32)


def linear_to_srgb8(rgb_linear: np.ndarray) -> np.ndarray:
    """Scene-linear float -> uint8 sRGB (rounded to nearest)."""
    return np.rint(linear_to_srgb(rgb_linear) * 255.0).astype(np.uint8)
