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


@dataclass(frozen=True)
class Alignment:
    """The applied alignment: est_aligned = T · diag(s,s,s,1)-scaled est (rotation R, translation t)."""

    method: str
    R: np.ndarray        # (3, 3)
    t: np.ndarray        # (3,)
    scale: float
    n_poses: int         # pose pairs used for the fit (0 for none)
    rotation_sigma_deg: float = 0.0   # se3/sim3: how well the fit fixes R (rotation_sigma_deg())

    @property
    def T(self) -> np.ndarray:
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = self.R, self.t
        return T

    def as_dict(self) -> dict:
        return {"method": self.method, "R": self.R.tolist(), "t": self.t.tolist(),
                "scale": self.scale, "n_poses": self.n_poses, "rotation_sigma_deg": self.rotation_sigma_deg}


def umeyama(x: np.ndarray, y: np.ndarray, with_scale: bool = False) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares (R, t, c) with y ≈ c·R·x + t (Umeyama, IEEE PAMI 1991).

    ``x``, ``y``: (n, 3) corresponding points. Eqs. 34–43: means, variance of x,
    covariance Σ_xy = (1/n) Σ (y−μy)(x−μx)ᵀ = U D Vᵀ, S = diag(1, 1, −1) when
    det(U)·det(V) < 0 (the reflection fix), R = U S Vᵀ, c = tr(D S)/σx², t = μy − c R μx.
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
    if np.count_nonzero(d > np.finfo(d.dtype).eps) < m - 1:
        raise VoError("degenerate point set (collinear or too few poses): alignment is not possible")
    S = np.eye(m)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0.0:
        S[m - 1, m - 1] = -1.0
    R = U @ S @ Vt
    c = float(np.trace(np.diag(d) @ S) / sigma_x) if with_scale else 1.0
    t = my - c * R @ mx
    return R, t, c


def rotation_sigma_deg(x: np.ndarray, y: np.ndarray, R: np.ndarray, t: np.ndarray, c: float = 1.0) -> float:
    """About how well the fit y ≈ c·R·x + t fixes R (1 σ, degrees, worst axis): the residuals'
    scatter over the points' spread perpendicular to the axis they spread most along, the
    axis a straight path leaves free (points on a line fix no rotation about it)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    res = y - (c * x @ R.T + t)
    dof = max(3 * len(x) - 6, 1)
    sigma = float(np.sqrt(np.sum(res * res) / dof))
    yc = y - y.mean(axis=0)
    perp = float(np.sum(np.linalg.eigvalsh(yc.T @ yc)[:2]))   # sums of squares off the main axis
    if sigma == 0.0:
        return 0.0
    return float(np.degrees(sigma / np.sqrt(perp))) if perp > 0 else float("inf")


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


def align(est: Trajectory, gt: Trajectory, method: str = "se3", n: int = -1) -> tuple[Trajectory, Alignment]:
    """Align ``est`` to ``gt`` (same length, associated); returns (aligned est, alignment).

    ``n``: use only the first n poses for the fit (-1: all), as evo's ``--n_to_align``.
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
    if k < 3:
        raise VoError(f"need at least 3 poses to align with {method}, got {k}")
    R, t, c = umeyama(est.positions[:k], gt.positions[:k], with_scale=method in ("sim3", "scale"))
    if method == "scale":
        a = Alignment("scale", np.eye(3), np.zeros(3), c, k)
    else:
        a = Alignment(method, R, t, c, k, rotation_sigma_deg(est.positions[:k], gt.positions[:k], R, t, c))
    return apply_alignment(est, a), a
