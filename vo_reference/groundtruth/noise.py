"""Additive Gaussian noise on 8-bit images, reproducible from a seed.

noisy = clip(round(clean + N(0, sigma²)), 0, 255), sigma in 8-bit grey levels, noise drawn
in float before rounding (rounding adds about 1/12 grey level² of variance). The random
stream is numpy's PCG64 seeded with the integers (seed, *stream): the same seed and
stream give identical bytes on every machine; exports use stream = (frame, view, kind) so
that frame k gets the same noise whichever frame range is exported.
"""
from __future__ import annotations

import numpy as np

from ..errors import VoError


def add_gaussian_noise(image_u8: np.ndarray, sigma: float, seed: int, stream: tuple[int, ...] = ()) -> np.ndarray:
    img = np.asarray(image_u8)
    if img.dtype != np.uint8:
        raise VoError(f"noise is defined on 8-bit images, got {img.dtype}")
    sigma = float(sigma)
    if not np.isfinite(sigma) or sigma < 0:
        raise VoError(f"noise sigma must be >= 0, got {sigma}")
    if sigma == 0:
        return img.copy()
    if int(seed) < 0 or any(int(s) < 0 for s in stream):
        raise VoError("noise seed must be >= 0")
    rng = np.random.default_rng([int(seed), *(int(s) for s in stream)])
    n = rng.standard_normal(img.shape, dtype=np.float64) * sigma
    return np.clip(np.rint(img.astype(np.float64) + n), 0, 255).astype(np.uint8)
