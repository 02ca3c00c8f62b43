"""Image files: read with a clear error, written atomically (``blender_sesgen.contract.atomic``:
a reader, or a crashed export, never sees a half-written file under the final name).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError


def write_image_atomic(path, image: np.ndarray, params: list[int] | None = None) -> Path:
    """Write an image with OpenCV (codec from the extension), atomically.

    ``image`` is given in OpenCV channel order (BGR for colour); uint8 or uint16.
    """
    import cv2
    path = Path(path)
    ok, buf = cv2.imencode(path.suffix, np.ascontiguousarray(image), params or [])
    if not ok:
        raise VoError(f"{path}: OpenCV could not encode a {image.dtype} {image.shape} image as {path.suffix}")
    return atomic.write_bytes(path, buf.tobytes())


def write_png_rgb(path, rgb: np.ndarray) -> Path:
    """uint8 RGB (H, W, 3) or grey (H, W) -> PNG."""
    import cv2
    rgb = np.asarray(rgb)
    img = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR) if rgb.ndim == 3 else rgb
    return write_image_atomic(path, img)


def write_png16(path, values: np.ndarray) -> Path:
    """uint16 (H, W) -> 16-bit grey PNG."""
    v = np.asarray(values)
    if v.dtype != np.uint16:
        raise VoError(f"{path}: 16-bit PNG needs uint16 data, got {v.dtype}")
    return write_image_atomic(path, v)


def read_image(path, flags: int | None = None) -> np.ndarray:
    """cv2.imread with a clear error when the file is missing or unreadable."""
    import cv2
    path = Path(path)
    if not path.is_file():
        raise VoError(f"{path}: no such image file")
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED if flags is None else flags)
    if img is None:
        raise VoError(f"{path}: not a readable image (corrupt or unknown format)")
    return img
