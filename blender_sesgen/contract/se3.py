"""Rigid-body maths on numpy arrays: SO(3), SE(3), unit quaternions, Euler angles.

The one home of this maths for both packages (numpy only: it runs in Blender's Python).
``T_a_b`` maps coordinates in frame b to frame a; poses are (4, 4) or stacks (..., 4, 4).
Rotation vectors and twists are in radians; only names ending in ``_deg`` hold degrees.
Quaternions are unit, ``xyzw`` (scalar last, the TUM order) unless a name says ``wxyz``,
and come out with ``w >= 0``. Euler angles follow the SES rule: XYZ about the fixed
world axes, ``R = Rz @ Ry @ Rx``.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .errors import ContractError

SMALL_ANGLE_RAD = 1e-8  # below it the closed forms switch to their Taylor series


def skew(w: Sequence[float]) -> np.ndarray:
    """(3, 3) cross-product matrix [w]x of one 3-vector."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _skew_stack(w: np.ndarray) -> np.ndarray:
    W = np.zeros(w.shape[:-1] + (3, 3))
    W[..., 0, 1], W[..., 0, 2], W[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    return W - np.swapaxes(W, -1, -2)


def se3(R: np.ndarray, t: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """The 4x4 transform [[R, t], [0, 1]]."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def translation(t: Sequence[float]) -> np.ndarray:
    """The 4x4 pure translation by ``t``."""
    return se3(np.eye(3), t)


def invert(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms (4, 4) or (..., 4, 4): exact, no general matrix inverse."""
    T = np.asarray(T, dtype=float)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def relative(T_world_a: np.ndarray, T_world_b: np.ndarray) -> np.ndarray:
    """``T_a_b = inv(T_world_a) @ T_world_b`` (broadcasts over stacks; exact rigid inverse)."""
    T_world_a = np.asarray(T_world_a, dtype=float)
    T_world_b = np.asarray(T_world_b, dtype=float)
    R_a_T = np.swapaxes(T_world_a[..., :3, :3], -1, -2)
    out = np.zeros(np.broadcast_shapes(T_world_a.shape, T_world_b.shape))
    out[..., :3, :3] = R_a_T @ T_world_b[..., :3, :3]
    out[..., :3, 3] = np.einsum("...ij,...j->...i", R_a_T, T_world_b[..., :3, 3] - T_world_a[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


# --- quaternions ----------------------------------------------------------------------

def R_to_quat_xyzw(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) ``xyzw`` with w >= 0 of rotation matrices (..., 3, 3).

    Shepperd's method: the largest of the four candidate divisors, per matrix.
    """
    R = np.asarray(R, dtype=float)
    tr = np.trace(R, axis1=-2, axis2=-1)
    r00, r11, r22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    pick = np.argmax(np.stack([tr, r00, r11, r22], axis=-1), axis=-1)
    q = np.empty(R.shape[:-2] + (4,))
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.sqrt(np.maximum(1.0 + tr, 0.0)) / 2.0
        x = np.sqrt(np.maximum(1.0 + 2 * r00 - tr, 0.0)) / 2.0
        y = np.sqrt(np.maximum(1.0 + 2 * r11 - tr, 0.0)) / 2.0
        z = np.sqrt(np.maximum(1.0 + 2 * r22 - tr, 0.0)) / 2.0
        a21, a02, a10 = R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]
        s01, s02, s12 = R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]
        cands = (
            np.stack([a21 / (4 * w), a02 / (4 * w), a10 / (4 * w), w], axis=-1),
            np.stack([x, s01 / (4 * x), s02 / (4 * x), a21 / (4 * x)], axis=-1),
            np.stack([s01 / (4 * y), y, s12 / (4 * y), a02 / (4 * y)], axis=-1),
            np.stack([s02 / (4 * z), s12 / (4 * z), z, a10 / (4 * z)], axis=-1),
        )
    for i, c in enumerate(cands):
        sel = pick == i
        q[sel] = c[sel]
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., 3:4] < 0, -q, q)


def quat_xyzw_to_R(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of quaternions (..., 4) ``xyzw`` (normalised first).

    A quaternion of (near) zero norm or with a non-finite component has no rotation:
    :class:`ContractError`.
    """
    q = np.asarray(q, dtype=float)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if not np.all(np.isfinite(q)) or np.any(norm < 1e-12):
        raise ContractError("a quaternion with zero norm or non-finite values is not a rotation")
    x, y, z, w = np.moveaxis(q / norm, -1, 0)
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
    R[..., 1, 0], R[..., 1, 1], R[..., 1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
    R[..., 2, 0], R[..., 2, 1], R[..., 2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
    return R


# --- SO(3) ----------------------------------------------------------------------------

def so3_exp(w_rad: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation matrices (..., 3, 3) of rotation vectors (..., 3) in radians."""
    w = np.asarray(w_rad, dtype=float)
    theta = np.linalg.norm(w, axis=-1)[..., None, None]
    W = _skew_stack(w)
    small = theta < SMALL_ANGLE_RAD
    th = np.where(small, 1.0, theta)
    A = np.where(small, 1.0 - theta**2 / 6.0, np.sin(th) / th)
    B = np.where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(th)) / th**2)
    return np.eye(3) + A * W + B * (W @ W)


def so3_log(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3), radians, of rotation matrices (..., 3, 3).

    Through the quaternion (angle = 2 atan2(|v|, w)): accurate near 0 and near pi, where the
    arccos of the trace is not.
    """
    q = R_to_quat_xyzw(R)
    v, w = q[..., :3], q[..., 3]
    s = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(s, w)
    small = s < 1e-12
    scale = np.where(small, 2.0 / np.where(w == 0, 1.0, w), angle / np.where(small, 1.0, s))
    return v * scale[..., None]


def rotation_angle_rad(R: np.ndarray) -> np.ndarray:
    """Angle (rad, in [0, pi]) of rotation matrices (..., 3, 3)."""
    return np.linalg.norm(so3_log(R), axis=-1)


def orthonormality_error(R: np.ndarray) -> np.ndarray:
    """max |R^T R - I| of each matrix of a stack (n, 3, 3): (n,)."""
    return np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max(axis=(1, 2))


def not_rotations(R: np.ndarray, tolerance: float) -> np.ndarray:
    """bool (n,): which matrices of a stack (n, 3, 3) are no rotation within ``tolerance``
    (max |R^T R - I| above it or not finite, or a reflection: det < 0). The one validity
    check of every rotation read from a file."""
    return ~(orthonormality_error(R) <= tolerance) | (np.linalg.det(R) < 0)


# --- SE(3) ----------------------------------------------------------------------------

def se3_exp(omega_rad: Sequence[float], v: Sequence[float]) -> np.ndarray:
    """Exponential of one twist [omega, v] (rotation in rad, translation) as a 4x4 transform.

    Closed form (Rodrigues with the left Jacobian V): T = [[R, V v], [0, 1]].
    """
    w = np.asarray(omega_rad, dtype=float)
    v = np.asarray(v, dtype=float)
    theta = float(np.linalg.norm(w))
    W = skew(w)
    W2 = W @ W
    if theta < SMALL_ANGLE_RAD:  # Taylor series to second order
        A, B, C = 1.0 - theta**2 / 6.0, 0.5 - theta**2 / 24.0, 1.0 / 6.0 - theta**2 / 120.0
    else:
        A = np.sin(theta) / theta
        B = (1.0 - np.cos(theta)) / theta**2
        C = (theta - np.sin(theta)) / theta**3
    R = np.eye(3) + A * W + B * W2
    V = np.eye(3) + B * W + C * W2
    return se3(R, V @ v)


def se3_log(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Twists (omega_rad, v), each (..., 3), with ``se3_exp(omega, v) == T`` (angle < pi)."""
    T = np.asarray(T, dtype=float)
    w = so3_log(T[..., :3, :3])
    theta = np.linalg.norm(w, axis=-1)[..., None, None]
    W = _skew_stack(w)
    small = theta < 1e-6
    th = np.where(small, 1.0, theta)
    # V^-1 = I - W/2 + (1/th^2)(1 - th sin th / (2 (1 - cos th))) W^2; series 1/12 + th^2/720 near 0
    coef = np.where(small, 1.0 / 12.0 + theta**2 / 720.0,
                    (1.0 - th * np.sin(th) / (2.0 * (1.0 - np.cos(th)))) / th**2)
    V_inv = np.eye(3) - 0.5 * W + coef * (W @ W)
    return w, np.einsum("...ij,...j->...i", V_inv, T[..., :3, 3])


# --- Euler angles (the SES rule) ---------------------------------------------------------

def euler_xyz_deg_to_R(rx_deg: float, ry_deg: float, rz_deg: float) -> np.ndarray:
    """Rotation of XYZ Euler angles in degrees about the fixed axes: Rz @ Ry @ Rx."""
    ax, ay, az = np.radians([rx_deg, ry_deg, rz_deg])
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def R_to_euler_xyz_deg(R: np.ndarray) -> tuple[float, float, float]:
    """Inverse of :func:`euler_xyz_deg_to_R` (ry in [-90, 90]; at gimbal lock rz = 0)."""
    ry = np.arcsin(np.clip(-R[2, 0], -1.0, 1.0))
    if abs(R[2, 0]) < 1.0 - 1e-12:
        rx = np.arctan2(R[2, 1], R[2, 2])
        rz = np.arctan2(R[1, 0], R[0, 0])
    else:
        rz = 0.0
        rx = np.arctan2(-R[1, 2], R[1, 1])
    return tuple(float(a) for a in np.degrees([rx, ry, rz]))


# --- interpolation between two poses ------------------------------------------------------

def interpolate_pose(T_world_a: np.ndarray, T_world_b: np.ndarray, s: float) -> np.ndarray:
    """The pose a fraction ``s`` of the way from ``T_world_a`` to ``T_world_b`` as keyframes
    are interpolated: the position moves on the straight line between them, the orientation
    turns at constant angular velocity about one axis (slerp),
    R = R_a @ exp(s * log(R_a^T R_b)), t = (1 - s) t_a + s t_b.

    s = 0 gives T_a, s = 1 gives T_b (to rounding). The rotation from a to b must be < 180 deg.
    ``s`` may be an array of fractions: (len(s), 4, 4); with stacks of poses (n, 4, 4) it holds
    one fraction per pair. See also :func:`interpolate_twist`.
    """
    T_a, T_b = np.asarray(T_world_a, dtype=float), np.asarray(T_world_b, dtype=float)
    if T_a.ndim == 3:         # stacks of pairs (n, 4, 4), one fraction each (n,): (n, 4, 4)
        s = np.asarray(s, dtype=float)[:, None]
        w = so3_log(np.swapaxes(T_a[:, :3, :3], 1, 2) @ T_b[:, :3, :3])
        out = np.zeros(T_a.shape)
        out[:, :3, :3] = T_a[:, :3, :3] @ so3_exp(s * w)
        out[:, :3, 3] = (1.0 - s) * T_a[:, :3, 3] + s * T_b[:, :3, 3]
        out[:, 3, 3] = 1.0
        return out
    w = so3_log(T_a[:3, :3].T @ T_b[:3, :3])
    if np.ndim(s):            # many fractions at once: (n, 4, 4)
        s = np.asarray(s, dtype=float)
        out = np.zeros(s.shape + (4, 4))
        out[..., :3, :3] = T_a[:3, :3] @ so3_exp(s[..., None] * w)
        out[..., :3, 3] = (1.0 - s)[..., None] * T_a[:3, 3] + s[..., None] * T_b[:3, 3]
        out[..., 3, 3] = 1.0
        return out
    R = T_a[:3, :3] @ so3_exp(float(s) * w)
    return se3(R, (1.0 - float(s)) * T_a[:3, 3] + float(s) * T_b[:3, 3])


def interpolate_twist(T_world_a: np.ndarray, T_world_b: np.ndarray, s: float) -> np.ndarray:
    """The pose a fraction ``s`` of the way from ``T_world_a`` to ``T_world_b`` along the
    constant body twist that joins them (the SE(3) geodesic, how EGO moves the rig within a
    frame step): T_a @ exp(s * log(inv(T_a) @ T_b)). The rotation must be < 180 deg.
    See also :func:`interpolate_pose`."""
    w, v = se3_log(relative(T_world_a, T_world_b))
    return np.asarray(T_world_a, dtype=float) @ se3_exp(float(s) * w, float(s) * v)
