"""The stereo rig, in one place: rectified and parallel, both views with the same K.

The rig's pose is the left camera's. The right camera sits ``baseline_m`` along the left
camera's +x axis (OpenCV camera: x right)::

    T_left_right = trans(B, 0, 0)        T_world_right = T_world_left @ T_left_right
    T_right_left = trans(-B, 0, 0)       X_right = X_left - (B, 0, 0)

Every module that needs the right view's pose, a point in the right camera or the right
camera's projection matrix asks this module (a test keeps baseline arithmetic here and in
``depth``, the disparity relation d = f B / Z).
"""
from __future__ import annotations

import numpy as np

VIEWS = ("left", "right")


def _check_view(view: str) -> None:
    if view not in VIEWS:
        raise ValueError(f"view must be one of {', '.join(VIEWS)}, got {view!r}")


def T_left_right(baseline_m: float) -> np.ndarray:
    """(4, 4) pose of the right camera in the left camera's frame: trans(B, 0, 0)."""
    T = np.eye(4)
    T[0, 3] = float(baseline_m)
    return T


def T_right_left(baseline_m: float) -> np.ndarray:
    """(4, 4) the left camera's frame seen from the right camera: trans(-B, 0, 0)."""
    T = np.eye(4)
    T[0, 3] = -float(baseline_m)
    return T


def T_left_view(view: str, baseline_m: float) -> np.ndarray:
    """(4, 4) pose of ``view``'s camera in the left camera's frame (identity for the left)."""
    _check_view(view)
    return T_left_right(baseline_m) if view == "right" else np.eye(4)


def T_view_left(view: str, baseline_m: float) -> np.ndarray:
    """(4, 4) left-camera coordinates -> ``view``'s camera coordinates."""
    _check_view(view)
    return T_right_left(baseline_m) if view == "right" else np.eye(4)


def T_world_view(T_world_left: np.ndarray, view: str, baseline_m: float) -> np.ndarray:
    """``view``'s camera pose(s) from the rig's (left) pose(s), (4, 4) or a stack (N, 4, 4):
    T_world_right = T_world_left @ trans(B, 0, 0) (written as t + B * x-axis: the same bits
    for every caller). Always a new array."""
    _check_view(view)
    T = np.array(T_world_left, dtype=float)
    if view == "right":
        T[..., :3, 3] += float(baseline_m) * T[..., :3, 0]
    return T


def right_from_left(T_world_left: np.ndarray, baseline_m: float) -> np.ndarray:
    """Right camera pose(s) of a rig pose (or stack): :func:`T_world_view` of the right view."""
    return T_world_view(T_world_left, "right", baseline_m)


def points_in_view(P_left: np.ndarray, view: str, baseline_m: float) -> np.ndarray:
    """Points (..., 3) given in the left camera's frame, in ``view``'s camera frame."""
    return np.asarray(P_left) + T_view_left(view, baseline_m)[:3, 3]


def projection_matrix(K: np.ndarray, view: str, baseline_m: float) -> np.ndarray:
    """(3, 4) P = K [I | t] of ``view`` with the left camera as the world (KITTI's P0/P1)."""
    K = np.asarray(K, dtype=float)
    P = np.hstack([K, np.zeros((3, 1))])
    P[:, 3] = K @ T_view_left(view, baseline_m)[:3, 3]
    return P
