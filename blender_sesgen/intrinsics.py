"""Pinhole intrinsics <-> Blender camera settings (the one home of this convention).

OpenCV pixel convention: pixel centres at integer coordinates, (0, 0) is the centre of
the top-left pixel. For a Blender camera with sensor_fit 'HORIZONTAL' and square pixels
(measured on bpy 5.0.1, see ../shared/blender-facts.md):
    fx = fy = lens_mm * W / sensor_width_mm
    cx = W/2 - shift_x * W - 0.5
    cy = H/2 + shift_y * W - 0.5
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SENSOR_WIDTH_MM = 36.0


@dataclass(frozen=True)
class BlenderCameraSettings:
    lens_mm: float
    sensor_width_mm: float
    sensor_fit: str
    shift_x: float
    shift_y: float
    resolution_x: int
    resolution_y: int
    clip_start: float
    clip_end: float


def K_matrix(focal_px: float, cx: float, cy: float) -> np.ndarray:
    return np.array([[focal_px, 0.0, cx], [0.0, focal_px, cy], [0.0, 0.0, 1.0]])


def default_principal_point(width: int, height: int) -> tuple[float, float]:
    """The image centre in the OpenCV convention: ((W-1)/2, (H-1)/2)."""
    return (width - 1) / 2.0, (height - 1) / 2.0


def blender_camera_settings(width: int, height: int, focal_px: float, cx: float, cy: float,
                            near: float, far: float,
                            sensor_width_mm: float = SENSOR_WIDTH_MM) -> BlenderCameraSettings:
    """Blender camera data settings that reproduce K = [[f,0,cx],[0,f,cy],[0,0,1]] exactly."""
    return BlenderCameraSettings(
        lens_mm=focal_px * sensor_width_mm / width,
        sensor_width_mm=sensor_width_mm,
        sensor_fit="HORIZONTAL",
        shift_x=(width / 2.0 - 0.5 - cx) / width,
        shift_y=(cy - height / 2.0 + 0.5) / width,
        resolution_x=int(width),
        resolution_y=int(height),
        clip_start=float(near),
        clip_end=float(far),
    )


def K_from_blender(settings: BlenderCameraSettings) -> np.ndarray:
    """Inverse of :func:`blender_camera_settings` (horizontal sensor fit, square pixels)."""
    if settings.sensor_fit != "HORIZONTAL":
        raise ValueError("only sensor_fit 'HORIZONTAL' is supported")
    W, H = settings.resolution_x, settings.resolution_y
    f = settings.lens_mm * W / settings.sensor_width_mm
    cx = W / 2.0 - settings.shift_x * W - 0.5
    cy = H / 2.0 + settings.shift_y * W - 0.5
    return K_matrix(f, cx, cy)


def field_of_view_deg(width: int, height: int, focal_px: float) -> tuple[float, float]:
    """Horizontal and vertical field of view (degrees) of a centred pinhole."""
    return (float(np.degrees(2 * np.arctan(width / (2 * focal_px)))),
            float(np.degrees(2 * np.arctan(height / (2 * focal_px)))))
