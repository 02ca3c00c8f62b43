"""Our two-view solver: RANSAC F -> E -> cheirality -> optional non-linear refinement.

Refinements (``refine``):
- ``none``: the pose from E decomposition (E from the 8-point F refit on the inliers);
- ``pnp``: the seed report's chain — non-linear triangulation of the inliers, then
  non-linear PnP of camera 2 on those points, repeated ``rounds`` times;
- ``sampson`` (default): minimise the Sampson distances of the inliers over the five
  degrees of freedom of E = [t]ₓR (rotation vector + unit t), then non-linearly
  triangulate the points. Sampson's error is the first-order geometric error, so this is
  the two-view "gold standard" fit without carrying every point as a parameter.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from ..errors import VoError
from ..lie import skew
from .essential import camera_motion, choose_pose, essential_from_fundamental
from .fundamental import ransac_fundamental
from .pnp import nonlinear_pnp
from .triangulation import projection_matrix, triangulate_nonlinear

REFINEMENTS = ("none", "pnp", "sampson")


@dataclass(frozen=True)
class RelativePose:
    R: np.ndarray            # point transform camera 1 -> camera 2 (x2 = R x1 + t)
    t: np.ndarray            # unit vector
    inliers: np.ndarray      # (N,) bool over the input matches (RANSAC inliers, in front)
    X_c1: np.ndarray         # (M, 3) points of the inliers in camera 1's frame, ‖t‖ = 1 units
    iterations: int

    @property
    def T_c1_c2(self) -> np.ndarray:
        """Camera motion: pose of camera 2 in camera 1's frame (unit translation)."""
        return camera_motion(self.R, self.t)

    @property
    def n_inliers(self) -> int:
        return int(self.inliers.sum())


def _tangent_basis(t: np.ndarray) -> np.ndarray:
    a = np.eye(3)[int(np.argmin(np.abs(t)))]
    b1 = np.cross(t, a)
    b1 /= np.linalg.norm(b1)
    return np.column_stack([b1, np.cross(t, b1)])


def refine_sampson(R: np.ndarray, t: np.ndarray, x1: np.ndarray, x2: np.ndarray, K: np.ndarray,
                   max_nfev: int = 50) -> tuple[np.ndarray, np.ndarray]:
    """Minimise Σ Sampson(E(R, t))² in pixels over a rotation increment and a unit t."""
    Kinv = np.linalg.inv(K)
    h1 = np.column_stack([x1, np.ones(len(x1))])
    h2 = np.column_stack([x2, np.ones(len(x2))])
    B = _tangent_basis(t)

    def model(p):
        Rp = Rotation.from_rotvec(p[:3]).as_matrix() @ R
        tp = t + B @ p[3:]
        tp = tp / np.linalg.norm(tp)
        return Rp, tp

    def fun(p):
        Rp, tp = model(p)
        F = Kinv.T @ skew(tp) @ Rp @ Kinv
        Fx1 = h1 @ F.T
        Ftx2 = h2 @ F
        num = np.sum(Fx1 * h2, axis=1)
        den = Fx1[:, 0] ** 2 + Fx1[:, 1] ** 2 + Ftx2[:, 0] ** 2 + Ftx2[:, 1] ** 2
        return num / np.sqrt(den)

    res = least_squares(fun, np.zeros(5), method="lm" if len(x1) >= 5 else "trf",
                        max_nfev=max_nfev * 6, xtol=1e-12, ftol=1e-12)
    return model(res.x)


def estimate_relative_pose(x1: np.ndarray, x2: np.ndarray, K: np.ndarray, threshold_px: float = 1.0,
                           confidence: float = 0.999, max_iterations: int = 5000,
                           seed: int | None = 0, refine: str = "sampson", rounds: int = 2) -> RelativePose:
    """Relative pose of frame 2 to frame 1 from pixel matches (N, 2) (unit translation)."""
    if refine not in REFINEMENTS:
        raise VoError(f"unknown refinement {refine!r} ({', '.join(REFINEMENTS)})")
    r = ransac_fundamental(x1, x2, threshold_px, confidence, max_iterations, seed)
    idx = np.flatnonzero(r.inliers)
    a, b = x1[idx], x2[idx]
    choice = choose_pose(essential_from_fundamental(r.F, K), K, a, b)
    R, t = choice.R, choice.t
    front = choice.in_front
    if front.sum() < 8:
        raise VoError(f"only {int(front.sum())} of {len(idx)} inliers in front of both cameras")
    P1 = projection_matrix(K, np.eye(3), np.zeros(3))
    X = choice.X[front]
    if refine == "sampson":
        R, t = refine_sampson(R, t, a[front], b[front], K)
        X = triangulate_nonlinear(P1, projection_matrix(K, R, t), a[front], b[front])
    elif refine == "pnp":
        for _ in range(rounds):
            X = triangulate_nonlinear(P1, projection_matrix(K, R, t), a[front], b[front], X)
            R, t = nonlinear_pnp(X, b[front], K, R, t)
        scale = np.linalg.norm(t)
        t = t / scale
        X = X / scale
    inliers = np.zeros(len(x1), bool)
    inliers[idx[front]] = True
    return RelativePose(R, t, inliers, X, r.iterations)
