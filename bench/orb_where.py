"""Where the ORB VO's inliers of one sixth of the image lie in 3-D, KITTI sequence_1 against a
city twin render: their lateral offset and height above the road (SGBM depth, each step's camera
k; the camera 1.65 m above the road), by depth band, and on the render the object kinds they
fall on. Session 17 (planting17): KITTI's upper-right inliers lie 8-12 m right, 2.3-4.6 m up (the
front gardens' young trees and the houses' dark ground-floor openings), the render's 8.5-9.3 m
right on its facades (balcony railings and windows).

    python bench/orb_where.py OUT/city [--frames 24] [--sixth 2] [--overlay DIR]

OUT/city: a render folder of ``bench/twin.py --scene city`` (its EXRs developed again with
sensor-noise seed 0, as twin.py's draw 0). ``--overlay DIR`` writes both images' sixth with the
inliers coloured by lateral offset (red < 9.5 m, green 9.5-12 m, blue beyond) for frames 0, 6, 12.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import twin  # noqa: E402  (bench/twin.py, beside this script)

from blender_sesgen.contract.camera import project  # noqa: E402
from vo_reference.io.sequence import open_sequence  # noqa: E402

HEIGHT_M = 1.65       # KITTI's camera above the road
BANDS_M = ((5, 12), (12, 18), (18, 25), (25, 35), (35, 60))


def inliers_in_sixth(frames: twin.Frames, n: int, sixth: int) -> tuple[list, list]:
    """Per step: the ORB VO's PnP inliers (points in camera k, m) whose pixels lie in ``sixth``
    (``twin.REGIONS``), and those pixels."""
    recs: list = []
    twin.orb_steps(frames, n, funnel=recs)
    W, H = frames.resolution
    pts, pix = [], []
    for r in recs:
        P = r.P[r.inliers] if len(r.inliers) else np.zeros((0, 3))
        px = project(frames.K, P) if len(P) else np.zeros((0, 2))
        m = twin._sixth(px[:, 0], px[:, 1], W, H) == sixth if len(P) else np.zeros(0, bool)
        pts.append(P[m])
        pix.append(px[m])
    return pts, pix


def lines(name: str, pts: list) -> list[str]:
    P = np.concatenate(pts) if pts else np.zeros((0, 3))
    steps = max(len(pts), 1)
    if not len(P):
        return [f"{name}: no inliers"]
    X, Y, Z = P.T
    h = HEIGHT_M - Y
    q = lambda v: "/".join(f"{x:.1f}" for x in np.percentile(v, [10, 50, 90]))  # noqa: E731
    out = [f"{name}: {len(P) / steps:.0f} a step at {np.median(Z):.1f} m; right of the camera p10/50/90 {q(X)} m, "
           f"above the road {q(h)} m"]
    for z0, z1 in BANDS_M:
        m = (Z >= z0) & (Z < z1)
        if m.any():
            out.append(f"  {z0}-{z1} m away: {m.sum() / steps:.1f} a step, right {q(X[m])} m, up {q(h[m])} m")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="a bench/twin.py city render folder (OUT/city)")
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--sixth", type=int, default=2, help="0-5, twin.REGIONS (default 2: upper right)")
    ap.add_argument("--overlay", type=Path, default=None)
    a = ap.parse_args(argv)
    if not (a.out / "manifest.json").is_file() or not 0 <= a.sixth <= 5 or a.frames < 3:
        print(f"{a.out}: no render (manifest.json), or --sixth outside 0-5, or --frames under 3", file=sys.stderr)
        return 2
    seq = open_sequence(a.out)
    n = min(a.frames, seq.num_frames)
    real = twin.resized(open_sequence(twin.DATA / "kitti" / "sequence_1"), n, tuple(seq.resolution))
    ours = twin.resensor(a.out, n, 0, 0)
    kind_of = twin._kind_of_ids(a.out)
    print(f"ORB VO's inliers in the {twin.REGIONS[a.sixth]} sixth, frames 0-{n - 1} at {seq.resolution[0]} px")
    for name, frames in (("KITTI sequence_1", real), ("render", ours)):
        pts, pix = inliers_in_sixth(frames, n, a.sixth)
        print("\n".join(lines(name, pts)))
        if name == "render":
            kinds: dict[str, int] = {}
            for k, px in enumerate(pix):
                ids = np.asarray(seq.ids(k, "left"))
                x = np.clip(np.rint(px[:, 0]).astype(int), 0, ids.shape[1] - 1)
                y = np.clip(np.rint(px[:, 1]).astype(int), 0, ids.shape[0] - 1)
                for i in ids[y, x]:
                    kd = kind_of.get(int(i), "sky")
                    kinds[kd] = kinds.get(kd, 0) + 1
            total = max(sum(kinds.values()), 1)
            print("  render's by object kind: " + ", ".join(f"{kd} {100 * c / total:.0f} %"
                                                         for kd, c in sorted(kinds.items(), key=lambda t: -t[1])))
        if a.overlay is not None:
            a.overlay.mkdir(parents=True, exist_ok=True)
            W, H = frames.resolution
            r0, c0 = (a.sixth // 3) * H // 2, (a.sixth % 3) * W // 3
            for k in (0, 6, 12):
                if k >= len(pts):
                    continue
                img = cv2.cvtColor(cv2.resize(frames.image_gray(k), (2 * W, 2 * H), interpolation=cv2.INTER_CUBIC),
                                   cv2.COLOR_GRAY2BGR)
                for (u, v), X in zip(pix[k], pts[k][:, 0]):
                    col = (0, 0, 255) if X < 9.5 else (0, 255, 0) if X < 12 else (255, 0, 0)
                    cv2.circle(img, (int(2 * u), int(2 * v)), 3, col, 1)
                tag = "kitti" if name.startswith("KITTI") else "render"
                cv2.imwrite(str(a.overlay / f"{tag}_{k}.png"), img[2 * r0:2 * r0 + H, 2 * c0:2 * c0 + 2 * W // 3])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
