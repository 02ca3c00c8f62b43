"""Optics applied to the linear image before the sensor (RGB only; ground truth untouched):
the lens and pixel MTF from physical parameters, vignetting and lateral chromatic aberration.

MTF (a product of optical transfer functions, frequencies nu in cycles per pixel):
- diffraction of a circular aperture (incoherent light), cut-off nu_c = p / (lambda N)
  (pixel pitch p, wavelength lambda per channel, f-number N):
  2/pi (acos x - x sqrt(1 - x^2)), x = nu / nu_c;
- defocus, a uniform blur disc of diameter d px: 2 J1(pi d nu) / (pi d nu);
- pixel aperture of width f px (fill factor): sinc(f nu_x) sinc(f nu_y) — on top of Cycles'
  own pixel filter, which the render already carries;
- optical low-pass filter (birefringent, four spots s px apart): |cos(pi s nu_x) cos(pi s nu_y)|.
Applied by FFT with mirrored borders, padded to the FFT's fast lengths. Vignetting: cos(theta)^(4 v) of each pixel's ray angle
(v = 1 is the natural cos^4 law). Chromatic aberration: red magnified and blue shrunk about
the principal point so that the corner moves by +-c px.
"""
from __future__ import annotations

import functools

import numpy as np

WAVELENGTH_NM = (610.0, 540.0, 465.0)   # R, G, B


def bessel_j1(x: np.ndarray) -> np.ndarray:
    """J1(x) (Abramowitz & Stegun 9.4.4 and 9.4.6, |error| < 1.3e-8)."""
    x = np.asarray(x, dtype=np.float64)
    ax = np.abs(x)
    out = np.empty_like(ax)
    small = ax <= 3.0
    t = (ax[small] / 3.0) ** 2
    out[small] = ax[small] * (0.5 + t * (-0.56249985 + t * (0.21093573 + t * (-0.03954289 + t * (
        0.00443319 + t * (-0.00031761 + t * 0.00001109))))))
    big = ~small
    y = 3.0 / ax[big]
    f1 = 0.79788456 + y * (0.00000156 + y * (0.01659667 + y * (0.00017105 + y * (
        -0.00249511 + y * (0.00113653 - y * 0.00020033)))))
    th = ax[big] - 2.35619449 + y * (0.12499612 + y * (0.00005650 + y * (-0.00637879 + y * (
        0.00074348 + y * (0.00079824 - y * 0.00029166)))))
    out[big] = f1 * np.cos(th) / np.sqrt(ax[big])
    return np.sign(x) * out


def otf(shape, *, pixel_um: float = 3.0, f_number: float = 0.0, wavelength_nm: float = 550.0,
        defocus_px: float = 0.0, fill_factor: float = 0.0, olpf_px: float = 0.0) -> np.ndarray:
    """The OTF on the ``np.fft.rfft2`` grid of an image of ``shape`` (H, W)."""
    H, W = shape
    fy = np.fft.fftfreq(H)[:, None]
    fx = np.fft.rfftfreq(W)[None, :]
    nu = np.hypot(fx, fy)
    out = np.ones((H, W // 2 + 1))
    if f_number > 0:
        nu_c = float(pixel_um) / (float(wavelength_nm) * 1e-3 * float(f_number))
        x = np.clip(nu / nu_c, 0.0, 1.0)
        out = out * (2 / np.pi) * (np.arccos(x) - x * np.sqrt(1 - x * x))
    if defocus_px > 0:
        a = np.pi * float(defocus_px) * nu
        with np.errstate(invalid="ignore", divide="ignore"):
            out = out * np.where(a > 1e-12, 2 * bessel_j1(a) / np.where(a > 1e-12, a, 1.0), 1.0)
    if fill_factor > 0:
        out = out * np.sinc(fill_factor * fx) * np.sinc(fill_factor * fy)
    if olpf_px > 0:
        out = out * np.abs(np.cos(np.pi * olpf_px * fx) * np.cos(np.pi * olpf_px * fy))
    return out


@functools.lru_cache(maxsize=8)
def _stored_otf(shape: tuple, params: tuple) -> np.ndarray:
    """``otf`` kept for the next image of the same size and optics (every view and frame of a
    render: a KITTI view's three OTFs cost a fifth of its camera model); read-only."""
    T = otf(shape, **dict(params))
    T.setflags(write=False)
    return T


@functools.lru_cache(maxsize=64)
def fast_length(n: int) -> int:
    """The smallest length >= n without a prime factor above 7, where numpy's FFT is fast:
    KITTI's padded 402 x 1258 (2*3*67 x 2*17*37) transforms in 1.5-2x the time of 405 x 1260;
    a length that is one already (640 x 480 and EuRoC's 752 x 480, padded) stays."""
    m = max(int(n), 1)
    while True:
        k = m
        for f in (2, 3, 5, 7):
            while k % f == 0:
                k //= f
        if k == 1:
            return m
        m += 1


def apply_mtf(rgb: np.ndarray, margin: int = 16, **params) -> np.ndarray:
    """Filter each channel of a linear (H, W, 3) image with its channel's OTF: the image with
    mirrored borders, ``margin`` px before it and up to the FFT's fast length after it (the
    circular convolution's wrap-around lands in the mirror, at least ``margin`` px from the
    image on either side)."""
    rgb = np.asarray(rgb, dtype=np.float64)
    H, W = rgb.shape[:2]
    m = int(min(margin, H - 1, W - 1))
    Hp, Wp = fast_length(H + 2 * m), fast_length(W + 2 * m)
    out = np.empty_like(rgb)
    for c in range(rgb.shape[2]):
        p = np.pad(rgb[..., c], ((m, Hp - H - m), (m, Wp - W - m)), mode="reflect")
        lam = params.get("wavelength_nm") or WAVELENGTH_NM[c % 3]
        T = _stored_otf(p.shape, tuple(sorted({**params, "wavelength_nm": lam}.items())))
        out[..., c] = np.fft.irfft2(np.fft.rfft2(p) * T, s=p.shape)[m:m + H, m:m + W]
    return out


def vignetting(rays: np.ndarray, strength: float) -> np.ndarray:
    """(H, W) relative illumination cos(theta)^(4 strength) of unit rays (H, W, 3)."""
    cos_t = np.clip(rays[..., 2], 0.0, 1.0)
    return cos_t ** (4.0 * float(strength))


def bilinear_sample(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Sample (H, W) ``img`` at float pixel coordinates (edge values beyond the border)."""
    H, W = img.shape
    x = np.clip(x, 0, W - 1)
    y = np.clip(y, 0, H - 1)
    x0 = np.minimum(np.floor(x).astype(int), W - 2) if W > 1 else np.zeros_like(x, dtype=int)
    y0 = np.minimum(np.floor(y).astype(int), H - 2) if H > 1 else np.zeros_like(y, dtype=int)
    fx, fy = x - x0, y - y0
    x1, y1 = np.minimum(x0 + 1, W - 1), np.minimum(y0 + 1, H - 1)
    return ((1 - fy) * ((1 - fx) * img[y0, x0] + fx * img[y0, x1])
            + fy * ((1 - fx) * img[y1, x0] + fx * img[y1, x1]))


def chromatic_aberration(rgb: np.ndarray, cx: float, cy: float, shift_px: float) -> np.ndarray:
    """Lateral CA: red scaled by (1 + s), blue by (1 - s) about (cx, cy); s = shift / corner radius."""
    H, W = rgb.shape[:2]
    corner = max(np.hypot(u - cx, v - cy) for u in (0, W - 1) for v in (0, H - 1))
    s = float(shift_px) / max(corner, 1e-9)
    v, u = np.mgrid[0:H, 0:W].astype(float)
    out = rgb.astype(np.float64, copy=True)
    for c, scale in ((0, 1 + s), (2, 1 - s)):
        # output pixel u shows the scene point that the ideal image has at cx + (u - cx) / scale
        out[..., c] = bilinear_sample(rgb[..., c], cx + (u - cx) / scale, cy + (v - cy) / scale)
    return out
