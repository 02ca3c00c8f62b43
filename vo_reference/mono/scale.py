"""Where the length of each step comes from (monocular VO recovers translation only up to
scale). Each source answers ``step_length(k, rel, x1)``: the metric distance between the
camera centres of frames k−1 and k, given the unit-baseline two-view result ``rel`` and the
pixels ``x1`` (in frame k−1) of its inlier points.

- ``gt``: ‖C_k − C_{k−1}‖ from the input's ground-truth poses (evaluation mode: only the
  direction and rotation are estimated);
- ``speed``: a known constant speed times the time between the frames;
- ``depth``: the ground-truth depth map of frame k−1 (renders): median of
  z_metric / z_triangulated over the inlier points;
- ``stereo``: the right image of frame k−1 (rectified stereo): the inlier points are
  tracked left -> right with LK, disparity d gives z = fx·B/d, then the same median ratio;
- ``none``: unit steps.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from blender_sesgen.contract.depth import depth_from_disparity

from ..errors import VoError

SOURCES = ("gt", "speed", "stereo", "depth", "none")


class Scale:
    """A source of step lengths: ``step_length(k, rel, x1)`` metres of step k-1 -> k (None:
    unknown); ``needs_points``: it uses the step's triangulated points."""
    name = ""
    needs_points = False

    def step_length(self, k: int, rel, x1: np.ndarray) -> float | None:
        raise NotImplementedError


class UnitScale(Scale):
    name = "none"

    def step_length(self, k: int, rel, x1: np.ndarray) -> float | None:
        return 1.0


class GroundTruthScale(Scale):
    name = "gt"

    def __init__(self, T_world_cam: np.ndarray):
        if T_world_cam is None:
            raise VoError("--scale gt needs ground-truth poses, and this input has none")
        self.C = np.asarray(T_world_cam)[:, :3, 3]

    def step_length(self, k, rel, x1):
        return float(np.linalg.norm(self.C[k] - self.C[k - 1]))


class SpeedScale(Scale):
    name = "speed"

    def __init__(self, speed_mps: float, timestamps_s: np.ndarray):
        if not speed_mps or speed_mps <= 0:
            raise VoError("--scale speed needs a positive --speed in m/s")
        self.v, self.ts = float(speed_mps), np.asarray(timestamps_s, dtype=float)

    def step_length(self, k, rel, x1):
        return self.v * float(self.ts[k] - self.ts[k - 1])


def _median_ratio(z_metric: np.ndarray, z_unit: np.ndarray, min_points: int = 5) -> float | None:
    ok = np.isfinite(z_metric) & np.isfinite(z_unit) & (z_metric > 0) & (z_unit > 0)
    if ok.sum() < min_points:
        return None
    return float(np.median(z_metric[ok] / z_unit[ok]))


class DepthScale(Scale):
    name = "depth"
    needs_points = True

    def __init__(self, depth_of: Callable[[int], np.ndarray | None]):
        self.depth_of = depth_of

    def step_length(self, k, rel, x1):
        depth = self.depth_of(k - 1)
        if depth is None:
            raise VoError("--scale stereo: this input has no depth for frame {k - 1}")
        h, w = depth.shape
        xi = np.round(x1).astype(int)
        ok = (xi[:, 0] >= 0) & (xi[:, 0] < w) & (xi[:, 1] >= 0) & (xi[:, 1] < h)
        z = np.full(len(x1), np.nan)
        z[ok] = depth[xi[ok, 1], xi[ok, 0]]
        return _median_ratio(z, rel.X_c1[:, 2])


class StereoScale(Scale):
    name = "stereo"
    needs_points = True

    def __init__(self, left_of: Callable[[int], np.ndarray], right_of: Callable[[int], np.ndarray],
                 fx: float, baseline_m: float, max_dy_px: float = 1.0, min_disparity_px: float = 1.0):
        if not baseline_m or baseline_m <= 0:
            raise VoError("--scale stereo needs a stereo input (a right view and a baseline) or depth")
        self.left_of, self.right_of = left_of, right_of
        self.fx, self.B = float(fx), float(baseline_m)
        self.max_dy, self.min_d = max_dy_px, min_disparity_px

    def step_length(self, k, rel, x1):
        from .features import lk_track
        x2, _, ok = lk_track(self.left_of(k - 1), self.right_of(k - 1), x1, win=21, levels=4)
        d = x1[:, 0] - x2[:, 0]
        ok &= (np.abs(x1[:, 1] - x2[:, 1]) < self.max_dy) & (d > self.min_d)
        return _median_ratio(depth_from_disparity(d[ok], self.fx, self.B), rel.X_c1[ok, 2])
