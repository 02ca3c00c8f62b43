"""Small vectorised pose helpers shared by the metrics (private)."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

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


def rotation_angle_rad(R: np.ndarray) -> np.ndarray:
    """Angle of the log map (|rotation vector|) of (..., 3, 3) rotations, as evo (via quaternions)."""
    R = np.asarray(R, dtype=float)
    return Rotation.from_matrix(R.reshape(-1, 3, 3)).magnitude().reshape(R.shape[:-2])


def relative(T_a: np.ndarray, T_b: np.ndarray) -> np.ndarray:
    """inv(T_a) @ T_b for stacks of rigid transforms (exact rigid inverse)."""
    R_a_T = np.swapaxes(T_a[..., :3, :3], -1, -2)
    out = np.zeros(np.broadcast_shapes(T_a.shape, T_b.shape))
    out[..., :3, :3] = R_a_T @ T_b[..., :3, :3]
    out[..., :3, 3] = np.einsum("...ij,...j->...i", R_a_T, T_b[..., :3, 3] - T_a[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out
