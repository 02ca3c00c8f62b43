"""The comparison solver: OpenCV's findEssentialMat (RANSAC) + recoverPose.

recoverPose returns the *point* transform (x2 = R x1 + t); the camera motion is its
inverse, ``T_c1_c2 = [Rᵀ | −Rᵀ t]`` — converted here, in one place.
"""
from __future__ import annotations

import numpy as np

from ..errors import VoError
from .relative_pose import RelativePose


METHODS = ("usac", "ransac")


def opencv_relative_pose(x1: np.ndarray, x2: np.ndarray, K: np.ndarray, threshold_px: float = 1.0,
                         confidence: float = 0.999, seed: int | None = 0, method: str = "usac") -> RelativePose:
    """``method``: ``usac`` = cv2.USAC_ACCURATE (5-point, local optimisation and a final
    least-squares refit: the accurate OpenCV), ``ransac`` = classic cv2.RANSAC (the best
    minimal 5-point model, not refit)."""
    import cv2
    if method not in METHODS:
        raise VoError(f"unknown OpenCV method {method!r} ({', '.join(METHODS)})")
    if len(x1) < 5:
        raise VoError(f"OpenCV needs at least 5 matches, got {len(x1)}")
    if seed is not None:
        cv2.setRNGSeed(int(seed))
    p1 = np.ascontiguousarray(x1, dtype=np.float64)
    p2 = np.ascontiguousarray(x2, dtype=np.float64)
    flag = cv2.USAC_ACCURATE if method == "usac" else cv2.RANSAC
    E, mask = cv2.findEssentialMat(p1, p2, K, method=flag, prob=confidence, threshold=threshold_px)
    if E is None or E.shape[0] < 3:
        raise VoError("OpenCV findEssentialMat found no essential matrix")
    E = E[:3]                                   # several solutions come stacked: take the first
    n, R, t, mask2 = cv2.recoverPose(E, p1, p2, K, mask=mask.copy())
    inl = mask2.ravel() > 0
    t = t.ravel() / np.linalg.norm(t)
    return RelativePose(R, t, inl, np.zeros((0, 3)), 0)
