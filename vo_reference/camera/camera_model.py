"""RobotCar camera model files (the dataset SDK's ``models/<camera>.txt``).

Line 1: ``fx fy cx cy`` (pixels, of the undistorted image); lines 2-5: the 4x4
``G_camera_image`` (the camera frame's axes expressed for the image frame). The matching
undistortion table is ``<camera>_distortion_lut.bin`` next to it in the SDK (not shipped
here; see :mod:`.undistort`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blender_sesgen.contract.camera import K_problem
from blender_sesgen.contract.inputs import read_text
from blender_sesgen.contract.manifest import LIMIT
from blender_sesgen.contract.trajectory_files import parse_table

from ..errors import VoError, as_vo_error


@dataclass(frozen=True)
class CameraModel:
    name: str
    fx: float
    fy: float
    cx: float
    cy: float
    G_camera_image: np.ndarray     # (4, 4)

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])


def read_camera_model(path) -> CameraModel:
    path = Path(path)
    if not path.exists():
        raise VoError(f"{path}: no such camera model file")
    with as_vo_error():
        rows, _ = parse_table(read_text(path, what="camera model", strict=False), (4,), str(path),
                              "a camera model row")
    if len(rows) < 5:
        raise VoError(f"{path}: expected 'fx fy cx cy' then four rows of G_camera_image (4 numbers each)")
    vals = rows.tolist()
    fx, fy, cx, cy = vals[0]
    problem = K_problem(np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]]), LIMIT)
    if problem:
        raise VoError(f"{path}: {problem}")
    return CameraModel(path.stem, fx, fy, cx, cy, np.array(vals[1:5]))


def write_camera_model(path, K: np.ndarray, G_camera_image: np.ndarray | None = None) -> None:
    G = np.eye(4) if G_camera_image is None else np.asarray(G_camera_image, dtype=float)
    rows = [f"{K[0, 0]:.6f} {K[1, 1]:.6f} {K[0, 2]:.6f} {K[1, 2]:.6f}"]
    rows += [" ".join(f"{v:.6f}" for v in r) for r in G]
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text("\n".join(rows) + "\n", encoding="utf-8")
