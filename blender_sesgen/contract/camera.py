"""Pinhole intrinsics: K, the principal point, rescaling, and K <-> Blender camera settings.

OpenCV pixel convention: pixel centres at integer coordinates, (0, 0) is the centre of the
top-left pixel; square pixels (fx = fy). For a Blender camera with sensor_fit 'HORIZONTAL'
(measured on bpy 5.0.1, see ../shared/blender-facts.md):

    fx = fy = lens_mm * W / sensor_width_mm
    cx = W/2 - shift_x * W - 0.5
    cy = H/2 + shift_y * W - 0.5
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

SENSOR_WIDTH_MM = 36.0
MIN_LENS_MM = 1.0   # Blender's shortest lens
FOCAL_MIN_PX = 1e-3   # no camera has a focal length below a thousandth of a pixel: a reader refuses it


def K_problem(K: np.ndarray, limit: float = 1e9) -> Optional[str]:
    """Why ``K`` is not a usable pinhole camera matrix, or None: it must be finite, have
    fx, fy in [FOCAL_MIN_PX, limit], |skew|, |cx|, |cy| <= limit and last row (0, 0, 1)."""
    K = np.asarray(K, dtype=float)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        return "K must be a finite 3x3 matrix"
    if not (FOCAL_MIN_PX <= K[0, 0] <= limit and FOCAL_MIN_PX <= K[1, 1] <= limit):
        return f"focal lengths fx {K[0, 0]:g}, fy {K[1, 1]:g} must lie in {FOCAL_MIN_PX:g}..{limit:g} px"
    if np.any(np.abs(K[0, 1:]) > limit) or abs(K[1, 2]) > limit or K[1, 0] != 0 or np.any(K[2] != (0.0, 0.0, 1.0)):
        return "K must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with |s|, |cx|, |cy| within the limit"
    return None


def K_matrix(focal_px: float, cx: float, cy: float) -> np.ndarray:
    """(3, 3) K of a square-pixel pinhole: [[f, 0, cx], [0, f, cy], [0, 0, 1]]."""
    return np.array([[focal_px, 0.0, cx], [0.0, focal_px, cy], [0.0, 0.0, 1.0]])


def default_principal_point(width: int, height: int) -> tuple[float, float]:
    """The image centre in the OpenCV convention: ((W-1)/2, (H-1)/2)."""
    return (width - 1) / 2.0, (height - 1) / 2.0


def scaled_size(width: int, height: int, scale: float) -> tuple[int, int]:
    """Image size rendered at ``scale`` (rounded, at least 1 px each way)."""
    return max(1, int(round(width * scale))), max(1, int(round(height * scale)))


def scaled_K(K: np.ndarray, W: int, H: int, W2: int, H2: int) -> np.ndarray:
    """K of the same camera rendered at W2 x H2 (square pixels: one scale W2/W).

    Pixel centres at integers: a point at pixel x maps to (x + 0.5) * s - 0.5.
    """
    s = W2 / W
    K2 = np.array(K, dtype=float)
    K2[0, 0] *= s
    K2[1, 1] *= s
    K2[0, 2] = (K[0, 2] + 0.5) * s - 0.5
    K2[1, 2] = (K[1, 2] + 0.5) * (H2 / H) - 0.5
    return K2


def field_of_view_deg(width: int, height: int, focal_px: float) -> tuple[float, float]:
    """Horizontal and vertical field of view (degrees) of a centred pinhole."""
    return (float(np.degrees(2 * np.arctan(width / (2 * focal_px)))),
            float(np.degrees(2 * np.arctan(height / (2 * focal_px)))))


def project(K: np.ndarray, P_cam: np.ndarray) -> np.ndarray:
    """Pixel coordinates (..., 2) of camera-frame points (..., 3) (z > 0 assumed)."""
    P = np.asarray(P_cam, dtype=float)
    z = P[..., 2]
    return np.stack([K[0, 0] * P[..., 0] / z + K[0, 2], K[1, 1] * P[..., 1] / z + K[1, 2]], axis=-1)


def backproject(K: np.ndarray, pts: np.ndarray, Z: np.ndarray) -> np.ndarray:
    """Camera-frame points (N, 3) of pixels (N, 2) at planar depths Z (N,)."""
    p = np.asarray(pts, dtype=float)
    Z = np.asarray(Z, dtype=float)
    return np.stack([(p[:, 0] - K[0, 2]) / K[0, 0] * Z, (p[:, 1] - K[1, 2]) / K[1, 1] * Z, Z], axis=1)


def pixel_rays(K: np.ndarray, width: int, height: int) -> np.ndarray:
    """(H, W, 3) camera-frame rays through every pixel centre, scaled to z = 1."""
    u, v = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    return np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=-1)


# --- Blender camera data ----------------------------------------------------------------

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


def blender_camera_settings(width: int, height: int, focal_px: float, cx: float, cy: float,
                            near: float, far: float,
                            sensor_width_mm: float = SENSOR_WIDTH_MM) -> BlenderCameraSettings:
    """Blender camera data settings that reproduce K = [[f,0,cx],[0,f,cy],[0,0,1]] exactly.

    Blender clamps the lens to at least ``MIN_LENS_MM``: a focal length that would need a
    shorter lens on this sensor gets a wider sensor instead (same K, since only their
    ratio matters)."""
    if focal_px * sensor_width_mm / width < MIN_LENS_MM:
        sensor_width_mm = MIN_LENS_MM * 1.001 * width / focal_px
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
