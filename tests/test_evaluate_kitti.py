"""The KITTI odometry metric against the devkit's published figures and a hand-built case."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.errors import VoError
from vo_reference.evaluate import kitti_metric, trajectory_distances
from vo_reference.io.trajectory import read_trajectory


@pytest.mark.data
@pytest.mark.parametrize("float32", [False, True])
def test_kitti_00_orb_slam2_matches_devkit(shared_data, float32):
    """A faithful devkit port gives 0.6997 % and 0.2533 deg/100 m (ORB-SLAM2 paper: 0.70 / 0.25)."""
    d = shared_data / "trajectories"
    gt = read_trajectory(d / "KITTI_00_gt.txt", "kitti")
    est = read_trajectory(d / "KITTI_00_ORB.txt", "kitti")
    r = kitti_metric(gt, est, devkit_float32=float32)
    assert r.t_err_pct == pytest.approx(0.6997, abs=5e-4)
    assert r.r_err_deg_per_100m == pytest.approx(0.2533, abs=5e-4)
    # the pooled mean is the segment-count-weighted mean of the per-length curve
    bl = r.by_length
    assert np.sum(bl["t_err_pct"] * bl["count"]) / np.sum(bl["count"]) == pytest.approx(r.t_err_pct, rel=1e-12)
    assert list(bl["length_m"]) == [100.0 * k for k in range(1, 9)]
    assert r.by_speed["speed_mps"].size > 0


def _straight_line(n, step_m):
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, 2, 3] = np.arange(n) * step_m
    return T


def test_segments_follow_the_devkit_rules():
    """1 m per frame along z: a 100 m segment from frame a ends at a + 101 (first frame *past* L)."""
    gt = _straight_line(251, 1.0)
    r = kitti_metric(gt, gt, lengths_m=(100.0, 200.0))
    # starts every 10th frame; 100 m needs a + 101 <= 250 -> a <= 149 (15 starts);
    # 200 m needs a + 201 <= 250 -> a <= 49 (5 starts)
    assert sorted(r.first_frame[r.length_m == 100.0].tolist()) == list(range(0, 150, 10))
    assert sorted(r.first_frame[r.length_m == 200.0].tolist()) == list(range(0, 50, 10))
    assert r.t_err_pct == 0.0 and r.r_err_deg_per_100m == 0.0
    # speed = L / (0.1 s * (b - a + 1)) = 100 / (0.1 * 102)
    assert r.speed_mps[r.length_m == 100.0][0] == pytest.approx(100.0 / 10.2)


def test_hand_computed_scale_and_rotation_error():
    """Estimate 1 % too long: every segment has t_err = 1.01 m per 100 m nominal.

    gt: 1 m/frame; est: 1.01 m/frame. Segment a -> a+101 (101 m of gt, L = 100):
    E translation = 101 * 0.01 = 1.01 m -> t_err = 1.01/100 = 1.01 %.
    A constant yaw offset between est and gt in the *world* leaves relative motions
    unchanged except for the rotation of the displacement -> still no rotation error.
    """
    gt = _straight_line(300, 1.0)
    est = _straight_line(300, 1.01)
    r = kitti_metric(gt, est, lengths_m=(100.0,))
    assert r.t_err_pct == pytest.approx(1.01, rel=1e-12)
    assert r.r_err_deg_per_100m == pytest.approx(0.0, abs=1e-9)
    # rotation: estimate turns by 0.001 rad per frame about y (translation unchanged)
    est_rot = _straight_line(300, 1.0)
    for k in range(300):
        c, s = np.cos(1e-3 * k), np.sin(1e-3 * k)
        est_rot[k, :3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    r = kitti_metric(gt, est_rot, lengths_m=(100.0,))
    # angle over 101 frames = 0.101 rad; per 100 m nominal: 0.101 rad/100 m
    assert r.r_err_deg_per_100m == pytest.approx(np.degrees(0.101), rel=1e-9)


def test_distances_and_errors():
    T = _straight_line(5, 2.0)
    np.testing.assert_allclose(trajectory_distances(T), [0, 2, 4, 6, 8])
    with pytest.raises(VoError, match="shorter than"):
        kitti_metric(T, T)
    with pytest.raises(VoError):
        kitti_metric(T, T[:4])
