"""PSNR and SSIM (vo_reference.evaluate.image_quality) against closed forms and scikit-image."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.evaluate.image_quality import psnr, ssim


def test_psnr_closed_form():
    ref = np.zeros((20, 30, 3))
    img = ref + 0.1                       # MSE 0.01 -> 20 dB
    assert psnr(img, ref) == pytest.approx(20.0)
    assert psnr(ref, ref) == float("inf")
    with pytest.raises(ValueError):
        psnr(img[:10], ref)


def test_ssim_identical_and_constant_offset():
    rng = np.random.default_rng(0)
    ref = rng.random((40, 50, 3))
    assert ssim(ref, ref) == pytest.approx(1.0)
    # flat images: sigma = 0, SSIM = (2 mu_x mu_y + c1) / (mu_x^2 + mu_y^2 + c1)
    a, b = np.full((30, 30), 0.2), np.full((30, 30), 0.6)
    c1 = 0.01 ** 2
    assert ssim(a, b) == pytest.approx((2 * 0.2 * 0.6 + c1) / (0.04 + 0.36 + c1))


def test_ssim_matches_scikit_image():
    metrics = pytest.importorskip("skimage.metrics", reason="scikit-image (the [test] extra) is the oracle")
    rng = np.random.default_rng(1)
    ref = rng.random((64, 80, 3))
    ref = (ref + np.roll(ref, 1, 0) + np.roll(ref, 1, 1)) / 3      # some structure
    for noise in (0.01, 0.05, 0.2):
        img = np.clip(ref + rng.normal(0, noise, ref.shape), 0, 1)
        expected = metrics.structural_similarity(img, ref, channel_axis=2, data_range=1.0, gaussian_weights=True,
                                                 sigma=1.5, use_sample_covariance=False)
        assert ssim(img, ref) == pytest.approx(expected, abs=1e-9)
        assert psnr(img, ref) == pytest.approx(metrics.peak_signal_noise_ratio(ref, img, data_range=1.0))
