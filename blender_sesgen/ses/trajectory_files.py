"""Small readers for the trajectory files that ``TRAJECTORY`` replays (TUM and KITTI).

Kept here (not in vo_reference) because blender_sesgen must not import vo_reference.
- TUM: ``timestamp tx ty tz qx qy qz qw`` per line (quaternion scalar last); '#' comments.
- KITTI: 12 numbers per line, the first three rows of T_world_cam, row-major.
Both give camera-to-world poses with an OpenCV camera frame. Errors are TrajectoryFileError
with the 1-based line in the file; the parser reports them at the script's ``file`` token.
"""
from __future__ import annotations

import math

import numpy as np


class TrajectoryFileError(ValueError):
    pass


def read_trajectory(path: str, fmt: str) -> np.ndarray:
    """(N, 4, 4) poses T_world_cam of a TUM or KITTI file (N >= 1)."""
    try:
        with open(path, "rb") as f:
            data = f.read()
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise TrajectoryFileError("is not UTF-8 text") from None
    except OSError as e:
        raise TrajectoryFileError(f"cannot be read ({e.strerror})") from None
    ncols = {"tum": 8, "kitti": 12}[fmt]
    poses = []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        fields = s.replace(",", " ").split()
        if len(fields) != ncols:
            raise TrajectoryFileError(f"line {lineno}: a {fmt.upper()} pose has {ncols} numbers, got {len(fields)}")
        try:
            values = [float(x) for x in fields]
        except ValueError:
            raise TrajectoryFileError(f"line {lineno}: not a number in '{s[:60]}'") from None
        if not all(math.isfinite(v) for v in values):
            raise TrajectoryFileError(f"line {lineno}: numbers must be finite")
        poses.append(_tum_pose(values, lineno) if fmt == "tum" else _kitti_pose(values, lineno))
    if not poses:
        raise TrajectoryFileError("holds no poses")
    return np.stack(poses)


def _tum_pose(values: list[float], lineno: int) -> np.ndarray:
    t = values[1:4]
    q = np.array(values[4:8])  # qx qy qz qw
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > 1e-3:
        raise TrajectoryFileError(f"line {lineno}: quaternion norm is {norm:.6g}, expected 1")
    x, y, z, w = q / norm
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def _kitti_pose(values: list[float], lineno: int) -> np.ndarray:
    T = np.eye(4)
    T[:3, :] = np.array(values).reshape(3, 4)
    R = T[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0:
        raise TrajectoryFileError(f"line {lineno}: the 3x3 part is not a rotation")
    # re-orthonormalise (files hold ~6 digits) so later products stay rigid
    U, _, Vt = np.linalg.svd(R)
    T[:3, :3] = U @ Vt
    return T
