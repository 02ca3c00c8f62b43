"""Disparity ground truth from planar depth, and its file formats.

Rectified parallel rig, baseline B (m), focal fx (px): d = fx·B/Z >= 0. Left view:
x_right = x_left - d; right view: x_left = x_right + d. In float arrays an invalid
disparity (no surface: Z = +inf) is NaN; ``np.isfinite(d)`` is the validity mask.

Formats:
- PFM / EXR (channel 'Y') / .npy: float32, NaN invalid (PFM writes +inf for invalid, as
  Middlebury does; :func:`read_disparity` returns NaN for it).
- KITTI PNG16: uint16 round(d·256), 0 = invalid (a tiny valid d is stored as 1; one above
  65535/256 px, which the encoding cannot hold, is invalid, never clipped).
- colour PNG: a visualisation, black = invalid.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.depth import disparity_from_depth
from blender_sesgen.contract.inputs import check_regular

from ..errors import VoError, as_vo_error
from ..io.files import load_npy
from ..io.files import read_image, write_image_atomic, write_png16
from ..io.pfm import read_pfm, write_pfm

__all__ = ["disparity_from_depth", "sequence_disparity", "disparity_to_png16", "PNG16_MAX_DISPARITY_PX", "png16_to_disparity",
           "write_disparity_png16", "read_disparity_png16", "write_disparity", "read_disparity", "disparity_color",
           "write_disparity_color"]


def sequence_disparity(seq, k: int, view: str = "left") -> np.ndarray:
    """Disparity of frame k in ``view`` of a stereo sequence with depth ground truth."""
    if seq.baseline_m <= 0:
        raise VoError("disparity needs a stereo sequence (baseline 0)")
    z = seq.depth(k, view)
    if z is None:
        raise VoError(f"{seq!r} has no depth ground truth: cannot derive disparity")
    return disparity_from_depth(z, seq.K[0, 0], seq.baseline_m)


# --- KITTI PNG16 ------------------------------------------------------------------------

PNG16_MAX_DISPARITY_PX = 65535 / 256.0   # the largest disparity KITTI's PNG16 holds (255.996 px)


def disparity_to_png16(d: np.ndarray) -> np.ndarray:
    """uint16 round(d·256), 0 = invalid; a valid d below 1/256 is stored as 1 (it never
    reads as invalid); one above 65535/256 px, which the encoding cannot hold, is invalid
    (0) -- clipped, it would read back as a plausible but wrong 255.996 px."""
    d = np.asarray(d, dtype=np.float64)
    v = np.rint(np.where(np.isfinite(d), d, -1.0) * 256.0)
    valid = np.isfinite(d) & (d >= 0) & (v <= 65535)
    out = np.zeros(d.shape, dtype=np.uint16)
    out[valid] = np.maximum(v[valid], 1).astype(np.uint16)
    return out


def png16_to_disparity(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v)
    d = v.astype(np.float32) / 256.0
    d[v == 0] = np.nan
    return d


def write_disparity_png16(path, d: np.ndarray) -> Path:
    return write_png16(path, disparity_to_png16(d))


def read_disparity_png16(path) -> np.ndarray:
    v = read_image(path)
    if v.dtype != np.uint16 or v.ndim != 2:
        raise VoError(f"{path}: expected a 16-bit grey PNG (KITTI disparity), got {v.dtype} {v.shape}")
    return png16_to_disparity(v)


# --- float formats ----------------------------------------------------------------------

def write_disparity(path, d: np.ndarray) -> Path:
    """Float disparity by extension: .pfm, .exr, .npy (.png -> KITTI PNG16)."""
    path = Path(path)
    d = np.asarray(d, dtype=np.float32)
    ext = path.suffix.lower()
    if ext == ".pfm":
        return write_pfm(path, np.where(np.isfinite(d), d, np.inf).astype(np.float32))
    if ext == ".exr":
        from ..io.exr import write_exr_single
        return write_exr_single(path, {"Y": d})
    if ext == ".npy":
        import io
        buf = io.BytesIO()
        np.save(buf, d)
        return atomic.write_bytes(path, buf.getvalue())
    if ext == ".png":
        return write_disparity_png16(path, d)
    raise VoError(f"{path}: unknown disparity format {ext!r} (.pfm, .exr, .npy, .png)")


def read_disparity(path, channel: str | None = None) -> np.ndarray:
    """float32 disparity (px), NaN where invalid, by extension (the one disparity reader):

    - ``.pfm`` (Middlebury 2014 / SceneFlow; inf = invalid), ``.npy``, ``.tif``/``.tiff`` float;
    - ``.exr``: the only channel, the one named ``channel``, or one whose name is (or ends
      in ``.``) disparity / Y / R / Z / V;
    - ``.png``: 16-bit KITTI (value / 256, 0 = invalid) or 8-bit (value = disparity,
      0 = invalid, as Middlebury 2003 at scale 1).
    """
    path = Path(path)
    if not path.exists():
        raise VoError(f"{path}: no such disparity file")
    with as_vo_error():
        check_regular(path, "disparity file")
    ext = path.suffix.lower()
    if ext == ".pfm":
        d = read_pfm(path)
    elif ext == ".exr":
        from ..io.exr import read_exr_channels
        d = _pick_channel(path, read_exr_channels(path), channel)
    elif ext == ".npy":
        d = load_npy(path)
    elif ext in (".png", ".tif", ".tiff"):
        img = read_image(path)
        if img.ndim == 3:
            raise VoError(f"{path}: a disparity image must have one channel, got {img.shape[2]}")
        if ext == ".png" and img.dtype == np.uint16:
            return png16_to_disparity(img)
        d = img.astype(np.float32)
        if np.issubdtype(img.dtype, np.integer):
            d[img == 0] = np.nan
    else:
        raise VoError(f"{path}: unknown disparity format {ext!r} (.png, .pfm, .npy, .tif, .exr)")
    if not (np.issubdtype(d.dtype, np.floating) or np.issubdtype(d.dtype, np.integer)):
        raise VoError(f"{path}: a disparity map holds numbers, got dtype {d.dtype}")
    d = np.asarray(d, dtype=np.float32)
    if d.ndim == 3 and d.shape[2] == 1:
        d = d[:, :, 0]
    if d.ndim != 2:
        raise VoError(f"{path}: expected a 2-D disparity map, got shape {d.shape}")
    d = d.copy()
    d[~np.isfinite(d)] = np.nan
    return d


def _pick_channel(path: Path, channels: dict[str, np.ndarray], channel: str | None) -> np.ndarray:
    if channel is not None:
        if channel not in channels:
            raise VoError(f"{path}: no channel {channel!r} (have {sorted(channels)})")
        return channels[channel]
    if len(channels) == 1:
        return next(iter(channels.values()))
    for want in ("disparity", "Disparity", "Y", "R", "Z", "V"):
        for name in sorted(channels):
            if name == want or name.endswith("." + want):
                return channels[name]
    raise VoError(f"{path}: several channels {sorted(channels)}; say which one")


# --- visualisation ----------------------------------------------------------------------

def disparity_color(d: np.ndarray, max_disp: float | None = None) -> np.ndarray:
    """uint8 RGB visualisation (OpenCV 'turbo' map: near = red, far = blue), black = invalid.
    ``max_disp`` fixes the scale (default: the 99.5th percentile of the valid values)."""
    import cv2
    d = np.asarray(d, dtype=np.float32)
    valid = np.isfinite(d)
    if max_disp is None:
        max_disp = float(np.percentile(d[valid], 99.5)) if valid.any() else 1.0
    max_disp = max(float(max_disp), 1e-6)
    v = np.zeros(d.shape, np.uint8)
    v[valid] = np.clip(d[valid] / max_disp * 255.0 + 0.5, 0, 255).astype(np.uint8)
    bgr = cv2.applyColorMap(v, cv2.COLORMAP_TURBO)
    bgr[~valid] = 0
    return bgr[..., ::-1].copy()


def write_disparity_color(path, d: np.ndarray, max_disp: float | None = None) -> Path:
    return write_image_atomic(path, disparity_color(d, max_disp)[..., ::-1])
