"""Image statistics that say how much a sequence looks like a real camera's, for VO.

All take 8-bit grey images (uint8, (H, W)), as a VO front end sees them:
- :func:`spectrum_slope`: slope of the radially averaged power spectrum in log-log
  (natural images ~ -2; more negative = less fine detail);
- :func:`gradient_stats`: median and 90th percentile of the Sobel gradient magnitude;
- :func:`corner_count`: Shi–Tomasi corners (quality 0.01, min distance 7, cap 2000);
- :func:`klt_fb_error`: median forward–backward error of pyramidal LK tracks between
  two frames (px);
- :func:`sgbm_valid_fraction`: share of pixels with a valid SGBM disparity (the OpenCV
  baseline VO's matcher) on a rectified pair;
- :func:`clipped_fraction`: share of pixels at 0 or 255.
:func:`sequence_stats` averages them over frames. numpy + OpenCV only.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from .sgbm import sgbm_disparity

CORNER_QUALITY, CORNER_MIN_DISTANCE, CORNER_CAP = 0.01, 7, 2000
LK_PARAMS = dict(winSize=(21, 21), maxLevel=3,
                 criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 0.01))


def _gray(img) -> np.ndarray:
    a = np.asarray(img)
    if a.ndim != 2 or a.dtype != np.uint8:
        raise ValueError(f"expected an 8-bit grey image (H, W) uint8, got {a.dtype} {a.shape}")
    return a


def spectrum_slope(img) -> float:
    """Slope of the radially averaged power spectrum in log-log: the mean is removed, a 2-D
    Hann window applied (the image border adds no spurious high frequencies), the power
    averaged over rings one frequency step wide (radius rho = |f| * min(H, W), f in cycles
    per pixel; ring k holds k <= rho < k + 1), and log(mean power) fitted against log k by
    least squares over k = 1 .. min(H, W)/2 - 1, every ring weighted alike. (This is the
    definition behind issue 17's figures: -2.52 on the real KITTI excerpt's first frame.)"""
    mean = ring_power(img)
    k = np.arange(1, len(mean))
    slope, _ = np.polyfit(np.log(k), np.log(mean[k]), 1)
    return float(slope)


def ring_power(img) -> np.ndarray:
    """The radially averaged power spectrum ``spectrum_slope`` fits: the mean power of rings
    k = 0 .. min(H, W)/2 - 1 (mean removed, 2-D Hann window, ring k holds k <= rho < k + 1,
    rho = |f| * min(H, W) in cycles per image height for a landscape frame)."""
    a = _gray(img).astype(np.float64)
    H, W = a.shape
    a = (a - a.mean()) * np.outer(np.hanning(H), np.hanning(W))
    P = np.abs(np.fft.fft2(a)) ** 2
    m = min(H, W)
    rho = np.sqrt((np.fft.fftfreq(W)[None, :] * m) ** 2 + (np.fft.fftfreq(H)[:, None] * m) ** 2)
    ring = rho.astype(np.int64).ravel()
    return (np.bincount(ring, P.ravel()) / np.maximum(np.bincount(ring), 1))[:m // 2]


def gradient_magnitude(img) -> np.ndarray:
    a = _gray(img).astype(np.float32)
    gx = cv2.Sobel(a, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(a, cv2.CV_32F, 0, 1, ksize=3)
    return np.sqrt(gx * gx + gy * gy)


def gradient_stats(img) -> tuple[float, float]:
    """(median, 90th percentile) of the 3x3 Sobel gradient magnitude (grey levels per px)."""
    g = gradient_magnitude(img)
    return float(np.median(g)), float(np.percentile(g, 90))


def corner_count(img) -> int:
    pts = cv2.goodFeaturesToTrack(_gray(img), CORNER_CAP, CORNER_QUALITY, CORNER_MIN_DISTANCE)
    return 0 if pts is None else int(len(pts))


def klt_fb_error(img0, img1) -> float:
    """Median forward-backward error (px) of LK tracks of img0's Shi-Tomasi corners into
    img1 and back (only points tracked both ways); nan if nothing is tracked."""
    a, b = _gray(img0), _gray(img1)
    pts = cv2.goodFeaturesToTrack(a, CORNER_CAP, CORNER_QUALITY, CORNER_MIN_DISTANCE)
    if pts is None:
        return float("nan")
    p1, s1, _ = cv2.calcOpticalFlowPyrLK(a, b, pts, None, **LK_PARAMS)
    p0, s2, _ = cv2.calcOpticalFlowPyrLK(b, a, p1, None, **LK_PARAMS)
    ok = (s1.ravel() == 1) & (s2.ravel() == 1)
    if not ok.any():
        return float("nan")
    return float(np.median(np.linalg.norm((p0 - pts).reshape(-1, 2)[ok], axis=1)))


def sgbm_valid_fraction(left, right, num_disp: int = 128) -> float:
    """Share of pixels with a valid (> 0) SGBM disparity: the matcher of the OpenCV baseline VO."""
    d = sgbm_disparity(_gray(left), _gray(right), num_disp)
    return float(np.mean(d > 0))


def clipped_fraction(img) -> float:
    a = _gray(img)
    return float(np.mean((a == 0) | (a == 255)))


@dataclass
class ImageStats:
    """Means over the frames used (``frames``), and per-statistic the values per frame."""
    slope: float
    grad_median: float
    grad_p90: float
    corners: float
    klt_fb_median: float
    sgbm_valid: float
    clipped: float
    frames: int
    per_frame: dict = field(default_factory=dict)


def sequence_stats(gray_left, gray_right=None) -> ImageStats:
    """Statistics of a sequence given as lists of grey images (left, optionally right):
    single-image figures on every left frame, KLT between consecutive left frames, SGBM on
    each rectified pair."""
    L = [_gray(x) for x in gray_left]
    per = {"slope": [spectrum_slope(x) for x in L],
           "grad": [gradient_stats(x) for x in L],
           "corners": [corner_count(x) for x in L],
           "klt": [klt_fb_error(a, b) for a, b in zip(L[:-1], L[1:])],
           "clipped": [clipped_fraction(x) for x in L]}
    if gray_right is not None:
        per["sgbm"] = [sgbm_valid_fraction(a, _gray(b)) for a, b in zip(L, gray_right)]
    g = np.array(per["grad"])
    return ImageStats(slope=float(np.mean(per["slope"])), grad_median=float(np.mean(g[:, 0])),
                      grad_p90=float(np.mean(g[:, 1])), corners=float(np.mean(per["corners"])),
                      klt_fb_median=float(np.nanmedian(per["klt"])) if per["klt"] else float("nan"),
                      sgbm_valid=float(np.mean(per["sgbm"])) if "sgbm" in per else float("nan"),
                      clipped=float(np.mean(per["clipped"])), frames=len(L), per_frame=per)
