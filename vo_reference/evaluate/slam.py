"""A SLAM (or VO) system's trajectory on a route with loop closures: the usual trajectory
metrics of its (keyframe) poses, how much of the drive they cover, and how consistent they
are where the route comes back.

- The estimate may hold keyframes only, with their timestamps: its poses are associated with
  the ground truth by time (as evo), then :func:`~vo_reference.evaluate.trajectory_eval.evaluate_trajectory`
  gives APE (after the alignment: the final, loop-closed estimate of a SLAM system), RPE and
  the KITTI metric over the associated poses (for keyframes the segments start every 10th
  keyframe; lengths are ground-truth path lengths, as the devkit).
- **Coverage**: the share of the ground-truth frames within the estimate's time span and the
  keyframes per second.
- **Loop-closure consistency**: for every true loop-closure pair (query q, match m; the
  covisibility ground truth) whose two frames both have an estimated pose, the relative pose
  error E = inv(inv(Q_m) Q_q) inv(P_m) P_q -- how far the estimate's idea of where it is when
  it comes back differs from the truth: the drift accumulated around the loop, which loop
  closure exists to remove. Translation (trajectory units) and rotation (deg) statistics, and
  the same for the pairs' time gaps.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from blender_sesgen.contract.se3 import invert, rotation_angle_rad

from ..errors import VoError
from ..io.trajectory import Trajectory
from .stats import ErrorStats
from .trajectory_eval import EvaluationOptions, TrajectoryEvaluation, evaluate_trajectory, summary_lines


@dataclass(frozen=True)
class LoopConsistency:
    """Relative pose errors over the true loop-closure pairs that both have an estimated pose."""
    pairs: np.ndarray                 # (n, 2) query, match frame indices
    gap_s: np.ndarray                 # (n,)
    trans_errors: np.ndarray          # (n,)
    rot_errors_deg: np.ndarray        # (n,)
    trans: ErrorStats
    rot_deg: ErrorStats

    def as_dict(self) -> dict:
        return {"n_pairs": int(len(self.pairs)), "trans": self.trans.as_dict(), "rot_deg": self.rot_deg.as_dict(),
                "gap_s": {"min": float(self.gap_s.min()), "max": float(self.gap_s.max())}}


@dataclass(frozen=True)
class SlamEvaluation:
    trajectory: TrajectoryEvaluation
    coverage: float                   # share of the ground-truth frames within the estimate's time span
    poses_per_s: float
    loops: Optional[LoopConsistency]

    def metrics(self) -> dict:
        m = {"coverage": self.coverage, "poses_per_s": self.poses_per_s, **self.trajectory.metrics()}
        if self.loops is not None:
            m["loop_trans_rmse"] = self.loops.trans.rmse
            m["loop_rot_rmse_deg"] = self.loops.rot_deg.rmse
            m["loop_consistency"] = self.loops.as_dict()
        return m

    def summary_lines(self) -> list[str]:
        rows = [f"coverage: {100 * self.coverage:.1f} % of the ground-truth frames within the estimate's span, "
                f"{self.poses_per_s:.2f} poses/s", *summary_lines(self.trajectory)]
        if self.loops is not None:
            lo = self.loops
            rows += ["", f"loop-closure consistency over {len(lo.pairs)} true loop-closure pairs "
                         f"({lo.gap_s.min():.1f}-{lo.gap_s.max():.1f} s apart):",
                     f"  relative translation error rmse {lo.trans.rmse:.4f}, max {lo.trans.max:.4f}; "
                     f"rotation rmse {lo.rot_deg.rmse:.4f} deg, max {lo.rot_deg.max:.4f} deg"]
        return rows


def loop_consistency(gt_T: np.ndarray, est_T: np.ndarray, gt_index: np.ndarray, pairs: np.ndarray,
                     timestamps_s: np.ndarray) -> Optional[LoopConsistency]:
    """Relative pose errors over ``pairs`` (query, match frame indices of the ground truth) whose
    frames are among ``gt_index`` (the ground-truth frames of the associated poses ``gt_T``,
    ``est_T``); None when no pair has both."""
    where = {int(k): i for i, k in enumerate(gt_index)}
    keep = [(q, m) for q, m in np.asarray(pairs, int) if int(q) in where and int(m) in where]
    if not keep:
        return None
    iq = np.array([where[q] for q, _ in keep])
    im = np.array([where[m] for _, m in keep])
    Q_rel = invert(gt_T[im]) @ gt_T[iq]
    P_rel = invert(est_T[im]) @ est_T[iq]
    E = invert(Q_rel) @ P_rel
    e_t = np.linalg.norm(E[:, :3, 3], axis=1)
    e_r = np.degrees(rotation_angle_rad(E[:, :3, :3]))
    kp = np.array(keep)
    t = np.asarray(timestamps_s, float)
    return LoopConsistency(kp, t[kp[:, 0]] - t[kp[:, 1]], e_t, e_r, ErrorStats.of(e_t), ErrorStats.of(e_r))


def evaluate_slam(gt: Trajectory, est: Trajectory, loop_pairs: Optional[np.ndarray] = None,
                  options: Optional[EvaluationOptions] = None) -> SlamEvaluation:
    """``est`` (all frames or keyframes, with timestamps) against the ground truth ``gt`` (one
    pose per frame); ``loop_pairs`` (n, 2) the true loop-closure pairs as ground-truth frame
    indices (``Covisibility.loop_closures``)."""
    o = options or EvaluationOptions()
    ev = evaluate_trajectory(gt, est, o)
    # the ground-truth frame of each associated pose (a render's stamps are distinct and increasing)
    idx_gt = np.clip(np.searchsorted(gt.timestamps_s, ev.gt.timestamps_s), 0, len(gt) - 1)
    if not np.array_equal(gt.timestamps_s[idx_gt], ev.gt.timestamps_s):
        raise VoError("the ground truth's timestamps must be distinct and increasing")
    order = np.argsort(idx_gt, kind="stable")
    idx_gt = idx_gt[order]
    t = gt.timestamps_s
    span = (t >= est.timestamps_s.min() + o.offset_s - o.max_diff_s) & \
        (t <= est.timestamps_s.max() + o.offset_s + o.max_diff_s)
    dur = float(est.timestamps_s.max() - est.timestamps_s.min())
    loops = None
    if loop_pairs is not None and len(loop_pairs):
        gt_T = ev.gt.T_world_cam[order]
        est_T = ev.est.T_world_cam[order]          # unaligned: relative errors need no alignment
        loops = loop_consistency(gt_T, est_T, idx_gt, loop_pairs, t)
    return SlamEvaluation(trajectory=ev, coverage=float(span.mean()),
                          poses_per_s=float((len(est) - 1) / dur) if dur > 0 else 0.0, loops=loops)
