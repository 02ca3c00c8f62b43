"""``python -m vo_reference run INPUT``: the one-shot path — stereo VO with both methods,
evaluation (APE/RPE, the SESGen paper's per-frame egomotion table), plots, into a report folder.

INPUT is a render folder, or any other sequence with ground-truth poses (a KITTI odometry
folder with its poses). Report folder: ``INPUT/report`` for a render, ``./NAME_report`` for
other inputs (a dataset folder is never written to), or ``--report DIR``. It holds
``summary.md`` (the paper-style RMSE table with the paper's Table 1 values beside ours, then
per method the evaluation), ``report.json``, and per method ``<method>/`` with ``est.txt``
(KITTI poses), ``est_tum.txt``, ``metrics.json``, ``summary.md`` and PNG plots.

A render with moving objects: the report gives the share of the image on objects that
move (per step: mean and max) and runs every method both without and with the
ground-truth motion mask (``--mask-dynamic-gt`` makes the masked run the main one), side by
side: the error each way and the share of the points each method kept that lie on moving
objects.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.cli import add_report_argument
from blender_sesgen.contract.progress import add_progress_argument, progress_mode
from blender_sesgen.contract.timing import FRAMES_HELP

from ..errors import VoError
from ..evaluate.align import CLI_DEFAULT
from .report import RunReport, error_summary, shape_errors, shape_line


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", metavar="INPUT", help="a sesgen render folder (manifest.json), or a KITTI odometry "
                                                  "folder with ground-truth poses")
    add_report_argument(p, "summary.md, report.json and per method its trajectory, metrics and plots",
                        "INPUT/report for a render folder, else ./NAME_report")
    p.add_argument("--methods", default="paper,accurate", help="comma-separated methods (default: paper,accurate)")
    p.add_argument("--gt-depth", action="store_true", help="run the methods with ground-truth depth")
    p.add_argument("--gt-flow", action="store_true", help="run the methods with ground-truth correspondences")
    p.add_argument("--mask-dynamic-gt", action="store_true",
                   help="run the methods with the ground-truth motion mask (keypoints on moving objects dropped); "
                        "with moving objects the report compares both ways anyway")
    p.add_argument("--frames", metavar="A:B", help=f"{FRAMES_HELP}; default all")
    p.add_argument("--align", default=CLI_DEFAULT, choices=["none", "origin", "se3", "sim3"],
                   help=f"trajectory alignment for APE (default {CLI_DEFAULT}: the VO starts at the ground-truth "
                        "first pose, so APE is the drift; se3 fitted to a short, nearly straight path is ill-posed)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    add_progress_argument(p)


def default_report_dir(root: Path) -> Path:
    """``RENDER/report`` for a render (our own output folder), else ``./NAME_report``."""
    folder = root.parent if root.is_file() else root
    if (folder / "manifest.json").exists():
        return folder / "report"
    return Path.cwd() / f"{folder.resolve().name}_report"


def run(args: argparse.Namespace) -> int:
    from ..evaluate.report import write_json, write_report
    from ..evaluate.trajectory_eval import evaluate_trajectory, summary_lines
    from ..io.sequence import open_sequence, require_complete
    from ..io.trajectory import Trajectory, write_kitti, write_tum
    from .cli import failed_summary, vo_progress
    from .pipeline import METHODS, check_stereo, parse_frames, run_stereo_vo

    root = Path(args.input)
    seq = open_sequence(root)
    T_gt = seq.T_world_cam("left")
    if T_gt is None:
        raise VoError(f"{root}: no ground-truth poses to evaluate against (a KITTI folder needs poses.txt; "
                      "use `stereo-vo` for an estimate alone)")
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    for m in methods:
        if m not in METHODS:
            raise VoError(f"unknown method {m!r} (choose from {', '.join(METHODS)})")
    frames = parse_frames(args.frames, seq.num_frames)
    check_stereo(seq)                                       # before any output is written
    require_complete(seq, range(frames[0], frames[1] + 1))
    out = Path(args.report) if args.report else default_report_dir(root)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise VoError(f"cannot create the report folder {out} ({e.strerror}); choose one with --report DIR") from None
    gt = Trajectory(T_gt[frames[0]:frames[1] + 1], np.asarray(seq.timestamps_s)[frames[0]:frames[1] + 1])
    variant = "".join([" +GT depth" if args.gt_depth else "", " +GT flow" if args.gt_flow else "",
                       " +GT motion mask" if args.mask_dynamic_gt else ""])
    dynamic = bool(seq.moving_ids)

    report = RunReport(root=root, frames=frames, K=seq.K, baseline_m=seq.baseline_m, resolution=seq.resolution,
                       gt_depth=args.gt_depth, gt_flow=args.gt_flow, mask_dynamic_gt=args.mask_dynamic_gt,
                       plots=not args.no_plots)
    for m in methods:
        print(f"== {m}{variant}: frames {frames[0]}..{frames[1]} of {root}")
        bar, show = vo_progress(m, frames, progress_mode(args))
        with bar:
            res = run_stereo_vo(seq, m, gt_depth=args.gt_depth, gt_flow=args.gt_flow,
                                mask_dynamic_gt=args.mask_dynamic_gt, frames=range(frames[0], frames[1] + 1),
                                progress=show)
        mdir = out / m
        mdir.mkdir(parents=True, exist_ok=True)
        write_kitti(mdir / "est.txt", res.trajectory)
        write_tum(mdir / "est_tum.txt", res.trajectory)
        ev = evaluate_trajectory(gt, res.trajectory, align=args.align, egomotion=True, by_index=True)
        files = write_report(mdir, ev, title=f"Stereo VO ({m}{variant}) on {root.name}",
                             inputs={"ground truth": root, "est": mdir / "est.txt"}, plots=not args.no_plots,
                             extra={"fps": res.fps, "n_points_min": int(res.n_points.min()),
                                    "n_points_mean": float(res.n_points.mean())})
        shape = shape_errors(gt, res.trajectory)
        summary = summary_lines(ev)
        failed = failed_summary(res.failed) if res.failed else None
        print("\n".join(summary))
        print(shape_line(shape))
        if failed:
            print(failed)
        report.add_method(m, f"{m}{variant}", ev, shape, res, summary, files, failed)
        if dynamic:  # the same method the other way round: without / with the ground-truth motion mask
            print(f"== {m}: {'without' if args.mask_dynamic_gt else 'with'} the ground-truth motion mask")
            other = run_stereo_vo(seq, m, gt_depth=args.gt_depth, gt_flow=args.gt_flow,
                                  mask_dynamic_gt=not args.mask_dynamic_gt,
                                  frames=range(frames[0], frames[1] + 1))
            ev_other = evaluate_trajectory(gt, other.trajectory, align=args.align, egomotion=True, by_index=True)
            this = error_summary(ev, shape, res)
            that = error_summary(ev_other, shape_errors(gt, other.trajectory), other)
            report.add_mask_comparison(m, *((that, this) if args.mask_dynamic_gt else (this, that)))
    atomic.write_text(out / "summary.md", report.markdown())
    write_json(out / "report.json", report.as_json())
    print(f"report: {out / 'summary.md'}")
    return 0
