"""``python -m vo_reference evaluate``: APE, RPE (and KITTI, egomotion) of an estimate vs ground truth."""
from __future__ import annotations

import argparse
from pathlib import Path

from blender_sesgen.contract.cli import add_report_argument
from blender_sesgen.contract.timing import FRAMES_HELP, frame_range

from ..errors import VoError, as_vo_error
from ..io.trajectory import Trajectory, guess_format, read_trajectory
from .align import CLI_DEFAULT, METHODS


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--gt", required=True, help="ground-truth trajectory file, or a sesgen render folder / manifest.json")
    p.add_argument("--est", required=True, help="estimated trajectory file")
    p.add_argument("--format", default="auto", choices=("tum", "kitti", "euroc", "auto"),
                   help="trajectory file format (default: guessed from the content; a folder is a render)")
    p.add_argument("--frames", metavar="A:B",
                   help=f"the ground-truth {FRAMES_HELP} that an estimate without timestamps (KITTI) covers, "
                        "as stereo-vo --frames wrote it; a TUM or EuRoC estimate is paired by its timestamps")
    p.add_argument("--align", default=CLI_DEFAULT, choices=METHODS,
                   help=f"alignment of the estimate before APE/RPE (default: {CLI_DEFAULT}: the first poses made "
                        "equal, so APE is the drift from the start, as `run` reports; se3/sim3 fit the whole path "
                        "(sim3 for monocular), ill-posed on a short or straight one)")
    p.add_argument("--n-align", type=int, default=-1, metavar="N",
                   help="align on the first N poses only (default: all)")
    p.add_argument("--delta", type=float, default=1, metavar="N", help="RPE pair distance (default: 1)")
    p.add_argument("--delta-unit", default="f", choices=("f", "m"), help="RPE delta in frames (f) or metres (m)")
    p.add_argument("--all-pairs", action="store_true", help="RPE over all pairs (i, i+delta), not consecutive ones")
    p.add_argument("--kitti", action="store_true", help="also the KITTI odometry metric (t_err %%, r_err deg/100 m)")
    p.add_argument("--egomotion", action="store_true",
                   help="also the SESGen per-frame egomotion table (U V W alpha beta gamma, RMSE per component)")
    p.add_argument("--max-diff", type=float, default=0.01, metavar="S",
                   help="timestamp association tolerance in seconds (default: 0.01, as evo)")
    p.add_argument("--view", default="left", choices=("left", "right"), help="render view used as ground truth")
    p.add_argument("--json", metavar="OUT.json", help="write the metrics as JSON")
    add_report_argument(p, "plots (PNG), metrics.json, summary.md")


def _fmt_of(path: str, fmt: str) -> str:
    p = Path(path)
    if p.is_dir() or p.name == "manifest.json":
        return "sesgen"
    return guess_format(p) if fmt == "auto" else fmt


def _take(traj: Trajectory, frames: range) -> Trajectory:
    return Trajectory(traj.T_world_cam[frames.start:frames.stop], traj.timestamps_s[frames.start:frames.stop])


def _select_frames(gt: Trajectory, est: Trajectory, spec, by_index: bool, est_name: str):
    """The ground truth of ``--frames`` (all without it); an estimate paired by index holds
    those frames' poses, or the whole sequence's (then the same frames of it are taken)."""
    n_gt = len(gt)
    if spec is not None:
        with as_vo_error():
            frames = frame_range(spec, n_gt, min_frames=2)
        gt = _take(gt, frames)
        if by_index and len(est) == n_gt != len(frames):
            est = _take(est, frames)
    if by_index and len(gt) != len(est):
        if spec is None:
            raise VoError(f"{est_name}: {len(est)} poses for {n_gt} ground-truth poses; KITTI files have no timestamps: "
                          f"give the frames they are, e.g. --frames 0:{len(est)}, or write the estimate with "
                          "timestamps (stereo-vo --out-format tum)")
        raise VoError(f"{est_name}: {len(est)} poses for the {len(gt)} ground-truth frames of --frames {spec}")
    return gt, est


def run(args: argparse.Namespace) -> int:
    from .report import write_json, write_report
    from .trajectory_eval import EvaluationOptions, evaluate_trajectory, summary_lines

    fmt_gt, fmt_est = _fmt_of(args.gt, args.format), _fmt_of(args.est, args.format)
    gt = read_trajectory(args.gt, fmt_gt, view=args.view)
    est = read_trajectory(args.est, fmt_est)
    by_index = "kitti" in (fmt_gt, fmt_est)  # KITTI pose files carry no timestamps
    n_gt, n_est = len(gt), len(est)
    gt, est = _select_frames(gt, est, args.frames, by_index, args.est)
    if args.delta_unit == "f" and args.delta != int(args.delta):
        raise VoError(f"--delta in frames must be an integer, got {args.delta}")
    options = EvaluationOptions(align=args.align, n_align=args.n_align, delta=args.delta, delta_unit=args.delta_unit,
                                all_pairs=args.all_pairs, kitti=args.kitti, egomotion=args.egomotion,
                                max_diff_s=args.max_diff, by_index=by_index)
    ev = evaluate_trajectory(gt, est, options)
    print(f"gt:  {args.gt} ({fmt_gt}, {n_gt} poses{f'; frames {args.frames}' if args.frames else ''})")
    print(f"est: {args.est} ({fmt_est}, {n_est} poses)")
    print("\n".join(summary_lines(ev)))
    if ev.egomotion is not None:
        print()
        print(ev.egomotion.to_markdown(max_rows=20), end="")
    inputs = {"gt": args.gt, "est": args.est}
    if args.json:
        m = ev.metrics()
        m["inputs"] = inputs
        write_json(args.json, m)
        print(f"metrics: {args.json}")
    if args.report:
        files = write_report(args.report, ev, inputs=inputs)
        print(f"report:  {args.report} ({len(files)} files)")
    return 0
