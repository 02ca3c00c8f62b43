"""Atomic file writing: write to a temporary name in the same folder, then rename.

A reader (or a crashed export) never sees a half-written file under the final name.
"""
from __future__ import annotations

import os
import shutil
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import VoError


def _tmp_for(path: Path) -> Path:
    # keep the extension last: OpenCV and OpenEXR pick the codec from it
    return path.with_name(f".{path.stem}.part{os.getpid()}{path.suffix}")


def write_bytes_atomic(path, data: bytes) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _tmp_for(path)
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


@contextmanager
def staged_folder(final):
    """Build a folder under a temporary sibling name (``.NAME.partPID``) and put it in place
    of ``final`` only when the ``with`` block succeeds; on an error (or Ctrl-C) the partial
    folder is removed and ``final`` is left as it was. An existing ``final`` is replaced
    (moved aside, then deleted) -- the caller decides whether it may be."""
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.with_name(f".{final.name}.part{os.getpid()}")
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    old = None
    if final.exists():
        old = final.with_name(f".{final.name}.old{os.getpid()}")
        os.replace(final, old)
    os.replace(tmp, final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def write_text_atomic(path, text: str) -> Path:
    return write_bytes_atomic(path, text.encode("utf-8"))


def write_image_atomic(path, image: np.ndarray, params: list[int] | None = None) -> Path:
    """Write an image with OpenCV (codec from the extension), atomically.

    ``image`` is given in OpenCV channel order (BGR for colour); uint8 or uint16.
    """
    import cv2
    path = Path(path)
    ok, buf = cv2.imencode(path.suffix, np.ascontiguousarray(image), params or [])
    if not ok:
        raise VoError(f"{path}: OpenCV could not encode a {image.dtype} {image.shape} image as {path.suffix}")
    return write_bytes_atomic(path, buf.tobytes())


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
