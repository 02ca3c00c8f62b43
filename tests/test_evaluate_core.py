"""Alignment, association, egomotion table and disparity metrics on hand-made cases."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vo_reference.errors import VoError
from vo_reference.evaluate import (align, ape, associate, disparity_metrics, egomotion,
                                   egomotion_table, evaluate_trajectory, matching_time_indices,
                                   rpe, umeyama)
from vo_reference.io.trajectory import Trajectory, read_render_poses, read_trajectory


def _random_trajectory(n=200, seed=0):
    rng = np.random.default_rng(seed)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.from_rotvec(np.cumsum(rng.normal(0, 0.05, (n, 3)), axis=0)).as_matrix()
    T[:, :3, 3] = np.cumsum(rng.normal(0, 0.3, (n, 3)), axis=0)
    return Trajectory.from_poses(T)


# --- alignment ------------------------------------------------------------------------------

def test_sim3_recovers_a_known_scale_and_transform():
    gt = _random_trajectory()
    s, R = 2.5, Rotation.from_rotvec([0.3, -1.2, 2.0]).as_matrix()
    t = np.array([10.0, -4.0, 7.5])
    # est = the gt seen through an unknown similarity: gt = s * R * est + t
    T_est = gt.T_world_cam.copy()
    T_est[:, :3, 3] = (gt.positions - t) @ R / s
    T_est[:, :3, :3] = R.T @ gt.T_world_cam[:, :3, :3]
    est = Trajectory(T_est, gt.timestamps_s)
    aligned, a = align(est, gt, "sim3")
    assert a.scale == pytest.approx(s, rel=1e-9)
    np.testing.assert_allclose(a.R, R, atol=1e-9)
    np.testing.assert_allclose(a.t, t, atol=1e-9)
    np.testing.assert_allclose(aligned.T_world_cam, gt.T_world_cam, atol=1e-9)
    res = ape(gt, aligned)
    assert res.trans.max < 1e-9 and res.rot_deg.max < 1e-6
    # se3 cannot undo the scale; scale-only recovers it but not the rotation
    assert align(est, gt, "se3")[1].scale == 1.0
    assert align(est, gt, "scale")[1].scale == pytest.approx(s, rel=1e-9)


def test_first_n_alignment_uses_only_the_first_poses():
    gt = _random_trajectory()
    est_T = gt.T_world_cam.copy()
    est_T[100:, :3, 3] += 5.0  # a jump after pose 100: the first 50 poses still align exactly
    est = Trajectory(est_T, gt.timestamps_s)
    aligned, a = align(est, gt, "se3", n=50)
    assert a.n_poses == 50
    np.testing.assert_allclose(aligned.positions[:100], gt.positions[:100], atol=1e-9)


def test_umeyama_determinant_fix_returns_a_rotation_for_mirrored_points():
    x = np.random.default_rng(1).normal(size=(30, 3))
    y = x * np.array([1.0, 1.0, -1.0])  # a mirror image: the best *rotation* is not a reflection
    R, _, _ = umeyama(x, y)
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)


def test_origin_alignment_makes_first_poses_equal():
    gt = _random_trajectory(50)
    est = _random_trajectory(50, seed=3)
    aligned, _ = align(est, gt, "origin")
    np.testing.assert_allclose(aligned.T_world_cam[0], gt.T_world_cam[0], atol=1e-12)
    # relative motions are unchanged by the rigid alignment
    r0, r1 = rpe(gt, est), rpe(gt, aligned)
    np.testing.assert_allclose(r0.trans_errors_m, r1.trans_errors_m, atol=1e-9)


def test_degenerate_alignment_is_a_vo_error():
    T = np.tile(np.eye(4), (10, 1, 1))
    T[:, 0, 3] = np.arange(10)  # collinear positions: the rotation about the line is undetermined
    traj = Trajectory.from_poses(T)
    with pytest.raises(VoError, match="degenerate"):
        align(traj, traj, "se3")
    with pytest.raises(VoError, match="unknown alignment"):
        align(traj, traj, "affine")


# --- association ----------------------------------------------------------------------------

def test_association_picks_the_nearest_stamp_within_max_diff():
    s_gt = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    s_est = np.array([0.004, 0.095, 0.25, 0.4099])  # 0.25: 0.05 away from both -> no match
    i_est, i_gt = matching_time_indices(s_est, s_gt, 0.01)
    assert i_est.tolist() == [0, 1, 3] and i_gt.tolist() == [0, 1, 4]
    T = np.tile(np.eye(4), (5, 1, 1))
    gt = Trajectory(T, s_gt)
    est = Trajectory(T[:4], s_est)
    g, e = associate(gt, est)
    np.testing.assert_array_equal(g.timestamps_s, [0.0, 0.1, 0.4])
    np.testing.assert_array_equal(e.timestamps_s, [0.004, 0.095, 0.4099])
    with pytest.raises(VoError, match="no matching timestamps"):
        associate(gt, Trajectory(T[:1], [5.0]))


def test_association_matches_evo_on_random_stamps():
    sync = pytest.importorskip("evo.core.sync")
    rng = np.random.default_rng(7)
    a = np.sort(rng.uniform(0, 10, 400))
    b = np.sort(np.concatenate([a[::2] + rng.uniform(-0.015, 0.015, 200), rng.uniform(0, 10, 50)]))
    b[10] = a[20] + 0.005  # exact tie between two neighbours is resolved the same way
    ours = matching_time_indices(a, b, 0.01)
    theirs = sync.matching_time_indices(a, b, 0.01)
    assert ours[0].tolist() == theirs[0] and ours[1].tolist() == theirs[1]


# --- egomotion table ------------------------------------------------------------------------

def _pose(rotvec_deg, t):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.radians(rotvec_deg)).as_matrix()
    T[:3, 3] = t
    return T


def test_egomotion_table_hand_computed():
    """gt: 0->1 turns 90 deg about z and moves (1, 2, 3); 1->2 moves 1 along its own z.

    Twist of [Rz(90)|(1,2,3)]: V^-1 for theta = pi/2 about z maps (1, 2) to
    (pi/4)·(1+2, -1+2) = (3pi/4, pi/4); v_z = 3.
    """
    T1 = _pose([0, 0, 90], [1, 2, 3])
    gt = np.stack([np.eye(4), T1, T1 @ _pose([0, 0, 0], [0, 0, 1])])
    np.testing.assert_allclose(egomotion(gt, "rotvec"), [[1, 2, 3, 0, 0, 90], [0, 0, 1, 0, 0, 0]], atol=1e-12)
    np.testing.assert_allclose(egomotion(gt, "twist"),
                               [[3 * np.pi / 4, np.pi / 4, 3, 0, 0, 90], [0, 0, 1, 0, 0, 0]], atol=1e-12)
    E1 = _pose([0, 0, 91], [1.1, 2, 3])
    est = np.stack([np.eye(4), E1, E1 @ _pose([0, 0, 0], [0, 0, 1.2])])
    table = egomotion_table(gt, est, "rotvec")
    np.testing.assert_allclose(table.error, [[0.1, 0, 0, 0, 0, 1], [0, 0, 0.2, 0, 0, 0]], atol=1e-12)
    r2 = np.sqrt(2.0)
    np.testing.assert_allclose(table.rmse, [0.1 / r2, 0, 0.2 / r2, 0, 0, 1 / r2], atol=1e-12)
    md = table.to_markdown()
    assert "rotvec" in md and "RMSE" in md and "0→1" in md


def test_egomotion_twist_inverts_the_ses_ego_integration():
    """An SES EGO line is the twist: T(k+1) = T(k)·exp([ω, v]) (built here with scipy's expm)."""
    from scipy.linalg import expm
    steps = np.array([[0.01, 0.02, 0.03, 0.5, -0.8, 0.3], [0.03, -0.01, 0.04, -0.2, 0.7, -0.5],
                      [0.1, 0.0, 0.0, 30.0, 40.0, -20.0]])
    T = [np.eye(4)]
    for U, V, W, a, b, g in steps:
        w = np.radians([a, b, g])
        X = np.zeros((4, 4))
        X[:3, :3] = [[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]
        X[:3, 3] = [U, V, W]
        T.append(T[-1] @ expm(X))
    np.testing.assert_allclose(egomotion(np.stack(T)), steps, atol=1e-10)


# --- disparity ------------------------------------------------------------------------------

def test_disparity_metrics_hand_computed():
    gt = np.array([[10.0, 20.0, 0.0], [40.0, 80.0, np.nan]])      # 0 and NaN: no ground truth
    est = np.array([[10.4, 21.5, 5.0], [43.5, 83.9, 1.0]])        # errors 0.4, 1.5, 3.5, 3.9
    noc = np.array([[True, True, True], [False, True, True]])
    m = disparity_metrics(gt, est, noc)
    a = m["all"]
    assert a["n_pixels"] == 4
    assert a["epe_px"] == pytest.approx((0.4 + 1.5 + 3.5 + 3.9) / 4)
    assert a["bad_0.5_pct"] == pytest.approx(75.0)
    assert a["bad_1_pct"] == pytest.approx(75.0)
    assert a["bad_2_pct"] == pytest.approx(50.0)
    assert a["bad_3_pct"] == pytest.approx(50.0)
    assert a["d1_pct"] == pytest.approx(25.0)  # 3.9 px at d = 80 is under 5 % (4 px): not D1
    n = m["noc"]
    assert n["n_pixels"] == 3 and n["epe_px"] == pytest.approx((0.4 + 1.5 + 3.9) / 3)
    assert n["d1_pct"] == 0.0
    est[0, 0] = np.nan  # a missing estimate is wrong for bad-N/D1 and left out of EPE
    a = disparity_metrics(gt, est)["all"]
    assert a["density_pct"] == pytest.approx(75.0)
    assert a["bad_0.5_pct"] == pytest.approx(100.0)
    assert a["epe_px"] == pytest.approx((1.5 + 3.5 + 3.9) / 3)
    with pytest.raises(VoError):
        disparity_metrics(gt, est[:, :2])


# --- render manifests and the one-call pipeline ---------------------------------------------

def write_manifest(folder, T_left, fps=None, timestamps=None):
    """A render manifest (the contract's writer) with these left poses and a 0.12 baseline."""
    from blender_sesgen.contract.manifest import Manifest
    T_left = np.asarray(T_left)
    n = len(T_left)
    ts = np.arange(n) / (fps or 1.0) if timestamps is None else np.asarray(timestamps, dtype=float)
    Manifest(resolution=(64, 48), K=np.array([[50.0, 0, 31.5], [0, 50, 23.5], [0, 0, 1]]), baseline=0.12,
             views=("left", "right"),
             poses={"left": T_left, "right": np.array([T @ _pose([0, 0, 0], [0.12, 0, 0]) for T in T_left])},
             files={v: [f"exr/{v}/{k:06d}.exr" for k in range(n)] for v in ("left", "right")},
             timestamps_s=ts, fps=fps or 1.0).write(folder)
    return folder


def test_read_render_poses(tmp_path):
    gt = _random_trajectory(20)
    folder = write_manifest(tmp_path / "render", gt.T_world_cam, fps=25)
    left = read_trajectory(folder)                 # auto: a folder is a render
    np.testing.assert_allclose(left.T_world_cam, gt.T_world_cam)
    np.testing.assert_allclose(left.timestamps_s, np.arange(20) / 25)
    right = read_render_poses(folder / "manifest.json", view="right")
    np.testing.assert_allclose(np.linalg.norm(right.positions - left.positions, axis=1), 0.12)
    with pytest.raises(VoError, match="view 'middle'"):
        read_render_poses(folder, "middle")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "manifest.json").write_text('{"format": "other"}')
    with pytest.raises(VoError, match="not a sesgen render"):
        read_render_poses(tmp_path / "bad")


def test_evaluate_trajectory_of_a_perfect_scaled_estimate():
    gt = _random_trajectory(120)
    T = gt.T_world_cam.copy()
    T[:, :3, 3] *= 0.5
    est = Trajectory(T, gt.timestamps_s)
    ev = evaluate_trajectory(gt, est, align="sim3", egomotion=True)
    m = ev.metrics()
    assert m["scale"] == pytest.approx(2.0, rel=1e-9)
    assert m["ape_trans_rmse"] < 1e-9 and m["rpe_trans_rmse"] < 1e-9
    assert np.all(ev.egomotion.rmse < 1e-6)
    json.dumps(m)  # JSON-ready


@pytest.mark.slow
def test_write_report_folder(tmp_path):
    pytest.importorskip("matplotlib")
    from vo_reference.evaluate.report import write_report
    gt = _random_trajectory(80)
    T = gt.T_world_cam.copy()
    T[:, :3, 3] += np.random.default_rng(2).normal(0, 0.01, (80, 3))
    ev = evaluate_trajectory(gt, Trajectory(T, gt.timestamps_s), egomotion=True)
    files = write_report(tmp_path / "rep", ev, title="noisy", inputs={"gt": "a", "est": "b"})
    assert {"metrics", "trajectories", "ape", "rpe", "egomotion", "summary"} <= set(files)
    m = json.loads((tmp_path / "rep" / "metrics.json").read_text())
    assert m["ape_trans_rmse"] == pytest.approx(ev.ape.trans.rmse) and m["inputs"]["gt"] == "a"
    md = (tmp_path / "rep" / "summary.md").read_text()
    assert md.startswith("# noisy") and "Egomotion per frame (twist" in md and "![egomotion](egomotion.png)" in md


def test_trajectory_plot_panels_are_titled_by_the_axes_they_show(tmp_path, monkeypatch):
    """A path that climbs (y) more than it strays sideways (x): its first panel shows z and y,
    and says so -- not "top view"."""
    pytest.importorskip("matplotlib")
    from vo_reference.evaluate import plots
    figures = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, path, dpi=120: figures.append(fig) or path)
    n = 30
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, 2, 3] = -0.1 * np.arange(n)              # forward 2.9
    T[:, 1, 3] = 0.05 * np.arange(n)              # up 1.45
    T[:, 0, 3] = 0.002 * np.arange(n) ** 1.5      # sideways 0.31
    gt = Trajectory.from_poses(T)
    plots.plot_trajectories(gt, gt, tmp_path / "t.png")
    shown = []
    for ax in figures[0].axes:
        x, y = ax.get_xlabel()[0], ax.get_ylabel()[0]
        assert ax.get_title().startswith(f"{x}–{y} plane"), (ax.get_title(), x, y)
        shown.append(x + y)
    assert shown == ["zy", "zx"]
