"""A study's evaluation of one run and its ground-truth control (vo_reference/study/evaluate.py),
on synthetic trajectories whose answers are known, and the report of a non-OAT design."""
from __future__ import annotations

import html
import json

import numpy as np
import pytest

from blender_sesgen.contract.se3 import euler_xyz_deg_to_R, se3
from vo_reference.io.trajectory import Trajectory, write_kitti, write_tum
from vo_reference.study.evaluate import evaluate_run, ground_truth_identical

N, RATE = 40, 10.0


def curved(n=N, radius=30.0, speed=1.5) -> Trajectory:
    """A camera driving along a circle (heading its tangent), 1.5 m per frame."""
    T = []
    for k in range(n):
        a = k * speed / radius
        T.append(se3(euler_xyz_deg_to_R(0, np.degrees(-a), 0), (radius * (1 - np.cos(a)), 1.5, -radius * np.sin(a))))
    return Trajectory(np.array(T), np.arange(n) / RATE)


def run(est_path, fmt, gt=None, mono=False, **kw):
    opts = {"min_coverage": 0.5, "jump_factor": 5.0, **kw}
    return evaluate_run(gt if gt is not None else curved(), est_path, fmt, mono=mono, rate_hz=RATE, **opts)


def test_a_perfect_trajectory_in_any_frame_has_no_error(tmp_path):
    gt = curved()
    moved = Trajectory(np.array([se3(euler_xyz_deg_to_R(10, 40, -5), (3, 2, 1)) @ T for T in gt.T_world_cam]),
                       gt.timestamps_s)
    write_tum(tmp_path / "est.txt", moved)
    r = run(tmp_path / "est.txt", "tum", gt)
    assert r["ok"] and r["alignment"] == "se3" and r["coverage"] == 1.0 and r["tracking_loss"] == 0.0
    assert r["ape_trans_rmse"] < 1e-6 and r["ape_rot_rmse_deg"] < 1e-6 and r["rpe_trans_per_m"] < 1e-6
    assert r["gt_path_length_m"] == pytest.approx(1.5 * (N - 1), rel=1e-3)


def test_a_monocular_trajectory_is_aligned_with_its_scale(tmp_path):
    gt = curved()
    T = gt.T_world_cam.copy()
    T[:, :3, 3] *= 0.25
    write_kitti(tmp_path / "est.txt", Trajectory(T, gt.timestamps_s))
    r = run(tmp_path / "est.txt", "kitti", gt, mono=True)
    assert r["ok"] and r["alignment"] == "sim3" and r["scale"] == pytest.approx(4.0, rel=1e-9)
    assert r["ape_trans_rmse"] < 1e-6
    r = run(tmp_path / "est.txt", "kitti", gt, mono=False)      # the same file, as a stereo system: wrong
    assert r["ape_trans_rmse"] > 1.0


def test_missing_frames_and_jumps_are_tracking_loss_and_too_few_a_failure(tmp_path):
    gt = curved()
    write_kitti(tmp_path / "short.txt", Trajectory(gt.T_world_cam[:30], gt.timestamps_s[:30]))
    r = run(tmp_path / "short.txt", "kitti", gt)
    assert r["ok"] and r["coverage"] == 0.75 and r["lost_frames"] == 10 and r["tracking_loss"] == 0.25
    write_kitti(tmp_path / "shorter.txt", Trajectory(gt.T_world_cam[:15], gt.timestamps_s[:15]))
    r = run(tmp_path / "shorter.txt", "kitti", gt)
    assert not r["ok"] and r["failure"] == "short trajectory: poses for 15 of 40 frames (at least 50% needed)"
    T = gt.T_world_cam.copy()
    T[25:, :3, 3] += (20.0, 0.0, 0.0)                                # lost, and found again 20 m off
    keep = [k for k in range(N) if k % 7 != 3]                        # TUM: frames 3, 10, 17, ... have no pose
    write_tum(tmp_path / "jump.txt", Trajectory(T[keep], gt.timestamps_s[keep] + 0.004))
    r = run(tmp_path / "jump.txt", "tum", gt)
    assert r["ok"] and r["jumps"] == [25] and r["lost_frames"] == N - len(keep)   # 24 has none: 23 -> 25 jumps
    assert r["tracking_loss"] == pytest.approx((N - len(keep) + 1) / N)


def test_poses_stamped_on_another_clock_fail_saying_so(tmp_path):
    """Every pose written but stamped 1000 s late (another clock): not a system that lost track,
    and the failure says so (it read 'poses for 0 of 40 frames' alone)."""
    gt = curved()
    write_tum(tmp_path / "late.txt", Trajectory(gt.T_world_cam, gt.timestamps_s + 1000.0))
    r = run(tmp_path / "late.txt", "tum", gt)
    assert not r["ok"] and r["failure"].startswith("short trajectory: poses for 0 of 40 frames")
    assert "40 poses written, 0 stamped within a quarter frame period of a frame" in r["failure"]


def test_a_malformed_or_missing_trajectory_is_a_failure(tmp_path):
    assert run(tmp_path / "none.txt", "kitti")["failure"] == "wrote no trajectory file"
    (tmp_path / "nan.txt").write_text("nan " * 12 + "\n")
    assert run(tmp_path / "nan.txt", "kitti")["failure"].startswith("malformed trajectory")
    gt = curved()
    write_kitti(tmp_path / "long.txt", Trajectory(np.concatenate([gt.T_world_cam] * 2), np.arange(2 * N)))
    assert "80 poses for 40 frames" in run(tmp_path / "long.txt", "kitti", gt)["failure"]
    # two poses for one instant (a stamp repeated, or stamps going back): malformed, not the first one judged
    twice = np.repeat(np.arange(N), 2)
    write_tum(tmp_path / "twice.txt", Trajectory(gt.T_world_cam[twice], gt.timestamps_s[twice]))
    r = run(tmp_path / "twice.txt", "tum", gt)
    assert not r["ok"] and r["failure"].startswith("malformed trajectory: timestamps not increasing: pose 2")
    back = np.r_[np.arange(N // 2), np.arange(N // 2 - 3, N)]
    write_tum(tmp_path / "back.txt", Trajectory(gt.T_world_cam[back], gt.timestamps_s[back]))
    assert "timestamps not increasing" in run(tmp_path / "back.txt", "tum", gt)["failure"]


def test_a_long_path_gets_the_kitti_metric_and_a_perfect_straight_one_no_error(tmp_path):
    straight = Trajectory(np.array([se3(np.eye(3), (0, 0, -k * 1.0)) for k in range(N)]), np.arange(N) / RATE)
    write_kitti(tmp_path / "s.txt", straight)
    r = run(tmp_path / "s.txt", "kitti", straight)
    assert r["ok"] and r["alignment"] == "se3" and r["ape_trans_rmse"] < 1e-9
    # a perfect estimate of a straight path still leaves the roll about it free: not measured
    assert r["alignment_ill_posed"] and r["ape_rot_rmse_deg"] is None and r["rotation_sigma_deg"] is None
    assert r["ape_rot_origin_rmse_deg"] < 1e-9
    long = curved(n=120, radius=300.0)                                # 178 m
    write_kitti(tmp_path / "l.txt", long)
    r = run(tmp_path / "l.txt", "kitti", long)
    assert r["kitti_t_err_pct"] < 1e-6 and "kitti_t_err_pct" not in run(tmp_path / "s.txt", "kitti", straight)


def _evo_ape_trans(gt: Trajectory, est: Trajectory, scale: bool) -> float:
    """evo's APE translation RMSE after its SE(3) (``scale``: Sim(3)) Umeyama alignment."""
    evo_metrics = pytest.importorskip("evo.core.metrics", reason="evo (test extra) is not installed")
    from evo.core.trajectory import PosePath3D
    ref, e = PosePath3D(poses_se3=list(gt.T_world_cam)), PosePath3D(poses_se3=list(est.T_world_cam))
    e.align(ref, correct_scale=scale)
    m = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    m.process_data((ref, e))
    return float(m.get_statistic(evo_metrics.StatisticsType.rmse))


@pytest.mark.parametrize("mono", [False, True])
def test_a_straight_path_and_one_a_hair_off_it_report_one_definition(tmp_path, mono):
    """An exactly straight drive and the same drive with a 1 um wiggle, the same VO (3 cm
    position noise, a 1 deg yaw bias; mono: at a quarter of the scale): both aligned by the
    same fit, both with the APE rotation free, and the same APE translation -- evo's se3/sim3
    on the wiggling one (evo refuses the straight one). Session 20 aligned the straight one at
    its first pose (and by the path-length ratio for mono): another definition, 0.488 m against
    the wiggling one's 0.043 m (11x), and a breaking point could come from the switch alone."""
    rng = np.random.default_rng(7)
    noise = rng.normal(0, 0.03, (N, 3))
    out = []
    for name, wiggle in (("straight", 0.0), ("hair", 1e-6)):
        gt = Trajectory(np.array([se3(np.eye(3), (wiggle * np.sin(1.3 * k), 1.6, -1.25 * k)) for k in range(N)]),
                        np.arange(N) / RATE)
        T = np.array([se3(G[:3, :3] @ euler_xyz_deg_to_R(0, 1.0, 0), G[:3, 3] + noise[k])
                      for k, G in enumerate(gt.T_world_cam)])
        if mono:
            T[:, :3, 3] *= 0.25
        est = Trajectory(T, gt.timestamps_s)
        write_kitti(tmp_path / f"{name}.txt", est)
        out.append((gt, est, run(tmp_path / f"{name}.txt", "kitti", gt, mono=mono)))
    (_, _, rs), (gt_h, est_h, rh) = out
    assert rs["alignment"] == rh["alignment"] == ("sim3" if mono else "se3")
    assert rs["alignment_ill_posed"] and rh["alignment_ill_posed"] and rs["ape_rot_rmse_deg"] is None
    assert rh["ape_trans_rmse"] == pytest.approx(_evo_ape_trans(gt_h, est_h, mono), rel=1e-6)
    assert rs["ape_trans_rmse"] == pytest.approx(rh["ape_trans_rmse"], rel=1e-4)
    assert rs["tracking_loss"] == rh["tracking_loss"] == 0.0
    if mono:
        assert rs["scale"] == pytest.approx(rh["scale"], rel=1e-6) and not rs["scale_ill_posed"]


def _shaped(gt: Trajectory, a: float, delta: float, seed: int = 0) -> tuple[Trajectory, float, float]:
    """A monocular estimate a·p + δ·w (w vertical, orthogonal to the constant and to the ground
    truth's centred x and z, |w| = 1), with the ground truth's rotations. Returns it with the
    Sim(3) fit's closed form: Σ_xy = a·Σ_y (R = I), so c = a·S_y / (a²·S_y + δ²) (S_y = Σ|p − p̄|²:
    the noise pulls the scale under 1/a) and the scale ambiguity 1/ρ² − 1 = δ² / (a²·S_y), the
    noise's energy over the motion's."""
    p = gt.positions
    basis = np.stack([np.ones(len(p)), p[:, 0] - p[:, 0].mean(), p[:, 2] - p[:, 2].mean()], axis=1)
    w = np.random.default_rng(seed).normal(size=len(p))
    w -= basis @ np.linalg.lstsq(basis, w, rcond=None)[0]
    w /= np.linalg.norm(w)
    x = a * p
    x[:, 1] += delta * w
    T = gt.T_world_cam.copy()
    T[:, :3, 3] = x
    S_y = float(np.sum((p - p.mean(axis=0)) ** 2))
    return Trajectory(T, gt.timestamps_s), a * S_y / (a * a * S_y + delta ** 2), delta ** 2 / (a * a * S_y)


def test_a_mono_scale_its_noise_swamps_is_refused_against_a_closed_form(tmp_path):
    """A monocular VO that follows the arc at 1/1000 of its size (10 cm of spread for 59 m) is
    scaled by ~1000: fine while its noise is small against its motion (scale and ambiguity the
    closed form's), refused when the noise is as large as its motion (ambiguity ~1: the fit's
    scale is half the true one; every translation after it would measure the fit's noise, so
    they are null and the record says why; rotations need no scale)."""
    gt = curved()
    for delta, refused in ((0.0005, False), (0.02, False), (0.1, True)):
        est, c, ambiguity = _shaped(gt, 1e-3, delta)
        write_kitti(tmp_path / "est.txt", est)
        r = run(tmp_path / "est.txt", "kitti", gt, mono=True)
        assert r["ok"] and r["alignment"] == "sim3" and r["scale_ambiguity"] == pytest.approx(ambiguity, rel=1e-6)
        assert r["scale_ill_posed"] is refused and (ambiguity >= 0.1) is refused
        if refused:
            assert ambiguity > 0.9 and c < 0.55e3
            for k in ("scale", "ape_trans_rmse", "rpe_trans_rmse", "tracking_loss", "jumps"):
                assert r[k] is None, k
            assert "rpe_trans_per_m" not in r
            assert r["ape_rot_origin_rmse_deg"] < 1e-6 and r["rpe_rot_rmse_deg"] < 1e-6 and r["coverage"] == 1.0
        else:
            assert r["scale"] == pytest.approx(c, rel=1e-6) and r["ape_trans_rmse"] is not None
    # an estimate that does not move fixes no scale at all; a stereo record has no scale to fix
    still = Trajectory(gt.T_world_cam.copy(), gt.timestamps_s)
    still.T_world_cam[:, :3, 3] = 0.0
    write_kitti(tmp_path / "still.txt", still)
    r = run(tmp_path / "still.txt", "kitti", gt, mono=True)
    assert r["ok"] and r["scale_ill_posed"] and r["scale_ambiguity"] is None and r["ape_trans_rmse"] is None
    assert "scale_ill_posed" not in run(tmp_path / "est.txt", "kitti", gt, mono=False)


def test_a_non_finite_measure_is_missing_not_nan_in_json(tmp_path, monkeypatch):
    """A measure that comes out NaN or infinite is null in the record, named in ``non_finite``
    (results.json refuses NaN, and a NaN averaged would poison its point's mean)."""
    import vo_reference.study.evaluate as ev
    gt = curved()
    write_kitti(tmp_path / "est.txt", gt)
    monkeypatch.setattr(ev, "rpe_per_metre", lambda g, e: float("nan"))
    r = run(tmp_path / "est.txt", "kitti", gt)
    assert r["ok"] and r["rpe_trans_per_m"] is None and r["non_finite"] == ["rpe_trans_per_m"]
    json.dumps(r, allow_nan=False)


def test_the_ground_truth_control_names_the_first_difference(tmp_path):
    from synthetic_render import write_render
    from vo_reference.io.render import RenderSequence
    K = np.array([[40.0, 0, 15.5], [0, 40.0, 11.5], [0, 0, 1]])
    rng = np.random.default_rng(0)
    z = rng.uniform(1, 5, (24, 32)).astype(np.float32)
    ids = rng.integers(0, 4, (24, 32)).astype(np.int32)
    rgb = rng.uniform(0, 1, (24, 32, 3)).astype(np.float32)
    T = curved(n=3).T_world_cam
    def render(name, depth, image):
        frames = [{"left": (image, depth, ids), "right": (image, depth, ids)} for _ in range(3)]
        return RenderSequence(write_render(tmp_path / name, K=K, baseline_m=0.1, T_world_left=T, frames=frames))
    base = render("base", z, rgb)
    assert ground_truth_identical(render("other_image", z, rgb * 0.5), base)["identical"]
    z2 = z.copy()
    z2[5, 7] += 1e-4
    diff = ground_truth_identical(render("other_depth", z2, rgb), base)
    assert not diff["identical"] and diff["difference"].startswith("frame 0 left depth")


def test_the_report_of_a_grid_design_plots_every_point(tmp_path):
    from vo_reference.study.report import write_report
    pts = [{"label": f"a={a},b={b}", "point": {"a": a, "b": b}, "system": "s", "n": 1, "n_failed": 0,
            "metrics": {"ape_trans_rmse": {"mean": a + b, "std": 0.0}}} for a in (1, 2) for b in (0.1, 0.2)]
    doc = {"format": "sesgen-study-results/1",
           "study": {"name": "g", "description": "", "seeds": [0],
                     "world": {"script": "x.ses", "frames": 6, "resolution": ["scale", 0.25], "quality": "draft"},
                     "design": {"kind": "grid", "samples": 0, "seed": 0}, "metric": "ape_trans_rmse",
                     "break_multiple": 2.0},
           "factors": [{"name": n, "unit": "u", "doc": "", "stage": "image", "levels": lv, "base_level": None}
                       for n, lv in (("a", [1, 2]), ("b", [0.1, 0.2]))],
           "systems": [{"name": "s", "builtin": None, "layout": "tum", "format": "tum", "mono": False, "trials": 1}],
           "variants": [], "runs": [], "points": pts, "curves": {}, "base": {}, "breaking_points": {}, "cost": {}}
    (tmp_path / "results.json").write_text(json.dumps(doc))
    page = write_report(tmp_path).read_text()
    assert page.count("data:image/png;base64,") == 2 and "Every point of the design" in page
    assert "the first 6 frames, 0.25 × the script's size, draft" in html.unescape(page)   # not "6, ['scale', 0.25]"


# --- the APE rotation an SE(3) fit leaves free (a short, nearly straight drive) ---------------------

def _evo_se3_ape(gt: Trajectory, est: Trajectory) -> tuple[float, float]:
    """evo's APE (translation m, rotation deg; RMSE) after its SE(3) Umeyama alignment: the oracle."""
    evo_metrics = pytest.importorskip("evo.core.metrics", reason="evo (test extra) is not installed")
    from evo.core.trajectory import PosePath3D
    ref, e = PosePath3D(poses_se3=list(gt.T_world_cam)), PosePath3D(poses_se3=list(est.T_world_cam))
    e.align(ref, correct_scale=False)
    out = []
    for relation in (evo_metrics.PoseRelation.translation_part, evo_metrics.PoseRelation.rotation_angle_deg):
        m = evo_metrics.APE(relation)
        m.process_data((ref, e))
        out.append(float(m.get_statistic(evo_metrics.StatisticsType.rmse)))
    return out[0], out[1]


def _evo_origin_ape_rot(gt: Trajectory, est: Trajectory) -> float:
    """evo's APE rotation (deg, RMSE) after its origin alignment (``--align_origin``)."""
    evo_metrics = pytest.importorskip("evo.core.metrics", reason="evo (test extra) is not installed")
    from evo.core.trajectory import PosePath3D
    ref, e = PosePath3D(poses_se3=list(gt.T_world_cam)), PosePath3D(poses_se3=list(est.T_world_cam))
    e.align_origin(ref)
    m = evo_metrics.APE(evo_metrics.PoseRelation.rotation_angle_deg)
    m.process_data((ref, e))
    return float(m.get_statistic(evo_metrics.StatisticsType.rmse))


def near_straight(n=10, step=1.25, wiggle=0.01) -> Trajectory:
    """The example studies' drive: 10 frames, 1.25 m apart (11 m), a 1 cm lateral wiggle."""
    return Trajectory(np.array([se3(np.eye(3), (wiggle * np.sin(1.3 * k), 1.6, -step * k)) for k in range(n)]),
                      np.arange(n) / RATE)


def test_the_rotation_a_fit_leaves_free_on_a_nearly_straight_drive_is_not_reported(tmp_path):
    """A VO 1 deg off in yaw at the start and drifting 0.1 deg a frame, its positions a few cm off:
    on 11 m of nearly straight road the SE(3) fit's roll about the path is free, and evo's se3 APE
    rotation is tens of degrees (the fit's, not the VO's). The record leaves it null and says why;
    the translation stays evo's; the rotation from the first pose is the drift's, analytically
    0.1 deg x rms(0..9) = 0.534 deg (and evo's origin-aligned APE rotation)."""
    gt = near_straight()
    rng = np.random.default_rng(3)
    est = Trajectory(np.array([se3(T[:3, :3] @ euler_xyz_deg_to_R(0, 1.0 + 0.1 * k, 0), T[:3, 3] + rng.normal(0, 0.03, 3))
                               for k, T in enumerate(gt.T_world_cam)]), gt.timestamps_s)
    write_kitti(tmp_path / "est.txt", est)
    evo_trans, evo_rot = _evo_se3_ape(gt, est)
    assert evo_rot > 10.0                                      # what session 19's studies reported (35-176 deg)
    r = run(tmp_path / "est.txt", "kitti", gt)
    assert r["ok"] and r["alignment"] == "se3" and r["ape_rot_rmse_deg"] is None
    assert r["alignment_ill_posed"] is True and r["rotation_sigma_deg"] > 0.5 * evo_rot
    assert r["ape_trans_rmse"] == pytest.approx(evo_trans, rel=1e-6)          # still the fit's minimum residual
    drift = 0.1 * np.sqrt(np.mean(np.arange(10) ** 2))
    assert r["ape_rot_origin_rmse_deg"] == pytest.approx(drift, rel=1e-6)
    assert r["ape_rot_origin_rmse_deg"] == pytest.approx(_evo_origin_ape_rot(gt, est), rel=1e-6)
    assert r["rpe_rot_rmse_deg"] == pytest.approx(0.1, rel=1e-6)               # frame to frame: the drift


def test_a_curved_drive_keeps_evos_se3_ape_and_a_bent_one_is_measured(tmp_path):
    """Well conditioned (a 40-frame arc, 59 m, 60 deg of turn): the record's APE is evo's, rotation
    included, and the fit is not flagged -- also with a real rotation error (2 deg of yaw drift)."""
    gt = curved()
    rng = np.random.default_rng(5)
    est = Trajectory(np.array([se3(T[:3, :3] @ euler_xyz_deg_to_R(rng.normal(0, 0.3), 2.0 * k / N, 0),
                                   T[:3, 3] + rng.normal(0, 0.05, 3)) for k, T in enumerate(gt.T_world_cam)]),
                     gt.timestamps_s)
    write_kitti(tmp_path / "est.txt", est)
    evo_trans, evo_rot = _evo_se3_ape(gt, est)
    r = run(tmp_path / "est.txt", "kitti", gt)
    assert r["alignment"] == "se3" and r["alignment_ill_posed"] is False and r["rotation_sigma_deg"] < 0.5 * evo_rot
    assert r["ape_rot_rmse_deg"] == pytest.approx(evo_rot, rel=1e-6)
    assert r["ape_trans_rmse"] == pytest.approx(evo_trans, rel=1e-6)


@pytest.mark.data
def test_real_kitti_excerpts_the_short_one_unmeasured_the_long_one_evos(tmp_path, shared_data):
    """KITTI 00 with ORB-SLAM's estimate: its first 15 poses (12 m, straight) leave the se3 fit's
    rotation free (evo: ~150 deg); its first 300 (216 m, a turn) fix it (evo: 0.9 deg)."""
    from vo_reference.io.trajectory import read_trajectory
    d = shared_data / "trajectories"
    gt_all = read_trajectory(d / "KITTI_00_gt.txt", "kitti")
    est_all = read_trajectory(d / "KITTI_00_ORB.txt", "kitti")
    for n, free in ((15, True), (300, False)):
        gt = Trajectory(gt_all.T_world_cam[:n], np.arange(n) / RATE)
        est = Trajectory(est_all.T_world_cam[:n], gt.timestamps_s)
        write_kitti(tmp_path / f"est{n}.txt", est)
        evo_trans, evo_rot = _evo_se3_ape(gt, est)
        r = run(tmp_path / f"est{n}.txt", "kitti", gt)
        if free:
            assert evo_rot > 90.0 and r["ape_rot_rmse_deg"] is None
        else:
            assert r["ape_rot_rmse_deg"] == pytest.approx(evo_rot, rel=1e-6) and evo_rot < 2.0
        assert r["alignment_ill_posed"] is free and r["ape_trans_rmse"] == pytest.approx(evo_trans, rel=1e-6)
        assert r["ape_rot_origin_rmse_deg"] == pytest.approx(_evo_origin_ape_rot(gt, est), rel=1e-6)


def test_a_resumed_study_evaluates_again_a_run_of_an_older_evaluation(tmp_path):
    """metrics.json written by an older definition of the record (no evaluation_version) is not
    taken as done: the run is evaluated again (else a resumed study keeps the old figures)."""
    import argparse
    from synthetic_render import write_render
    from vo_reference.commands.study import evaluate as study_evaluate
    from vo_reference.io.trajectory import read_render_poses
    from vo_reference.study.evaluate import EVALUATION_VERSION, sha256_file
    K = np.array([[40.0, 0, 15.5], [0, 40.0, 11.5], [0, 0, 1]])
    z, ids, rgb = np.full((24, 32), 3.0, np.float32), np.zeros((24, 32), np.int32), np.zeros((24, 32, 3), np.float32)
    gt = near_straight()
    folder = write_render(tmp_path / "render", K=K, baseline_m=0.1, T_world_left=gt.T_world_cam,
                          frames=[{"left": (rgb, z, ids), "right": (rgb, z, ids)}] * len(gt))
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    rng = np.random.default_rng(3)
    gtr = read_render_poses(folder)
    est = Trajectory(np.array([se3(T[:3, :3], T[:3, 3] + rng.normal(0, 0.03, 3)) for T in gtr.T_world_cam]),
                     gtr.timestamps_s)
    write_kitti(run_dir / "est.txt", est)
    settings = {"min_coverage": 0.5, "jump_factor": 5.0}
    stale = {"ok": True, "ape_rot_rmse_deg": 87.0, "settings": settings, "est_sha256": sha256_file(run_dir / "est.txt"),
             "gt": str(folder)}
    (run_dir / "metrics.json").write_text(json.dumps(stale))
    job = {"settings": settings, "runs": [{"run_dir": str(run_dir), "gt": str(folder), "est": str(run_dir / "est.txt"),
                                           "format": "kitti", "mono": False}], "controls": []}
    (tmp_path / "job.json").write_text(json.dumps(job))
    assert study_evaluate(argparse.Namespace(job=str(tmp_path / "job.json"), progress="off")) == 0
    m = json.loads((run_dir / "metrics.json").read_text())
    assert m["evaluation_version"] == EVALUATION_VERSION and m["alignment_ill_posed"] and m["ape_rot_rmse_deg"] is None
    before = (run_dir / "metrics.json").stat().st_mtime_ns
    assert study_evaluate(argparse.Namespace(job=str(tmp_path / "job.json"), progress="off")) == 0
    assert (run_dir / "metrics.json").stat().st_mtime_ns == before                 # now done: kept as it is


def test_the_report_shows_a_rotation_the_fit_left_free_as_not_measured(tmp_path):
    from vo_reference.study.report import write_report
    cell = {"n": 1, "n_failed": 0, "mean": None, "std": None, "n_missing": 1, "n_ill_posed": 1}
    run_ = {"variant": "base@s0", "system": "s", "trial": 0, "status": "ok", "failure": None, "wall_s": 1.0,
            "metrics": {"ape_trans_rmse": 0.155, "ape_rot_rmse_deg": None, "alignment": "se3",
                        "alignment_ill_posed": True, "rotation_sigma_deg": 216.5, "rpe_trans_rmse": 0.06,
                        "ape_rot_origin_rmse_deg": 0.085}}
    doc = {"format": "sesgen-study-results/2",
           "study": {"name": "o", "description": "", "seeds": [0],
                     "world": {"script": "x.ses", "frames": 10, "resolution": ["scale", 0.25], "quality": "draft"},
                     "design": {"kind": "oat", "samples": 0, "seed": 0}, "metric": "ape_rot_rmse_deg",
                     "break_multiple": 2.0},
           "factors": [{"name": "a", "unit": "u", "doc": "", "stage": "image", "levels": [1], "base_level": None}],
           "systems": [{"name": "s", "builtin": None, "layout": "tum", "format": "tum", "mono": False, "trials": 1}],
           "variants": [], "runs": [run_], "points": [], "curves": {"a": {"s": [dict(cell)]}}, "base": {"s": dict(cell)},
           "breaking_points": {"a": {"s": {"level": None, "reason": "not measured at the base"}}}, "cost": {}}
    (tmp_path / "results.json").write_text(json.dumps(doc))
    import re
    page = html.unescape(re.sub(r"<[^>]+>", "", write_report(tmp_path).read_text()))
    assert "not measured in 1 of 1 runs" in page and "rotation ±216°, free: APE rotation not measured" in page
    assert "— (not measured: the fit leaves the rotation free; from the first pose 0.085°)" in page
    assert page.count("not measured (missing from 1 run(s); rotation free)") == 2        # base and level cells
    assert "s: 2 of 2 points not measured (○ on the axis: ape_rot_rmse_deg missing from 2 run(s), 2 with the " \
           "rotation free)" in page                                                    # under the plot: counted


def test_a_drive_that_starts_standing_loses_no_frames_but_a_jump_still_counts(tmp_path):
    """Standing for 16 of 30 frames (as EuRoC's sequences start), then 1 m a frame: a VO 2 mm
    off everywhere has lost nothing (the estimate's median step was its noise, and every moving
    step counted as a jump: tracking loss 0.47); lost and found 20 m off at frame 24 is a jump."""
    rng = np.random.default_rng(0)
    z = [0.0] * 16 + list(np.cumsum([1.0] * 14))
    gt = Trajectory(np.array([se3(euler_xyz_deg_to_R(0, 3 * k, 0), (0.3 * np.sin(k / 5), 1.5, -zk))
                              for k, zk in enumerate(z)]), np.arange(30) / RATE)
    est = Trajectory(np.array([se3(T[:3, :3], T[:3, 3] + rng.normal(0, 0.002, 3)) for T in gt.T_world_cam]),
                     gt.timestamps_s)
    write_kitti(tmp_path / "est.txt", est)
    r = run(tmp_path / "est.txt", "kitti", gt)
    assert r["tracking_loss"] == 0.0 and r["jumps"] == []
    T = est.T_world_cam.copy()
    T[24:, :3, 3] += (20.0, 0.0, 0.0)
    write_kitti(tmp_path / "jump.txt", Trajectory(T, gt.timestamps_s))
    r = run(tmp_path / "jump.txt", "kitti", gt)
    assert r["jumps"] == [24] and r["tracking_loss"] == pytest.approx(1 / 30)


@pytest.mark.parametrize("step", [1.25, 2.5])
def test_rpe_per_metre_is_the_error_over_each_pieces_length(tmp_path, step):
    """A VO whose every step is 1 % too long (a 1 % scale error, stereo: not aligned away) errs
    0.01 m per metre whatever the frame step (a same-path factor such as rig_speed changes it);
    the error of a piece is not its error per metre (old: 0.0125 at 1.25 m a frame, 0.025 at 2.5)."""
    n = 12
    gt = Trajectory(np.array([se3(euler_xyz_deg_to_R(0, 2 * k, 0), (0.4 * np.sin(k / 3), 1.5, -step * k))
                              for k in range(n)]), np.arange(n) / RATE)
    T = gt.T_world_cam.copy()
    T[:, :3, 3] = T[0, :3, 3] + 1.01 * (T[:, :3, 3] - T[0, :3, 3])
    write_kitti(tmp_path / "est.txt", Trajectory(T, gt.timestamps_s))
    r = run(tmp_path / "est.txt", "kitti", gt)
    assert r["rpe_trans_per_m"] == pytest.approx(0.01, rel=0.02)


def test_the_scatter_of_a_grid_design_shows_and_counts_points_without_a_value(tmp_path, monkeypatch):
    """A point whose measure is missing (the APE rotation left free) and one that failed are not
    dropped from the grid design's scatter: ○ on the axis and × at the top, each with a legend
    entry and its count, and the page says how many; a categorical factor's points are plotted
    at their level's place (the old plot dropped all three kinds silently)."""
    from vo_reference.study import report
    metric = "ape_rot_rmse_deg"

    def point(a, b, mean, n_failed=0):
        m = {"mean": mean, "std": None if mean is None else 0.0, "n_missing": int(mean is None and not n_failed)}
        return {"label": f"a={a},b={b}", "point": {"a": a, "b": b}, "system": "s", "n": 1, "n_failed": n_failed,
                "n_ill_posed": int(mean is None and not n_failed), "metrics": {metric: m}}
    pts = [point(1, "wet", 0.5), point(2, "wet", None), point(1, "dry", 0.7), point(2, "dry", None, n_failed=1)]
    factors = [{"name": "a", "unit": "u", "doc": "", "stage": "image", "levels": [1, 2], "base_level": None},
               {"name": "b", "unit": "-", "doc": "", "stage": "world", "levels": ["wet", "dry"], "base_level": None}]
    systems = [{"name": "s", "builtin": None, "layout": "tum", "format": "tum", "mono": False, "trials": 1}]
    drawn = {}

    def capture(ax, fig, factor, metric_, title):
        drawn[factor["name"]] = {ln.get_label(): list(zip(ln.get_xdata(), ln.get_ydata())) for ln in ax.get_lines()}
        report.pyplot().close(fig)
        return "data:image/png;base64,"
    monkeypatch.setattr(report, "_finish", capture)
    report.scatter_plot(factors[1], pts, systems, metric)
    assert drawn["b"]["s"] == [(0, 0.5), (1, 0.7)]                         # categorical: at 0 (wet), 1 (dry)
    assert drawn["b"]["s: not measured (1)"] == [(0, 0.0)] and drawn["b"]["s: failed (1)"][0][0] == 1
    monkeypatch.undo()
    doc = {"format": "sesgen-study-results/3",
           "study": {"name": "g", "description": "", "seeds": [0],
                     "world": {"script": "x.ses", "frames": 6, "resolution": None, "quality": "draft"},
                     "design": {"kind": "grid", "samples": 0, "seed": 0}, "metric": metric, "break_multiple": 2.0},
           "factors": factors, "systems": systems, "variants": [], "runs": [], "points": pts, "curves": {}, "base": {},
           "breaking_points": {}, "cost": {}}
    (tmp_path / "results.json").write_text(json.dumps(doc))
    import re
    page = html.unescape(re.sub(r"<[^>]+>", "", report.write_report(tmp_path).read_text()))
    assert page.count("s: 1 of 4 points not measured (○ on the axis: ape_rot_rmse_deg missing from 1 run(s), "
                      "1 with the rotation free); 1 of 4 points failed (× at the top)") == 2     # under each plot
    assert "0.5 (1 run: no spread)" in page and "± 0" not in page      # one run's spread is unknown, not 0
