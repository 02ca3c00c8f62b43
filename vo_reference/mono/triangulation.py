"""Triangulation: linear (DLT, H&Z §12.2) and non-linear (reprojection error, H&Z §12.3).

Cameras are 3x4 projection matrices ``P = K [R | t]`` mapping world points to pixels
(``x_cam = R X + t``); points are (N, 3), pixels (N, 2).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import csr_matrix


def projection_matrix(K: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """P = K [R | t] for the point transform x_cam = R X + t."""
    return np.asarray(K, dtype=float) @ np.column_stack([R, np.asarray(t, dtype=float).reshape(3)])


def project(P: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) of world points X (N, 3) through P (3, 4)."""
    h = X @ P[:, :3].T + P[:, 3]
    return h[:, :2] / h[:, 2:3]


def triangulate_linear(P1: np.ndarray, P2: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """Homogeneous DLT triangulation of each correspondence (vectorised SVD of 4x4 systems)."""
    x1 = np.asarray(x1, dtype=float)
    x2 = np.asarray(x2, dtype=float)
    A = np.stack([
        x1[:, 0:1] * P1[2] - P1[0],
        x1[:, 1:2] * P1[2] - P1[1],
        x2[:, 0:1] * P2[2] - P2[0],
        x2[:, 1:2] * P2[2] - P2[1],
    ], axis=1)                                    # (N, 4, 4)
    # scale rows to unit norm: conditioning without changing the solution
    A = A / np.linalg.norm(A, axis=2, keepdims=True)
    _, _, Vt = np.linalg.svd(A)
    Xh = Vt[:, -1, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        return Xh[:, :3] / Xh[:, 3:4]


def reprojection_residuals(P_list, x_list, X: np.ndarray) -> np.ndarray:
    """Stacked residuals (projected − measured) for all cameras, shape (N, 2·ncams)."""
    return np.concatenate([project(P, X) - x for P, x in zip(P_list, x_list)], axis=1)


def triangulate_nonlinear(P1: np.ndarray, P2: np.ndarray, x1: np.ndarray, x2: np.ndarray,
                          X0: np.ndarray | None = None, max_nfev: int = 50) -> np.ndarray:
    """Refine points to minimise the reprojection error in both views (scipy least_squares).

    min_X Σ_j ‖x_j − π(P_j X)‖² per point; the points are independent, so the Jacobian is
    block diagonal (2 views × 2 residuals by 3 coordinates), given analytically as a
    sparse matrix. ``X0`` defaults to the linear triangulation.
    """
    x1 = np.asarray(x1, dtype=float)
    x2 = np.asarray(x2, dtype=float)
    X0 = triangulate_linear(P1, P2, x1, x2) if X0 is None else np.asarray(X0, dtype=float)
    n = len(X0)
    if n == 0:
        return X0.copy()
    ok = np.all(np.isfinite(X0), axis=1)
    X = X0.copy()
    if not ok.any():
        return X
    m = int(ok.sum())
    P_list, x_list = (P1, P2), (x1[ok], x2[ok])

    def fun(p):
        return reprojection_residuals(P_list, x_list, p.reshape(m, 3)).ravel()

    rows = np.repeat(np.arange(4 * m).reshape(m, 4), 3, axis=1)            # (m, 12)
    cols = np.tile(np.arange(3 * m).reshape(m, 1, 3), (1, 4, 1)).reshape(m, 12)

    def jac(p):
        Xp = p.reshape(m, 3)
        blocks = []
        for P in P_list:
            h = Xp @ P[:, :3].T + P[:, 3]                                     # (m, 3)
            for r in range(2):   # d(h_r / h_2)/dX = (P_r - (h_r / h_2) P_2) / h_2
                blocks.append((P[r, :3] - (h[:, r] / h[:, 2])[:, None] * P[2, :3]) / h[:, 2:3])
        vals = np.stack(blocks, axis=1).reshape(m, 12)
        return csr_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(4 * m, 3 * m))

    res = least_squares(fun, X0[ok].ravel(), jac=jac, method="trf", tr_solver="lsmr",
                        x_scale="jac", max_nfev=max_nfev, xtol=1e-10, ftol=1e-10, gtol=1e-10)
    X[ok] = res.x.reshape(m, 3)
    return X
