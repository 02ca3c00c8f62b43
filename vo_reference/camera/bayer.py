"""Bayer mosaics: demosaic with OpenCV, and the inverse (mosaic an RGB image).

A pattern is named by its top-left 2x2 cell read row by row, as RobotCar and most camera
datasheets do: ``gbrg`` = row 0 ``G B``, row 1 ``R G``. OpenCV names its conversion codes
by the *second* row, second and third columns (cv::cvtColor docs), so ``gbrg`` is
``COLOR_BayerGR2RGB``, ``rggb`` is ``COLOR_BayerBG2RGB``. That mapping lives here only.
"""
from __future__ import annotations

import numpy as np

from blender_sesgen.contract import cfa
from blender_sesgen.contract.cfa import PATTERNS  # noqa: F401 - re-exported for callers

from ..errors import VoError, as_vo_error

def check_pattern(pattern: str) -> str:
    """The pattern (``contract.cfa``) in lower case; VoError for anything else."""
    with as_vo_error():
        return cfa.check_pattern(pattern)


def opencv_code(pattern: str, method: str = "bilinear") -> int:
    """The cv2.COLOR_Bayer??2RGB[_EA|_VNG] code of a pattern named by its first two rows."""
    import cv2
    p = check_pattern(pattern)
    name = (p[3] + p[2]).upper()           # second row, second and third columns
    suffix = {"bilinear": "", "ea": "_EA", "vng": "_VNG"}.get(method)
    if suffix is None:
        raise VoError(f"unknown demosaic method {method!r} (bilinear, ea or vng)")
    return getattr(cv2, f"COLOR_Bayer{name}2RGB{suffix}")


def demosaic(raw: np.ndarray, pattern: str = "gbrg", method: str = "bilinear") -> np.ndarray:
    """uint8 (H, W) Bayer mosaic -> uint8 (H, W, 3) RGB."""
    import cv2
    raw = np.asarray(raw)
    if raw.ndim == 3 and raw.shape[2] in (3, 4):   # PNG loaded as colour: all channels equal
        raw = raw[..., 0]
    if raw.ndim != 2:
        raise VoError(f"a Bayer mosaic is a single-channel image, got shape {raw.shape}")
    if raw.dtype != np.uint8:
        raise VoError(f"demosaic expects an 8-bit mosaic, got {raw.dtype}")
    return cv2.cvtColor(np.ascontiguousarray(raw), opencv_code(pattern, method))


def mosaic(rgb: np.ndarray, pattern: str = "gbrg") -> np.ndarray:
    """(H, W, 3) RGB -> (H, W) mosaic keeping, at each pixel, the channel the pattern samples."""
    with as_vo_error():
        return cfa.mosaic(rgb, pattern)
