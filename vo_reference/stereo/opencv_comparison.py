"""A plain OpenCV stereo VO, as a comparison baseline (not the reference method).

Shi–Tomasi corners, pyramidal LK with a forward–backward check, SGBM depth,
``solvePnPRansac`` + ``solvePnPRefineLM``. About forty lines of OpenCV calls: what a
reasonable engineer writes in an afternoon, so our accurate variant has to beat it.
"""
from __future__ import annotations

import cv2
import numpy as np

from blender_sesgen.contract.camera import backproject
from blender_sesgen.contract.depth import depth_from_disparity
from blender_sesgen.contract.se3 import invert, se3

from ..errors import VoError
from ..evaluate.sgbm import sgbm_disparity
from .motion_field import T_to_twist
from .paper import StepResult


def baseline_step(left0, right0, left1, K: np.ndarray, baseline_m: float, num_disp: int = 128,
                  gt=None, mask_dynamic: bool = False) -> StepResult:
    """``mask_dynamic``: drop corners on objects that move (``gt``: a GroundTruthStep)."""
    pts = cv2.goodFeaturesToTrack(left0, 1000, 0.01, 8)
    if pts is None:
        raise VoError("no corners")
    if mask_dynamic:
        if gt is None:
            raise VoError("--mask-dynamic-gt needs ground truth (a render folder with ids and poses)")
        pts = pts[gt.static(pts.reshape(-1, 2))]
    lk = dict(winSize=(21, 21), maxLevel=3, criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 0.01))
    p1, s1, _ = cv2.calcOpticalFlowPyrLK(left0, left1, pts, None, **lk)
    p0b, s2, _ = cv2.calcOpticalFlowPyrLK(left1, left0, p1, None, **lk)
    ok = (s1.ravel() == 1) & (s2.ravel() == 1) & (np.linalg.norm((p0b - pts).reshape(-1, 2), axis=1) < 0.5)
    disp = sgbm_disparity(left0, right0, num_disp)
    p0 = pts.reshape(-1, 2)
    xi, yi = np.rint(p0[:, 0]).astype(int), np.rint(p0[:, 1]).astype(int)
    d = disp[yi, xi]
    ok &= d > 1.0
    p0, p1, d = p0[ok], p1.reshape(-1, 2)[ok], d[ok]
    Z = depth_from_disparity(d, K[0, 0], baseline_m)
    P = backproject(K, p0, Z)
    if len(P) < 6:
        raise VoError("too few tracked points")
    okr, rvec, tvec, inl = cv2.solvePnPRansac(P, p1, K, None, iterationsCount=200, reprojectionError=1.0,
                                              confidence=0.999)
    if not okr or inl is None:
        raise VoError("solvePnPRansac failed")
    inl = inl.ravel()
    rvec, tvec = cv2.solvePnPRefineLM(P[inl], p1[inl], K, None, rvec, tvec)
    T_k1_k = se3(cv2.Rodrigues(rvec)[0], tvec.ravel())
    T = invert(T_k1_k)
    return StepResult(T_to_twist(T), T, int(len(inl)), p0[inl], p1[inl], Z[inl])
