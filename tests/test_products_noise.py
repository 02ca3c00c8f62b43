"""Gaussian noise on 8-bit images: reproducible, and of the stated sigma."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.errors import VoError
from vo_reference.groundtruth.noise import add_gaussian_noise


def test_same_seed_identical_bytes_different_seed_different():
    img = np.random.default_rng(0).integers(0, 256, (50, 60, 3), dtype=np.uint8)
    a = add_gaussian_noise(img, 3.0, 42, (5, 0, 0))
    b = add_gaussian_noise(img, 3.0, 42, (5, 0, 0))
    assert a.tobytes() == b.tobytes()
    assert add_gaussian_noise(img, 3.0, 43, (5, 0, 0)).tobytes() != a.tobytes()
    assert add_gaussian_noise(img, 3.0, 42, (6, 0, 0)).tobytes() != a.tobytes()  # other frame
    assert a.dtype == np.uint8 and a.shape == img.shape


@pytest.mark.parametrize("sigma", [2.0, 5.0, 12.0])
def test_std_matches_sigma_on_mid_grey(sigma):
    clean = np.full((480, 640), 128, np.uint8)
    noisy = add_gaussian_noise(clean, sigma, 7)
    diff = noisy.astype(np.float64) - clean
    assert 0 < noisy.min() and noisy.max() < 255  # no clipping
    assert abs(diff.std(ddof=1) / sigma - 1) < 0.02
    assert abs(diff.mean()) < 0.05 * sigma


def test_zero_sigma_is_identity_and_bad_input():
    img = np.arange(12, dtype=np.uint8).reshape(3, 4)
    assert np.array_equal(add_gaussian_noise(img, 0.0, 1), img)
    with pytest.raises(VoError, match="8-bit"):
        add_gaussian_noise(img.astype(np.float32), 1.0, 1)
    with pytest.raises(VoError, match="sigma"):
        add_gaussian_noise(img, -1.0, 1)
