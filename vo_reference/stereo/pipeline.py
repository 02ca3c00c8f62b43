"""Run a stereo VO method over a :class:`~vo_reference.io.sequence.Sequence`.

Frame-to-frame motions T_k_k1 are composed into poses T(k+1) = T(k) T_k_k1 starting at the
ground-truth pose of the first frame when the sequence has one (so estimate and ground truth
share a world frame), else at the identity.

A step that cannot be estimated (too few points, e.g. a blank or blurred frame) keeps the
previous step's motion (constant velocity; identity for the first) and is listed in
``VoResult.failed`` — as the monocular pipeline does; the run fails only when no step succeeds.

Moving objects (a render with ``moving_ids``): the ground truth of each step knows the
movers' pixels and motion (``GroundTruthStep``), so ``gt_flow`` moves their keypoints with
them, ``mask_dynamic_gt`` drops keypoints on them, and every run records the share of the
image on objects moving in each step (``dynamic_share``) and the share of the points the
method kept that lie on them (``dynamic_points``: 0 when the method rejected every
moving point).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from blender_sesgen.contract.se3 import relative
from blender_sesgen.contract.timing import frame_range

from ..errors import VoError, as_vo_error
from ..io.sequence import require_complete
from ..io.trajectory import Trajectory
from .accurate import AccurateParams, StereoTracks, accurate_step
from .groundtruth import GroundTruthStep
from .motion_field import T_to_twist, compose
from .baseline import baseline_step
from .paper import PaperParams, StepResult, paper_step

__all__ = ["METHODS", "VoResult", "run_stereo_vo", "parse_frames", "check_stereo"]

METHODS = ("paper", "accurate", "opencv-baseline")


@dataclass
class VoResult:
    method: str
    frames: tuple[int, int]                 # [first, last] frame indices used (inclusive)
    trajectory: Trajectory                  # estimated left-camera poses, one per frame
    twists: np.ndarray                      # (N-1, 6) [U, V, W, alpha, beta, gamma], rad
    gt_twists: Optional[np.ndarray]         # (N-1, 6) or None
    n_points: np.ndarray                    # (N-1,) keypoints used per step
    seconds: np.ndarray                     # (N-1,) wall time per step (image reading excluded)
    options: dict = field(default_factory=dict)
    failed: list = field(default_factory=list)  # (k, reason) of steps k -> k+1 that kept the previous motion
    dynamic_share: Optional[np.ndarray] = None  # (N-1,) image share on objects moving k -> k+1 (needs ids)
    dynamic_points: Optional[np.ndarray] = None  # (N-1,) share of the step's kept points on them

    @property
    def fps(self) -> float:
        return float(len(self.seconds) / max(self.seconds.sum(), 1e-12))


def parse_frames(spec: Optional[str], num_frames: int) -> tuple[int, int]:
    """``A:B`` (Python-style, B exclusive, either may be empty) -> inclusive (first, last), >= 2 frames."""
    with as_vo_error():
        r = frame_range(spec, num_frames, min_frames=2)
    return r.start, r.stop - 1


def frame_span(frames, num_frames: int) -> tuple[int, int]:
    """(first, last) of what :func:`run_stereo_vo` takes: ``"A:B"`` (frames A..B-1, as
    ``--frames``), ``range(A, B)`` or None (all)."""
    if frames is None or isinstance(frames, str):
        return parse_frames(frames, num_frames)
    if isinstance(frames, range) and frames.step == 1 and len(frames) >= 2:
        return frames[0], frames[-1]
    raise VoError(f"frames: 'A:B' (frames A..B-1, as --frames) or range(A, B), at least 2 frames; got {frames!r}")


def check_stereo(seq) -> None:
    """VoError unless ``seq`` is a stereo sequence (left and right views, baseline > 0); a
    negative baseline -- a right camera whose calibration puts it to the left -- is named."""
    where = f"{seq.root}: " if getattr(seq, "root", None) else ""
    if "right" not in seq.views or seq.baseline_m == 0:
        raise VoError(f"{where}stereo VO needs a stereo sequence (left and right views, baseline > 0)")
    if seq.baseline_m < 0:
        raise VoError(f"{where}the calibration puts the right camera {-seq.baseline_m:g} m to the left of the left "
                      "one (a negative baseline: in KITTI's calib.txt the right camera's P[0,3] = -fx * B is "
                      "negative); its sign is wrong, or the left and right images are swapped")


def _ids(seq, k: int):
    """The left id map of frame k, or None (sequences without ids)."""
    return seq.ids(k, "left")


def ground_truth_step(seq, k: int, T_gt: np.ndarray) -> GroundTruthStep:
    """The ground truth of step k -> k+1 (depth, ids and the movers' point motion at k)."""
    from ..products.flow import sequence_object_poses
    from ..products.scene_flow import object_motion_in_camera
    K = np.asarray(seq.K, dtype=float)
    moving = {i: P for i, P in sequence_object_poses(seq, k, k + 1).items() if not np.array_equal(*P)}
    ids = _ids(seq, k) if moving else None
    D = {i: object_motion_in_camera(T_gt[k], *P) for i, P in moving.items()}
    depth = seq.depth(k, "left")
    return GroundTruthStep(np.asarray(depth) if depth is not None else None, K, float(seq.baseline_m),
                           relative(T_gt[k], T_gt[k + 1]), ids, D)


def _dynamic_shares(seq, k: int, gt: Optional[GroundTruthStep], res) -> tuple[float, float]:
    """(share of the image on movers, share of the step's points on them); NaN without ids."""
    if gt is None or _ids(seq, k) is None:
        return np.nan, np.nan
    if gt.ids_m is None:                     # nothing moves in this step
        return 0.0, 0.0
    pts = np.asarray(res.pts0, dtype=float).reshape(-1, 2)
    on = ~gt.static(pts, margin_px=0) if pts.shape[0] else np.zeros(0, bool)
    return gt.dynamic_share(), float(on.mean()) if on.size else 0.0


def run_stereo_vo(seq, method: str = "accurate", *, gt_depth: bool = False, gt_flow: bool = False,
                  mask_dynamic_gt: bool = False, frames: "str | range | None" = None, params=None,
                  progress: Optional[Callable[[int, int, object, float], None]] = None) -> VoResult:
    """Estimate the left camera's trajectory of ``seq`` with ``method`` ('paper' or 'accurate')
    over ``frames`` (``"A:B"`` = frames A..B-1 as ``--frames``, or ``range(A, B)``; None: all).

    ``mask_dynamic_gt``: drop keypoints on objects that move in each step (the ground-truth
    motion mask of a render with moving objects; a static scene is unaffected)."""
    if method not in METHODS:
        raise VoError(f"unknown method {method!r} (choose {' or '.join(METHODS)})")
    check_stereo(seq)
    first, last = frame_span(frames, seq.num_frames)
    if not (0 <= first < last < seq.num_frames):
        raise VoError(f"frame range {first}..{last} outside 0..{seq.num_frames - 1}")
    require_complete(seq, range(first, last + 1))
    T_gt = seq.T_world_cam("left")
    if (gt_depth or gt_flow):
        if T_gt is None or seq.depth(first, "left") is None:
            raise VoError("--gt-depth/--gt-flow need a render folder with depth and poses")
    if mask_dynamic_gt and (T_gt is None or _ids(seq, first) is None):
        raise VoError("--mask-dynamic-gt needs a render folder with object ids and poses")
    with_gt = T_gt is not None and seq.depth(first, "left") is not None
    K = np.asarray(seq.K, dtype=float)
    B = float(seq.baseline_m)
    if params is None:
        params = PaperParams() if method == "paper" else AccurateParams()
    tracks = StereoTracks(params) if method == "accurate" else None

    steps, n_pts, secs, gt_tw, failed, shares = [], [], [], [], [], []
    left0, right0 = seq.image_gray(first, "left"), seq.image_gray(first, "right")
    for k in range(first, last):
        left1, right1 = seq.image_gray(k + 1, "left"), seq.image_gray(k + 1, "right")
        gt = None
        if T_gt is not None:
            gt_tw.append(T_to_twist(relative(T_gt[k], T_gt[k + 1])))
            if with_gt:
                gt = ground_truth_step(seq, k, T_gt)
        mask = bool(mask_dynamic_gt)
        t0 = time.perf_counter()
        try:
            if method == "paper":
                res = paper_step(left0, right0, left1, K, B, params, gt, gt_depth, gt_flow, mask)
            elif method == "opencv-baseline":
                res = baseline_step(left0, right0, left1, K, B, gt=gt, mask_dynamic=mask)
            else:
                res = accurate_step(left0, right0, left1, right1, K, B, params, gt, gt_depth, gt_flow, tracks, mask)
        except VoError as e:                # constant velocity; tracks restart from fresh corners
            T_prev = steps[-1] if steps else np.eye(4)
            res = StepResult(T_to_twist(T_prev), T_prev, 0, failure=str(e))
            failed.append((k, str(e)))
        dt = time.perf_counter() - t0
        shares.append(_dynamic_shares(seq, k, gt, res))
        steps.append(res.T_k_k1)
        n_pts.append(res.n_points)
        secs.append(dt)
        if progress is not None:
            progress(k, last, res, dt)
        left0, right0 = left1, right1

    if len(failed) == len(steps):
        k, why = failed[0]
        raise VoError(f"{method}: no frame step could be estimated (frame {k} -> {k + 1}: {why})")
    T0 = T_gt[first] if T_gt is not None else np.eye(4)
    poses = compose(T0, steps)
    ts = np.asarray(seq.timestamps_s, dtype=float)[first:last + 1]
    sh = np.array(shares, dtype=float).reshape(-1, 2)
    has_ids = bool(np.isfinite(sh).all()) if len(sh) else False
    return VoResult(method, (first, last), Trajectory(poses, ts),
                    np.stack([T_to_twist(T) for T in steps]),
                    np.stack(gt_tw) if gt_tw else None,
                    np.array(n_pts), np.array(secs),
                    {"gt_depth": gt_depth, "gt_flow": gt_flow, "mask_dynamic_gt": bool(mask_dynamic_gt)}, failed,
                    sh[:, 0] if has_ids else None, sh[:, 1] if has_ids else None)
