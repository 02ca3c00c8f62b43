"""``python -m vo_reference mono-vo INPUT ...``: the classic monocular VO on a render folder,
a KITTI folder or a folder of (Bayer) images with timestamps. See docs/mono-vo.md.

This module parses and prints; the run is ``mono.run``."""
from __future__ import annotations

import argparse

from blender_sesgen.contract.cli import add_report_argument
from blender_sesgen.contract.progress import add_progress_argument, progress_mode
from blender_sesgen.contract.timing import FRAMES_HELP


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", metavar="INPUT", help="render folder (manifest.json), KITTI folder, or image folder")
    p.add_argument("--out", required=True, metavar="FILE", help="estimated trajectory file")
    p.add_argument("--out-format", choices=("kitti", "tum"), default="kitti", help="trajectory format (default kitti)")
    p.add_argument("--scale", choices=("auto", "gt", "stereo", "speed", "none"), default="auto",
                   help="step lengths: gt = from ground-truth poses, stereo = from depth or the right "
                        "view, speed = --speed x frame time, none = unit steps; auto (default) = gt when "
                        "the input has poses, else none")
    p.add_argument("--speed", type=float, metavar="M_PER_S", help="known speed for --scale speed")
    p.add_argument("--bayer", metavar="PATTERN", help="image folder holds raw Bayer mosaics (gbrg, grbg, rggb, bggr)")
    p.add_argument("--model", metavar="FILE", help="RobotCar camera model (fx fy cx cy + G_camera_image): K")
    p.add_argument("--lut", metavar="FILE", help="undistortion lookup table, RobotCar binary layout")
    p.add_argument("--dist", metavar="K1,K2,P1,P2[,K3]", help="undistort with OpenCV distortion coefficients")
    p.add_argument("--features", choices=("klt", "orb", "sift"), default="klt", help="correspondences (default klt)")
    p.add_argument("--best-n", type=int, default=1000, metavar="N", help="keep the best N matches by error (default 1000)")
    p.add_argument("--threshold", type=float, default=1.0, metavar="PX", help="RANSAC Sampson threshold (default 1 px)")
    p.add_argument("--refine", choices=("sampson", "pnp", "none"), default="sampson",
                   help="pose refinement after E (default sampson; pnp = non-linear triangulation + PnP)")
    p.add_argument("--solver", choices=("5pt", "8pt"), default="5pt",
                   help="minimal solver in our RANSAC: 5pt = calibrated 5-point essential matrix (default), "
                        "8pt = normalised 8-point fundamental matrix")
    p.add_argument("--score", choices=("msac", "count"), default="msac",
                   help="hypothesis selection: msac = lowest truncated-quadratic Sampson cost, bounded "
                        "(arctan) robust refinement (default); count = most inliers, Cauchy refinement "
                        "(the earlier rule)")
    p.add_argument("--seed", type=int, default=0, help="RANSAC seed (default 0)")
    p.add_argument("--blur", type=float, default=0.0, metavar="SIGMA", help="Gaussian blur sigma in px (default 0)")
    p.add_argument("--equalize", choices=("none", "hist", "clahe"), default="none", help="contrast (default none)")
    p.add_argument("--mask-bottom", type=float, default=0.0, metavar="ROWS",
                   help="ignore the bottom rows (bonnet): pixels, or a fraction of the height if < 1")
    p.add_argument("--mask-rect", action="append", default=[], metavar="X0,Y0,X1,Y1", help="ignore a box (repeatable)")
    p.add_argument("--mask", metavar="PNG", help="mask image: non-zero = usable")
    p.add_argument("--frames", metavar="A:B", help=f"{FRAMES_HELP}; default all")
    p.add_argument("--compare-opencv", action="store_true",
                   help="also run OpenCV findEssentialMat + recoverPose on the same matches")
    p.add_argument("--opencv-method", choices=("usac", "ransac"), default="usac",
                   help="OpenCV's robust estimator: usac = USAC_ACCURATE (default), ransac = classic RANSAC")
    add_report_argument(p, "plots (trajectories.png, per_frame.png), the per-frame table (frames.csv), summary.json")
    add_progress_argument(p)


def run(args: argparse.Namespace) -> int:
    from .run import MonoRunOptions, run_mono, summary_lines
    opts = MonoRunOptions.of(args)
    result = run_mono(opts, progress_mode(args))
    for line in summary_lines(result.summary):
        print(line)
    print("wrote " + ", ".join(result.outputs))
    if opts.report:
        print(f"report: {opts.report}")
    return 0
