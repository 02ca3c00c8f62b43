"""``python -m vo_reference evaluate-slam``: a SLAM system's outputs on a render with loop
closures -- its (keyframe) trajectory and its loop-closure detections -- against the ground
truth (poses and the covisibility written by ``python -m vo_reference covisibility``)."""
from __future__ import annotations

import argparse

from ..errors import VoError
from .align import METHODS


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--gt", required=True, metavar="RENDER",
                   help="render folder with its covisibility (python -m vo_reference covisibility RENDER)")
    p.add_argument("--est", metavar="FILE", help="estimated trajectory: all frames or keyframes (TUM with "
                                                 "timestamps, KITTI with one pose per frame, EuRoC)")
    p.add_argument("--format", default="auto", choices=("tum", "kitti", "euroc", "auto"))
    p.add_argument("--detections", metavar="FILE",
                   help="loop-closure detections, one per line: 'query match [score]' (frame indices)")
    p.add_argument("--by-time", action="store_true", help="the detections give the frames' timestamps (s)")
    p.add_argument("--threshold", type=float, default=None, metavar="C",
                   help="true loop closure: the query sees at least this share of itself in the match "
                        "(default: the covisibility's loop threshold)")
    p.add_argument("--min-gap", type=float, default=None, metavar="S",
                   help="true loop closure: at least S seconds apart (default: the covisibility's)")
    p.add_argument("--align", default="se3", choices=METHODS, help="alignment before APE/RPE (default se3)")
    p.add_argument("--max-diff", type=float, default=0.01, metavar="S", help="timestamp association tolerance")
    p.add_argument("--view", default="left", choices=("left", "right"))
    p.add_argument("--json", metavar="OUT.json", help="write the metrics as JSON")


def run(args: argparse.Namespace) -> int:
    from ..io.trajectory import guess_format, read_trajectory
    from ..products.covisibility import read_covisibility
    from .loops import evaluate_loops, read_detections
    from .report import write_json
    from .slam import evaluate_slam
    from .trajectory_eval import EvaluationOptions
    if not args.est and not args.detections:
        raise VoError("nothing to evaluate: give --est and/or --detections")
    cov = read_covisibility(args.gt)
    out = {"gt": args.gt}
    if args.detections:
        det = read_detections(args.detections, cov.timestamps_s, args.by_time, args.max_diff)
        le = evaluate_loops(cov, det, args.threshold, args.min_gap)
        print("\n".join(le.summary_lines()))
        out["loops"] = le.metrics()
    if args.est:
        fmt = guess_format(args.est) if args.format == "auto" else args.format
        gt = read_trajectory(args.gt, "sesgen", view=args.view)
        est = read_trajectory(args.est, fmt)
        kitti_file = fmt == "kitti"
        if kitti_file and len(est) != len(gt):
            raise VoError(f"{args.est}: {len(est)} poses for {len(gt)} frames; KITTI files have no timestamps, so "
                          "they must have one pose per frame (give keyframes as TUM)")
        long_enough = gt.path_length() >= 100.0        # the KITTI metric's shortest segment
        opts = EvaluationOptions(align=args.align, kitti=long_enough, max_diff_s=args.max_diff, by_index=kitti_file,
                                 kitti_frame_period_s=float(gt.timestamps_s[1] - gt.timestamps_s[0]))
        pairs = cov.positives(args.threshold, args.min_gap)
        ev = evaluate_slam(gt, est, pairs, opts)
        if args.detections:
            print()
        print(f"est: {args.est} ({fmt}, {len(est)} poses)")
        print("\n".join(ev.summary_lines()))
        if not long_enough:
            print(f"(no KITTI metric: the route is {gt.path_length():.1f} m, its shortest segment 100 m)")
        out["trajectory"] = ev.metrics()
    if args.json:
        write_json(args.json, out)
        print(f"metrics: {args.json}")
    return 0
