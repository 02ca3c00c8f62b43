"""``python -m vo_reference stereo-vo INPUT``: the reference stereo VO on a render or KITTI folder."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from blender_sesgen.contract.progress import Progress, add_progress_argument, progress_mode
from blender_sesgen.contract.timing import FRAMES_HELP

from ..errors import VoError

METHOD_CHOICES = ("paper", "accurate", "opencv-baseline")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", metavar="INPUT", help="a sesgen render folder (manifest.json) or a KITTI odometry folder")
    p.add_argument("--method", default="accurate", choices=METHOD_CHOICES,
                   help="paper: the SESGen paper's method (SAD, pixel disparity, Eq. 6); accurate: sub-pixel "
                        "LK + RANSAC + SE(3) refinement; opencv-baseline: a plain OpenCV comparison (default: accurate)")
    p.add_argument("--gt-depth", action="store_true",
                   help="use the render's depth at each keypoint instead of stereo matching (render folders only)")
    p.add_argument("--gt-flow", action="store_true",
                   help="use each keypoint's exact position in the next frame (from depth + K + poses) instead of tracking")
    p.add_argument("--mask-dynamic-gt", action="store_true",
                   help="drop keypoints on objects that move (the render's ground-truth motion mask)")
    p.add_argument("--out", required=True, metavar="EST.txt", help="estimated trajectory (left camera poses)")
    p.add_argument("--out-format", default="kitti", choices=("kitti", "tum"),
                   help="trajectory format: kitti (12 numbers per line, default) or tum (with timestamps)")
    p.add_argument("--frames", metavar="A:B", help=f"{FRAMES_HELP}; default all")
    p.add_argument("--search", type=int, metavar="R", help="paper method: tracking search range +-R px (default 16)")
    p.add_argument("--block", type=int, metavar="M", help="paper method: SAD block size M (odd, default 9)")
    p.add_argument("--d-max", type=int, metavar="D", help="disparity search range in px (paper 64, accurate 128)")
    add_progress_argument(p)


def make_params(method: str, args: argparse.Namespace):
    """Method parameters with the command-line overrides applied."""
    from .accurate import AccurateParams
    from .paper import PaperParams
    if method == "paper":
        p = PaperParams()
        if getattr(args, "search", None) is not None:
            p.search = int(args.search)
        if getattr(args, "block", None) is not None:
            if args.block < 3 or args.block % 2 != 1:
                raise VoError(f"--block must be an odd number >= 3, got {args.block}")
            p.block = int(args.block)
    elif method == "accurate":
        p = AccurateParams()
    else:
        return None
    if getattr(args, "d_max", None) is not None:
        if args.d_max < 2:
            raise VoError(f"--d-max must be >= 2, got {args.d_max}")
        p.d_max = int(args.d_max)
    return p


def failed_summary(failed: list) -> str:
    """One line naming the steps that kept the previous motion (constant velocity)."""
    steps = ", ".join(f"{k}->{k + 1}" for k, _ in failed[:10]) + (" ..." if len(failed) > 10 else "")
    return f"warning: {len(failed)} step(s) could not be estimated and kept the previous motion: {steps}"


def step_detail(k: int, res) -> str:
    """The per-step line of the stereo VO: points, motion U V W (units/frame), angles (deg), time."""
    X = res.twist
    return (f"frame {k:4d}->{k + 1:<4d} {res.n_points:4d} pts  U V W = {X[0]:+.4f} {X[1]:+.4f} {X[2]:+.4f}  "
            f"a b g = {np.degrees(X[3]):+.3f} {np.degrees(X[4]):+.3f} {np.degrees(X[5]):+.3f} deg")


def vo_progress(method: str, frames: tuple[int, int], mode: str = "auto", stream=None, callback=None):
    """(reporter, step callback for :func:`run_stereo_vo`): one progress unit per frame step;
    a failed step is a note (kept in every mode)."""
    bar = Progress(frames[1] - frames[0], f"stereo-vo {method}", mode=mode, stream=stream, callback=callback,
                   unit="step")

    def show(k: int, last: int, res, dt: float) -> None:
        if res.failure:
            bar.note(f"[{method}] frame {k}->{k + 1}: FAILED ({res.failure}); keeps the previous motion")
            bar.update(frame=k, failure=res.failure)
            return
        bar.update(detail=f"{step_detail(k, res)}  {1000 * dt:6.1f} ms", frame=k, n_points=int(res.n_points),
                   twist=[float(x) for x in res.twist], seconds=dt)
    return bar, show


def run(args: argparse.Namespace) -> int:
    from ..io.sequence import open_sequence, require_complete
    from ..io.trajectory import write_kitti, write_tum
    from .pipeline import parse_frames, run_stereo_vo

    seq = open_sequence(args.input)
    frames = parse_frames(args.frames, seq.num_frames)
    require_complete(seq, range(frames[0], frames[1] + 1))  # refused before anything starts
    bar, show = vo_progress(args.method, frames, progress_mode(args))
    with bar:
        res = run_stereo_vo(seq, args.method, gt_depth=args.gt_depth, gt_flow=args.gt_flow,
                            mask_dynamic_gt=args.mask_dynamic_gt, frames=range(frames[0], frames[1] + 1),
                            params=make_params(args.method, args), progress=show)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if args.out_format == "tum":
        write_tum(out, res.trajectory)
    else:
        write_kitti(out, res.trajectory)
    print(f"{args.method}: {len(res.trajectory)} poses (frames {frames[0]}..{frames[1]}) -> {out} "
          f"({args.out_format}); {res.fps:.1f} frames/s")
    if res.failed:
        print(failed_summary(res.failed), file=sys.stderr)
    return 0
