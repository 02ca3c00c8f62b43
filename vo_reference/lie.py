"""SO(3)/SE(3) helpers on numpy arrays (pure math, no I/O).

``T_a_b`` maps coordinates in frame b to frame a; poses are (4, 4) or stacked (N, 4, 4).
"""
from __future__ import annotations

import numpy as np


def skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def so3_exp(w: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation matrix of the rotation vector ``w`` (rad)."""
    w = np.asarray(w, dtype=float)
    theta = float(np.linalg.norm(w))
    W = skew(w)
    if theta < 1e-8:
        return np.eye(3) + W + 0.5 * W @ W
    return np.eye(3) + np.sin(theta) / theta * W + (1 - np.cos(theta)) / theta**2 * W @ W


def so3_log(R: np.ndarray) -> np.ndarray:
    """Rotation vector (rad) of a rotation matrix (robust near 0 and pi)."""
    from scipy.spatial.transform import Rotation
    return Rotation.from_matrix(R).as_rotvec()


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Angle (rad) of rotation matrices (..., 3, 3): |rotation vector|, via quaternions as
    evo does (accurate for small angles, where arccos of the trace is not)."""
    from scipy.spatial.transform import Rotation
    R = np.asarray(R, dtype=float)
    return Rotation.from_matrix(R.reshape(-1, 3, 3)).magnitude().reshape(R.shape[:-2])


def se3(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def se3_inverse(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms (4, 4) or (N, 4, 4)."""
    T = np.asarray(T, dtype=float)
    R = T[..., :3, :3]
    t = T[..., :3, 3]
    Rt = np.swapaxes(R, -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, t)
    out[..., 3, 3] = 1.0
    return out


def se3_exp(w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Exponential of the twist (w rad, v) as a 4x4 transform."""
    w = np.asarray(w, dtype=float)
    theta = float(np.linalg.norm(w))
    W = skew(w)
    if theta < 1e-8:
        B, C = 0.5 - theta**2 / 24, 1 / 6 - theta**2 / 120
    else:
        B, C = (1 - np.cos(theta)) / theta**2, (theta - np.sin(theta)) / theta**3
    V = np.eye(3) + B * W + C * W @ W
    return se3(so3_exp(w), V @ np.asarray(v, dtype=float))


def se3_log(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Twist (w rad, v) with se3_exp(w, v) == T."""
    w = so3_log(T[:3, :3])
    theta = float(np.linalg.norm(w))
    W = skew(w)
    if theta < 1e-8:
        V_inv = np.eye(3) - 0.5 * W + W @ W / 12
    else:
        A, B = np.sin(theta) / theta, (1 - np.cos(theta)) / theta**2
        V_inv = np.eye(3) - 0.5 * W + (1 - A / (2 * B)) / theta**2 * W @ W
    return w, V_inv @ T[:3, 3]


def relative(T_world_a: np.ndarray, T_world_b: np.ndarray) -> np.ndarray:
    """T_a_b = inv(T_world_a) @ T_world_b (broadcasts over stacks; exact rigid inverse)."""
    R_a_T = np.swapaxes(T_world_a[..., :3, :3], -1, -2)
    out = np.zeros(np.broadcast_shapes(np.shape(T_world_a), np.shape(T_world_b)))
    out[..., :3, :3] = R_a_T @ T_world_b[..., :3, :3]
    out[..., :3, 3] = np.einsum("...ij,...j->...i", R_a_T, T_world_b[..., :3, 3] - T_world_a[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def quat_xyzw_to_R(q: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions, scalar last (TUM order) -> (N, 3, 3); normalises."""
    from scipy.spatial.transform import Rotation
    return Rotation.from_quat(np.asarray(q, dtype=float)).as_matrix()


def R_to_quat_xyzw(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation
    return Rotation.from_matrix(R).as_quat()
