"""Input and image files: read with a clear error, written atomically (``blender_sesgen.contract.atomic``:
a reader, or a crashed export, never sees a half-written file under the final name).
"""
from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.inputs import BINARY_LIMIT, check_regular, read_bytes

from ..errors import VoError, as_vo_error
from .native import captured_stderr, first_complaint


def read_binary(path, what: str) -> bytes:
    """The bytes of the input file ``path`` (a ``what``: "PFM file"); VoError when it is absent,
    not a regular file or larger than the input limit."""
    path = Path(path)
    if not path.exists():
        raise VoError(f"{path}: no such {what}")
    with as_vo_error():
        return read_bytes(path, BINARY_LIMIT, what)


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
    """cv2.imread with a clear error when the file is missing, not a regular file, or
    unreadable (what libpng and friends print about it goes into the message). A PNG's chunk
    structure is walked first (lengths within the file, CRCs): OpenCV spends seconds on a
    PNG whose chunk length is corrupt."""
    import cv2
    path = Path(path)
    with as_vo_error():
        data = read_bytes(path, BINARY_LIMIT, "image file")
    if data.startswith(PNG_SIGNATURE):
        problem = png_structure_problem(data)
        if problem:
            raise VoError(f"{path}: not a readable image (corrupt PNG: {problem})")
    with captured_stderr() as complaints:
        try:
            img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED if flags is None else flags)
        except cv2.error as e:  # e.g. a header claiming more pixels than OpenCV allows
            img = None
            complaints.append(str(e).strip().splitlines()[-1] if str(e).strip() else "OpenCV error")
    if img is None:
        why = first_complaint(complaints, path)
        raise VoError(f"{path}: not a readable image (corrupt or unknown format{': ' + why if why else ''})")
    return img


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_structure_problem(data: bytes) -> str:
    """'' when the PNG's chunks fit the file with correct CRCs up to IEND; else the problem."""
    pos, seen = 8, 0
    while pos + 12 <= len(data):
        length, kind = struct.unpack_from(">I4s", data, pos)
        end = pos + 12 + length
        if end > len(data):
            return f"chunk {kind!r} of {length} bytes runs past the end of the file (truncated?)"
        if zlib.crc32(data[pos + 4:pos + 8 + length]) & 0xFFFFFFFF != struct.unpack_from(">I", data, end - 4)[0]:
            return f"chunk {kind!r} has a bad CRC"
        if seen == 0 and kind != b"IHDR":
            return "the first chunk is not IHDR"
        seen += 1
        if kind == b"IEND":
            return ""
        pos = end
    return "no IEND chunk (truncated?)"


def load_npy(path) -> np.ndarray:
    """A ``.npy`` array (no pickles), VoError when it is not a readable one."""
    path = Path(path)
    with as_vo_error():
        check_regular(path, ".npy file")
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError, TypeError, MemoryError) as e:
        raise VoError(f"{path}: not a readable .npy array ({type(e).__name__}: {e})") from None
