"""``stereo-vo`` and ``run`` on a render folder written without Blender (tests/synthetic_render.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from vo_reference.cli import main
from vo_reference.io.trajectory import read_kitti, read_tum

import stereo_synth as S

pytestmark = pytest.mark.slow   # subprocesses and end-to-end runs (left out of make test-fast)


@pytest.fixture(scope="module")
def render_dir(tmp_path_factory):
    from synthetic_render import write_render
    frames, T = S.sequence(S.smooth_twists(4), seed=2)
    fr = []
    for f in frames:
        d = {}
        for v, dk in (("left", "depth"), ("right", "depth_right")):
            lin = (f[v].astype(np.float32) / 255.0) ** 2.2      # the reader sRGB-encodes it back
            d[v] = (np.repeat(lin[..., None], 3, axis=2), f[dk], np.ones(f[dk].shape, np.int32))
        fr.append(d)
    root = tmp_path_factory.mktemp("render") / "plane"
    write_render(root, K=S.K, baseline_m=S.B, T_world_left=T, frames=fr)
    return root, T


def test_stereo_vo_cli_gt_depth_and_flow_recovers_the_poses(render_dir, tmp_path, capsys):
    root, T = render_dir
    out = tmp_path / "est.txt"
    assert main(["stereo-vo", str(root), "--method", "accurate", "--gt-depth", "--gt-flow", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "frame    0->1" in err and "\r" not in err             # per-step progress, plain lines
    est = read_kitti(out)
    np.testing.assert_allclose(est.T_world_cam, T, atol=1e-5)


def test_stereo_vo_cli_paper_tum_and_frames(render_dir, tmp_path):
    root, T = render_dir
    out = tmp_path / "est.tum"
    assert main(["stereo-vo", str(root), "--method", "paper", "--out", str(out), "--out-format", "tum",
                 "--frames", "1:4", "--quiet"]) == 0
    est = read_tum(out)
    assert len(est) == 3
    np.testing.assert_allclose(est.T_world_cam[0], T[1], atol=1e-9)    # starts at the GT pose of frame 1
    assert np.linalg.norm(est.T_world_cam[-1, :3, 3] - T[3, :3, 3]) < 0.03


def test_stereo_vo_cli_errors_exit_2(tmp_path, shared_data, capsys):
    kitti = shared_data / "kitti" / "sequence_1"
    assert main(["stereo-vo", str(tmp_path / "missing"), "--out", str(tmp_path / "e.txt")]) == 2
    if kitti.is_dir():  # real data without depth: the GT switches are refused with one line
        assert main(["stereo-vo", str(kitti), "--gt-depth", "--out", str(tmp_path / "e.txt")]) == 2
    assert "error:" in capsys.readouterr().err


def test_run_writes_the_report(render_dir, tmp_path):
    root, _ = render_dir
    rep = tmp_path / "report"
    assert main(["run", str(root), "--report", str(rep), "--quiet"]) == 0
    summary = (rep / "summary.md").read_text()
    assert "0.0049" in summary and "paper" in summary and "accurate" in summary
    data = json.loads((rep / "report.json").read_text())
    assert set(data["methods"]) == {"paper", "accurate"}
    acc = data["methods"]["accurate"]["egomotion_rmse"]
    assert acc["U"] < 5e-4 and acc["alpha_deg"] < 0.01
    for m in ("paper", "accurate"):
        assert (rep / m / "est.txt").is_file() and (rep / m / "trajectories.png").is_file()
    # scale/shape numbers: Sim3 RMSE as evo computes it from the written estimate, step ratio ~ 1
    from evo.core.trajectory import PosePath3D
    _, T = render_dir
    est = PosePath3D(poses_se3=list(read_kitti(rep / "accurate" / "est.txt").T_world_cam))
    est.align(PosePath3D(poses_se3=list(T)), correct_scale=True)
    evo_rmse = np.sqrt(np.mean(np.sum((est.positions_xyz - T[:, :3, 3]) ** 2, axis=1)))
    a = data["methods"]["accurate"]
    assert a["sim3_position_rmse"] == pytest.approx(evo_rmse, rel=1e-6, abs=1e-9)
    assert abs(a["step_length_ratio"] - 1) < 0.01 and a["end_point_drift_pct"] < 1
    assert "Sim3-aligned position RMSE" in summary


def test_run_on_a_kitti_folder_writes_beside_not_into_it(render_dir, tmp_path, monkeypatch, capsys):
    # a KITTI odometry folder made from the synthetic render (exact images, calibration and poses)
    import cv2
    from vo_reference.io.sequence import open_sequence
    from vo_reference.io.trajectory import Trajectory, write_kitti
    root, T = render_dir
    seq = open_sequence(root)
    kitti = tmp_path / "dataset" / "sequences" / "05"
    for view, folder in (("left", "image_0"), ("right", "image_1")):
        (kitti / folder).mkdir(parents=True)
        for k in range(seq.num_frames):
            cv2.imwrite(str(kitti / folder / f"{k:06d}.png"), seq.image_gray(k, view))
    K = seq.K
    P0 = np.hstack([K, np.zeros((3, 1))])
    P1 = np.hstack([K, [[-K[0, 0] * seq.baseline_m], [0], [0]]])
    (kitti / "calib.txt").write_text("".join(f"P{i}: " + " ".join(f"{x:.12e}" for x in P.ravel()) + "\n"
                                             for i, P in enumerate((P0, P1))))
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main(["run", str(kitti), "--methods", "accurate", "--quiet", "--no-plots"]) == 2   # no poses yet
    assert "no ground-truth poses" in capsys.readouterr().err
    (tmp_path / "dataset" / "poses").mkdir()
    write_kitti(tmp_path / "dataset" / "poses" / "05.txt", Trajectory(np.linalg.inv(T[0]) @ T, np.arange(len(T)) * 0.1))
    assert main(["run", str(kitti), "--methods", "accurate", "--quiet", "--no-plots"]) == 0
    data = json.loads((work / "05_report" / "report.json").read_text())
    assert data["methods"]["accurate"]["egomotion_rmse"]["U"] < 5e-4
    assert not (kitti / "report").exists()


@pytest.mark.data
def test_run_on_the_real_kitti_excerpt(shared_data, tmp_path):
    kitti = shared_data / "kitti" / "sequence_1"
    if not kitti.is_dir():
        pytest.skip(f"{kitti} not found")
    assert main(["run", str(kitti), "--report", str(tmp_path / "r"), "--methods", "accurate",
                 "--frames", "0:11", "--quiet", "--no-plots"]) == 0
    acc = json.loads((tmp_path / "r" / "report.json").read_text())["methods"]["accurate"]
    assert acc["end_point_drift"] / acc["path_length"] < 0.02 and acc["path_length"] > 10
