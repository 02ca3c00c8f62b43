"""Ground-truth preview images from a rendered frame (pure: numpy + ``exr.read_exr``).

``preview_rgba(out_dir, frame, view, kind)`` reads ``OUT/manifest.json`` and the frame's
EXR and returns an (H, W, 4) float32 RGBA image (display colours 0..1), row 0 = top, in
the colours of the contact sheet (``contact_sheet.colormap`` / ``id_colours``):
- ``disparity``: d = fx * B / Z px (DESIGN.md; either view), colour-mapped from 0 to the
  frame's largest disparity, background black;
- ``segmentation``: one colour per object id, background black;
- ``depth``: inverse planar depth (near = top of the ramp), background black;
- ``rgb``: the beauty pass (linear -> sRGB).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..files.contact_sheet import colormap, id_colours
from ..contract.colour import linear_to_srgb8
from ..contract.depth import depth_from_pass, disparity_from_depth
from ..contract.errors import ContractError
from ..contract.manifest import MANIFEST, Manifest
from ..errors import SesgenError
from ..files.exr import read_exr

KINDS = ("disparity", "segmentation", "depth", "rgb")


def _rgba(rgb8: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 display colours -> (H, W, 4) float32 RGBA in 0..1."""
    rgb = np.asarray(rgb8, dtype=np.float32) / 255.0
    return np.concatenate([rgb, np.ones(rgb.shape[:2] + (1,), dtype=np.float32)], axis=-1)


def _ramp(values: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, float]:
    top = float(values[valid].max()) if valid.any() else 1.0
    rgb = colormap(values / max(top, 1e-12))
    rgb[~valid] = 0
    return rgb, top


def disparity_px(depth_pass: np.ndarray, focal_px: float, baseline: float) -> np.ndarray:
    """Disparity to show: fx * B / Z, 0 (black) where nothing was hit."""
    return np.nan_to_num(disparity_from_depth(depth_from_pass(depth_pass), focal_px, baseline), nan=0.0)


def preview_rgba(out_dir, frame: int, view: str, kind: str) -> tuple[np.ndarray, str]:
    """(RGBA image, one-line description) of ``kind`` for ``frame``/``view`` of a render."""
    out_dir = Path(out_dir)
    if not (out_dir / MANIFEST).is_file():
        raise SesgenError(f"{out_dir}: no render here (no manifest.json)")
    try:
        m = Manifest.read(out_dir)
    except ContractError as e:
        raise SesgenError(str(e)) from None
    if kind not in KINDS:
        raise SesgenError(f"preview kind must be one of {', '.join(KINDS)}, got '{kind}'")
    if view not in m.views:
        raise SesgenError(f"this render has no '{view}' view (views: {', '.join(m.views)})")
    if not (0 <= frame < m.frames):
        raise SesgenError(f"frame {frame} is outside 0..{m.frames - 1}")
    if not m.frames_complete[frame]:
        raise SesgenError(f"frame {frame} is not rendered yet: render it first")
    path = out_dir / m.files[view][frame]
    try:
        c = read_exr(path)
    except (OSError, ValueError) as e:
        raise SesgenError(f"cannot read {path}: {e}") from None
    ch = m.channels
    if kind == "rgb":
        rgb = np.stack([c[n] for n in ch["rgb"][:3]], axis=-1)
        return _rgba(linear_to_srgb8(rgb)), f"RGB, frame {frame}, {view}"
    if kind == "segmentation":
        ids = np.rint(c[ch["object_index"]]).astype(np.int64)
        present = sorted(int(i) for i in np.unique(ids) if i > 0)
        return _rgba(id_colours(ids)), f"segmentation, frame {frame}, {view}: ids {present}"
    z = depth_from_pass(c[ch["depth"]], m.depth_background)
    valid = np.isfinite(z)
    if kind == "depth":
        rgb, _ = _ramp(1.0 / np.where(valid, z, 1.0), valid)
        return _rgba(rgb), f"inverse depth, frame {frame}, {view}"
    if m.baseline <= 0:
        raise SesgenError("a monocular render has no disparity (baseline 0): preview depth instead")
    d = disparity_px(c[ch["depth"]], m.K[0, 0], m.baseline)
    rgb, top = _ramp(d, valid)
    return _rgba(rgb), f"disparity, frame {frame}, {view}: 0..{top:.2f} px"
