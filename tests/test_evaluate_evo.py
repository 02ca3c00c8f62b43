"""APE / RPE / association / alignment agree with evo 1.38.1 (the oracle) on real trajectories."""
from __future__ import annotations

import copy

import numpy as np
import pytest

evo_metrics = pytest.importorskip("evo.core.metrics", reason="evo (test extra) is not installed")
from evo.core import sync
from evo.core.units import Unit
from evo.tools import file_interface

from vo_reference.evaluate import ape, associate, align, rpe
from vo_reference.io.trajectory import read_trajectory

pytestmark = [pytest.mark.data, pytest.mark.slow]
RTOL = 1e-6

CASES = {
    "kitti_orb": ("KITTI_00_gt.txt", "KITTI_00_ORB.txt", "kitti"),
    "kitti_sptam": ("KITTI_00_gt.txt", "KITTI_00_SPTAM.txt", "kitti"),
    "tum_rgbdslam": ("freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-rgbdslam.txt", "tum"),
}


_LOADED: dict = {}


def _load_pair(shared_data, case):
    """Both readers' trajectories of ``case``, read once per module: ours read-only (shared by
    the tests), evo's deep copies (its ``align`` works in place)."""
    if case not in _LOADED:
        ours, evo_pair = _read_pair(shared_data, case)
        for traj in ours:
            traj.T_world_cam.flags.writeable = traj.timestamps_s.flags.writeable = False
        _LOADED[case] = ours, evo_pair
    ours, evo_pair = _LOADED[case]
    return ours, copy.deepcopy(evo_pair)


def _read_pair(shared_data, case):
    gt_name, est_name, fmt = CASES[case]
    d = shared_data / "trajectories"
    ours = (read_trajectory(d / gt_name, fmt), read_trajectory(d / est_name, fmt))
    if fmt == "kitti":
        ref = file_interface.read_kitti_poses_file(str(d / gt_name))
        est = file_interface.read_kitti_poses_file(str(d / est_name))
    else:
        ref = file_interface.read_tum_trajectory_file(str(d / gt_name))
        est = file_interface.read_tum_trajectory_file(str(d / est_name))
        ref, est = sync.associate_trajectories(ref, est, max_diff=0.01)
        ours = associate(*ours, max_diff=0.01)
        assert len(ours[0]) == ref.num_poses
        np.testing.assert_array_equal(ours[0].timestamps_s, ref.timestamps)
        np.testing.assert_array_equal(ours[1].timestamps_s, est.timestamps)
    return ours, (ref, est)


def _evo_aligned(ref, est, method):
    est = copy.deepcopy(est)
    if method == "se3":
        est.align(ref)
    elif method == "sim3":
        est.align(ref, correct_scale=True)
    elif method == "scale":
        est.align(ref, correct_only_scale=True)
    elif method == "origin":
        est.align_origin(ref)
    return est


def _assert_stats(ours, evo_metric):
    evo_stats = evo_metric.get_all_statistics()
    for key in ("rmse", "mean", "median", "std", "min", "max", "sse"):
        assert getattr(ours, key) == pytest.approx(evo_stats[key], rel=RTOL, abs=1e-12), key


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("method", ["none", "origin", "se3", "sim3", "scale"])
def test_ape_matches_evo(shared_data, case, method):
    (gt, est), (ref, est_evo) = _load_pair(shared_data, case)
    est_evo = _evo_aligned(ref, est_evo, method)
    est_ours, _ = align(est, gt, method)
    res = ape(gt, est_ours)
    for relation, ours, errors in (
        (evo_metrics.PoseRelation.translation_part, res.trans, res.trans_errors_m),
        (evo_metrics.PoseRelation.rotation_angle_deg, res.rot_deg, res.rot_errors_deg),
    ):
        m = evo_metrics.APE(relation)
        m.process_data((ref, est_evo))
        _assert_stats(ours, m)
        np.testing.assert_allclose(errors, m.error, rtol=RTOL, atol=1e-12)


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("delta,unit,all_pairs", [(1, "f", False), (10, "f", True), (10, "f", False),
                                                  (2.0, "m", False), (2.0, "m", True)])
def test_rpe_matches_evo(shared_data, case, delta, unit, all_pairs):
    (gt, est), (ref, est_evo) = _load_pair(shared_data, case)
    if unit == "m" and case == "tum_rgbdslam":
        delta = 0.1  # fr1/xyz is a short (~7 m) hand-held path
    res = rpe(gt, est, delta, unit, all_pairs)
    evo_unit = Unit.frames if unit == "f" else Unit.meters
    for relation, ours, errors in (
        (evo_metrics.PoseRelation.translation_part, res.trans, res.trans_errors_m),
        (evo_metrics.PoseRelation.rotation_angle_deg, res.rot_deg, res.rot_errors_deg),
    ):
        m = evo_metrics.RPE(relation, delta, evo_unit, all_pairs=all_pairs)
        m.process_data((ref, est_evo))
        assert [int(j) for j in res.pairs[:, 1]] == m.delta_ids
        _assert_stats(ours, m)
        np.testing.assert_allclose(errors, m.error, rtol=RTOL, atol=1e-12)


def test_sim3_rpe_matches_evo(shared_data):
    """RPE after a Sim3 alignment (scale changes relative translations) agrees too."""
    (gt, est), (ref, est_evo) = _load_pair(shared_data, "tum_rgbdslam")
    est_evo = _evo_aligned(ref, est_evo, "sim3")
    est_ours, a = align(est, gt, "sim3")
    res = rpe(gt, est_ours)
    m = evo_metrics.RPE(evo_metrics.PoseRelation.translation_part)
    m.process_data((ref, est_evo))
    _assert_stats(res.trans, m)


def test_headline_numbers_on_kitti_00_orb(shared_data):
    """The README's figure: evo APE (translation, SE3-aligned) RMSE 1.303450 m."""
    (gt, est), _ = _load_pair(shared_data, "kitti_orb")
    est_aligned, _ = align(est, gt, "se3")
    assert ape(gt, est_aligned).trans.rmse == pytest.approx(1.303450, abs=5e-7)
