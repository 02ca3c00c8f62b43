"""``python -m vo_reference run INPUT``: the one-shot path — stereo VO with both methods,
evaluation (APE/RPE, the SESGen paper's per-frame egomotion table), plots, into a report folder.

INPUT is a render folder, or any other sequence with ground-truth poses (a KITTI odometry
folder with its poses). Report folder: ``INPUT/report`` for a render, ``./NAME_report`` for
other inputs (a dataset folder is never written to), or ``--report DIR``. It holds
``summary.md`` (the paper-style RMSE table with the paper's Table 1 values beside ours, then
per method the evaluation), ``report.json``, and per method ``<method>/`` with ``est.txt``
(KITTI poses), ``est_tum.txt``, ``metrics.json``, ``summary.md`` and PNG plots.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..errors import VoError

# The SESGen paper, Sec. 5: RMSE of the estimated motion components over its sequence
# (distances in OpenGL units, angles in degrees).
PAPER_TABLE1_RMSE = {"U": 0.0049, "V": 0.0101, "W": 0.0062, "alpha_deg": 0.101, "beta_deg": 0.091, "gamma_deg": 0.057}
COLS = ("U", "V", "W", "alpha_deg", "beta_deg", "gamma_deg")
NAMES = ("U", "V", "W", "α (deg)", "β (deg)", "γ (deg)")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", metavar="INPUT", help="a sesgen render folder (manifest.json), or a KITTI odometry "
                                                  "folder with ground-truth poses")
    p.add_argument("--report", metavar="DIR", help="report folder (default: INPUT/report for a render folder, "
                                                   "else ./NAME_report)")
    p.add_argument("--methods", default="paper,accurate", help="comma-separated methods (default: paper,accurate)")
    p.add_argument("--gt-depth", action="store_true", help="run the methods with ground-truth depth")
    p.add_argument("--gt-flow", action="store_true", help="run the methods with ground-truth correspondences")
    p.add_argument("--frames", metavar="A:B", help="frame range, half-open like Python (default: all)")
    p.add_argument("--align", default="origin", choices=["none", "origin", "se3", "sim3"],
                   help="trajectory alignment for APE (default origin: the VO starts at the ground-truth "
                        "first pose, so APE is the drift; se3 fitted to a short, nearly straight path is ill-posed)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--quiet", action="store_true", help="no per-frame progress lines")


def default_report_dir(root: Path) -> Path:
    """``RENDER/report`` for a render (our own output folder), else ``./NAME_report``."""
    folder = root.parent if root.is_file() else root
    if (folder / "manifest.json").exists():
        return folder / "report"
    return Path.cwd() / f"{folder.resolve().name}_report"


def shape_errors(gt, est) -> dict:
    """End-point drift, Sim3-aligned position RMSE and mean step-length ratio (est / gt): the
    three numbers that separate scale from shape errors (docs/stereo-vo.md)."""
    from ..evaluate.align import align
    L = max(gt.path_length(), 1e-12)
    drift = float(np.linalg.norm(est.positions[-1] - gt.positions[-1]))
    out = {"path_length": gt.path_length(), "end_point_drift": drift, "end_point_drift_pct": 100 * drift / L}
    if len(gt) >= 3:
        sim3, _ = align(est, gt, "sim3")
        rmse = float(np.sqrt(np.mean(np.sum((sim3.positions - gt.positions) ** 2, axis=1))))
        out.update(sim3_position_rmse=rmse, sim3_position_rmse_pct=100 * rmse / L)
    steps_gt = np.linalg.norm(np.diff(gt.positions, axis=0), axis=1)
    moving = steps_gt > 1e-9
    if moving.any():
        steps_est = np.linalg.norm(np.diff(est.positions, axis=0), axis=1)
        out["step_length_ratio"] = float(np.mean(steps_est[moving] / steps_gt[moving]))
    return out


def rmse_table_markdown(rows: dict[str, dict]) -> str:
    """Markdown table: one row per source, RMSE of U V W α β γ."""
    lines = ["| | " + " | ".join(NAMES) + " |", "|---|" + "---|" * 6]
    for name, r in rows.items():
        lines.append(f"| {name} | " + " | ".join(f"{r[c]:.5f}" if r.get(c) is not None else "–" for c in COLS) + " |")
    return "\n".join(lines) + "\n"


def run(args: argparse.Namespace) -> int:
    from ..evaluate.report import write_json, write_report
    from ..evaluate.trajectory_eval import evaluate_trajectory, summary_lines
    from ..io.sequence import open_sequence
    from ..io.trajectory import Trajectory, write_kitti, write_tum
    from .cli import failed_summary, progress_printer
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
    out = Path(args.report) if args.report else default_report_dir(root)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise VoError(f"cannot create the report folder {out} ({e.strerror}); choose one with --report DIR") from None
    gt = Trajectory(T_gt[frames[0]:frames[1] + 1], np.asarray(seq.timestamps_s)[frames[0]:frames[1] + 1])
    variant = "".join([" +GT depth" if args.gt_depth else "", " +GT flow" if args.gt_flow else ""])

    rmse_rows: dict[str, dict] = {"SESGen paper, Table 1 (OpenGL units, 40 frames)": dict(PAPER_TABLE1_RMSE)}
    report: dict = {"input": str(root), "frames": list(frames), "gt_depth": args.gt_depth, "gt_flow": args.gt_flow,
                    "paper_table1_rmse": PAPER_TABLE1_RMSE, "methods": {}}
    sections = []
    for m in methods:
        print(f"== {m}{variant}: frames {frames[0]}..{frames[1]} of {root}")
        res = run_stereo_vo(seq, m, gt_depth=args.gt_depth, gt_flow=args.gt_flow, frames=frames,
                            progress=None if args.quiet else progress_printer(m))
        mdir = out / m
        mdir.mkdir(parents=True, exist_ok=True)
        write_kitti(mdir / "est.txt", res.trajectory)
        write_tum(mdir / "est_tum.txt", res.trajectory)
        ev = evaluate_trajectory(gt, res.trajectory, align=args.align, egomotion=True, by_index=True)
        files = write_report(mdir, ev, title=f"Stereo VO ({m}{variant}) on {root.name}",
                             inputs={"ground truth": root, "est": mdir / "est.txt"}, plots=not args.no_plots,
                             extra={"fps": res.fps, "n_points_min": int(res.n_points.min()),
                                    "n_points_mean": float(res.n_points.mean())})
        rmse = dict(zip(COLS, ev.egomotion.rmse.tolist()))
        rmse_rows[f"{m}{variant} (ours)"] = rmse
        shape = shape_errors(gt, res.trajectory)
        report["methods"][m] = {"egomotion_rmse": rmse, "ape_trans_rmse": ev.ape.trans.rmse,
                                "ape_rot_rmse_deg": ev.ape.rot_deg.rmse, "rpe_trans_rmse": ev.rpe.trans.rmse,
                                "rpe_rot_rmse_deg": ev.rpe.rot_deg.rmse, **shape, "fps": res.fps,
                                "failed_steps": [[k, why] for k, why in res.failed],
                                "report": {k: str(v) for k, v in files.items()}}
        print("\n".join(summary_lines(ev)))
        line = (f"End-point drift {shape['end_point_drift']:.4f} ({shape['end_point_drift_pct']:.2f} % of the "
                f"{shape['path_length']:.3f} path)")
        if "sim3_position_rmse" in shape:
            line += f"; Sim3-aligned position RMSE {shape['sim3_position_rmse']:.4f} ({shape['sim3_position_rmse_pct']:.3f} %)"
        if "step_length_ratio" in shape:
            line += f"; step length est/gt {shape['step_length_ratio']:.4f}"
        print(line)
        sections += [f"## {m}{variant}", "", "```", *summary_lines(ev), "```", "",
                     f"{line}; {res.fps:.1f} frames/s; details: [{m}/summary.md]({m}/summary.md)", ""]
        if res.failed:
            print(failed_summary(res.failed))
            sections += [f"**{failed_summary(res.failed)}**", ""]
        if not args.no_plots:
            sections += [f"![{m} trajectory]({m}/trajectories.png) ![{m} egomotion]({m}/egomotion.png)", ""]
    lines = [f"# Stereo VO report: {root.name}", "",
             f"Sequence `{root}`, frames {frames[0]}..{frames[1]}, left camera; K f = {seq.K[0, 0]:g} px, "
             f"baseline {seq.baseline_m:g}, {seq.resolution[0]}x{seq.resolution[1]}.", "",
             "## Per-frame egomotion RMSE (the SESGen paper's Table 1 measure)", "",
             "RMSE over frames of the estimated minus true frame-to-frame motion (U V W: scene units per frame; "
             "α β γ: degrees per frame), ours beside the values the paper reports for its own scene.", "",
             rmse_table_markdown(rmse_rows), *sections]
    (out / "summary.md").write_text("\n".join(lines), encoding="utf-8")
    write_json(out / "report.json", report)
    print(f"report: {out / 'summary.md'}")
    return 0
