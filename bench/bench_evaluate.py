"""Benchmark: APE + RPE + KITTI metric on KITTI 00 (4541 poses), ours vs evo in the same run.

Both sides start from trajectories already in memory (file parsing excluded) and compute:
SE3 (Umeyama) alignment, APE translation + rotation, RPE (1 frame) translation + rotation.
Ours also computes the KITTI devkit metric (evo has none), so the ratio is conservative.
Prints best-of-N wall times and ours/evo (goal <= 1).

    python bench/bench_evaluate.py [--repeat 5] [--data ../shared/data]
"""
from __future__ import annotations

import argparse
import copy
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def best_of(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--data", default=os.environ.get("SESGEN_SHARED_DATA", str(REPO.parent / "shared" / "data")))
    args = ap.parse_args()
    d = Path(args.data) / "trajectories"
    if not (d / "KITTI_00_gt.txt").is_file():
        print(f"skipped: KITTI 00 trajectories not found under {d}")
        return 0

    from vo_reference.evaluate import align, ape, kitti_metric, rpe
    from vo_reference.io.trajectory import read_trajectory
    gt = read_trajectory(d / "KITTI_00_gt.txt", "kitti")
    est = read_trajectory(d / "KITTI_00_ORB.txt", "kitti")

    def ours():
        aligned, _ = align(est, gt, "se3")
        a = ape(gt, aligned)
        r = rpe(gt, aligned, 1, "f")
        k = kitti_metric(gt, est)
        return a.trans.rmse, a.rot_deg.rmse, r.trans.rmse, r.rot_deg.rmse, k.t_err_pct, k.r_err_deg_per_100m

    try:
        from evo.core import metrics
        from evo.tools import file_interface
    except ImportError:
        print("evo is not installed (test extra): timing ours only")
        t, out = best_of(ours, args.repeat)
        print(f"ours: {t * 1e3:.1f} ms  {out}")
        return 0
    ref_evo = file_interface.read_kitti_poses_file(str(d / "KITTI_00_gt.txt"))
    est_evo = file_interface.read_kitti_poses_file(str(d / "KITTI_00_ORB.txt"))

    def evo():
        e = copy.deepcopy(est_evo)
        e.align(ref_evo)
        out = []
        for metric in (metrics.APE, metrics.RPE):
            for rel in (metrics.PoseRelation.translation_part, metrics.PoseRelation.rotation_angle_deg):
                m = metric(rel)
                m.process_data((ref_evo, e))
                out.append(m.get_statistic(metrics.StatisticsType.rmse))
        return tuple(out)

    ours()  # warm-up (imports, caches)
    evo()
    t_ours, o = best_of(ours, args.repeat)
    t_evo, e = best_of(evo, args.repeat)
    print(f"KITTI 00, {len(gt)} poses, best of {args.repeat}")
    print(f"  ours (align + APE + RPE + KITTI): {t_ours * 1e3:8.1f} ms   APE {o[0]:.6f} m  RPE {o[2]:.6f} m  "
          f"KITTI {o[4]:.4f} % {o[5]:.4f} deg/100m")
    print(f"  evo  (align + APE + RPE):         {t_evo * 1e3:8.1f} ms   APE {e[0]:.6f} m  RPE {e[2]:.6f} m")
    print(f"  ratio ours/evo: {t_ours / t_evo:.3f}  (goal <= 1)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
