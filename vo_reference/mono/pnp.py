"""Perspective-n-point: linear DLT (H&Z §7.1) and non-linear refinement with a quaternion.

Pose convention: the point transform ``x_cam = R X + t`` (world -> camera), i.e. the
projection ``P = K [R | t] = K R [I | −C]`` with camera centre ``C = −Rᵀ t``.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from blender_sesgen.contract.se3 import R_to_quat_xyzw, quat_xyzw_to_R

from ..errors import VoError


def _normalise_3d(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    c = X.mean(axis=0)
    s = np.sqrt(3.0) / max(np.linalg.norm(X - c, axis=1).mean(), 1e-12)
    T = np.diag([s, s, s, 1.0])
    T[:3, 3] = -s * c
    return (X - c) * s, T


def linear_pnp(X: np.ndarray, x: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """DLT on calibrated rays: solve [R | t] up to scale from ≥ 6 points, then project R
    onto SO(3) (SVD) and divide t by the mean singular value. Returns (R, t)."""
    X = np.asarray(X, dtype=float)
    x = np.asarray(x, dtype=float)
    if len(X) < 6:
        raise VoError(f"linear PnP needs at least 6 points, got {len(X)}")
    xn = (np.column_stack([x, np.ones(len(x))]) @ np.linalg.inv(K).T)[:, :2]
    Xn, TX = _normalise_3d(X)
    Xh = np.column_stack([Xn, np.ones(len(Xn))])
    zero = np.zeros_like(Xh)
    A = np.concatenate([
        np.hstack([Xh, zero, -xn[:, :1] * Xh]),
        np.hstack([zero, Xh, -xn[:, 1:2] * Xh]),
    ])
    _, _, Vt = np.linalg.svd(A)
    P = Vt[-1].reshape(3, 4) @ TX                 # back to the original world coordinates
    M = P[:, :3]
    if np.linalg.det(M) < 0:
        P, M = -P, -M
    U, S, Vt3 = np.linalg.svd(M)
    R = U @ Vt3
    t = P[:, 3] / S.mean()
    return R, t


def nonlinear_pnp(X: np.ndarray, x: np.ndarray, K: np.ndarray, R0: np.ndarray, t0: np.ndarray,
                  max_nfev: int = 100, loss: str = "linear", f_scale: float = 1.0
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Minimise the reprojection error over the camera centre C and a unit quaternion q,
    ``P = K R(q) [I | −C]`` (q normalised inside the model; a residual ‖q‖² − 1 fixes its
    scale). Starts from (R0, t0); returns (R, t)."""
    X = np.asarray(X, dtype=float)
    x = np.asarray(x, dtype=float)
    C0 = -R0.T @ t0
    q0 = R_to_quat_xyzw(R0)       # x, y, z, w

    def fun(p):
        q, C = p[:4], p[4:]
        R = quat_xyzw_to_R(q)
        h = (X - C) @ R.T @ K.T
        r = (h[:, :2] / h[:, 2:3] - x).ravel()
        return np.append(r, q @ q - 1.0)

    res = least_squares(fun, np.concatenate([q0, C0]), method="trf", loss=loss,
                        f_scale=f_scale, max_nfev=max_nfev, xtol=1e-12, ftol=1e-12)
    q, C = res.x[:4], res.x[4:]
    R = quat_xyzw_to_R(q)
    return R, -R @ C
