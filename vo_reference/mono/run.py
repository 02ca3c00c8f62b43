"""One run of the monocular VO on an input (``mono-vo``'s work, without its command line):
open the input, prepare the images (Bayer, undistortion, masks), choose the scale, run
:func:`~vo_reference.mono.pipeline.run_mono_vo`, write the trajectories, summarise against
the ground truth and plot. ``cli`` parses the arguments into :class:`MonoRunOptions` and
prints :func:`summary_lines`."""
from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.progress import Progress
from blender_sesgen.contract.timing import frame_range

from ..errors import VoError


@dataclass(frozen=True)
class MonoRunOptions:
    """What ``mono-vo`` is asked (its options; docs/mono-vo.md)."""
    input: str
    out: str
    out_format: str = "kitti"
    scale: str = "auto"
    speed: Optional[float] = None
    bayer: Optional[str] = None
    model: Optional[str] = None
    lut: Optional[str] = None
    dist: Optional[str] = None
    features: str = "klt"
    best_n: int = 1000
    threshold: float = 1.0
    refine: str = "sampson"
    solver: str = "5pt"
    score: str = "msac"
    seed: int = 0
    blur: float = 0.0
    equalize: str = "none"
    mask_bottom: float = 0.0
    mask_rect: tuple = ()
    mask: Optional[str] = None
    frames: Optional[str] = None
    compare_opencv: bool = False
    opencv_method: str = "usac"
    report: Optional[str] = None   # folder for plots, the per-frame table and summary.json

    @classmethod
    def of(cls, values) -> "MonoRunOptions":
        """The options named in ``values`` (an argparse Namespace or any object with them)."""
        return cls(**{f.name: getattr(values, f.name) for f in dataclasses.fields(cls) if hasattr(values, f.name)})


@dataclass
class MonoRun:
    """What a run gives: the VO result, its summary (``summarise``) and the files written."""
    result: object
    summary: dict
    outputs: list


def open_input(input: str, bayer=None, model=None):
    from ..io.images_folder import ImageFolderSequence
    from ..io.kitti import looks_like_kitti
    root = Path(input)
    if not root.exists():
        raise VoError(f"{root}: no such folder")
    if (root / "manifest.json").exists() or (root.is_dir() and looks_like_kitti(root)):
        from ..io.sequence import open_sequence
        if bayer:
            raise VoError("--bayer applies to folders of raw images (render and KITTI images are RGB/grey)")
        seq = open_sequence(root)
        if model:
            raise VoError("--model applies to image folders (this input carries its own K)")
        return seq, (lambda k: seq.image_rgb(k))
    seq = ImageFolderSequence(root, bayer=None, model=model)
    if seq.K is None:
        raise VoError(f"{root}: no camera intrinsics: give --model FILE (RobotCar model) or put model.txt in the folder")
    return seq, (lambda k: seq.raw(k))


def run_mono(opts: MonoRunOptions, progress: str = "off") -> MonoRun:
    """Run the VO as ``opts`` asks (``progress``: a ``contract.progress`` mode); VoError on bad input."""
    from ..io.trajectory import Trajectory, write_kitti, write_tum
    from .motion_errors import per_frame_errors
    from .pipeline import MonoVoConfig, run_mono_vo
    from .prepare import Preparation, build_mask
    from . import scale as scales

    seq, raw_of = open_input(opts.input, opts.bayer, opts.model)
    W, H = seq.resolution
    maps = None
    if opts.lut and opts.dist:
        raise VoError("give either --lut or --dist, not both")
    if opts.lut:
        from ..camera.undistort import read_lut
        maps = read_lut(opts.lut, W, H)
    elif opts.dist:
        from ..camera.undistort import lut_from_distortion, parse_distortion
        maps = lut_from_distortion(seq.K, parse_distortion(opts.dist), W, H)
    elif seq.undistortion_maps() is not None:
        maps = seq.undistortion_maps()          # a render through a distorting LENS: its own table
    if opts.bayer:
        from ..camera.bayer import check_pattern
        check_pattern(opts.bayer)
    prep = Preparation(bayer=opts.bayer, maps=maps, blur_sigma=opts.blur, equalize=opts.equalize)
    rects = []
    for r in opts.mask_rect:
        try:
            x0, y0, x1, y1 = (float(v) for v in r.split(","))
        except ValueError:
            raise VoError(f"--mask-rect {r!r}: expected X0,Y0,X1,Y1") from None
        rects.append((x0, y0, x1, y1))
    mask = build_mask(W, H, bottom=opts.mask_bottom, rects=rects, file=opts.mask, maps=maps)
    frames = frame_range(opts.frames, seq.num_frames, min_frames=2)
    from ..io.sequence import require_complete
    require_complete(seq, frames)
    idx = list(frames)
    gt = seq.T_world_cam("left")
    gt = None if gt is None else gt[idx]
    ts = np.asarray(seq.timestamps_s, dtype=float)[idx]

    mode = opts.scale
    if mode == "auto":
        mode = "gt" if gt is not None else "none"
    cache: dict = {}

    def gray(i):           # i: index into frames
        if i not in cache:
            if len(cache) > 3:
                cache.pop(next(iter(cache)))
            cache[i] = prep.gray(raw_of(idx[i]))
        return cache[i]

    if mode == "gt":
        scale = scales.GroundTruthScale(gt)
    elif mode == "speed":
        scale = scales.SpeedScale(opts.speed, ts)
    elif mode == "stereo":
        d0 = seq.depth(idx[0], "left")
        if d0 is not None:
            scale = scales.DepthScale(lambda i: seq.depth(idx[i], "left"))
        elif "right" in seq.views and seq.baseline_m > 0:
            right_prep = Preparation(blur_sigma=opts.blur, equalize=opts.equalize)
            scale = scales.StereoScale(gray, lambda i: right_prep.gray(seq.image_rgb(idx[i], "right")),
                                       seq.K[0, 0], seq.baseline_m)
        else:
            raise VoError("--scale stereo needs depth ground truth or a right view (stereo input)")
    else:
        scale = scales.UnitScale()

    cfg = MonoVoConfig(features=opts.features, best_n=opts.best_n, threshold_px=opts.threshold,
                       seed=opts.seed, refine=opts.refine, solver=opts.solver, score=opts.score,
                       compare_opencv=opts.compare_opencv,
                       opencv_method=opts.opencv_method)
    n = len(idx)

    bar = Progress(n - 1, "mono-vo", mode=progress, unit="step")

    def report(rec):
        line = (f"frame {rec.k:4d}/{n - 1}: {rec.n_matches:4d} matches, {rec.n_inliers:4d} inliers "
                f"({100 * rec.inlier_ratio:5.1f} %), step {rec.step_m:.3f}")
        if opts.compare_opencv:
            line += f", OpenCV {rec.n_inliers_cv} inliers"
        if rec.status != "ok":
            bar.note(f"{line}  [{rec.status}: {rec.message}]")
        bar.update(detail=line, frame=rec.k, matches=rec.n_matches, inliers=rec.n_inliers, status=rec.status)

    with bar:
        res = run_mono_vo(gray, n, seq.K, scale, cfg, mask=mask,
                          T_world_first=None if gt is None else gt[0], progress=report)

    writer = write_tum if opts.out_format == "tum" else write_kitti
    out = Path(opts.out)
    writer(out, Trajectory(res.T_world_cam, ts))
    outputs = [str(out)]
    if res.T_world_cam_cv is not None:
        out_cv = out.with_name(out.stem + "_opencv" + out.suffix)
        writer(out_cv, Trajectory(res.T_world_cam_cv, ts))
        outputs.append(str(out_cv))

    errs = per_frame_errors(res.records, gt)
    summary = summarise(res, gt, ts, errs, mode)
    if opts.report:
        write_plots(Path(opts.report), res, gt, errs, summary)
    return MonoRun(res, summary, outputs)


def _median(v):
    v = np.asarray(v, float)
    return float(np.nanmedian(v)) if np.isfinite(v).any() else None


def summarise(res, gt, ts, errs, scale_mode) -> dict:
    recs = [r for r in res.records if r.k > 0]
    s = {"frames": len(res.records), "scale": scale_mode,
         "failed": [r.k for r in recs if r.status == "failed"],
         "static": [r.k for r in recs if r.status == "static"],
         "inlier_ratio_median": _median([r.inlier_ratio for r in recs if r.n_matches]),
         "inlier_ratio_min": float(min((r.inlier_ratio for r in recs if r.n_matches), default=0.0)),
         "matches_median": _median([r.n_matches for r in recs])}
    if res.T_world_cam_cv is not None:
        s["inlier_ratio_opencv_median"] = _median([r.n_inliers_cv / r.n_matches for r in recs if r.n_matches])
        s["rot_ours_vs_opencv_deg_median"] = _median(errs["rot_ours_cv_deg"])
        s["dir_ours_vs_opencv_deg_median"] = _median(errs["dir_ours_cv_deg"])
    moves = np.array([r.T_rel[:3, 3] for r in recs if r.T_rel is not None])
    if len(moves):
        s["mean_direction_cam"] = (moves.mean(axis=0) / np.linalg.norm(moves.mean(axis=0))).tolist()
    if gt is not None:
        from ..evaluate import align, ape
        from ..io.trajectory import Trajectory
        G = Trajectory(gt, ts)
        L = G.path_length()
        s["path_length_m"] = L
        s["rot_vs_gt_deg_median"] = _median(errs["rot_gt_deg"])
        s["dir_vs_gt_deg_median"] = _median(errs["dir_gt_deg"])
        for name, T in (("ours", res.T_world_cam), ("opencv", res.T_world_cam_cv)):
            if T is None:
                continue
            if name == "opencv":
                s["rot_opencv_vs_gt_deg_median"] = _median(errs["rot_cv_gt_deg"])
                s["dir_opencv_vs_gt_deg_median"] = _median(errs["dir_cv_gt_deg"])
            try:
                al, a = align(Trajectory(T, ts), G, "sim3")
                rmse = ape(G, al).trans.rmse
            except VoError:
                rmse = float("nan")
            drift = float(np.linalg.norm(T[-1, :3, 3] - gt[-1, :3, 3]))
            s[f"{name}_sim3_rmse_m"] = rmse
            s[f"{name}_sim3_rmse_pct"] = 100 * rmse / L if L > 0 else None
            s[f"{name}_end_drift_m"] = drift
            s[f"{name}_end_drift_pct"] = 100 * drift / L if L > 0 else None
    return s


def summary_lines(s: dict) -> list[str]:
    def f(v, fmt="{:.3f}"):
        return "n/a" if v is None else fmt.format(v)
    lines = [f"mono VO: {s['frames']} frames, scale {s['scale']}, inlier ratio median "
             f"{f(s['inlier_ratio_median'], '{:.2f}')} (min {s['inlier_ratio_min']:.2f})"
             + (f", OpenCV {f(s.get('inlier_ratio_opencv_median'), '{:.2f}')}" if "inlier_ratio_opencv_median" in s else "")]
    if s["failed"] or s["static"]:
        lines.append(f"  failed frames {s['failed']}, static frames {s['static']}")
    if "mean_direction_cam" in s:
        lines.append("  mean motion direction (camera x right, y down, z forward): "
                     + " ".join(f"{v:+.3f}" for v in s["mean_direction_cam"]))
    if "rot_ours_vs_opencv_deg_median" in s:
        lines.append(f"  ours vs OpenCV per frame (median): rotation {f(s['rot_ours_vs_opencv_deg_median'])} deg, "
                     f"translation direction {f(s['dir_ours_vs_opencv_deg_median'])} deg")
    if "path_length_m" in s:
        lines.append(f"  vs ground truth per frame (median): rotation {f(s['rot_vs_gt_deg_median'])} deg, "
                     f"direction {f(s['dir_vs_gt_deg_median'])} deg (ours)"
                     + (f"; {f(s['rot_opencv_vs_gt_deg_median'])} / {f(s['dir_opencv_vs_gt_deg_median'])} deg (OpenCV)"
                        if "rot_opencv_vs_gt_deg_median" in s else ""))
        for name in ("ours", "opencv"):
            if f"{name}_sim3_rmse_m" in s:
                lines.append(f"  {name}: position RMSE after Sim3 {s[f'{name}_sim3_rmse_m']:.3f} m "
                             f"({f(s[f'{name}_sim3_rmse_pct'])} % of {s['path_length_m']:.1f} m), end-point drift "
                             f"{s[f'{name}_end_drift_m']:.3f} m ({f(s[f'{name}_end_drift_pct'])} %)")
    return lines


def write_plots(out: Path, res, gt, errs, summary) -> None:
    from .plots import plot_frame_series, plot_paths
    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    if gt is not None:
        paths["ground truth"] = gt[:, :3, 3]
    paths["ours"] = res.T_world_cam[:, :3, 3]
    if res.T_world_cam_cv is not None:
        paths["OpenCV"] = res.T_world_cam_cv[:, :3, 3]
    plot_paths(paths, out / "trajectories.png", title=f"mono VO (scale: {summary['scale']})")
    recs = [r for r in res.records if r.k > 0]
    series = {"inlier ratio": [r.inlier_ratio for r in recs]}
    series.update({k.replace("_deg", " (deg)").replace("_", " "): v for k, v in errs.items()})
    plot_frame_series(series, out / "per_frame.png")
    rows = ["frame,status,matches,inliers,inliers_opencv,step_m," + ",".join(errs)]
    for i, r in enumerate(recs):
        rows.append(f"{r.k},{r.status},{r.n_matches},{r.n_inliers},{r.n_inliers_cv},{r.step_m:.6f},"
                    + ",".join(f"{errs[k][i]:.6f}" for k in errs))
    atomic.write_text(out / "frames.csv", "\n".join(rows) + "\n")
    atomic.write_text(out / "summary.json", json.dumps(summary, indent=1) + "\n")
