"""Contact sheet of a render folder: one PNG, a row per chosen frame with left RGB, right RGB,
left disparity and left segmentation (pure: numpy + zlib, reads EXRs with ``exr.py``).

    python -m blender_sesgen.files.contact_sheet OUT [--png OUT/contact_sheet.png] [--frames 4]

RGB: linear beauty -> sRGB, clipped. Disparity d = fx * B / Z (px), colour-mapped from 0 to
its 99th percentile over the sheet; background black. Segmentation: a fixed colour per id
(background black). For a monocular render the columns are RGB, inverse depth, segmentation.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ..contract import atomic
from ..contract.colour import linear_to_srgb8
from ..contract.depth import depth_from_pass, disparity_from_depth
from ..contract.manifest import Manifest
from .exr import read_exr
from .png import encode_png

GAP = 4  # pixels between panels


def write_png(path, rgb: np.ndarray) -> None:
    """Write an (H, W, 3) uint8 image as an 8-bit RGB PNG (stdlib zlib only), atomically."""
    atomic.write_bytes(path, encode_png(np.ascontiguousarray(rgb, dtype=np.uint8)))


# a perceptually ordered ramp (dark blue -> cyan -> yellow -> dark red), like 'turbo'
_STOPS = np.array([[0.19, 0.07, 0.23], [0.27, 0.47, 0.93], [0.10, 0.83, 0.78], [0.64, 0.99, 0.24],
                   [0.98, 0.73, 0.22], [0.88, 0.28, 0.06], [0.48, 0.02, 0.01]])


def colormap(t: np.ndarray) -> np.ndarray:
    t = np.clip(np.nan_to_num(t), 0, 1) * (len(_STOPS) - 1)
    i = np.minimum(t.astype(int), len(_STOPS) - 2)
    f = (t - i)[..., None]
    return ((_STOPS[i] * (1 - f) + _STOPS[i + 1] * f) * 255 + 0.5).astype(np.uint8)


def id_colours(ids: np.ndarray) -> np.ndarray:
    """A fixed, well-spread colour per id (golden-ratio hues); 0 = black."""
    ids = ids.astype(np.int64)
    h = (ids * 0.618033988749895) % 1.0
    s = 0.55 + 0.45 * ((ids * 7) % 3) / 2
    v = 0.75 + 0.25 * ((ids * 5) % 2)
    k = (np.stack([5.0, 3.0, 1.0], -1) + h[..., None] * 6) % 6
    rgb = v[..., None] - v[..., None] * s[..., None] * np.clip(np.minimum(k, 4 - k), 0, 1)
    rgb[ids == 0] = 0
    return (rgb * 255 + 0.5).astype(np.uint8)


def _panels(out: Path, m: Manifest, k: int) -> list[np.ndarray]:
    left = read_exr(out / m.files["left"][k])
    ch = m.channels
    rgb_l = np.stack([left[c] for c in ch["rgb"][:3]], -1)
    Z = depth_from_pass(left[ch["depth"]], m.depth_background)
    valid = np.isfinite(Z)
    ids = np.rint(left[ch["object_index"]]).astype(np.int64)
    panels = [linear_to_srgb8(rgb_l)]
    if "right" in m.views:
        right = read_exr(out / m.files["right"][k])
        panels.append(linear_to_srgb8(np.stack([right[c] for c in ch["rgb"][:3]], -1)))
        disp = disparity_from_depth(Z, m.K[0, 0], m.baseline)
    else:  # monocular: show inverse depth instead
        disp = np.where(valid, 1.0 / np.where(valid, Z, 1.0), np.nan)
    panels.append(disp)  # colour-mapped later, with one scale for the sheet
    panels.append(id_colours(ids))
    return panels


def write_contact_sheet(out_dir, png_path=None, n_frames: int = 4) -> Path:
    """Write the contact sheet of the render in ``out_dir``; returns the PNG path."""
    out = Path(out_dir)
    m = Manifest.read(out)
    done = [k for k, d in enumerate(m.frames_complete) if d]
    if not done:
        raise ValueError(f"{out}: no complete frame to show")
    pick = sorted({done[int(round(i))] for i in np.linspace(0, len(done) - 1, min(n_frames, len(done)))})
    rows = [_panels(out, m, k) for k in pick]
    disp_all = np.concatenate([r[-2][np.isfinite(r[-2])] for r in rows] or [np.array([1.0])])
    scale = float(np.percentile(disp_all, 99)) if disp_all.size else 1.0
    W, H = m.resolution
    sheet_rows = []
    for r in rows:
        d = r[-2]
        dm = colormap(d / max(scale, 1e-12))
        dm[~np.isfinite(d)] = 0
        r[-2] = dm
        gap = np.full((H, GAP, 3), 255, dtype=np.uint8)
        row = [r[0]]
        for p in r[1:]:
            row += [gap, p]
        sheet_rows.append(np.concatenate(row, axis=1))
    hgap = np.full((GAP, sheet_rows[0].shape[1], 3), 255, dtype=np.uint8)
    parts = [sheet_rows[0]]
    for sr in sheet_rows[1:]:
        parts += [hgap, sr]
    png = Path(png_path) if png_path else out / "contact_sheet.png"
    write_png(png, np.concatenate(parts, axis=0))
    return png


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m blender_sesgen.files.contact_sheet", description=__doc__.splitlines()[0])
    p.add_argument("out", help="a render folder (with manifest.json)")
    p.add_argument("--png", help="output PNG (default OUT/contact_sheet.png)")
    p.add_argument("--frames", type=int, default=4, help="how many frames (rows), evenly spaced")
    a = p.parse_args(argv)
    try:
        png = write_contact_sheet(a.out, a.png, a.frames)
    except (OSError, ValueError, KeyError) as e:  # ContractError is a ValueError
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(png)
    return 0


if __name__ == "__main__":
    sys.exit(main())
