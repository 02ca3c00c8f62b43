"""Disparity error metrics: end-point error, bad-N and KITTI D1.

Per pixel e = |d_est − d_gt| (pixels). Evaluated pixels: the ground truth is valid
(finite and > 0: 0 means "unknown" in KITTI and Middlebury files); ``mask`` (optional,
True = evaluate, e.g. non-occluded) restricts them further.
- ``epe_px``: mean of e over the evaluated pixels where the estimate is valid (finite);
- ``bad_<t>_pct``: percentage of evaluated pixels with e > t (t = 0.5, 1, 2, 3 px);
- ``d1_pct``: KITTI 2015 D1: percentage with e > 3 px **and** e > 5 % of d_gt.
A missing estimate (non-finite) counts as wrong in bad-N and D1 and is left out of EPE;
``density_pct`` says how many evaluated pixels had an estimate. Results on ``all`` valid
pixels and, when a non-occlusion mask is given, on ``noc``.
"""
from __future__ import annotations

import numpy as np

from ..errors import VoError

BAD_THRESHOLDS_PX = (0.5, 1.0, 2.0, 3.0)


def _threshold_key(t: float) -> str:
    return f"bad_{t:g}_pct"


def disparity_errors(gt_px: np.ndarray, est_px: np.ndarray, mask: np.ndarray | None = None,
                     thresholds=BAD_THRESHOLDS_PX) -> dict:
    """Metrics on the pixels where gt is valid (and ``mask`` is True); see the module doc."""
    gt = np.asarray(gt_px, dtype=float)
    est = np.asarray(est_px, dtype=float)
    if gt.shape != est.shape or gt.ndim != 2:
        raise VoError(f"disparity maps must be 2-D and the same shape, got {gt.shape} and {est.shape}")
    valid = np.isfinite(gt) & (gt > 0)
    if mask is not None:
        m = np.asarray(mask)
        if m.shape != gt.shape:
            raise VoError(f"mask shape {m.shape} differs from the disparity shape {gt.shape}")
        valid &= m.astype(bool)
    n = int(valid.sum())
    if n == 0:
        raise VoError("no valid ground-truth pixels to evaluate")
    g, e = gt[valid], est[valid]
    has = np.isfinite(e)
    err = np.where(has, np.abs(e - g), np.inf)
    out = {"n_pixels": n,
           "density_pct": float(100.0 * has.mean()),
           "epe_px": float(err[has].mean()) if has.any() else float("nan")}
    for t in thresholds:
        out[_threshold_key(t)] = float(100.0 * np.mean(err > t))
    out["d1_pct"] = float(100.0 * np.mean((err > 3.0) & (err > 0.05 * g)))
    return out


def disparity_metrics(gt_px: np.ndarray, est_px: np.ndarray, noc_mask: np.ndarray | None = None,
                      thresholds=BAD_THRESHOLDS_PX) -> dict:
    """``{"all": {...}, "noc": {...}}`` (``noc`` only with a non-occlusion mask, True = visible)."""
    out = {"all": disparity_errors(gt_px, est_px, None, thresholds)}
    if noc_mask is not None:
        out["noc"] = disparity_errors(gt_px, est_px, noc_mask, thresholds)
    return out


def disparity_error_map(gt_px: np.ndarray, est_px: np.ndarray) -> np.ndarray:
    """|d_est − d_gt| per pixel, NaN where the ground truth is invalid (float64)."""
    gt = np.asarray(gt_px, dtype=float)
    est = np.asarray(est_px, dtype=float)
    valid = np.isfinite(gt) & (gt > 0)
    with np.errstate(invalid="ignore"):
        return np.where(valid, np.abs(est - gt), np.nan)
