"""The SESGen paper's reference stereo VO (Skulimowski & Strumillo 2015, Section 3), faithfully.

Per stereo frame pair k -> k+1:

1. **Keypoints** (Sec. 3.1): Shi–Tomasi corners of the left image at k (OpenCV
   ``goodFeaturesToTrack``), so they sit on corners/texture where block matching works.
2. **Disparity with pixel accuracy** (Sec. 5): SAD block matching of each keypoint's M x M
   block along the same row of the right image; Z = B f / d (Eq. 1).
   *Gross errors are dropped*: d = 0 (infinite depth), d on the search limit, and matches
   failing the left-right consistency check; d < ``d_min`` too.
   *Small depths are preferred* (the disparity-depth relation is hyperbolic, so the depth of
   near points is the most precise): of the surviving keypoints the ``n_keep`` with the
   largest disparity are used — *enough of them* to average out the pixel quantisation.
3. **Tracking** (Sec. 3.1): full-search SAD block matching of the M x M block of frame k in
   a +-R window of frame k+1 (pixel accuracy): x' = x + u, y' = y + v (Eq. 3).
4. **Egomotion**: the coefficients a_i, b_i of Eq. 5 and the normal equations H X = K of
   Eq. 6, solved for X = [U, V, W, alpha, beta, gamma].
5. The frame's X is taken as the constant body twist of the step: T_k_k1 = exp([omega, v]),
   T(k+1) = T(k) T_k_k1 (the SES EGO convention).

**Which frame's depth.** Z_i is the depth at frame k, where the keypoint (x_i, y_i) was
detected: Eq. 2 is the instantaneous motion field *at* (x, y) with that point's depth, and
Eq. 3 integrates it over the frame with a single forward step, so the coefficients a_i, b_i
must be evaluated at frame k's position and depth. (Using k+1's depth with k's position
would mix two instants; the first-order model is exact only as the motion -> 0 either way.)

The paper uses the right camera as reference; here the left one is (the rig pose of the
render contract), which changes nothing in the equations.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from blender_sesgen.contract.depth import depth_from_disparity, disparity_from_depth

from ..errors import VoError
from .blockmatch import sad_disparity, sad_track
from .keypoints import shi_tomasi
from .motion_field import solve_egomotion, twist_to_T


@dataclass
class PaperParams:
    block: int = 9              # M: block size (odd) for both matchers
    search: int = 16            # R: tracking search range, +-R px in x and y
    d_max: int = 64             # disparity search range 0..d_max px
    d_min: int = 1              # smallest accepted disparity (d = 0 is infinite depth)
    lr_tolerance: int = 1       # left-right consistency tolerance (px)
    max_corners: int = 1000     # Shi–Tomasi candidates
    quality: float = 0.01
    min_distance: float = 7.0
    n_keep: int = 300           # keypoints kept, largest disparity (smallest depth) first


@dataclass
class StepResult:
    """One frame step's estimate and what it was computed from."""

    twist: np.ndarray                   # [U, V, W, alpha, beta, gamma], angles in rad
    T_k_k1: np.ndarray                  # (4, 4)
    n_points: int
    pts0: np.ndarray = field(repr=False, default_factory=lambda: np.zeros((0, 2)))  # keypoints at k
    pts1: np.ndarray = field(repr=False, default_factory=lambda: np.zeros((0, 2)))  # matches at k+1
    depth: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    failure: str = ""                   # why the step failed (the pipeline then keeps the previous motion)


def paper_step(left0: np.ndarray, right0: np.ndarray, left1: np.ndarray, K: np.ndarray, baseline_m: float,
               params: PaperParams | None = None, gt=None, gt_depth: bool = False,
               gt_flow: bool = False, mask_dynamic: bool = False) -> StepResult:
    """The paper's egomotion estimate from the stereo pair at k and the left image at k+1.

    ``gt`` (a :class:`~vo_reference.stereo.groundtruth.GroundTruthStep`) is needed for
    ``gt_depth`` (Z from the render's depth at the keypoint instead of SAD disparity),
    ``gt_flow`` (the keypoint's exact position at k+1 instead of SAD tracking) and
    ``mask_dynamic`` (keypoints on objects that move from k to k+1 are dropped).
    """
    p = params or PaperParams()
    if (gt_depth or gt_flow or mask_dynamic) and gt is None:
        raise VoError("--gt-depth/--gt-flow/--mask-dynamic-gt need ground truth (a render folder with depth and poses)")
    f = float(K[0, 0])
    cx, cy = float(K[0, 2]), float(K[1, 2])
    margin = p.block // 2 + 1
    pts = shi_tomasi(left0, p.max_corners, p.quality, p.min_distance, margin)
    if mask_dynamic:
        pts = pts[gt.static(pts)]
    if gt_depth:
        Z = gt.depth(pts)
        ok = np.isfinite(Z)
        disp = np.nan_to_num(disparity_from_depth(Z, f, baseline_m, np.float64), nan=0.0)
        ok &= disp >= p.d_min
    else:
        d, ok = sad_disparity(left0, right0, pts, p.block, p.d_max, p.lr_tolerance)
        ok &= d >= max(p.d_min, 1)
        disp = d.astype(float)
        Z = np.where(ok, depth_from_disparity(disp, f, baseline_m), np.nan)
    idx = np.flatnonzero(ok)
    idx = idx[np.argsort(-disp[idx], kind="stable")][:p.n_keep]   # prefer small depth
    pts, Z = pts[idx], Z[idx]
    if gt_flow:
        pts1, _ = gt.correspondences(pts)
        good = np.all(np.isfinite(pts1), axis=1)
        pts, Z, pts1 = pts[good], Z[good], pts1[good]
    else:
        pts1, _ = sad_track(left0, left1, pts, p.block, p.search)
        pts1 = pts1.astype(float)
    if pts.shape[0] < 3:
        raise VoError(f"only {pts.shape[0]} usable keypoints (need >= 3)")
    X = solve_egomotion(pts[:, 0] - cx, pts[:, 1] - cy, Z, pts1[:, 0] - cx, pts1[:, 1] - cy, f)
    return StepResult(X, twist_to_T(X), int(pts.shape[0]), pts, pts1, Z)
