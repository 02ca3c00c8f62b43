"""Mono VO speed and accuracy on the KITTI snippet: ours vs OpenCV per frame.

    python bench/bench_mono.py [KITTI_DIR]      (default ../shared/data/kitti/sequence_1)

Prints seconds per frame of each stage (features, our solver with the 5-point and with the
8-point minimal solver, OpenCV's USAC and RANSAC solvers on the same matches) and the accuracy against ground
truth. Figures, not asserts: the machine is shared, so compare ratios.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from vo_reference.io.sequence import open_sequence
from vo_reference.mono.features import correspondences
from vo_reference.mono.motion_errors import direction_difference_deg, gt_motions, rotation_difference_deg
from vo_reference.mono.opencv_ref import opencv_relative_pose
from vo_reference.mono.relative_pose import estimate_relative_pose


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    root = Path(argv[0]) if argv else Path(__file__).resolve().parents[1].parent / "shared/data/kitti/sequence_1"
    seq = open_sequence(root)
    G = gt_motions(seq.T_world_cam())
    imgs = [seq.image_gray(k) for k in range(seq.num_frames)]
    t = {"features": 0.0, "ours 5pt": 0.0, "ours 8pt": 0.0, "opencv usac": 0.0, "opencv ransac": 0.0}
    err = {k: ([], []) for k in t if k != "features"}
    last = {"5pt": np.eye(4), "8pt": np.eye(4)}
    for k in range(1, len(imgs)):
        t0 = time.perf_counter()
        m = correspondences(imgs[k - 1], imgs[k])
        t["features"] += time.perf_counter() - t0
        for name in err:
            t0 = time.perf_counter()
            if name.startswith("ours"):
                solver = name.split()[1]
                rel = estimate_relative_pose(m.x1, m.x2, seq.K, priors=(last[solver],), triangulate=False,
                                             solver=solver)
                last[solver] = rel.T_c1_c2
            else:
                rel = opencv_relative_pose(m.x1, m.x2, seq.K, method=name.split()[1])
            t[name] += time.perf_counter() - t0
            err[name][0].append(rotation_difference_deg(rel.T_c1_c2, G[k - 1]))
            err[name][1].append(direction_difference_deg(rel.T_c1_c2, G[k - 1]))
    n = len(imgs) - 1
    print(f"{root}: {n} frame pairs, {seq.resolution[0]}x{seq.resolution[1]}")
    for name, secs in t.items():
        line = f"  {name:14s} {1000 * secs / n:7.1f} ms/frame"
        if name in err:
            line += (f"   rotation error median {np.median(err[name][0]):.3f} deg, "
                     f"direction error median {np.median(err[name][1]):.3f} deg")
        print(line)
    for solver in ("5pt", "8pt"):
        print(f"  ours {solver} / OpenCV USAC time ratio: {t['ours ' + solver] / t['opencv usac']:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
