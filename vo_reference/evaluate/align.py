"""Aligning an estimated trajectory to ground truth before APE (evo's definitions).

Methods:
- ``none``: as given.
- ``origin``: T = T_gt[0] · inv(T_est[0]) left-multiplies every estimated pose.
- ``se3``: rigid Umeyama fit of the estimated positions to the ground-truth ones.
- ``sim3``: Umeyama with scale: p ↦ s·R·p + t (poses: translations scaled by s, then R, t).
- ``scale``: only the Umeyama (Sim3) scale is applied to the estimated translations.
``n`` (first-N poses, default all) restricts the fit to the first n pose pairs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blender_sesgen.contract.se3 import invert

from ..errors import VoError
from ..io.trajectory import Trajectory

METHODS = ("none", "origin", "se3", "sim3", "scale")
# The commands' default (evaluate, run): the first estimated pose put on the first
# ground-truth one -- every VO here starts there, APE is then the drift -- whereas an SE(3)
# fit to a short or nearly straight path cannot fix the rotation about it.
CLI_DEFAULT = "origin"
# An se3/sim3 fit whose own rotation uncertainty (rotation_sigma_deg, 1 sigma, worst axis) is at
# least this share of the APE rotation it yields does not measure the estimate's rotation: the
# figure is then mostly the fit's (the roll about a nearly straight path). A ratio, not a bound
# in degrees: a large rotation error stays measurable under a loose fit, a small one does not.
# The fit's error adds to the estimate's roughly in quadrature (figure² ≈ true² + sigma²), so at
# sigma < 0.5 x the figure the figure overstates the true error by at most 1/sqrt(1 - 0.25) = 1.15x.
ILL_POSED_RATIO = 0.5
# ... unless the fit's uncertainty is below this at all (degrees): a fit to within rounding (a
# trajectory file's digits) fixes its rotation far better than any VO or ground truth turns
# (KITTI's poses: ~0.06 deg a step), even where the APE rotation is ~0 too.
ROTATION_FLOOR_DEG = 1e-3
# A sim3 fit whose scale ambiguity (fit_conditioning: 1/rho^2 - 1, the gap between the scale fitted
# estimate -> ground truth and the inverse of the reverse fit's) is at least this does not fix the
# estimate's scale to 10 %: the estimate barely moves against its noise, or does not follow the
# path. Every translation measured after it would scale with the fit's noise.
SCALE_AMBIGUITY_MAX = 0.1


@dataclass(frozen=True)
class Alignment:
    """The applied alignment: est_aligned = T · diag(s,s,s,1)-scaled est (rotation R, translation t)."""

    method: str
    R: np.ndarray        # (3, 3)
    t: np.ndarray        # (3,)
    scale: float
    n_poses: int         # pose pairs used for the fit (0 for none)
    rotation_sigma_deg: float = 0.0   # se3/sim3: how well the fit fixes R (fit_conditioning())
    scale_ambiguity: float = 0.0      # sim3/scale: how well it fixes the scale (fit_conditioning())

    @property
    def T(self) -> np.ndarray:
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = self.R, self.t
        return T

    def as_dict(self) -> dict:
        return {"method": self.method, "R": self.R.tolist(), "t": self.t.tolist(),
                "scale": self.scale, "n_poses": self.n_poses, "rotation_sigma_deg": self.rotation_sigma_deg,
                "scale_ambiguity": self.scale_ambiguity}


def umeyama(x: np.ndarray, y: np.ndarray, with_scale: bool = False,
            allow_degenerate: bool = False) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares (R, t, c) with y ≈ c·R·x + t (Umeyama, IEEE PAMI 1991).

    ``x``, ``y``: (n, 3) corresponding points. Eqs. 34–43: means, variance of x,
    covariance Σ_xy = (1/n) Σ (y−μy)(x−μx)ᵀ = U D Vᵀ, S = diag(1, 1, −1) when
    det(U)·det(V) < 0 (the reflection fix), R = U S Vᵀ, c = tr(D S)/σx², t = μy − c R μx.

    ``allow_degenerate``: on collinear points (rank Σ_xy < 2) return one of the minimisers
    instead of raising: R = U S Vᵀ still attains the least residual (tr(D S) is the maximum of
    tr(Rᵀ Σ_xy) when d2 = d3 = 0), so the residual, and c, are the fit's; only the rotation about
    the line is arbitrary (``fit_conditioning`` says so: infinite). Points that do not spread at all
    (σx = 0) get c = 1: no scale is determined.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.shape != y.shape or x.ndim != 2:
        raise VoError(f"umeyama: point sets must have the same (n, m) shape, got {x.shape} and {y.shape}")
    n, m = x.shape
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    sigma_x = float(np.sum(xc * xc)) / n
    cov = yc.T @ xc / n
    U, d, Vt = np.linalg.svd(cov)
    if np.count_nonzero(d > np.finfo(d.dtype).eps) < m - 1 and not allow_degenerate:
        raise VoError("degenerate point set (collinear or too few poses): alignment is not possible")
    S = np.eye(m)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0.0:
        S[m - 1, m - 1] = -1.0
    R = U @ S @ Vt
    c = 1.0
    if with_scale and sigma_x > 0.0:
        c = float(np.trace(np.diag(d) @ S) / sigma_x)
    t = my - c * R @ mx
    return R, t, c


def fit_conditioning(x: np.ndarray, y: np.ndarray, R: np.ndarray, t: np.ndarray, c: float = 1.0,
                     with_scale: bool = False) -> tuple[float, float]:
    """How well the least-squares fit y ≈ c·R·x + t fixes its rotation and its scale:
    (rotation 1 σ in degrees about the worst axis, the scale's relative ambiguity; inf where
    not determined).

    Rotation, from the fit's Fisher information with the residuals' scatter σ (per coordinate,
    over 3n − 6 − [scale] degrees of freedom) as the noise: the objective is −2cn·tr(Rᵀ Σ_xy) +
    const; about the axis of Σ_xy's largest singular value it curves as cn·(d2 + s3·d3) (s3 = −1
    under the reflection fix), the least of the three, so σ_rot = σ / √(cn(d2 + s3·d3)). A
    straight path (or a straight estimate) has d2 = d3 = 0: the rotation about it is free. With
    the estimate on the ground truth (cΣ_xy ≈ the ground truth's covariance) this is the residual
    scatter over the path's spread off its main axis.

    Scale: the noise of a VO is in the estimate, the fit's regressor, which biases the scale
    towards 0 (errors in variables): c = tr(DS)/σx² fits the estimate to the ground truth, the
    reverse fit's inverse is σy²/tr(DS) = c/ρ² (ρ = tr(DS)/(σx·σy), the Procrustes correlation,
    1 for a similar shape), and the scale is fixed only to within that bracket: ambiguity
    1/ρ² − 1, the estimate's noise energy over its motion's where the noise is uncorrelated (0.005
    for a VO 30 cm off each pose of an 11 m drive, median of 200 draws; 1 where its noise is as large as its motion and c
    half the true scale; inf for an estimate that does not move)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = len(x)
    res = y - (c * x @ R.T + t)
    dof = max(3 * n - 6 - int(with_scale), 1)
    sigma = float(np.sqrt(np.sum(res * res) / dof))
    xc, yc = x - x.mean(axis=0), y - y.mean(axis=0)
    U, d, Vt = np.linalg.svd(yc.T @ xc / n)
    s3 = -1.0 if np.linalg.det(U) * np.linalg.det(Vt) < 0.0 else 1.0
    spread2 = d[1] + s3 * d[2]
    # free, even with no residual at all (a perfect estimate of a straight path: any roll fits)
    rot = float("inf") if spread2 <= 1e-12 * d[0] or c <= 0.0 else float(np.degrees(sigma / np.sqrt(c * n * spread2)))
    if not with_scale:
        return rot, 0.0
    var_x, var_y = float(np.sum(xc * xc)) / n, float(np.sum(yc * yc)) / n
    rho = (d[0] + d[1] + s3 * d[2]) / np.sqrt(var_x * var_y) if var_x > 0.0 and var_y > 0.0 else 0.0
    return rot, (float(1.0 / rho ** 2 - 1.0) if rho > 0.0 else float("inf"))


def fixes_scale(alignment: "Alignment") -> bool:
    """Whether a sim3/scale fit fixes the estimate's scale: its ambiguity under
    ``SCALE_AMBIGUITY_MAX`` (always for the other methods: no fitted scale)."""
    if alignment.method not in ("sim3", "scale"):
        return True
    s = alignment.scale_ambiguity
    return bool(np.isfinite(s)) and s < SCALE_AMBIGUITY_MAX


def fixes_rotation(alignment: Alignment, ape_rot_deg: float) -> bool:
    """Whether an APE rotation of ``ape_rot_deg`` after ``alignment`` measures the estimate:
    always for none/origin/scale (no fitted rotation); for se3/sim3 when the fit's own rotation
    uncertainty is under ``ILL_POSED_RATIO`` of it, or under ``ROTATION_FLOOR_DEG``."""
    if alignment.method not in ("se3", "sim3"):
        return True
    s = alignment.rotation_sigma_deg
    return bool(np.isfinite(s)) and (s < ILL_POSED_RATIO * ape_rot_deg or s < ROTATION_FLOOR_DEG)


def apply_alignment(est: Trajectory, alignment: Alignment) -> Trajectory:
    """Scale the estimated translations by ``alignment.scale``, then left-multiply by [R|t]."""
    T = est.T_world_cam.copy()
    T[:, :3, 3] *= alignment.scale
    return Trajectory(alignment.T @ T, est.timestamps_s)


def align(est: Trajectory, gt: Trajectory, method: str = "se3", n: int = -1,
          allow_degenerate: bool = False) -> tuple[Trajectory, Alignment]:
    """Align ``est`` to ``gt`` (same length, associated); returns (aligned est, alignment).

    ``n``: use only the first n poses for the fit (-1: all), as evo's ``--n_to_align``.
    ``allow_degenerate``: fit collinear positions too (and 2 poses), ``umeyama``'s minimiser; the
    alignment's conditioning says what the fit leaves free. Otherwise a VoError, as evo's.
    """
    if method not in METHODS:
        raise VoError(f"unknown alignment {method!r} (one of {', '.join(METHODS)})")
    if len(est) != len(gt):
        raise VoError(f"cannot align {len(est)} estimated poses to {len(gt)} ground-truth poses (associate first)")
    if method == "none":
        a = Alignment("none", np.eye(3), np.zeros(3), 1.0, 0)
        return est, a
    if method == "origin":
        T = gt.T_world_cam[0] @ invert(est.T_world_cam[0])
        a = Alignment("origin", T[:3, :3].copy(), T[:3, 3].copy(), 1.0, 1)
        return apply_alignment(est, a), a
    k = len(est) if n is None or n < 0 else int(n)
    if k < (2 if allow_degenerate else 3):
        raise VoError(f"need at least 3 poses to align with {method}, got {k}")
    scaled = method in ("sim3", "scale")
    R, t, c = umeyama(est.positions[:k], gt.positions[:k], with_scale=scaled, allow_degenerate=allow_degenerate)
    rot, rel = fit_conditioning(est.positions[:k], gt.positions[:k], R, t, c, with_scale=scaled)
    if method == "scale":
        a = Alignment("scale", np.eye(3), np.zeros(3), c, k, 0.0, rel)
    else:
        a = Alignment(method, R, t, c, k, rot, rel)
    return apply_alignment(est, a), a
