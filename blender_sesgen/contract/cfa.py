"""Colour filter arrays (Bayer patterns): which colour each pixel of a raw mosaic samples.

A pattern is named by its top-left 2x2 cell read row by row (``rggb`` = R G / G B), as the
camera datasheets and RobotCar do; OpenCV names its demosaic codes by the *second* row
(vo_reference.camera.bayer maps the two).
"""
from __future__ import annotations

import numpy as np

from .errors import ContractError

PATTERNS = ("rggb", "bggr", "grbg", "gbrg")
_CHANNEL = {"r": 0, "g": 1, "b": 2}


def check_pattern(pattern: str) -> str:
    """The pattern in lower case; ContractError for anything else."""
    p = str(pattern).lower()
    if p not in PATTERNS:
        raise ContractError(f"unknown Bayer/CFA pattern {pattern!r} (use one of {', '.join(PATTERNS)})")
    return p


def cfa_channels(pattern: str, height: int, width: int) -> np.ndarray:
    """(H, W) int: the colour (0 R, 1 G, 2 B) each pixel of the mosaic samples."""
    p = check_pattern(pattern)
    cell = np.array([[_CHANNEL[p[0]], _CHANNEL[p[1]]], [_CHANNEL[p[2]], _CHANNEL[p[3]]]])
    return np.tile(cell, ((height + 1) // 2, (width + 1) // 2))[:height, :width]


def mosaic(rgb: np.ndarray, pattern: str) -> np.ndarray:
    """(H, W, 3) RGB -> (H, W) mosaic: at each pixel the channel the pattern passes."""
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] < 3:
        raise ContractError(f"a mosaic is made of an (H, W, 3) RGB image, got shape {rgb.shape}")
    ch = cfa_channels(pattern, *rgb.shape[:2])
    return np.take_along_axis(rgb, ch[..., None], axis=2)[..., 0]
