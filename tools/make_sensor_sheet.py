"""docs/img/sensors_contact_sheet.jpg: a render of scenes/sensors.ses, one row per chosen frame:
the EXR beauty (motion blur, rolling shutter, distortion), the sensor's RGB output, planar
depth (inverse, colour-mapped) and the segmentation, all of the left view.

    python -m blender_sesgen render scenes/sensors.ses --out out/sensors --resolution-scale 0.5 --samples 8
    python tools/make_sensor_sheet.py out/sensors [--frames 0 8 16 23]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
from blender_sesgen.contact_sheet import colormap, id_colours
from blender_sesgen.contract.colour import linear_to_srgb8
from vo_reference.io.render import RenderSequence


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("render")
    p.add_argument("--frames", type=int, nargs="+", default=[0, 8, 16, 23])
    p.add_argument("--out", default=str(REPO / "docs" / "img" / "sensors_contact_sheet.jpg"))
    args = p.parse_args()
    import cv2
    seq = RenderSequence(args.render)
    rows = []
    inv = [1.0 / seq.depth(k) for k in args.frames]
    top = np.nanpercentile(np.concatenate([i[np.isfinite(i)] for i in inv]), 99)
    for k, d in zip(args.frames, inv):
        beauty = linear_to_srgb8(seq.rgb_linear(k))
        sensor = seq.image_rgb(k)
        depth = colormap(np.nan_to_num(d / top, nan=0.0))
        depth[~np.isfinite(d) | (d == 0)] = 0
        ids = id_colours(seq.ids(k))
        gap = np.full((beauty.shape[0], 4, 3), 255, np.uint8)
        rows.append(np.concatenate([beauty, gap, sensor, gap, depth, gap, ids], axis=1))
        rows.append(np.full((4, rows[-1].shape[1], 3), 255, np.uint8))
    sheet = np.concatenate(rows[:-1], axis=0)
    cv2.imwrite(args.out, cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 88])
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
