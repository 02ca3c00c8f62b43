"""Stereo VO on real KITTI (../shared/data/kitti/sequence_1: 51 frames, ~60 m) — data tests.

Oracle: KITTI's ground-truth poses; Sim(3)-aligned position error computed by evo."""
from __future__ import annotations

import numpy as np
import pytest

pytestmark = [pytest.mark.data, pytest.mark.slow]


@pytest.fixture(scope="module")
def kitti(shared_data):
    from vo_reference.io.sequence import open_sequence
    root = shared_data / "kitti" / "sequence_1"
    if not root.is_dir():
        pytest.skip(f"{root} not found")
    return open_sequence(root)


def sim3_position_rmse(est, gt):
    from evo.core import metrics, sync  # noqa: F401
    from evo.core.trajectory import PosePath3D
    from evo.core.metrics import APE, PoseRelation
    e = PosePath3D(poses_se3=list(est))
    g = PosePath3D(poses_se3=list(gt))
    e.align(g, correct_scale=True)
    ape = APE(PoseRelation.translation_part)
    ape.process_data((g, e))
    return ape.get_statistic(metrics.StatisticsType.rmse)


def test_accurate_stereo_vo_drift_on_kitti(kitti):
    from vo_reference.stereo.pipeline import run_stereo_vo
    res = run_stereo_vo(kitti, "accurate")
    gt = kitti.T_world_cam("left")
    L = np.linalg.norm(np.diff(gt[:, :3, 3], axis=0), axis=1).sum()
    assert 55 < L < 65
    drift = np.linalg.norm(res.trajectory.T_world_cam[-1, :3, 3] - gt[-1, :3, 3]) / L
    rmse = sim3_position_rmse(res.trajectory.T_world_cam, gt) / L
    assert drift <= 0.01, f"end-point drift {100 * drift:.3f} % of the path"
    assert rmse <= 0.002, f"Sim3 position RMSE {100 * rmse:.3f} % of the path"
