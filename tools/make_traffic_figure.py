"""Make docs/img/street_kitti_traffic.jpg: a frame of scenes/street_kitti_traffic.ses, its
optical flow to the next frame (hue = direction, saturation = magnitude) and its motion
mask (red: pixels of objects that move between the two frames).

    python -m blender_sesgen render scenes/street_kitti_traffic.ses --out out/traffic \\
        --frames 14:16 --samples 16 --denoise --resolution-scale 0.5
    python tools/make_traffic_figure.py out/traffic 14
"""
from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np

from vo_reference.io.render import RenderSequence
from vo_reference.products.scene_flow import sequence_scene_flow

OUT = Path(__file__).resolve().parent / "img" / "street_kitti_traffic.jpg"


def flow_colour(flow: np.ndarray) -> np.ndarray:
    """uint8 RGB: hue = direction, saturation = magnitude (99th percentile = full), black = no flow."""
    ok = np.all(np.isfinite(flow), axis=-1)
    mag = np.hypot(flow[..., 0], flow[..., 1])
    top = float(np.percentile(mag[ok], 99)) if ok.any() else 1.0
    hsv = np.zeros(flow.shape[:2] + (3,), np.uint8)
    hsv[..., 0] = np.where(ok, (np.degrees(np.arctan2(-flow[..., 1], -flow[..., 0])) + 180) / 2, 0).astype(np.uint8)
    hsv[..., 1] = np.where(ok, np.clip(mag / max(top, 1e-6) * 255, 0, 255), 0).astype(np.uint8)
    hsv[..., 2] = np.where(ok, 255, 0).astype(np.uint8)
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)


def main(render: str, k: int) -> None:
    seq = RenderSequence(render)
    rgb = seq.image_rgb(k)
    sf = sequence_scene_flow(seq, k, k + 1)
    over = rgb.copy()
    over[sf.dynamic] = (0.45 * rgb[sf.dynamic] + 0.55 * np.array([255, 40, 40])).astype(np.uint8)
    img = np.concatenate([rgb, flow_colour(sf.flow), over], axis=0)
    cv2.imwrite(str(OUT), img[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 88])
    print(f"{OUT}: frame {k}, {100 * sf.dynamic.mean():.1f} % of the image on moving objects")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]))
