"""Relative pose error (RPE), as evo defines it (Sturm et al., IROS 2012).

For a pair (i, j): Q_rel = inv(Q_i)·Q_j (ground truth), P_rel = inv(P_i)·P_j (estimate),
E = inv(Q_rel)·P_rel; translation error ‖t(E)‖, rotation error angle(R(E)) in degrees.

Pairs (evo's rules, chosen on the estimate's poses by default):
- ``delta_unit='f'`` (frames): consecutive pairs (0, d), (d, 2d), ...; with ``all_pairs``
  every (i, i + d).
- ``delta_unit='m'`` (metres of travelled path): consecutive: walk the path, close a pair
  each time the accumulated distance reaches d (then restart); with ``all_pairs``: for each i
  the j > i whose path distance from i is nearest to d, kept if within ``rel_tol``·d.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blender_sesgen.contract.se3 import relative, rotation_angle_rad

from ..errors import VoError
from .poses import check_pair
from .stats import ErrorStats

DELTA_UNITS = ("f", "m")


@dataclass(frozen=True)
class RPEResult:
    pairs: np.ndarray            # (M, 2) index pairs (i, j)
    trans_errors_m: np.ndarray   # (M,)
    rot_errors_deg: np.ndarray   # (M,)
    trans: ErrorStats
    rot_deg: ErrorStats
    delta: float
    delta_unit: str
    all_pairs: bool

    def as_dict(self) -> dict:
        return {"delta": self.delta, "delta_unit": self.delta_unit, "all_pairs": self.all_pairs,
                "n_pairs": int(len(self.pairs)),
                "trans_m": self.trans.as_dict(), "rot_deg": self.rot_deg.as_dict()}


def rpe_pairs(T_world_cam: np.ndarray, delta: float = 1, delta_unit: str = "f",
              all_pairs: bool = False, rel_tol: float = 0.1) -> np.ndarray:
    """Index pairs (M, 2) for the RPE, chosen on ``T_world_cam`` (N, 4, 4) by evo's rules."""
    T = np.asarray(T_world_cam, dtype=float)
    n = T.shape[0]
    if delta_unit not in DELTA_UNITS:
        raise VoError(f"unknown delta unit {delta_unit!r} (f = frames, m = metres)")
    if delta <= 0:
        raise VoError(f"delta must be positive, got {delta}")
    if delta_unit == "f":
        if float(delta) != int(delta):
            raise VoError(f"delta in frames must be an integer, got {delta}")
        d = int(delta)
        if all_pairs:
            i = np.arange(max(n - d, 0))
            pairs = np.column_stack([i, i + d])
        else:
            ids = np.arange(0, n, d)
            pairs = np.column_stack([ids[:-1], ids[1:]])
    else:
        steps = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)
        if all_pairs:
            pairs = _pairs_by_path_all(steps, float(delta), float(delta) * rel_tol)
        else:
            ids, acc = [0], 0.0
            for k, s in enumerate(steps.tolist(), start=1):   # sequential sum, as evo
                acc += s
                if acc >= delta:
                    ids.append(k)
                    acc = 0.0
            pairs = np.column_stack([ids[:-1], ids[1:]]).astype(int).reshape(-1, 2)
    if len(pairs) == 0:
        raise VoError(f"delta = {delta} ({'frames' if delta_unit == 'f' else 'm'}) gives no pose pairs "
                      f"among {n} poses; try a smaller delta")
    return pairs.astype(int)


def _pairs_by_path_all(steps: np.ndarray, delta: float, tol: float) -> np.ndarray:
    """evo's all-pairs-by-path rule, vectorised with a binary search on the cumulative path."""
    dist = np.concatenate([[0.0], np.cumsum(steps)])
    n = dist.size
    i = np.arange(n - 1)
    k = np.searchsorted(dist, dist[i] + delta, side="left")        # first with dist >= target
    k = np.clip(np.maximum(k, i + 1), 0, n - 1)
    below = np.maximum(k - 1, i + 1)
    below = np.searchsorted(dist, dist[below], side="left")        # first index of equal values
    below = np.maximum(below, i + 1)
    err_k = np.abs((dist[k] - dist[i]) - delta)
    err_b = np.abs((dist[below] - dist[i]) - delta)
    j = np.where(err_b <= err_k, below, k)
    err = np.minimum(err_b, err_k)
    keep = err <= tol
    return np.column_stack([i[keep], j[keep]])


def rpe(gt, est, delta: float = 1, delta_unit: str = "f", all_pairs: bool = False,
        rel_tol: float = 0.1, pairs_from_gt: bool = False) -> RPEResult:
    """RPE of ``est`` against ``gt`` (Trajectory or (N, 4, 4), associated).

    Defaults as evo: delta 1 frame, consecutive pairs, pairs chosen on the estimate.
    """
    Q, P = check_pair(gt, est)
    pairs = rpe_pairs(Q if pairs_from_gt else P, delta, delta_unit, all_pairs, rel_tol)
    i, j = pairs[:, 0], pairs[:, 1]
    E = relative(relative(Q[i], Q[j]), relative(P[i], P[j]))
    e_t = np.linalg.norm(E[:, :3, 3], axis=1)
    e_r = np.degrees(rotation_angle_rad(E[:, :3, :3]))
    return RPEResult(pairs, e_t, e_r, ErrorStats.of(e_t), ErrorStats.of(e_r),
                     float(delta), delta_unit, bool(all_pairs))
