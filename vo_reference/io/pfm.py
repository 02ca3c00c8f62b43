"""PFM (portable float map) as Middlebury uses it: 'Pf' grey or 'PF' colour, scale < 0 =
little-endian, rows stored bottom-to-top. Arrays here are row 0 = top."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from .files import read_binary


def write_pfm(path, image: np.ndarray) -> Path:
    a = np.asarray(image, dtype=np.float32)
    if a.ndim == 2:
        kind = b"Pf"
    elif a.ndim == 3 and a.shape[2] == 3:
        kind = b"PF"
    else:
        raise VoError(f"{path}: PFM holds (H, W) or (H, W, 3) arrays, got {a.shape}")
    H, W = a.shape[:2]
    header = kind + b"\n" + f"{W} {H}\n-1.0\n".encode("ascii")
    data = np.ascontiguousarray(np.flipud(a)).astype("<f4").tobytes()
    return atomic.write_bytes(path, header + data)


def read_pfm(path) -> np.ndarray:
    path = Path(path)
    raw = read_binary(path, "PFM file")
    # magic, width, height, scale; the data starts after the one whitespace ending the scale
    m = re.match(rb"(P[fF])\s+(\d+)\s+(\d+)\s+([-+0-9.eE]+)\s", raw[:256])
    if m is None:
        raise VoError(f"{path}: not a PFM file (bad header {raw[:12]!r})")
    kind, W, H, off = m.group(1), int(m.group(2)), int(m.group(3)), m.end()
    try:
        scale = float(m.group(4))
    except ValueError:
        raise VoError(f"{path}: not a PFM file (bad scale)") from None
    if not (0 < W <= 65536 and 0 < H <= 65536) or not math.isfinite(scale) or scale == 0:
        raise VoError(f"{path}: not a PFM file (size {W}x{H}, scale {scale:g})")
    ch = 3 if kind == b"PF" else 1
    n = W * H * ch
    dt = "<f4" if scale < 0 else ">f4"
    if len(raw) - off < 4 * n:
        raise VoError(f"{path}: PFM data truncated")
    a = np.frombuffer(raw, dtype=dt, count=n, offset=off).astype(np.float32)
    a = a.reshape(H, W, ch) if ch == 3 else a.reshape(H, W)
    return np.ascontiguousarray(np.flipud(a))
