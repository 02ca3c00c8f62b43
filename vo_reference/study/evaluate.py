"""Evaluation of one run of a system in a verification study, and the ground-truth
controls of its variants (docs/studies.md).

A run's trajectory is paired with the variant's ground truth -- by index for KITTI files
(line k is frame k), by timestamp for TUM and EuRoC (the nearest frame stamp within a
quarter of a frame period) -- and then:

- **failure**: the file is missing, does not parse (a row of NaN, a broken rotation, more
  poses than frames), or covers fewer than ``min_coverage`` of the frames (a short
  trajectory); the run's own end (an exit code, a timeout) is the study's to report;
- **tracking loss**: the share of frames without a pose, plus those after a *jump* -- a
  step of the (aligned) estimate that misses the ground truth's same step by more than
  ``jump_factor`` times the ground truth's mean step (its path over its steps). Not the
  estimate's median step: a sequence standing still for half its frames (EuRoC's start, a
  still camera) has a median step of its noise, and every step after it would be a jump;
- **APE**: after SE(3) alignment (Sim(3) for monocular systems; Umeyama over every paired
  pose), on every path: on a straight one (collinear positions) too, whose least residual is
  as defined as any path's (session 20 and before: aligned at the first pose there, so a path a
  hair off straight and a straight one reported two definitions). The fit's positions fix its
  rotation only as well as the path spreads off its main axis (``rotation_sigma_deg``, 1 sigma,
  worst axis; infinite on a straight path): where that is at least ``ILL_POSED_RATIO`` of the
  APE rotation it yields (a short, nearly straight drive: the roll about the path is free), the
  APE rotation measures the fit, not the estimate, and the record has ``ape_rot_rmse_deg`` null
  and ``alignment_ill_posed`` true. APE translation stays the fit's minimum residual either way
  (positions barely move under the free roll).
  ``ape_rot_origin_rmse_deg``, on every run: the APE rotation after putting the first paired
  poses together (``origin``: every VO starts at its first pose), the rotation drift from the
  start -- defined on any path, and what to read where the fit leaves the rotation free
  (besides the alignment-free RPE);
- **the mono scale**: a Sim(3) fit fixes the estimate's scale only to within the gap between
  the scale fitted estimate -> ground truth and the inverse of the reverse fit's
  (``scale_ambiguity``, 1/rho^2 - 1, rho the Procrustes correlation: the estimate's noise
  energy over its motion's); at ``SCALE_AMBIGUITY_MAX`` or more (an estimate that barely moves
  against its noise, or does not follow the path: the scale is biased towards 0 by it) every translation measured after it -- APE and RPE translation, per
  metre, KITTI t_err, the jumps of the tracking loss -- would scale with the fit's noise: they
  are null, ``scale`` too, and ``scale_ill_posed`` true;
- **RPE** per frame (consecutive frames) and per metre: the ground truth's path cut into
  consecutive pieces of at least 1 m (whole frame steps), each piece's translation error over
  its length (m/m: KITTI's t_err on 1 m pieces; session 19 and before: the error of pieces
  chosen on the estimate, not divided by their length -- a 1.25 m frame step read 1.25x, a
  2.5 m one 2.5x); the **KITTI** metric where the ground-truth path is at least 100 m (its shortest
  segment).
"""
from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np

from ..errors import VoError
from ..evaluate.align import Alignment, align, fixes_rotation, fixes_scale
from ..evaluate.ape import ape
from ..evaluate.associate import matching_time_indices
from ..evaluate.kitti import kitti_metric
from ..evaluate.rpe import rpe
from ..io.trajectory import Trajectory, read_trajectory

KITTI_MIN_PATH_M = 100.0
# The record's definition: a study resumed on newer code evaluates its runs again when this
# differs from their metrics.json's (2: ape_rot_rmse_deg null where the fit leaves it free;
# a jump measured against the ground truth's step; rpe_trans_per_m divided by its pieces' lengths;
# ape_rot_origin_rmse_deg; 3: one alignment on every path, a straight one too; the mono scale's
# conditioning, scale_ill_posed; the rotation's 1 sigma from the fit's cross-covariance).
EVALUATION_VERSION = 3
FORMATS = ("tum", "kitti", "euroc")


def sha256_file(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def pair(gt: Trajectory, est: Trajectory, fmt: str, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(frame index, estimate index) of every pose paired with a frame."""
    if fmt == "kitti":
        if len(est) > len(gt):
            raise VoError(f"{len(est)} poses for {len(gt)} frames")
        n = len(est)
        return np.arange(n), np.arange(n)
    # A file whose stamps repeat or go back holds two answers for one instant: which one the
    # system meant is unknown, so the file is malformed (judging the first would be a guess).
    back = np.nonzero(np.diff(est.timestamps_s) <= 0.0)[0]
    if len(back):
        k = int(back[0]) + 1
        raise VoError(f"timestamps not increasing: pose {k + 1} at {est.timestamps_s[k]:.9g} s "
                      f"after {est.timestamps_s[k - 1]:.9g} s")
    i_est, i_gt = matching_time_indices(est.timestamps_s, gt.timestamps_s, max_diff=0.25 / rate_hz)
    keep = np.unique(i_gt, return_index=True)[1]         # one pose per frame (stamps within 1/4 frame)
    return i_gt[keep], i_est[keep]


def jumps(positions: np.ndarray, factor: float, gt_positions: np.ndarray) -> np.ndarray:
    """Indices k of steps k -> k+1 of ``positions`` that miss ``gt_positions``' same step by
    more than ``factor`` times the ground truth's mean step."""
    d_est, d_gt = np.diff(positions, axis=0), np.diff(gt_positions, axis=0)
    if len(d_est) < 3:
        return np.zeros(0, dtype=int)
    scale = float(np.mean(np.linalg.norm(d_gt, axis=1)))
    return np.nonzero(np.linalg.norm(d_est - d_gt, axis=1) > factor * max(scale, 1e-12))[0]


def rpe_per_metre(gt: Trajectory, est: Trajectory) -> "float | None":
    """RMSE over the ground truth's consecutive >= 1 m pieces of each piece's RPE translation
    error divided by its length (m/m)."""
    r = rpe(gt, est, 1.0, "m", pairs_from_gt=True)
    dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(gt.positions, axis=0), axis=1))])
    length = dist[r.pairs[:, 1]] - dist[r.pairs[:, 0]]
    return float(np.sqrt(np.mean((r.trans_errors_m / length) ** 2))) if len(length) else None


def _align(gt: Trajectory, est: Trajectory, mono: bool) -> tuple[Trajectory, str, Alignment]:
    """The study's one alignment, on every path: se3 (sim3 for monocular systems) over every
    paired pose. A straight path (collinear positions) is fitted too -- its least residual is as
    defined as any path's; only the rotation about it is free (``fit_conditioning``: infinite), which
    ``fixes_rotation`` then flags -- so a path a hair off straight and a straight one report APE
    under the same definition (session 20 and before: aligned at the first pose instead)."""
    method = "sim3" if mono else "se3"
    aligned, a = align(est, gt, method, allow_degenerate=True)
    return aligned, method, a


def _finite(x):
    return x if x is None or math.isfinite(x) else None


def evaluate_run(gt: Trajectory, est_path, fmt: str, *, mono: bool, rate_hz: float, min_coverage: float,
                 jump_factor: float) -> dict:
    """The record of one run's trajectory (see the module docstring): ``ok``, ``failure``
    and, when it could be measured, ``coverage``, ``tracking_loss`` and the metrics."""
    est_path = Path(est_path)
    n = len(gt)
    if not est_path.is_file():
        return {"ok": False, "failure": "wrote no trajectory file"}
    try:
        est = read_trajectory(est_path, fmt)
        i_gt, i_est = pair(gt, est, fmt, rate_hz)
    except VoError as e:
        return {"ok": False, "failure": f"malformed trajectory: {e}"}
    coverage = len(i_gt) / n if n else 0.0
    rec = {"n_frames": n, "n_poses": int(len(est)), "n_paired": int(len(i_gt)), "coverage": coverage}
    if coverage < min_coverage or len(i_gt) < 2:
        why = f"short trajectory: poses for {len(i_gt)} of {n} frames (at least {min_coverage:.0%} needed)"
        if fmt != "kitti" and len(est) >= max(min_coverage * n, 2) > len(i_gt):
            # the poses are there, their stamps missed the frames': not a system that lost track
            why += (f"; {len(est)} poses written, {len(i_gt)} stamped within a quarter frame period of a frame: "
                    f"are its stamps the dataset's ({'nanoseconds' if fmt == 'euroc' else 'seconds'}, its clock)?")
        rec.update(ok=False, failure=why)
        return rec
    g = Trajectory(gt.T_world_cam[i_gt], gt.timestamps_s[i_gt])
    e = Trajectory(est.T_world_cam[i_est], gt.timestamps_s[i_gt])
    aligned, how, al = _align(g, e, mono)
    scaled = fixes_scale(al)          # always for se3; sim3: a scale its noise does not swamp
    jumped = jumps(aligned.positions, jump_factor, g.positions)
    lost = (n - len(i_gt)) + len(jumped)
    a = ape(g, aligned)
    r = rpe(g, aligned, 1, "f")
    fixed = fixes_rotation(al, a.rot_deg.rmse)
    rot_origin = ape(g, align(e, g, "origin")[0]).rot_deg.rmse      # rotations: no scale involved
    rec.update(ok=True, failure=None, alignment=how, scale=al.scale if scaled else None,
               tracking_loss=lost / n if scaled else None,
               lost_frames=int(n - len(i_gt)), jumps=[int(i_gt[k + 1]) for k in jumped] if scaled else None,
               ape_trans_rmse=a.trans.rmse if scaled else None, ape_rot_rmse_deg=a.rot_deg.rmse if fixed else None,
               ape_rot_origin_rmse_deg=rot_origin,
               rpe_trans_rmse=r.trans.rmse if scaled else None, rpe_rot_rmse_deg=r.rot_deg.rmse,
               gt_path_length_m=g.path_length(),
               rotation_sigma_deg=_finite(al.rotation_sigma_deg),
               alignment_ill_posed=not fixed)
    if mono:
        rec.update(scale_ambiguity=_finite(al.scale_ambiguity), scale_ill_posed=not scaled)
    if g.path_length() >= 2.0 and scaled:
        rec["rpe_trans_per_m"] = rpe_per_metre(g, aligned)
    if g.path_length() >= KITTI_MIN_PATH_M:
        est_k = e
        if mono:
            T = e.T_world_cam.copy()
            T[:, :3, 3] *= al.scale
            est_k = Trajectory(T, e.timestamps_s)
        k = kitti_metric(g, est_k, frame_period_s=1.0 / rate_hz)
        if k.n_segments:
            if scaled:
                rec["kitti_t_err_pct"] = k.t_err_pct
            rec["kitti_r_err_deg_per_100m"] = k.r_err_deg_per_100m     # rotations: no scale involved
    rec["frames"] = [int(k) for k in i_gt]
    rec["est_xyz"] = np.round(aligned.positions, 6).tolist()
    # NaN and infinities are not JSON (results.json refuses them): a measure that is not a finite
    # number is missing -- counted as such by the aggregates, never averaged -- and named here
    bad = [k for k, v in rec.items() if isinstance(v, float) and not math.isfinite(v)]
    for k in bad:
        rec[k] = None
    if bad:
        rec["non_finite"] = bad
    return rec


def ground_truth_identical(variant, base) -> dict:
    """Whether two renders (``RenderSequence``) hold the same ground truth: every frame's
    depth and object ids, both views, byte for byte, and the same poses."""
    if variant.num_frames != base.num_frames or variant.views != base.views:
        return {"identical": False, "difference": "frame count or views differ"}
    for view in variant.views:
        if not np.array_equal(variant.T_world_cam(view), base.T_world_cam(view)):
            return {"identical": False, "difference": f"{view} poses differ"}
    for k in range(variant.num_frames):
        for view in variant.views:
            for what in ("depth", "ids"):
                a, b = getattr(variant, what)(k, view), getattr(base, what)(k, view)
                if a.dtype != b.dtype or a.tobytes() != b.tobytes():
                    diff = float(np.nanmax(np.abs(np.where(np.isfinite(a) & np.isfinite(b), a - b, 0)))) \
                        if what == "depth" else int((a != b).sum())
                    return {"identical": False, "difference": f"frame {k} {view} {what}: "
                                                              f"{'max |difference|' if what == 'depth' else 'pixels'} {diff:g}"}
    return {"identical": True, "frames": variant.num_frames}
