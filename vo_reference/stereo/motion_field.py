"""The SESGen paper's egomotion equations (Skulimowski & Strumillo 2015, Section 3).

Camera frame: x right, y down, z forward (OpenCV); image coordinates (x, y) are in pixels
**relative to the principal point**; f is the focal length in pixels. The motion vector
X = [U, V, W, alpha, beta, gamma] is the rig's translation (scene units per frame) and
rotation (rad per frame) about the camera's x, y, z axes.

Eq. 2 (instantaneous motion field of a static point at depth Z):
    u = (-U f + x W)/Z + alpha x y/f - beta (x^2/f + f) + gamma y
    v = (-V f + y W)/Z + alpha (y^2/f + f) - beta x y/f - gamma x
Eq. 3: x' = x + u, y' = y + v (the flow over one frame is the field, to first order).
Eq. 5: u_i = a_i . X, v_i = b_i . X with the coefficients of :func:`motion_field_coefficients`.
Eq. 6: H X = K with h_mn = sum(a_m a_n + b_m b_n), k_m = sum(a_m (x'-x) + b_m (y'-y)).

Sign convention (derived, and checked in tests/test_stereo_motion_field.py): the field is
that of a camera moving with body twist [omega, v] = [(alpha, beta, gamma), (U, V, W)], a
static point moving as dP/dt = -v - omega x P in the camera frame. So the frame-to-frame
pose change is T_k_k1 = exp([omega, v]) — the convention of the SES language's EGO lines
(T(k+1) = T(k) . exp([omega, v])).
"""
from __future__ import annotations

import numpy as np

from blender_sesgen.contract.se3 import se3_exp, se3_log

from ..errors import VoError


def motion_field_coefficients(x: np.ndarray, y: np.ndarray, Z: np.ndarray, f: float) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients a_i, b_i (Eq. 5) of the motion field at image points.

    Parameters
    ----------
    x, y : array, shape (P,)
        Image coordinates in pixels relative to the principal point.
    Z : array, shape (P,)
        Depth of each point (scene units), > 0.
    f : float
        Focal length in pixels.

    Returns
    -------
    a, b : arrays, shape (P, 6), with u_i = a_i . X and v_i = b_i . X.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    Z = np.asarray(Z, dtype=float)
    P = x.shape[0]
    a = np.zeros((P, 6))
    b = np.zeros((P, 6))
    a[:, 0] = -f / Z
    a[:, 2] = x / Z
    a[:, 3] = x * y / f
    a[:, 4] = -(x * x / f + f)
    a[:, 5] = y
    b[:, 1] = -f / Z
    b[:, 2] = y / Z
    b[:, 3] = y * y / f + f
    b[:, 4] = -x * y / f
    b[:, 5] = -x
    return a, b


def motion_field(X: np.ndarray, x: np.ndarray, y: np.ndarray, Z: np.ndarray, f: float) -> tuple[np.ndarray, np.ndarray]:
    """Flow (u, v) of Eq. 2 for the motion vector X = [U, V, W, alpha, beta, gamma] (rad)."""
    a, b = motion_field_coefficients(x, y, Z, f)
    X = np.asarray(X, dtype=float)
    return a @ X, b @ X


def normal_equations(x, y, Z, x1, y1, f: float) -> tuple[np.ndarray, np.ndarray]:
    """H (6, 6) and K (6,) of Eq. 6 from points (x, y) at depth Z seen at (x1, y1) next frame."""
    a, b = motion_field_coefficients(x, y, Z, f)
    du = np.asarray(x1, dtype=float) - np.asarray(x, dtype=float)
    dv = np.asarray(y1, dtype=float) - np.asarray(y, dtype=float)
    H = a.T @ a + b.T @ b
    K = a.T @ du + b.T @ dv
    return H, K


def solve_small(H: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Solve the small dense system H x = g (e.g. 6x6 normal equations).

    ``scipy.linalg.solve`` rather than ``numpy.linalg.solve``: with this OpenBLAS build the
    latter was measured at ~15 ms for a 6x6 system on the shared 2-core machine (thread
    hand-off under load), ~300x slower than scipy's 45 us. Raises ``LinAlgError`` when singular.
    """
    from scipy.linalg import solve
    return solve(H, g, check_finite=False)


def solve_egomotion(x, y, Z, x1, y1, f: float) -> np.ndarray:
    """The paper's estimate X = [U, V, W, alpha, beta, gamma] (angles in rad): solve H X = K.

    Needs P >= 3 points with finite positive depth (else :class:`VoError`).
    """
    x = np.asarray(x, dtype=float)
    Z = np.asarray(Z, dtype=float)
    if x.shape[0] < 3:
        raise VoError(f"egomotion needs at least 3 keypoints, got {x.shape[0]}")
    if not np.all(np.isfinite(Z) & (Z > 0)):
        raise VoError("egomotion needs finite positive depths")
    H, K = normal_equations(x, y, Z, x1, y1, f)
    try:
        X = solve_small(H, K)
    except np.linalg.LinAlgError:
        raise VoError("egomotion normal equations are singular (degenerate keypoints)") from None
    if not np.all(np.isfinite(X)):
        raise VoError("egomotion normal equations are singular (degenerate keypoints)")
    return X


def twist_to_T(X: np.ndarray) -> np.ndarray:
    """T_k_k1 = exp([omega, v]) of a motion vector X = [U, V, W, alpha, beta, gamma] (rad)."""
    X = np.asarray(X, dtype=float)
    return se3_exp(X[3:6], X[0:3])


def T_to_twist(T_k_k1: np.ndarray) -> np.ndarray:
    """Inverse of :func:`twist_to_T`: [U, V, W, alpha, beta, gamma] (rad) of a relative pose."""
    w, v = se3_log(np.asarray(T_k_k1, dtype=float))
    return np.concatenate([v, w])


def compose(T_world_cam0: np.ndarray, T_k_k1: list[np.ndarray] | np.ndarray) -> np.ndarray:
    """Poses (N+1, 4, 4): T(k+1) = T(k) . T_k_k1[k]."""
    poses = [np.asarray(T_world_cam0, dtype=float)]
    for T in T_k_k1:
        poses.append(poses[-1] @ T)
    return np.stack(poses)
