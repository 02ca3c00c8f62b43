"""Ground-truth preview images from a rendered frame (pure: numpy + the EXR reader).

``preview_rgba(out_dir, frame, view, kind)`` reads ``OUT/manifest.json`` and the frame's
EXR and returns an (H, W, 4) float32 RGBA image, row 0 = top:
- ``disparity``: d = fx * B / Z px (DESIGN.md; left and right views alike, background 0),
  colour-mapped from 0 (dark blue) to the frame's largest disparity (yellow-white);
- ``segmentation``: one distinct colour per object id, background black;
- ``depth``: planar depth as inverse depth (near bright), background black;
- ``rgb``: the beauty pass.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import contract
from ..errors import SesgenError
from .exr import read_channels

KINDS = ("disparity", "segmentation", "depth", "rgb")

# a perceptually ordered ramp (dark blue -> purple -> orange -> pale yellow)
_RAMP = np.array([[0.02, 0.02, 0.20], [0.35, 0.05, 0.55], [0.80, 0.20, 0.35],
                  [0.98, 0.55, 0.10], [1.00, 0.95, 0.60]], dtype=np.float32)


def depth_m(z: np.ndarray) -> np.ndarray:
    """Cycles' planar depth with the background (1e10) turned into +inf (DESIGN.md)."""
    z = np.asarray(z, dtype=np.float32)
    return np.where(z >= contract.DEPTH_BACKGROUND * 0.5, np.inf, z)


def disparity_px(depth: np.ndarray, focal_px: float, baseline: float) -> np.ndarray:
    """Rectified disparity d = fx * B / Z (0 where Z is infinite)."""
    with np.errstate(divide="ignore"):
        return (float(focal_px) * float(baseline) / depth_m(depth)).astype(np.float32)


def colour_ramp(t: np.ndarray) -> np.ndarray:
    """(H, W) values in [0, 1] -> (H, W, 3) colours along the ramp."""
    t = np.clip(np.nan_to_num(np.asarray(t, dtype=np.float32)), 0.0, 1.0) * (len(_RAMP) - 1)
    i = np.minimum(t.astype(np.int64), len(_RAMP) - 2)
    f = (t - i)[..., None]
    return _RAMP[i] * (1.0 - f) + _RAMP[i + 1] * f


def id_colours(ids: np.ndarray) -> np.ndarray:
    """(H, W) object ids -> (H, W, 3): a distinct colour per id (golden-ratio hues), 0 black."""
    ids = np.rint(np.asarray(ids)).astype(np.int64)
    hue = (ids * 0.6180339887) % 1.0
    sat = 0.55 + 0.45 * ((ids * 0.379) % 1.0)
    val = 0.65 + 0.35 * ((ids * 0.7548776662) % 1.0)
    h6 = hue * 6.0
    k = np.stack([(5.0 + h6) % 6.0, (3.0 + h6) % 6.0, (1.0 + h6) % 6.0], axis=-1)
    rgb = val[..., None] - (val * sat)[..., None] * np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0)
    rgb[ids == 0] = 0.0
    return rgb.astype(np.float32)


def _rgba(rgb: np.ndarray) -> np.ndarray:
    return np.concatenate([rgb, np.ones(rgb.shape[:2] + (1,), dtype=np.float32)], axis=-1).astype(np.float32)


def preview_rgba(out_dir, frame: int, view: str, kind: str) -> tuple[np.ndarray, str]:
    """(RGBA image, one-line description) of ``kind`` for ``frame``/``view`` of a render."""
    out_dir = Path(out_dir)
    m = contract.load_manifest(out_dir)
    if m is None:
        raise SesgenError(f"{out_dir}: no render here (no manifest.json)")
    if kind not in KINDS:
        raise SesgenError(f"preview kind must be one of {', '.join(KINDS)}, got '{kind}'")
    if view not in m["views"]:
        raise SesgenError(f"this render has no '{view}' view (views: {', '.join(m['views'])})")
    if not (0 <= frame < m["frames"]):
        raise SesgenError(f"frame {frame} is outside 0..{m['frames'] - 1}")
    if not m["frames_complete"][frame]:
        raise SesgenError(f"frame {frame} is not rendered yet: render it first")
    path = out_dir / m["files"][view][frame]
    ch = m["channels"]
    if kind == "rgb":
        c = read_channels(path, ch["rgb"][:3])
        rgb = np.stack([c[n] for n in ch["rgb"][:3]], axis=-1)
        srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * np.power(np.maximum(rgb, 0), 1 / 2.4) - 0.055)
        return _rgba(np.clip(srgb, 0, 1)), f"RGB, frame {frame}, {view}"
    if kind == "segmentation":
        ids = read_channels(path, [ch["object_index"]])[ch["object_index"]]
        present = sorted(int(i) for i in np.unique(np.rint(ids)) if i > 0)
        return _rgba(id_colours(ids)), f"segmentation, frame {frame}, {view}: ids {present}"
    z = read_channels(path, [ch["depth"]])[ch["depth"]]
    if kind == "depth":
        inv = 1.0 / depth_m(z)
        top = float(inv.max()) if np.isfinite(inv).any() and inv.max() > 0 else 1.0
        return _rgba(colour_ramp(inv / top) * (inv > 0)[..., None]), f"inverse depth, frame {frame}, {view}"
    if m["baseline"] <= 0:
        raise SesgenError("a monocular render has no disparity (baseline 0)")
    d = disparity_px(z, m["K"][0][0], m["baseline"])
    top = float(d.max()) if d.max() > 0 else 1.0
    return _rgba(colour_ramp(d / top)), f"disparity, frame {frame}, {view}: 0..{top:.2f} px"
