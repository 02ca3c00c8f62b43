"""A small PNG encoder (numpy + zlib: works in Blender's own Python): 8- or 16-bit,
grey or RGB, written atomically."""
from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np


def encode_png(image: np.ndarray, level: int = 6) -> bytes:
    """PNG bytes of an (H, W) grey or (H, W, 3) RGB image, uint8 or uint16 (big-endian samples)."""
    a = np.asarray(image)
    if a.dtype not in (np.uint8, np.uint16) or a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[2] != 3):
        raise ValueError(f"PNG needs uint8/uint16 (H, W) or (H, W, 3), got {a.dtype} {a.shape}")
    H, W = a.shape[:2]
    channels = 1 if a.ndim == 2 else 3
    bits = 8 if a.dtype == np.uint8 else 16
    rows = np.ascontiguousarray(a.astype(">u2") if bits == 16 else a).view(np.uint8).reshape(H, -1)
    raw = np.concatenate([np.zeros((H, 1), dtype=np.uint8), rows], axis=1).tobytes()

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    colour_type = 0 if channels == 1 else 2
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", W, H, bits, colour_type, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, level)) + chunk(b"IEND", b""))


def write_png(path, image: np.ndarray, level: int = 6) -> None:
    """Write ``image`` (see :func:`encode_png`, deflate ``level``) to ``path`` atomically."""
    from ..contract import atomic
    atomic.write_bytes(Path(path), encode_png(image, level))
