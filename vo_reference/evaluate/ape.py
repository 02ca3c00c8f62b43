"""Absolute pose error (APE), as evo defines it.

For associated (and aligned) poses P_i (estimate) and Q_i (ground truth):
- translation error ‖t(P_i) − t(Q_i)‖ (metres: the trajectory's unit);
- rotation error: the angle of E_i = inv(P_i)·Q_i, i.e. ‖log(R(P_i)ᵀR(Q_i))‖ (degrees).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blender_sesgen.contract.se3 import rotation_angle_rad

from .poses import check_pair
from .stats import ErrorStats


@dataclass(frozen=True)
class APEResult:
    trans_errors_m: np.ndarray    # (N,)
    rot_errors_deg: np.ndarray    # (N,)
    trans: ErrorStats
    rot_deg: ErrorStats

    def as_dict(self) -> dict:
        return {"trans_m": self.trans.as_dict(), "rot_deg": self.rot_deg.as_dict()}


def ape(gt, est) -> APEResult:
    """APE of ``est`` against ``gt`` (Trajectory or (N, 4, 4) arrays, already associated/aligned)."""
    Q, P = check_pair(gt, est)
    e_t = np.linalg.norm(P[:, :3, 3] - Q[:, :3, 3], axis=1)
    R_err = np.swapaxes(P[:, :3, :3], 1, 2) @ Q[:, :3, :3]
    e_r = np.degrees(rotation_angle_rad(R_err))
    return APEResult(e_t, e_r, ErrorStats.of(e_t), ErrorStats.of(e_r))
