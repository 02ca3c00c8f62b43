"""Colour conversions: scene-linear float <-> 8-bit sRGB, RGB -> grey.

The sRGB transfer function is the IEC 61966-2-1 one (linear segment below 0.0031308),
not a plain 2.2 gamma.
"""
from __future__ import annotations

import numpy as np


def linear_to_srgb(rgb_linear: np.ndarray) -> np.ndarray:
    """Scene-linear values (clipped to [0, 1]) -> sRGB-encoded float in [0, 1]."""
    c = np.clip(np.asarray(rgb_linear, dtype=np.float32), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055).astype(np.float32)


def srgb_to_linear(srgb: np.ndarray) -> np.ndarray:
    """sRGB-encoded float in [0, 1] -> linear float32."""
    s = np.asarray(srgb, dtype=np.float32)
    return np.where(s <= 0.04045, s / 12.92, np.power((s + 0.055) / 1.055, 2.4)).astype(np.float32)


def linear_to_srgb8(rgb_linear: np.ndarray) -> np.ndarray:
    """Scene-linear float -> uint8 sRGB (rounded to nearest)."""
    return np.rint(linear_to_srgb(rgb_linear) * 255.0).astype(np.uint8)


def rgb8_to_gray8(rgb: np.ndarray) -> np.ndarray:
    """uint8 RGB (H, W, 3) -> uint8 grey with OpenCV's weights (0.299 R + 0.587 G + 0.114 B)."""
    import cv2
    return cv2.cvtColor(np.ascontiguousarray(rgb, dtype=np.uint8), cv2.COLOR_RGB2GRAY)
