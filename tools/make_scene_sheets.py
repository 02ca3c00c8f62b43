"""The scene library's pictures for the README and docs/rendering.md, from renders.

For each render folder given: a contact sheet of up to four frames, each a 2 x 2 block
(left and right display images — what the camera's JPEG is, vo_reference's ``image_rgb`` —,
ground-truth disparity colour-mapped with one scale for the sheet, and the Cityscapes
semantic colours of the object ids), or with ``--single`` the left image of the first
complete frame alone. Written as JPEG (quality 88), scaled by ``--scale``.

    python tools/make_scene_sheets.py out/realism/city --out docs/img/city_kitti_contact_sheet.jpg --scale 0.5
    python tools/make_scene_sheets.py out/sheets/office --single --out docs/img/office_frame.jpg
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
from blender_sesgen.contract import semantics
from blender_sesgen.contract.depth import disparity_from_depth
from vo_reference.io.sequence import open_sequence


def _disparity_colours(d: np.ndarray, scale: float) -> np.ndarray:
    t = np.clip(np.nan_to_num(d / max(scale, 1e-12), nan=0.0), 0, 1)
    rgb = cv2.applyColorMap((t * 255).astype(np.uint8), cv2.COLORMAP_MAGMA)[..., ::-1]
    rgb[~np.isfinite(d)] = 0
    return rgb


def sheet(folder: Path, frames: int) -> np.ndarray:
    seq = open_sequence(folder)
    m = seq.manifest
    done = [k for k, ok in enumerate(m.get("frames_complete", [])) if ok]
    if not done:
        raise SystemExit(f"{folder}: no complete frame")
    pick = sorted({done[int(round(i))] for i in np.linspace(0, len(done) - 1, min(frames, len(done)))})
    classes = {int(o["id"]): o.get("class", semantics.DEFAULT_OBJECT_CLASS) for o in m["objects"]}
    lut, pal = semantics.label_lut(classes), semantics.palette()
    K = np.asarray(seq.K, float)
    rows, disps = [], []
    for k in pick:
        ids = seq.ids(k)
        disps.append(disparity_from_depth(seq.depth(k), K[0, 0], seq.baseline_m))
        sem = pal[lut[np.clip(ids, 0, len(lut) - 1)]]
        rows.append([seq.image_rgb(k, "left"), seq.image_rgb(k, "right"), None, sem])
    finite = np.concatenate([d[np.isfinite(d)] for d in disps])
    scale = float(np.percentile(finite, 99)) if finite.size else 1.0
    gap = 6
    blocks = []
    for r, d in zip(rows, disps):
        r[2] = _disparity_colours(d, scale)
        H, W = r[0].shape[:2]
        vgap = np.full((H, gap, 3), 255, np.uint8)
        top = np.concatenate([r[0], vgap, r[1]], axis=1)
        bottom = np.concatenate([r[2], vgap, r[3]], axis=1)
        blocks += [top, np.full((gap // 2, top.shape[1], 3), 255, np.uint8), bottom,
                   np.full((gap * 2, top.shape[1], 3), 255, np.uint8)]
    return np.concatenate(blocks[:-1], axis=0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--single", action="store_true", help="the left image of the first complete frame only")
    ap.add_argument("--scale", type=float, default=1.0)
    a = ap.parse_args(argv)
    if a.single:
        seq = open_sequence(a.folder)
        k = next(k for k, ok in enumerate(seq.manifest["frames_complete"]) if ok)
        img = seq.image_rgb(k, "left")
    else:
        img = sheet(a.folder, a.frames)
    if a.scale != 1.0:
        img = cv2.resize(img, None, fx=a.scale, fy=a.scale, interpolation=cv2.INTER_AREA)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(a.out), np.ascontiguousarray(img[..., ::-1]), [cv2.IMWRITE_JPEG_QUALITY, 88])
    print(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
