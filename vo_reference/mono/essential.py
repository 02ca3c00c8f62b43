"""Essential matrix and relative pose: E = KᵀFK, the four (R, C) candidates, cheirality.

Conventions: ``R, t`` is the *point transform* from camera 1 to camera 2,
``x_cam2 = R x_cam1 + t``, so that ``E = [t]ₓ R`` and ``x̂2ᵀ E x̂1 = 0`` for normalised
image points. The camera *motion* (pose of camera 2 in camera 1's frame) is its inverse:
``T_c1_c2 = [Rᵀ | C]`` with the camera centre ``C = −Rᵀ t``. (The seed report writes
``C = U(:, 3)``; that is the translation ``t`` of the point transform, which equals ``−C``
only when R = I; we keep t and C apart.)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blender_sesgen.contract.se3 import se3

from .triangulation import projection_matrix, triangulate_linear

W = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def essential_from_fundamental(F: np.ndarray, K1: np.ndarray, K2: np.ndarray | None = None) -> np.ndarray:
    """E = K2ᵀ F K1 projected onto the essential manifold: singular values (1, 1, 0)."""
    K2 = K1 if K2 is None else K2
    E = K2.T @ F @ K1
    U, _, Vt = np.linalg.svd(E)
    return U @ np.diag([1.0, 1.0, 0.0]) @ Vt


def pose_candidates(E: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The four point transforms (R, t), ‖t‖ = 1, consistent with E (H&Z Result 9.19).

    R ∈ {U W Vᵀ, U Wᵀ Vᵀ}, t = ±U[:, 2]; a candidate R with det −1 (E defined up to sign)
    is replaced by −R (and t by −t, which the ± already covers).
    """
    U, _, Vt = np.linalg.svd(E)
    out = []
    for Wm in (W, W.T):
        R = U @ Wm @ Vt
        sign = 1.0
        if np.linalg.det(R) < 0:
            R, sign = -R, -1.0
        for s in (1.0, -1.0):
            out.append((R, sign * s * U[:, 2]))
    return out


def camera_motion(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """T_c1_c2 (4, 4) of the point transform x2 = R x1 + t: rotation Rᵀ, centre −Rᵀ t."""
    return se3(R.T, -R.T @ t)


@dataclass(frozen=True)
class PoseChoice:
    R: np.ndarray          # point transform camera 1 -> camera 2
    t: np.ndarray          # unit translation of the point transform
    X: np.ndarray          # (N, 3) linear triangulation in camera 1's frame (unit baseline)
    in_front: np.ndarray   # (N,) bool: positive depth in both cameras
    counts: tuple[int, ...]  # points in front for each of the four candidates

    @property
    def T_c1_c2(self) -> np.ndarray:
        return camera_motion(self.R, self.t)


def choose_pose(E: np.ndarray, K: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> PoseChoice:
    """Cheirality: the candidate that puts the most linearly triangulated points in front
    of both cameras (depth z > 0 in camera 1 and in camera 2)."""
    P1 = projection_matrix(K, np.eye(3), np.zeros(3))
    best, counts = None, []
    for R, t in pose_candidates(E):
        X = triangulate_linear(P1, projection_matrix(K, R, t), x1, x2)
        z1 = X[:, 2]
        z2 = X @ R[2] + t[2]
        front = np.isfinite(z1) & (z1 > 0) & (z2 > 0)
        counts.append(int(front.sum()))
        if best is None or counts[-1] > best[3]:
            best = (R, t, X, counts[-1], front)
    R, t, X, _, front = best
    return PoseChoice(R, t, X, front, tuple(counts))
