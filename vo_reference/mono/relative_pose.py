"""Our two-view solver: RANSAC (5-point E or 8-point F) -> E -> cheirality -> optional
non-linear refinement.

Minimal solvers (``solver``):
- ``5pt`` (default): the calibrated 5-point essential matrix (``five_point.py``) in our
  RANSAC on normalised points K⁻¹x, scored by the Sampson distance in pixels;
- ``8pt``: the normalised 8-point fundamental matrix in our RANSAC (``fundamental.py``),
  then E = KᵀFK.

Refinements (``refine``):
- ``none``: the pose from E decomposition (E of the RANSAC winner refit on its inliers);
- ``pnp``: the seed report's chain — non-linear triangulation of the inliers, then
  non-linear PnP of camera 2 on those points, repeated ``rounds`` times;
- ``sampson`` (default): a robust Sampson fit over all matches from the RANSAC pose and
  from prior motions (keep the one with the lowest MSAC cost, or most inliers with
  ``select='count'``), then minimise the Sampson
  distances of its inliers over the five degrees of freedom of E = [t]ₓR (rotation
  vector + unit t), settle the sign of t by cheirality, and non-linearly triangulate.
  Sampson's error is the first-order geometric error, so this is the two-view "gold standard" fit without carrying every point as a parameter.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from blender_sesgen.contract.se3 import skew, so3_exp

from ..errors import VoError
from .essential import camera_motion, choose_pose, essential_from_fundamental
from .five_point import ransac_essential
from .fundamental import ransac_fundamental
from .pnp import nonlinear_pnp
from .triangulation import projection_matrix, triangulate_linear, triangulate_nonlinear

REFINEMENTS = ("none", "pnp", "sampson")
SCORES = ("msac", "count")
# robust loss of the all-matches Sampson fit for each score: arctan is bounded (a smooth
# truncated quadratic, like MSAC); Cauchy grows without bound (log), so a few gross
# outliers can pull the fit to a wrong motion that brings them closer
ROBUST_LOSS = {"msac": "arctan", "count": "cauchy"}
SOLVERS = ("5pt", "8pt")


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


def _sampson_residuals(R, t, h1, h2, Kinv):
    F = Kinv.T @ skew(t) @ R @ Kinv
    Fx1 = h1 @ F.T
    Ftx2 = h2 @ F
    num = np.sum(Fx1 * h2, axis=1)
    den = Fx1[:, 0] ** 2 + Fx1[:, 1] ** 2 + Ftx2[:, 0] ** 2 + Ftx2[:, 1] ** 2
    return num / np.sqrt(den)


def refine_sampson(R: np.ndarray, t: np.ndarray, x1: np.ndarray, x2: np.ndarray, K: np.ndarray,
                   loss: str = "linear", f_scale: float = 1.0, max_nfev: int = 50
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Minimise Σ ρ(Sampson(E(R, t))) in pixels over a rotation increment and a unit t
    (``loss``/``f_scale`` as scipy's least_squares: a robust loss lets all matches in)."""
    Kinv = np.linalg.inv(K)
    h1 = np.column_stack([x1, np.ones(len(x1))])
    h2 = np.column_stack([x2, np.ones(len(x2))])
    B = _tangent_basis(t)

    def model(p):
        tp = t + B @ p[3:]
        return so3_exp(p[:3]) @ R, tp / np.linalg.norm(tp)

    def fun(p):
        return _sampson_residuals(*model(p), h1, h2, Kinv)

    method = "lm" if loss == "linear" and len(x1) >= 5 else "trf"
    res = least_squares(fun, np.zeros(5), method=method, loss=loss, f_scale=f_scale,
                        max_nfev=max_nfev * 6, xtol=1e-12, ftol=1e-12)
    return model(res.x)


def _msac(R, t, x1, x2, K, threshold_px):
    """Inliers and the MSAC cost Σ min(d², τ²) of the Sampson distances d (pixels)."""
    h1 = np.column_stack([x1, np.ones(len(x1))])
    h2 = np.column_stack([x2, np.ones(len(x2))])
    d2 = _sampson_residuals(R, t, h1, h2, np.linalg.inv(K)) ** 2
    return d2 < threshold_px**2, float(np.minimum(d2, threshold_px**2).sum())


def _cheirality_sign(R, t, x1, x2, K):
    """±t, whichever puts more linearly triangulated points in front of both cameras."""
    P1 = projection_matrix(K, np.eye(3), np.zeros(3))
    best = None
    for s in (1.0, -1.0):
        X = triangulate_linear(P1, projection_matrix(K, R, s * t), x1, x2)
        front = np.isfinite(X[:, 2]) & (X[:, 2] > 0) & (X @ R[2] + s * t[2] > 0)
        if best is None or front.sum() > best[1].sum():
            best = (s * t, front, X)
    return best


def _point_transform(T_c1_c2: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    C = T_c1_c2[:3, 3]
    n = np.linalg.norm(C)
    if n < 1e-9:
        return None
    R = T_c1_c2[:3, :3].T
    return R, -R @ C / n


@dataclass(frozen=True)
class TwoViewParams:
    """How :func:`estimate_relative_pose` estimates: our RANSAC (``solver``: ``5pt``
    calibrated 5-point or ``8pt`` 8-point F; ``select``: ``msac`` or ``count`` scoring, with
    ``threshold_px`` Sampson distance, ``confidence``, ``max_iterations``, ``seed``) and the
    refinement (``refine``: ``sampson``, ``pnp`` with ``rounds`` of triangulation/PnP, or ``none``)."""
    threshold_px: float = 1.0
    confidence: float = 0.999
    max_iterations: int = 5000
    seed: int | None = 0
    refine: str = "sampson"
    rounds: int = 2
    solver: str = "5pt"
    select: str = "msac"

    def __post_init__(self):
        for value, allowed, what in ((self.refine, REFINEMENTS, "refinement"), (self.select, SCORES, "score"),
                                     (self.solver, SOLVERS, "solver")):
            if value not in allowed:
                raise VoError(f"unknown {what} {value!r} ({', '.join(allowed)})")


def estimate_relative_pose(x1: np.ndarray, x2: np.ndarray, K: np.ndarray, params: TwoViewParams | None = None, *,
                           priors: tuple = (), triangulate: bool = True, **overrides) -> RelativePose:
    """Relative pose of frame 2 to frame 1 from pixel matches (N, 2) (unit translation).

    ``params`` (fields may also be given as keywords) say how. With ``refine='sampson'``, the
    RANSAC pose and each motion in ``priors`` (camera motions T_c1_c2, e.g. the previous
    frame's: a constant-velocity hypothesis) are refined with a robust Sampson fit over all
    matches (bounded arctan loss; Cauchy with ``select='count'``), and the one with the lowest
    MSAC cost Σ min(d², τ²) wins (``select='count'``: the most inliers); ``select`` also sets
    the RANSAC score. That guards against the rotation/translation ambiguity of forward
    motion, where a noisy 8-point sample can lead RANSAC into a false optimum with sideways
    translation. ``triangulate=False`` keeps the linear triangulation in ``X_c1`` (the
    non-linear one is only needed when the points set the scale).
    """
    p = replace(params or TwoViewParams(), **overrides)
    threshold_px, refine, select, solver = p.threshold_px, p.refine, p.select, p.solver
    x1 = np.asarray(x1, dtype=float)
    x2 = np.asarray(x2, dtype=float)
    K = np.asarray(K, dtype=float)
    if solver == "5pt":
        r = ransac_essential(x1, x2, K, threshold_px, p.confidence, p.max_iterations, p.seed,
                             score="msac" if select == "msac" else "count")
        E = r.E
    else:
        r = ransac_fundamental(x1, x2, threshold_px, p.confidence, p.max_iterations, p.seed)
        E = essential_from_fundamental(r.F, K)
    idx = np.flatnonzero(r.inliers)
    choice = choose_pose(E, K, x1[idx], x2[idx])
    R, t = choice.R, choice.t
    P1 = projection_matrix(K, np.eye(3), np.zeros(3))
    if refine == "sampson":
        starts = [(R, t)] + [p for p in (_point_transform(T) for T in priors) if p is not None]
        best = None
        for R0, t0 in starts:
            Rr, tr = refine_sampson(R0, t0, x1, x2, K, loss=ROBUST_LOSS[select], f_scale=threshold_px)
            inl, cost = _msac(Rr, tr, x1, x2, K, threshold_px)
            key = (cost, -inl.sum()) if select == "msac" else (-inl.sum(), cost)
            if best is None or key < best[3]:
                best = (Rr, tr, inl, key)
        R, t, inl, _ = best
        if inl.sum() < 8:
            raise VoError(f"only {int(inl.sum())} inliers after the robust refinement")
        R, t = refine_sampson(R, t, x1[inl], x2[inl], K)
        idx = np.flatnonzero(inl)
        t, front, X = _cheirality_sign(R, t, x1[idx], x2[idx], K)
        if front.sum() < 8:
            raise VoError(f"only {int(front.sum())} of {len(idx)} inliers in front of both cameras")
        X = X[front]
        if triangulate:
            X = triangulate_nonlinear(P1, projection_matrix(K, R, t), x1[idx[front]], x2[idx[front]], X)
    else:
        front = choice.in_front
        if front.sum() < 8:
            raise VoError(f"only {int(front.sum())} of {len(idx)} inliers in front of both cameras")
        X = choice.X[front]
        if refine == "pnp":
            a, b = x1[idx[front]], x2[idx[front]]
            for _ in range(p.rounds):
                X = triangulate_nonlinear(P1, projection_matrix(K, R, t), a, b, X)
                R, t = nonlinear_pnp(X, b, K, R, t)
            scale = np.linalg.norm(t)
            t = t / scale
            X = X / scale
    inliers = np.zeros(len(x1), bool)
    inliers[idx[front]] = True
    return RelativePose(R, t, inliers, X, r.iterations)
