"""``python -m vo_reference evaluate-disparity``: EPE, bad-N and D1 of a disparity map."""
from __future__ import annotations

import argparse
from pathlib import Path

from blender_sesgen.contract.cli import add_report_argument


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--gt", required=True, help="ground-truth disparity (PNG16 KITTI /256, PFM, .npy, TIFF, EXR)")
    p.add_argument("--est", required=True, help="estimated disparity (same formats)")
    p.add_argument("--mask", help="non-occlusion mask image (nonzero = visible in both views): adds 'noc' metrics")
    p.add_argument("--json", metavar="OUT.json", help="write the metrics as JSON")
    add_report_argument(p, "the disparity error map (disparity_error.png)")


def run(args: argparse.Namespace) -> int:
    from .disparity import disparity_metrics
    from ..products.disparity import read_disparity
    from .disparity_io import read_mask
    from .report import write_json

    gt = read_disparity(args.gt)
    est = read_disparity(args.est)
    mask = read_mask(args.mask) if args.mask else None
    m = disparity_metrics(gt, est, mask)
    keys = [k for k in m["all"] if k not in ("n_pixels",)]
    print(f"gt:  {args.gt} ({gt.shape[1]}x{gt.shape[0]})")
    print(f"est: {args.est}")
    print(f"{'pixels':<8}{'n':>10}" + "".join(f"{k.replace('_pct', ' %').replace('_px', ' px'):>12}" for k in keys))
    for name, r in m.items():
        print(f"{name:<8}{r['n_pixels']:>10d}" + "".join(f"{r[k]:>12.4f}" for k in keys))
    m["inputs"] = {"gt": args.gt, "est": args.est, "mask": args.mask}
    if args.json:
        write_json(args.json, m)
        print(f"metrics: {args.json}")
    if args.report:
        from .plots import plot_disparity_error
        p = plot_disparity_error(gt, est, Path(args.report) / "disparity_error.png", title=Path(args.est).name)
        print(f"plot:    {p}")
    return 0
