"""Segmentation images: object ids as 16-bit PNG and as a colour-palette PNG.

The palette is a pure function of the id (the same id has the same colour in every frame
and every export): hue steps by the golden ratio, 0 (background) is black.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VoError
from ..io.files import write_image_atomic, write_png16


def id_colour(ids: np.ndarray) -> np.ndarray:
    """(..., 3) uint8 RGB colours for integer ids; 0 -> black."""
    import colorsys
    ids = np.asarray(ids)
    uniq, inv = np.unique(ids, return_inverse=True)
    pal = np.zeros((len(uniq), 3), np.uint8)
    for i, u in enumerate(uniq):
        if u == 0:
            continue
        h = (float(u) * 0.6180339887498949) % 1.0
        s = 0.55 + 0.45 * ((int(u) * 7) % 5) / 4.0
        v = 0.65 + 0.35 * ((int(u) * 3) % 4) / 3.0
        pal[i] = np.rint(np.array(colorsys.hsv_to_rgb(h, s, v)) * 255)
    return pal[inv.reshape(ids.shape)]


def write_ids_png16(path, ids: np.ndarray) -> Path:
    ids = np.asarray(ids)
    if ids.size and (ids.min() < 0 or ids.max() > 65535):
        raise VoError(f"{path}: ids outside 0..65535 cannot go into a 16-bit PNG")
    return write_png16(path, ids.astype(np.uint16))


def write_ids_colour(path, ids: np.ndarray) -> Path:
    return write_image_atomic(path, id_colour(ids)[..., ::-1])
