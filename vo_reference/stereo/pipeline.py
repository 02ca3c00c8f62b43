"""Run a stereo VO method over a :class:`~vo_reference.io.sequence.Sequence`.

Frame-to-frame motions T_k_k1 are composed into poses T(k+1) = T(k) T_k_k1 starting at the
ground-truth pose of the first frame when the sequence has one (so estimate and ground truth
share a world frame), else at the identity.

A step that cannot be estimated (too few points, e.g. a blank or blurred frame) keeps the
previous step's motion (constant velocity; identity for the first) and is listed in
``VoResult.failed`` — as the monocular pipeline does; the run fails only when no step succeeds.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from blender_sesgen.contract.se3 import relative
from blender_sesgen.contract.timing import frame_range

from ..errors import VoError, as_vo_error
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

    @property
    def fps(self) -> float:
        return float(len(self.seconds) / max(self.seconds.sum(), 1e-12))


def parse_frames(spec: Optional[str], num_frames: int) -> tuple[int, int]:
    """``A:B`` (Python-style, B exclusive, either may be empty) -> inclusive (first, last), >= 2 frames."""
    with as_vo_error():
        r = frame_range(spec, num_frames, min_frames=2)
    return r.start, r.stop - 1


def check_stereo(seq) -> None:
    """VoError unless ``seq`` is a stereo sequence (left and right views, baseline > 0)."""
    if "right" not in seq.views or seq.baseline_m <= 0:
        raise VoError("stereo VO needs a stereo sequence (left and right views, baseline > 0)")


def run_stereo_vo(seq, method: str = "accurate", *, gt_depth: bool = False, gt_flow: bool = False,
                  frames: Optional[tuple[int, int]] = None, params=None,
                  progress: Optional[Callable[[int, int, object, float], None]] = None) -> VoResult:
    """Estimate the left camera's trajectory of ``seq`` with ``method`` ('paper' or 'accurate')."""
    if method not in METHODS:
        raise VoError(f"unknown method {method!r} (choose {' or '.join(METHODS)})")
    check_stereo(seq)
    first, last = frames if frames is not None else (0, seq.num_frames - 1)
    if not (0 <= first < last < seq.num_frames):
        raise VoError(f"frame range {first}..{last} outside 0..{seq.num_frames - 1}")
    T_gt = seq.T_world_cam("left")
    if (gt_depth or gt_flow):
        if T_gt is None or seq.depth(first, "left") is None:
            raise VoError("--gt-depth/--gt-flow need a render folder with depth and poses")
    K = np.asarray(seq.K, dtype=float)
    B = float(seq.baseline_m)
    if params is None:
        params = PaperParams() if method == "paper" else AccurateParams()
    tracks = StereoTracks(params) if method == "accurate" else None

    steps, n_pts, secs, gt_tw, failed = [], [], [], [], []
    left0, right0 = seq.image_gray(first, "left"), seq.image_gray(first, "right")
    for k in range(first, last):
        left1, right1 = seq.image_gray(k + 1, "left"), seq.image_gray(k + 1, "right")
        gt = None
        if T_gt is not None:
            T_rel = relative(T_gt[k], T_gt[k + 1])
            gt_tw.append(T_to_twist(T_rel))
            if gt_depth or gt_flow:
                gt = GroundTruthStep(np.asarray(seq.depth(k, "left")), K, B, T_rel)
        t0 = time.perf_counter()
        try:
            if method == "paper":
                res = paper_step(left0, right0, left1, K, B, params, gt, gt_depth, gt_flow)
            elif method == "opencv-baseline":
                res = baseline_step(left0, right0, left1, K, B)
            else:
                res = accurate_step(left0, right0, left1, right1, K, B, params, gt, gt_depth, gt_flow, tracks)
        except VoError as e:                # constant velocity; tracks restart from fresh corners
            T_prev = steps[-1] if steps else np.eye(4)
            res = StepResult(T_to_twist(T_prev), T_prev, 0, failure=str(e))
            failed.append((k, str(e)))
        dt = time.perf_counter() - t0
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
    return VoResult(method, (first, last), Trajectory(poses, ts),
                    np.stack([T_to_twist(T) for T in steps]),
                    np.stack(gt_tw) if gt_tw else None,
                    np.array(n_pts), np.array(secs),
                    {"gt_depth": gt_depth, "gt_flow": gt_flow}, failed)
