"""The KITTI odometry metric, exactly as the KITTI devkit (``evaluate_odometry.cpp``) computes it.

- ``dist[k]``: ground-truth path length from frame 0 to frame k (sum of position steps).
- Segments start at every ``step``-th frame (10); for each length L in 100, 200, ..., 800 m
  the end frame is the first k with dist[k] > dist[first] + L (segments running past the
  end of the sequence are skipped).
- Error pose: E = inv(inv(P_a)·P_b) · inv(Q_a)·Q_b (P: estimate, Q: ground truth, no
  alignment), with *general* 4×4 matrix inverses as the devkit's ``Matrix::inv`` (not the
  rigid transpose: the rotations in real pose files are orthonormal to ~1e-7 only, and this
  choice moves r_err of KITTI 00 / ORB-SLAM2 from 0.2536 to the devkit's 0.2533); t_err = ‖t(E)‖ / L, r_err = acos(clip((tr R(E) − 1)/2)) / L with L the
  *nominal* length; speed = L / (frame_period · (b − a + 1)).
- Score: the mean over all segments (pooled): t_err in %, r_err in deg per 100 m.
- Error vs length: mean over the segments of each length (shown when > 2 segments);
  error vs speed: speeds 2, 4, ..., 24 m/s, segments with |speed − v| < 2 (> 2 segments).
The devkit stores the distances as 32-bit floats and evaluates the angle in float;
``devkit_float32=True`` reproduces that too (on KITTI 00 the two differ by 6e-6 % and
3e-5 deg/100 m).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import VoError
from .poses import check_pair

KITTI_LENGTHS_M = (100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0)
KITTI_SPEEDS_MPS = tuple(float(v) for v in range(2, 25, 2))


@dataclass(frozen=True)
class KittiResult:
    """Pooled scores plus the per-segment errors and the devkit's per-length/per-speed curves."""

    t_err_pct: float                 # mean of ‖t(E)‖/L over segments, × 100
    r_err_deg_per_100m: float        # mean of angle(E)/L over segments, in deg/100 m
    first_frame: np.ndarray          # (S,) per segment
    length_m: np.ndarray             # (S,) nominal length L
    t_err: np.ndarray                # (S,) ‖t(E)‖/L (ratio)
    r_err_rad_per_m: np.ndarray      # (S,) angle(E)/L
    speed_mps: np.ndarray            # (S,)
    by_length: dict                  # {"length_m", "t_err_pct", "r_err_deg_per_100m", "count"}
    by_speed: dict                   # {"speed_mps", "t_err_pct", "r_err_deg_per_100m", "count"}

    @property
    def n_segments(self) -> int:
        return int(self.t_err.size)

    def as_dict(self) -> dict:
        return {"t_err_pct": self.t_err_pct, "r_err_deg_per_100m": self.r_err_deg_per_100m,
                "n_segments": self.n_segments,
                "by_length": {k: np.asarray(v).tolist() for k, v in self.by_length.items()},
                "by_speed": {k: np.asarray(v).tolist() for k, v in self.by_speed.items()}}


def trajectory_distances(T_world_cam: np.ndarray, float32: bool = False) -> np.ndarray:
    """Cumulative path length (N,) along the positions, 0 at frame 0 (devkit's ``trajectoryDistances``)."""
    p = np.asarray(T_world_cam)[:, :3, 3]
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    if float32:  # the devkit: float dist[i] = dist[i-1] + sqrt(double), summed in float
        return np.concatenate([[0.0], np.cumsum(steps.astype(np.float32), dtype=np.float32)]).astype(np.float32)
    return np.concatenate([[0.0], np.cumsum(steps)])


def kitti_metric(gt, est, lengths_m=KITTI_LENGTHS_M, step: int = 10, frame_period_s: float = 0.1,
                 devkit_float32: bool = False) -> KittiResult:
    """KITTI devkit odometry errors of ``est`` against ``gt`` (same length, frame-aligned, unaligned)."""
    Q, P = check_pair(gt, est)
    dist = trajectory_distances(Q, devkit_float32)
    n = dist.size
    firsts = np.arange(0, n, int(step))
    L = np.asarray(lengths_m, dtype=dist.dtype)
    target = dist[firsts][:, None] + L[None, :]                       # (F, nL)
    last = np.searchsorted(dist, target.ravel(), side="right").reshape(target.shape)
    ok = last < n                                                     # first k with dist[k] > target
    a = np.broadcast_to(firsts[:, None], last.shape)[ok]
    b = last[ok]
    seg_len = np.broadcast_to(np.asarray(lengths_m, dtype=float)[None, :], last.shape)[ok]
    if a.size == 0:
        raise VoError(f"ground truth path ({float(dist[-1]):.1f} m) is shorter than the shortest "
                      f"KITTI segment ({min(lengths_m)} m)")
    inv = np.linalg.inv
    E = inv(inv(P[a]) @ P[b]) @ (inv(Q[a]) @ Q[b])
    t_e = np.linalg.norm(E[:, :3, 3], axis=1)
    tr = E[:, 0, 0] + E[:, 1, 1] + E[:, 2, 2]
    if devkit_float32:  # float a, b, c; float d = 0.5 * (a + b + c - 1.0); acos(float)
        s = E[:, 0, 0].astype(np.float32) + E[:, 1, 1].astype(np.float32) + E[:, 2, 2].astype(np.float32)
        d = (0.5 * (s.astype(float) - 1.0)).astype(np.float32)
        r_e = np.arccos(np.clip(d, np.float32(-1), np.float32(1))).astype(float)
    else:
        r_e = np.arccos(np.clip(0.5 * (tr - 1.0), -1.0, 1.0))
    t_err = t_e / seg_len
    r_err = r_e / seg_len
    speed = seg_len / (frame_period_s * (b - a + 1))
    by_length = _binned(seg_len, t_err, r_err, np.asarray(lengths_m, dtype=float), 1.0, "length_m")
    by_speed = _binned(speed, t_err, r_err, np.asarray(KITTI_SPEEDS_MPS), 2.0, "speed_mps")
    return KittiResult(
        t_err_pct=float(np.mean(t_err) * 100.0),
        r_err_deg_per_100m=float(np.degrees(np.mean(r_err)) * 100.0),
        first_frame=a, length_m=seg_len, t_err=t_err, r_err_rad_per_m=r_err, speed_mps=speed,
        by_length=by_length, by_speed=by_speed)


def _binned(x, t_err, r_err, centres, half_width, name) -> dict:
    """Devkit's ``saveErrorPlots``: mean errors of segments with |x − c| < half_width, if > 2."""
    sel = np.abs(x[None, :] - centres[:, None]) < half_width          # (C, S)
    count = sel.sum(axis=1)
    keep = count > 2.5
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (sel @ t_err) / count
        r = (sel @ r_err) / count
    return {name: centres[keep], "t_err_pct": t[keep] * 100.0,
            "r_err_deg_per_100m": np.degrees(r[keep]) * 100.0, "count": count[keep]}
