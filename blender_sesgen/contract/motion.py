"""EGO motion: the SES language's per-frame body twist, in one unit convention.

An EGO line ``U V W alpha beta gamma`` is the rig's motion from frame k to k+1 expressed in
the left camera's frame at k: translation (U, V, W) and rotation (alpha, beta, gamma) about
the camera's x, y, z axes in **degrees** (right-hand rule), taken as a constant body twist
over the frame interval: ``T(k+1) = T(k) @ exp([omega, v])`` with omega in radians. Degrees
exist only in EGO rows (scripts, tables, reports); every computation uses
:func:`ego_to_twist` / :func:`twist_to_ego` at that boundary.
"""
from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np

from .se3 import relative, se3_exp, se3_log

EGO_COLUMNS = ("U", "V", "W", "alpha_deg", "beta_deg", "gamma_deg")


def ego_to_twist(ego: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """(omega_rad (..., 3), v (..., 3)) of EGO rows (..., 6) ``U V W alpha beta gamma`` (deg)."""
    e = np.asarray(ego, dtype=float)
    return np.radians(e[..., 3:6]), e[..., 0:3]


def twist_to_ego(omega_rad: np.ndarray, v: np.ndarray) -> np.ndarray:
    """EGO rows (..., 6) of twists: (U, V, W) = v, (alpha, beta, gamma) = omega in degrees."""
    return np.concatenate([np.asarray(v, dtype=float), np.degrees(omega_rad)], axis=-1)


def ego_step(U: float, V: float, W: float, alpha_deg: float, beta_deg: float, gamma_deg: float) -> np.ndarray:
    """``T_k_k1``: the camera motion of one EGO line, expressed in the camera frame at k."""
    omega_rad, v = ego_to_twist((U, V, W, alpha_deg, beta_deg, gamma_deg))
    return se3_exp(omega_rad, v)


def integrate_ego(T_world_cam0: np.ndarray, steps: Iterable[Sequence[float]]) -> np.ndarray:
    """Poses (N+1, 4, 4) of the camera after each EGO step: T(k+1) = T(k) @ exp([w, v])."""
    poses = [np.asarray(T_world_cam0, dtype=float)]
    for step in steps:
        poses.append(poses[-1] @ ego_step(*step))
    return np.stack(poses)


def ego_between(T_world_a: np.ndarray, T_world_b: np.ndarray) -> np.ndarray:
    """EGO rows (..., 6) of the constant body twists that take poses a to poses b (log map)."""
    omega_rad, v = se3_log(relative(T_world_a, T_world_b))
    return twist_to_ego(omega_rad, v)


def ego_from_poses(T_world_a: np.ndarray, T_world_b: np.ndarray) -> tuple[float, ...]:
    """(U, V, W, alpha, beta, gamma) taking one pose a to pose b: inverse of :func:`ego_step`."""
    return tuple(float(x) for x in ego_between(T_world_a, T_world_b))


def ego_table(T_world_cam: np.ndarray) -> np.ndarray:
    """(N-1, 6) per-step EGO rows of a pose sequence (N, 4, 4)."""
    T = np.asarray(T_world_cam, dtype=float)
    return ego_between(T[:-1], T[1:]).reshape(-1, 6)
