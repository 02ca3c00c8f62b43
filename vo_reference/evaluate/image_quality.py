"""Image quality against a reference: PSNR and SSIM (numpy only).

Both compare display-encoded images in [0, 1] (sRGB of the scene-linear EXR beauty pass,
``contract.colour.linear_to_srgb``), channel by channel, averaged over channels.

- PSNR = 10 log10(1 / MSE), MSE over every pixel and channel (data range 1).
- SSIM: Wang, Bovik, Sheikh & Simoncelli, "Image quality assessment: from error visibility
  to structural similarity", IEEE TIP 13(4), 2004: an 11x11 Gaussian window of sigma 1.5
  (truncated at 3.5 sigma, as scikit-image does), K1 = 0.01, K2 = 0.03, population
  (not sample) covariances, the mean over the pixels whose window lies inside the image.
  Checked against scikit-image's ``structural_similarity`` with the same parameters.
"""
from __future__ import annotations

import numpy as np

SSIM_SIGMA = 1.5
SSIM_TRUNCATE = 3.5
K1, K2 = 0.01, 0.03


def _as_float(a) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    return a[..., None] if a.ndim == 2 else a


def psnr(image: np.ndarray, reference: np.ndarray, data_range: float = 1.0) -> float:
    """PSNR in dB of ``image`` against ``reference`` (same shape; (H, W) or (H, W, C))."""
    a, b = _as_float(image), _as_float(reference)
    if a.shape != b.shape:
        raise ValueError(f"psnr: shapes differ {a.shape} vs {b.shape}")
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0.0 else float(10.0 * np.log10(data_range ** 2 / mse))


def _gaussian_kernel(sigma: float = SSIM_SIGMA, truncate: float = SSIM_TRUNCATE) -> np.ndarray:
    r = int(truncate * sigma + 0.5)
    x = np.arange(-r, r + 1, dtype=np.float64)
    k = np.exp(-0.5 * (x / sigma) ** 2)
    return k / k.sum()


def _filter_valid(img: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Separable correlation with ``k`` along both axes, only where the window fits."""
    n = len(k)
    rows = sum(k[i] * img[i:img.shape[0] - n + 1 + i] for i in range(n))
    return sum(k[i] * rows[:, i:img.shape[1] - n + 1 + i] for i in range(n))


def ssim(image: np.ndarray, reference: np.ndarray, data_range: float = 1.0) -> float:
    """Mean SSIM of ``image`` against ``reference`` (see the module docstring)."""
    a, b = _as_float(image), _as_float(reference)
    if a.shape != b.shape:
        raise ValueError(f"ssim: shapes differ {a.shape} vs {b.shape}")
    k = _gaussian_kernel()
    if min(a.shape[:2]) < len(k):
        raise ValueError(f"ssim: image smaller than the {len(k)}x{len(k)} window")
    c1, c2 = (K1 * data_range) ** 2, (K2 * data_range) ** 2
    out = []
    for c in range(a.shape[2]):
        x, y = a[..., c], b[..., c]
        mx, my = _filter_valid(x, k), _filter_valid(y, k)
        sxx = _filter_valid(x * x, k) - mx * mx
        syy = _filter_valid(y * y, k) - my * my
        sxy = _filter_valid(x * y, k) - mx * my
        s = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
        out.append(float(s.mean()))
    return float(np.mean(out))
