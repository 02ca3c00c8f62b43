"""The crowns' finest band (issue 28, session 18): KITTI sequence_1's hand-marked tree boxes
against a city render's crowns, and how much of a render's finest band its denoiser keeps.

    python bench/crown_detail.py RENDER [--frames 0,8,16] [--cross RENDER_B --denoised RENDER_D]

RENDER: a render folder of scenes/city_kitti.ses at KITTI's half size (bench/twin.py's
OUT/city, or ``sesgen render scenes/city_kitti.ses --frames 0:1 --resolution-scale 0.5
--quality draft``: frame 0 alone reproduces the twin's frame 0). Printed:

- ``topsky``: the top band's contrast power (``twin.band_images``, 72-92 cycles per image
  height, x 1e4) in the crowns of the frame's upper 45 %, with the frame over the open
  sky's 8-bit median instead of over the frame's mean (a crown's detail against its sky, free of
  what else the frame holds); KITTI in its hand-marked tree boxes (``twin.KITTI_REGIONS``,
  frames 0, 20, 40; the sky from the same frames' sky boxes), the render in ``twin``'s
  ``crown`` region (leaves and the sky seen through them, by object id) - the whole and per
  object (its kind, size, depth, share of sky inside, median over the sky, its leaves').
- ``--cross B --denoised D``: RENDER and B rendered undenoised with different ``--seed`` (their
  path-tracing noise independent), D the same frame denoised: the mean product of RENDER's and
  B's band images per region is the band's power without the path noise (the sensor's noise is
  one draw in both and stays in, as KITTI's own does), beside D's plain power (``twin``'s frame
  normalisation, as its ``contrast power by region`` line).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from twin import KITTI_REGIONS, _region_masks, band_images, kitti_marked_frame, render_classes  # noqa: E402

W, H = 613, 185          # the twin's size (KITTI at half size)
UPPER = 0.45             # the upper share of the frame where the crowns stand against the sky


def kitti_topsky() -> list[tuple[int, float, float]]:
    """(frame, topsky, 48-72 band likewise) in each hand-marked tree box of KITTI sequence_1."""
    rows = []
    for k, reg in KITTI_REGIONS.items():
        full = kitti_marked_frame(k)
        img = cv2.resize(full, (W, H), interpolation=cv2.INTER_AREA)
        sx, sy = W / full.shape[1], H / full.shape[0]

        def box(name):
            x0, y0, x1, y1 = reg[name]
            return slice(int(y0 * sy) + 2, int(y1 * sy) - 2), slice(int(x0 * sx) + 2, int(x1 * sx) - 2)
        b = band_images(img)
        f = (img.mean() / np.median(img[box("sky")])) ** 2
        rows.append((k, 1e4 * f * float(np.mean(b[-1][box("tree")] ** 2)), 1e4 * f * float(np.mean(b[-2][box("tree")] ** 2))))
    return rows


def _frame(out: Path, k: int):
    img = cv2.imread(str(out / "sensor" / "left" / "rgb" / f"{k:06d}.png"), 0)
    if img is None:
        raise SystemExit(f"{out}: no sensor/left/rgb/{k:06d}.png (a SENSOR render of the city at half size)")
    return img


def render_topsky(out: Path, k: int) -> list[str]:
    """Frame k's upper crowns: the whole, then per object of 150+ px (its crown's pixels: its
    leaves and the sky within 4 px of them)."""
    man = json.loads((out / "manifest.json").read_text())
    obj = {o["id"]: o for o in man["objects"]}
    seq, cls = render_classes(out)
    img = _frame(out, k)
    ids = np.asarray(seq.ids(k, "left")).astype(int)
    dep = np.asarray(seq.depth(k, "left"))
    r = _region_masks(ids, cls)
    up = np.zeros(img.shape, bool)
    up[:int(UPPER * img.shape[0])] = True
    sky = np.median(img[r["sky"] & up])
    b = band_images(img)
    f = (img.mean() / sky) ** 2
    crown = r["crown"] & up
    veg = np.where(np.isin(ids, [i for i, c in cls.items() if c == "vegetation"]), ids, 0)
    kid = np.where(veg > 0, veg, cv2.dilate(veg.astype(np.float32), np.ones((9, 9))).astype(int))
    lines = [f"frame {k}: upper crowns {crown.sum()} px, topsky {1e4 * f * np.mean(b[-1][crown] ** 2):.1f}, "
             f"48-72 {1e4 * f * np.mean(b[-2][crown] ** 2):.1f}, open sky's 8-bit median {sky:.0f}"]
    for i in np.unique(kid[crown]):
        m = crown & (kid == i)
        if m.sum() < 150:
            continue
        o = obj.get(int(i), {})
        lines.append(f"  id {i} {o.get('kind')} size {o.get('size')} {m.sum()} px at {np.median(dep[m & (veg > 0)]):.1f} m: "
                     f"topsky {1e4 * f * np.mean(b[-1][m] ** 2):.1f}, sky inside {np.mean(veg[m] == 0):.2f}, "
                     f"median / sky {np.median(img[m]) / sky:.2f}, leaves' {np.median(img[m & (veg > 0)]) / sky:.2f}")
    return lines


def cross_power(a: Path, b: Path, d: Path, k: int) -> list[str]:
    """Per region (twin's by object id) and band: D's power and RENDER x B's cross power."""
    seq, cls = render_classes(d)
    regions = _region_masks(np.asarray(seq.ids(k, "left")).astype(int), cls)
    regions["frame"] = np.ones_like(regions["sky"])
    A, B, D = (band_images(_frame(x, k)) for x in (a, b, d))
    lines = []
    for name, m in regions.items():
        if m.sum() < 50:
            continue
        den = [1e4 * float(np.mean(x[m] ** 2)) for x in D]
        sig = [1e4 * float(np.mean(x[m] * y[m])) for x, y in zip(A, B)]
        lines.append(f"  {name}: denoised " + "/".join(f"{x:.1f}" for x in den)
                     + ", undenoised without path noise " + "/".join(f"{x:.1f}" for x in sig)
                     + f", kept {den[-1] / max(sig[-1], 1e-9):.2f} of the top band")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("render", type=Path)
    ap.add_argument("--frames", default="0")
    ap.add_argument("--cross", type=Path)
    ap.add_argument("--denoised", type=Path)
    a = ap.parse_args(argv)
    if (a.cross is None) != (a.denoised is None):
        print("crown_detail.py: --cross and --denoised go together", file=sys.stderr)
        return 2
    frames = [int(x) for x in a.frames.split(",")]
    ks = kitti_topsky()
    print("KITTI sequence_1's tree boxes (frame: topsky, 48-72): "
          + ", ".join(f"{k}: {t:.1f}, {m:.1f}" for k, t, m in ks) + f"; median {np.median([t for _, t, _ in ks]):.1f}")
    for k in frames:
        print("\n".join(render_topsky(a.render, k)))
        if a.cross is not None:
            print(f"frame {k}, contrast power by region x 1e4 (2-16/16-48/48-72/72-92 cycles):")
            print("\n".join(cross_power(a.render, a.cross, a.denoised, k)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
