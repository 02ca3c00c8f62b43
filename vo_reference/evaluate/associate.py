"""Timestamp association of two trajectories (evo's ``nearest_time`` sync, same results).

For every pose of the trajectory with fewer poses, the nearest timestamp of the other one is
taken if it is within ``max_diff`` seconds (default 0.01 s, as evo); ties go to the earlier
stamp. Poses without a partner are dropped.
"""
from __future__ import annotations

import numpy as np

from ..errors import VoError
from ..io.trajectory import Trajectory


def matching_time_indices(stamps_1: np.ndarray, stamps_2: np.ndarray, max_diff: float = 0.01,
                          offset_2: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Indices (i1, i2) of the best match in ``stamps_2 + offset_2`` for each of ``stamps_1``.

    Same rule as ``evo.core.sync.matching_time_indices`` (vectorised): nearest stamp within
    ``max_diff``; on a tie the earlier one. Unsorted ``stamps_2``: plain nearest (argmin).
    """
    s1 = np.asarray(stamps_1, dtype=float)
    s2 = np.asarray(stamps_2, dtype=float) + offset_2
    if s1.size == 0 or s2.size == 0:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    if not np.all(np.diff(s2) >= 0):
        d = np.abs(s2[None, :] - s1[:, None])
        i2 = np.argmin(d, axis=1)
        ok = d[np.arange(s1.size), i2] <= max_diff
        return np.nonzero(ok)[0], i2[ok]
    inside = (s1 >= s2[0] - max_diff) & (s1 <= s2[-1] + max_diff)
    k = np.minimum(np.searchsorted(s2, s1, side="right"), s2.size - 1)
    diff_ub = s2[k] - s1
    diff_lb = np.where(k > 0, s1 - s2[np.maximum(k - 1, 0)], np.inf)
    take_ub = (diff_ub <= max_diff) & (diff_ub < diff_lb)
    take_lb = ~take_ub & (diff_lb <= max_diff) & (diff_lb <= diff_ub)
    ok = inside & (take_ub | take_lb)
    i2 = np.where(take_ub, k, k - 1)
    return np.nonzero(ok)[0], i2[ok]


def associate(gt: Trajectory, est: Trajectory, max_diff: float = 0.01,
              offset_s: float = 0.0) -> tuple[Trajectory, Trajectory]:
    """Synchronised copies (gt, est) of equal length, matched by timestamp.

    ``offset_s`` is added to the estimate's timestamps for matching only. Raises
    :class:`VoError` when nothing matches.
    """
    est_longer = len(est) > len(gt)
    short, long_ = (gt, est) if est_longer else (est, gt)
    i_short, i_long = matching_time_indices(short.timestamps_s, long_.timestamps_s, max_diff,
                                            offset_s if est_longer else -offset_s)
    if i_short.size == 0:
        raise VoError(f"no matching timestamps between ground truth and estimate "
                      f"(max diff {max_diff} s, offset {offset_s} s)")
    short = Trajectory(short.T_world_cam[i_short], short.timestamps_s[i_short])
    long_ = Trajectory(long_.T_world_cam[i_long], long_.timestamps_s[i_long])
    return (short, long_) if est_longer else (long_, short)


def needs_association(gt: Trajectory, est: Trajectory) -> bool:
    """False when both already pair up one-to-one (same length and same timestamps)."""
    return not (len(gt) == len(est) and np.array_equal(gt.timestamps_s, est.timestamps_s))
