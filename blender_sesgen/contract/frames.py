"""Coordinate frames: the SES world, the OpenCV camera, Blender's world and camera, the rig.

- SES world: right-handed, **Y up** (as in SESGen/OpenGL). Blender's world is Z up:
  ``R_BLENDER_SES`` turns SES coordinates into Blender's (+90 deg about X).
- Camera frame everywhere outside Blender: **OpenCV** (x right, y down, z forward).
  Blender cameras look along -z with y up: ``R_CV_BLENDERCAM`` (its own inverse).
- ``START position x y z [rx ry rz]``: R_world_cam = R(rx, ry, rz) @ ``R_START_CAM``, so with
  no rotation the camera looks along world -Z with world +Y up.
- The stereo rig (pose = left camera, right = left @ trans(B, 0, 0)): ``contract.rig``.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .se3 import R_to_euler_xyz_deg, euler_xyz_deg_to_R, se3

R_CV_BLENDERCAM = np.diag([1.0, -1.0, -1.0])  # OpenCV camera axes <-> Blender camera axes (own inverse)
R_START_CAM = np.diag([1.0, -1.0, -1.0])      # START's "no rotation": look along world -Z, +Y up
R_BLENDER_SES = np.array([[1.0, 0.0, 0.0],    # SES world (Y up) -> Blender world (Z up):
                          [0.0, 0.0, -1.0],   # +90 deg about X: (x, y, z) -> (x, -z, y)
                          [0.0, 1.0, 0.0]])


def object_pose(position: Sequence[float], rotation_deg: Sequence[float] = (0, 0, 0)) -> np.ndarray:
    """``T_world_object`` (SES world) of an object's ``position x y z [rx ry rz]``."""
    return se3(euler_xyz_deg_to_R(*rotation_deg), position)


def start_pose(position: Sequence[float], rotation_deg: Sequence[float] = (0, 0, 0)) -> np.ndarray:
    """``T_world_cam`` (SES world, OpenCV camera) of ``START position x y z [rx ry rz]``."""
    return se3(euler_xyz_deg_to_R(*rotation_deg) @ R_START_CAM, position)


def start_rotation_deg(T_world_cam: np.ndarray) -> tuple[float, float, float]:
    """The START-statement angles (rx, ry, rz) of a camera pose: inverse of :func:`start_pose`."""
    return R_to_euler_xyz_deg(np.asarray(T_world_cam)[:3, :3] @ R_START_CAM)


def ses_to_blender_world(T_ses: np.ndarray) -> np.ndarray:
    """Re-express a pose (or any transform whose target frame is the SES world) in Blender's world."""
    return se3(R_BLENDER_SES) @ T_ses


def blender_to_ses_world(T_blender: np.ndarray) -> np.ndarray:
    return se3(R_BLENDER_SES.T) @ T_blender


def cv_to_blender_camera(T_world_cam_cv: np.ndarray) -> np.ndarray:
    """OpenCV camera pose -> Blender camera object's pose (same world): right-multiply the flip."""
    return T_world_cam_cv @ se3(R_CV_BLENDERCAM)


def blender_to_cv_camera(T_world_cam_blender: np.ndarray) -> np.ndarray:
    return T_world_cam_blender @ se3(R_CV_BLENDERCAM)


def camera_matrix_world(T_world_cam_cv_ses: np.ndarray) -> np.ndarray:
    """The Blender ``matrix_world`` of a camera whose OpenCV pose is given in the SES world."""
    return cv_to_blender_camera(ses_to_blender_world(T_world_cam_cv_ses))
