"""Small vectorised pose helpers shared by the metrics (private)."""
from __future__ import annotations

import numpy as np

from ..errors import VoError
from ..io.trajectory import Trajectory


def as_poses(x) -> np.ndarray:
    """(N, 4, 4) float array from a Trajectory or an array of poses."""
    T = x.T_world_cam if isinstance(x, Trajectory) else np.asarray(x, dtype=float)
    if T.ndim != 3 or T.shape[1:] != (4, 4):
        raise VoError(f"expected poses of shape (N, 4, 4), got {T.shape}")
    return T


def check_pair(gt, est) -> tuple[np.ndarray, np.ndarray]:
    P_gt, P_est = as_poses(gt), as_poses(est)
    if P_gt.shape[0] != P_est.shape[0]:
        raise VoError(f"ground truth has {P_gt.shape[0]} poses, estimate {P_est.shape[0]} (associate first)")
    if P_gt.shape[0] == 0:
        raise VoError("empty trajectories")
    return P_gt, P_est
