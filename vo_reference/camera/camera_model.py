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

from ..errors import VoError


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
    if not path.is_file():
        raise VoError(f"{path}: no such camera model file")
    lines = [ln.split() for ln in path.read_text(encoding="utf-8", errors="replace").splitlines() if ln.strip()]
    try:
        vals = [[float(v) for v in ln] for ln in lines]
    except ValueError:
        raise VoError(f"{path}: a camera model holds numbers only") from None
    if len(vals) < 5 or len(vals[0]) != 4 or any(len(r) != 4 for r in vals[1:5]):
        raise VoError(f"{path}: expected 'fx fy cx cy' then four rows of G_camera_image (4 numbers each)")
    fx, fy, cx, cy = vals[0]
    if fx <= 0 or fy <= 0:
        raise VoError(f"{path}: focal lengths must be positive, got {fx}, {fy}")
    return CameraModel(path.stem, fx, fy, cx, cy, np.array(vals[1:5]))


def write_camera_model(path, K: np.ndarray, G_camera_image: np.ndarray | None = None) -> None:
    G = np.eye(4) if G_camera_image is None else np.asarray(G_camera_image, dtype=float)
    rows = [f"{K[0, 0]:.6f} {K[1, 1]:.6f} {K[0, 2]:.6f} {K[1, 2]:.6f}"]
    rows += [" ".join(f"{v:.6f}" for v in r) for r in G]
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text("\n".join(rows) + "\n", encoding="utf-8")
