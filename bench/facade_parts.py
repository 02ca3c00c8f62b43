"""Where the render's facade contrast power lies: twin.py's band power (``band_images``: the frame
over its mean, band-passed at 2-16 / 16-48 / 48-72 / 72-92 cycles per image height) over each
building's pixels (by object id, 3 px in), grouped by asset kind, by distance and by brightness
(above / below 0.7 x the buildings' median: sunlit and shaded), and per object; beside it KITTI
sequence_1's hand-marked facade boxes (twin.py's ``KITTI_REGIONS``) and the render's same boxes.

    python bench/facade_parts.py OUT_DIR/city [--frames N] [--draw D]

OUT_DIR/city: a twin render (bench/twin.py --out OUT_DIR); its EXRs developed through the camera
chain with sensor-noise draw D (twin.py's ``resensor``). Issue 28, session 20 (facades20).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import twin  # noqa: E402

DEPTHS = ((0, 20), (20, 40), (40, 80), (80, np.inf))


def _erode(m):
    return cv2.erode(m.astype(np.uint8), np.ones((7, 7))) > 0


def measure(out: Path, n: int, draw: int = 0) -> list[str]:
    ours = twin.resensor(out, n, 0, draw)
    seq, cls = twin.render_classes(out)
    kind = {o["id"]: o.get("kind") for o in json.loads((out / "manifest.json").read_text())["objects"]}
    W, H = ours.resolution
    lines = ["KITTI's facade boxes (frame: KITTI / the render's same box, band power x 1e4, 2-16/16-48/48-72/72-92):"]
    for k, reg in twin.KITTI_REGIONS.items():
        full = twin.kitti_marked_frame(k)
        sx, sy = W / full.shape[1], H / full.shape[0]
        x0, y0, x1, y1 = reg["facade"]
        m = (slice(int(y0 * sy) + 2, int(y1 * sy) - 2), slice(int(x0 * sx) + 2, int(x1 * sx) - 2))
        real = [1e4 * float(np.mean(b[m] ** 2)) for b in twin.band_images(cv2.resize(full, (W, H), interpolation=cv2.INTER_AREA))]
        mine = ([1e4 * float(np.mean(b[m] ** 2)) for b in twin.band_images(ours.image_gray(k))] if k < n else None)
        lines.append(f"  frame {k}: " + "/".join(f"{x:.0f}" for x in real) + " | "
                     + ("/".join(f"{x:.0f}" for x in mine) if mine else "not rendered"))
    groups: dict[str, list] = {}
    per_id: dict[int, list] = {}
    bid = [i for i, c in cls.items() if c == "building"]
    for k in range(n):
        bands = twin.band_images(ours.image_gray(k))
        ids = np.asarray(seq.ids(k, "left")).astype(int)
        z = np.asarray(seq.depth(k, "left"))
        L = ours.linear(k, "kitti")
        fac = _erode(np.isin(ids, bid))
        if fac.sum() < 50:
            continue
        sub = {f"kind {kd}": _erode(np.isin(ids, [i for i in bid if kind[i] == kd]))
               for kd in sorted({kind[i] for i in bid})}
        sub.update({f"{a}-{b:g} m": fac & (z >= a) & (z < b) for a, b in DEPTHS})
        med = np.median(L[fac])
        sub["sunlit (> 0.7 x median)"], sub["shaded"] = fac & (L > 0.7 * med), fac & (L <= 0.7 * med)
        sub["all buildings"] = fac
        for name, m in sub.items():
            if m.sum() >= 50:
                groups.setdefault(name, []).append([float(np.mean(b[m] ** 2)) for b in bands] + [m.mean()])
        for i in bid:
            m = _erode(ids == i)
            if m.sum() >= 30:
                per_id.setdefault(i, []).append([float(np.sum(b[m] ** 2)) for b in bands] + [m.sum(), float(np.sum(z[m]))])
    lines.append(f"render's buildings (median over {n} frames; band power x 1e4, share of the frame's pixels):")
    for name, v in groups.items():
        a = np.median(np.array(v), axis=0)
        lines.append(f"  {name:26s} " + "/".join(f"{1e4 * x:.0f}" for x in a[:4]) + f"  {100 * a[4]:.1f} % ({len(v)} frames)")
    lines.append("per object (pixel-weighted over the frames; band power x 1e4, pixels a frame, mean depth):")
    for i, v in sorted(per_id.items(), key=lambda t: -sum(r[4] for r in t[1])):
        a = np.sum(np.array(v), axis=0)
        lines.append(f"  {i} {kind[i]:15s} " + "/".join(f"{1e4 * x / a[4]:.0f}" for x in a[:4])
                     + f"  {a[4] / n:.0f} px  {a[5] / a[4]:.1f} m")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--draw", type=int, default=0)
    a = ap.parse_args(argv)
    if not (a.out / "manifest.json").is_file():
        print(f"{a.out}: no manifest.json (a twin render's city folder)", file=sys.stderr)
        return 2
    if a.frames < 1:
        print(f"--frames: 1 or more, got {a.frames}", file=sys.stderr)
        return 2
    seq = twin.open_sequence(a.out)
    done = sum(1 for k in range(min(a.frames, seq.num_frames)) if seq.frame_complete(k))
    if done < a.frames:
        print(f"{a.out}: {done} of frames 0-{a.frames - 1} rendered completely; ask for fewer (--frames {done})",
              file=sys.stderr)
        return 2
    print("\n".join(measure(a.out, a.frames, a.draw)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
