"""Depth and disparity: the ground-truth values and what "nothing there" is.

- Depth is **planar** z along the optical axis (what Cycles' Depth pass holds), float32.
  Cycles writes ``DEPTH_BACKGROUND`` (1e10) where a ray hits nothing; every reader turns it
  (and any non-finite or non-positive value) into +inf: :func:`depth_from_pass`.
- Disparity of a rectified parallel rig, baseline B, focal fx (px): d = fx * B / Z >= 0;
  left view: x_right = x_left - d; right view: x_left = x_right + d. Where there is no
  surface (Z = +inf) the disparity is invalid: **NaN** (``np.isfinite(d)`` is the mask).
"""
from __future__ import annotations

import numpy as np

DEPTH_BACKGROUND = 1e10
# a pass value at or above this is background (half the marker: robust to float32 rounding)
BACKGROUND_THRESHOLD = 0.5 * DEPTH_BACKGROUND


def depth_from_pass(z: np.ndarray, background: float = DEPTH_BACKGROUND) -> np.ndarray:
    """float32 planar depth from a Depth pass: +inf for background, non-finite or z <= 0."""
    z = np.array(z, dtype=np.float32)
    z[~np.isfinite(z) | (z >= 0.5 * background) | (z <= 0.0)] = np.inf
    return z


def depth_to_pass(depth: np.ndarray, background: float = DEPTH_BACKGROUND) -> np.ndarray:
    """float32 Depth-pass values of depths: +inf (nothing hit) -> the background marker."""
    z = np.array(depth, dtype=np.float32)
    z[~np.isfinite(z)] = background
    return z


def disparity_of_depth(depth: np.ndarray, focal_px: float, baseline_m: float) -> np.ndarray:
    """fx * B / Z of every value, float64, unmasked: 0 where Z = +inf, negative behind the
    camera (disparity changes and warped points need those; images use
    :func:`disparity_from_depth`)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return (float(focal_px) * float(baseline_m)) / np.asarray(depth, dtype=np.float64)


def disparity_from_depth(depth: np.ndarray, focal_px: float, baseline_m: float, dtype=np.float32) -> np.ndarray:
    """d = fx * B / Z (float32 for image products, ``dtype=np.float64`` for maths); NaN where Z
    is not finite and positive."""
    z = np.asarray(depth, dtype=np.float64)
    valid = np.isfinite(z) & (z > 0)
    d = np.full(z.shape, np.nan, dtype=dtype)
    d[valid] = disparity_of_depth(z[valid], focal_px, baseline_m)
    return d


def depth_from_disparity(disparity_px: np.ndarray, focal_px: float, baseline_m: float) -> np.ndarray:
    """Planar depth Z = fx * B / d (float64); +inf where d is not finite and positive."""
    d = np.asarray(disparity_px, dtype=np.float64)
    valid = np.isfinite(d) & (d > 0)
    z = np.full(d.shape, np.inf)
    z[valid] = (float(focal_px) * float(baseline_m)) / d[valid]
    return z
