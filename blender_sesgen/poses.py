"""Pose math for SES scripts (numpy only: this runs inside Blender's own Python).

Conventions (see docs/ses-language.md):
- SES world: right-handed, Y up. Blender world: Z up.
- Camera frame: OpenCV (x right, y down, z forward). Blender cameras look along -z with y up.
- ``T_a_b`` maps coordinates in frame b to frame a (4x4 homogeneous); ``T_world_cam`` is
  the camera's pose in the world.
- Euler angles in scripts are degrees, applied X then Y then Z about the world axes:
  R = Rz @ Ry @ Rx.
"""
from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np

# The one home of each axis convention.
R_CV_BLENDERCAM = np.diag([1.0, -1.0, -1.0])  # OpenCV camera axes <-> Blender camera axes (own inverse)
R_BLENDER_SES = np.array([[1.0, 0.0, 0.0],    # SES world (Y up) -> Blender world (Z up):
                          [0.0, 0.0, -1.0],   # +90 deg about X: (x, y, z) -> (x, -z, y)
                          [0.0, 1.0, 0.0]])


def _homogeneous(R: np.ndarray, t: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def euler_xyz_deg_to_R(rx_deg: float, ry_deg: float, rz_deg: float) -> np.ndarray:
    """Rotation matrix of XYZ Euler angles in degrees about the fixed axes: Rz @ Ry @ Rx."""
    ax, ay, az = np.radians([rx_deg, ry_deg, rz_deg])
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def R_to_euler_xyz_deg(R: np.ndarray) -> tuple[float, float, float]:
    """Inverse of :func:`euler_xyz_deg_to_R` (ry in [-90, 90])."""
    ry = np.arcsin(np.clip(-R[2, 0], -1.0, 1.0))
    if abs(R[2, 0]) < 1.0 - 1e-12:
        rx = np.arctan2(R[2, 1], R[2, 2])
        rz = np.arctan2(R[1, 0], R[0, 0])
    else:  # gimbal lock: put everything into rx
        rz = 0.0
        rx = np.arctan2(-R[1, 2], R[1, 1])
    return tuple(float(a) for a in np.degrees([rx, ry, rz]))


def object_pose(position: Sequence[float], rotation_deg: Sequence[float] = (0, 0, 0)) -> np.ndarray:
    """``T_world_object`` (SES world) of an object's ``position x y z [rx ry rz]``."""
    return _homogeneous(euler_xyz_deg_to_R(*rotation_deg), position)


def start_pose(position: Sequence[float], rotation_deg: Sequence[float] = (0, 0, 0)) -> np.ndarray:
    """``T_world_cam`` (SES world, OpenCV camera) of ``START position x y z [rx ry rz]``.

    With no rotation the camera looks along world -Z with world +Y up:
    R_world_cam = R(rx, ry, rz) @ diag(1, -1, -1).
    """
    return _homogeneous(euler_xyz_deg_to_R(*rotation_deg) @ np.diag([1.0, -1.0, -1.0]), position)


def skew(w: Sequence[float]) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def se3_exp(omega_rad: Sequence[float], v: Sequence[float]) -> np.ndarray:
    """Exponential of the twist [omega, v] (rotation rate in rad, velocity) as a 4x4 transform.

    Closed form (Rodrigues with the left Jacobian V): T = [[R, V v], [0, 1]].
    """
    w = np.asarray(omega_rad, dtype=float)
    v = np.asarray(v, dtype=float)
    theta = float(np.linalg.norm(w))
    W = skew(w)
    W2 = W @ W
    if theta < 1e-8:  # Taylor series to second order
        A, B, C = 1.0 - theta**2 / 6.0, 0.5 - theta**2 / 24.0, 1.0 / 6.0 - theta**2 / 120.0
    else:
        A = np.sin(theta) / theta
        B = (1.0 - np.cos(theta)) / theta**2
        C = (theta - np.sin(theta)) / theta**3
    R = np.eye(3) + A * W + B * W2
    V = np.eye(3) + B * W + C * W2
    return _homogeneous(R, V @ v)


def ego_step(U: float, V: float, W: float, alpha_deg: float, beta_deg: float, gamma_deg: float) -> np.ndarray:
    """``T_k_k1``: the camera motion of one EGO line, expressed in the camera frame at k.

    The motion is a constant body twist over the frame interval: translation velocity
    (U, V, W) and rotation rates (alpha, beta, gamma) about the camera's x, y, z axes.
    """
    return se3_exp(np.radians([alpha_deg, beta_deg, gamma_deg]), (U, V, W))


def integrate_ego(T_world_cam0: np.ndarray, steps: Iterable[Sequence[float]]) -> np.ndarray:
    """Poses (N+1, 4, 4) of the camera after each EGO step: T(k+1) = T(k) @ exp([w, v])."""
    poses = [np.asarray(T_world_cam0, dtype=float)]
    for step in steps:
        poses.append(poses[-1] @ ego_step(*step))
    return np.stack(poses)


def relative_motion(T_world_a: np.ndarray, T_world_b: np.ndarray) -> np.ndarray:
    """``T_a_b`` = inv(T_world_a) @ T_world_b: frame b's pose in frame a."""
    return invert(T_world_a) @ T_world_b


def invert(T: np.ndarray) -> np.ndarray:
    """Inverse of a rigid transform (exact, no general matrix inverse)."""
    R, t = T[:3, :3], T[:3, 3]
    return _homogeneous(R.T, -R.T @ t)


def right_from_left(T_world_left: np.ndarray, baseline: float) -> np.ndarray:
    """Right camera of a rectified parallel rig: T_world_right = T_world_left @ trans(B, 0, 0)."""
    return T_world_left @ _homogeneous(np.eye(3), (baseline, 0.0, 0.0))


def ses_to_blender_world(T_ses: np.ndarray) -> np.ndarray:
    """Re-express a pose (or any transform whose target frame is the SES world) in Blender's world."""
    return _homogeneous(R_BLENDER_SES) @ T_ses


def blender_to_ses_world(T_blender: np.ndarray) -> np.ndarray:
    return _homogeneous(R_BLENDER_SES.T) @ T_blender


def cv_to_blender_camera(T_world_cam_cv: np.ndarray) -> np.ndarray:
    """OpenCV camera pose -> Blender camera object's pose (same world): right-multiply the flip."""
    return T_world_cam_cv @ _homogeneous(R_CV_BLENDERCAM)


def blender_to_cv_camera(T_world_cam_blender: np.ndarray) -> np.ndarray:
    return T_world_cam_blender @ _homogeneous(R_CV_BLENDERCAM)


def camera_matrix_world(T_world_cam_cv_ses: np.ndarray) -> np.ndarray:
    """The Blender ``matrix_world`` of a camera whose OpenCV pose is given in the SES world."""
    return cv_to_blender_camera(ses_to_blender_world(T_world_cam_cv_ses))


def interpolate_pose(T_world_a: np.ndarray, T_world_b: np.ndarray, s: float) -> np.ndarray:
    """The pose a fraction ``s`` of the way from ``T_world_a`` to ``T_world_b`` as keyframes
    are interpolated: the position moves on the straight line between them, the orientation
    turns at constant angular velocity about one axis (slerp),
    R = R_a @ exp(s * log(R_a^T R_b)), t = (1 - s) t_a + s t_b.

    s = 0 gives T_a, s = 1 gives T_b (to rounding). The rotation from a to b must be < 180 deg.
    """
    T_a, T_b = np.asarray(T_world_a, dtype=float), np.asarray(T_world_b, dtype=float)
    w, _ = se3_log(relative_motion(T_a, T_b))
    R = T_a[:3, :3] @ se3_exp(float(s) * w, (0.0, 0.0, 0.0))[:3, :3]
    return _homogeneous(R, (1.0 - float(s)) * T_a[:3, 3] + float(s) * T_b[:3, 3])


def interpolate_twist(T_world_a: np.ndarray, T_world_b: np.ndarray, s: float) -> np.ndarray:
    """The pose a fraction ``s`` of the way from ``T_world_a`` to ``T_world_b`` along the
    constant body twist that joins them (the SE(3) geodesic, how EGO moves the rig within a
    frame step): T_a @ exp(s * log(inv(T_a) @ T_b)). The rotation must be < 180 deg."""
    w, v = se3_log(relative_motion(T_world_a, T_world_b))
    return np.asarray(T_world_a, dtype=float) @ se3_exp(float(s) * w, float(s) * v)


def rotation_angle_deg(T_a_b: np.ndarray) -> float:
    """Angle of the rotation part of a transform, in degrees (0..180)."""
    R = np.asarray(T_a_b, dtype=float)[:3, :3]
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))))


def ego_from_poses(T_world_a: np.ndarray, T_world_b: np.ndarray) -> tuple[float, ...]:
    """(U, V, W, alpha, beta, gamma) of the constant body twist that takes pose a to pose b.

    The inverse of :func:`ego_step` (log map of SE(3)); angles in degrees.
    """
    T = relative_motion(T_world_a, T_world_b)
    w, v = se3_log(T)
    return (*(float(x) for x in v), *(float(a) for a in np.degrees(w)))


def se3_log(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Twist (omega_rad, v) with se3_exp(omega, v) == T (rotation angle < pi)."""
    R, t = T[:3, :3], T[:3, 3]
    cos_theta = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    theta = float(np.arccos(cos_theta))
    if theta < 1e-8:
        w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2.0
    elif np.pi - theta < 1e-6:
        # near pi: axis from the symmetric part
        M = (R + np.eye(3)) / 2.0
        axis = np.sqrt(np.clip(np.diag(M), 0.0, None))
        k = int(np.argmax(axis))
        axis = M[:, k] / np.sqrt(M[k, k])
        w = axis * theta
    else:
        w = theta / (2.0 * np.sin(theta)) * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    theta = float(np.linalg.norm(w))
    W = skew(w)
    if theta < 1e-8:
        V_inv = np.eye(3) - 0.5 * W + W @ W / 12.0
    else:
        A = np.sin(theta) / theta
        B = (1.0 - np.cos(theta)) / theta**2
        V_inv = np.eye(3) - 0.5 * W + (1.0 - A / (2.0 * B)) / theta**2 * (W @ W)
    return w, V_inv @ t
