"""Undistortion: RobotCar lookup tables and OpenCV (Brown-Conrady) distortion coefficients.

RobotCar LUT binary layout: float64, first all W·H u-values (columns) then all W·H
v-values (rows), each row-major, 0-based pixel coordinates; entry i gives, for undistorted
pixel i, the distorted pixel to sample. That is exactly a ``cv2.remap`` map pair.

Distortion coefficients follow OpenCV: ``(k1, k2, p1, p2[, k3])`` on normalised
coordinates ``x̂ = K⁻¹ x``, distorted pixel = K · distort(x̂). The map is our own code; the
remap (bilinear sampling) is OpenCV's.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract.inputs import check_regular

from ..errors import VoError, as_vo_error


def parse_distortion(text: str | None) -> np.ndarray | None:
    """``k1,k2,p1,p2[,k3]`` (commas or spaces) -> coefficients, None for nothing."""
    if text is None or not str(text).strip():
        return None
    try:
        d = np.array([float(v) for v in str(text).replace(",", " ").split()])
    except ValueError:
        raise VoError(f"dist={text!r}: expected k1,k2,p1,p2[,k3]") from None
    if d.size not in (4, 5):
        raise VoError(f"dist={text!r}: expected 4 or 5 coefficients (k1,k2,p1,p2[,k3])")
    return d


def read_lut(path, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(map_x, map_y) float32 (H, W) from a RobotCar LUT file for a W x H image."""
    path = Path(path)
    if not path.exists():
        raise VoError(f"{path}: no such lookup table")
    with as_vo_error():
        size = check_regular(path, "lookup table")
    if size != 16 * width * height:
        raise VoError(f"{path}: {size} bytes ({size / 8:g} float64 values), a {width}x{height} image needs "
                      f"{2 * width * height} values")
    a = np.fromfile(path, dtype="<f8")
    return (a[: width * height].reshape(height, width).astype(np.float32),
            a[width * height:].reshape(height, width).astype(np.float32))


def write_lut(path, map_x: np.ndarray, map_y: np.ndarray) -> None:
    """Write (map_x, map_y) (H, W) in the RobotCar layout."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    np.concatenate([np.asarray(map_x, "<f8").ravel(), np.asarray(map_y, "<f8").ravel()]).tofile(path)


def remap(image: np.ndarray, map_x: np.ndarray, map_y: np.ndarray) -> np.ndarray:
    """Sample ``image`` at (map_x, map_y) bilinearly (cv2.remap); outside -> black."""
    import cv2
    if image.shape[:2] != map_x.shape:
        raise VoError(f"image is {image.shape[1]}x{image.shape[0]}, the map is {map_x.shape[1]}x{map_x.shape[0]}")
    return cv2.remap(image, map_x.astype(np.float32), map_y.astype(np.float32), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def _coeffs(dist) -> np.ndarray:
    d = np.zeros(5)
    dist = np.asarray(dist, dtype=float).ravel()
    if dist.size not in (4, 5):
        raise VoError(f"distortion coefficients are (k1, k2, p1, p2[, k3]), got {dist.size} values")
    d[: dist.size] = dist
    return d


def distort_normalised(xn: np.ndarray, dist) -> np.ndarray:
    """Brown-Conrady on normalised points (..., 2) (OpenCV's model, radial k1 k2 k3,
    tangential p1 p2)."""
    k1, k2, p1, p2, k3 = _coeffs(dist)
    x, y = xn[..., 0], xn[..., 1]
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd, yd], axis=-1)


def undistort_normalised(xd: np.ndarray, dist, iterations: int = 30) -> np.ndarray:
    """Inverse of :func:`distort_normalised` by fixed-point iteration x ← x + (xd − d(x))."""
    x = np.array(xd, dtype=float)
    for _ in range(iterations):
        x = x + (xd - distort_normalised(x, dist))
    return x


def _pixel_grid(width: int, height: int) -> np.ndarray:
    u, v = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    return np.stack([u, v], axis=-1)


def _to_norm(K, px):
    return np.stack([(px[..., 0] - K[0, 2]) / K[0, 0], (px[..., 1] - K[1, 2]) / K[1, 1]], axis=-1)


def _to_px(K, xn):
    return np.stack([K[0, 0] * xn[..., 0] + K[0, 2], K[1, 1] * xn[..., 1] + K[1, 2]], axis=-1)


def lut_from_distortion(K: np.ndarray, dist, width: int, height: int,
                        K_new: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Undistortion maps: for each pixel of the undistorted image (intrinsics ``K_new``,
    default K) the distorted pixel to sample (intrinsics K). Same meaning as a RobotCar LUT."""
    K_new = K if K_new is None else K_new
    d = _to_px(K, distort_normalised(_to_norm(K_new, _pixel_grid(width, height)), dist))
    return d[..., 0].astype(np.float32), d[..., 1].astype(np.float32)


def distortion_maps(K: np.ndarray, dist, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """The inverse maps: for each pixel of the *distorted* image, the undistorted pixel to
    sample — used to synthesise distorted images from ideal (pinhole) renders."""
    u = _to_px(K, undistort_normalised(_to_norm(K, _pixel_grid(width, height)), dist))
    return u[..., 0].astype(np.float32), u[..., 1].astype(np.float32)


def distort_image(image: np.ndarray, K: np.ndarray, dist) -> np.ndarray:
    h, w = image.shape[:2]
    return remap(image, *distortion_maps(K, dist, w, h))
