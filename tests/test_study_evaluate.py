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


def test_a_malformed_or_missing_trajectory_is_a_failure(tmp_path):
    assert run(tmp_path / "none.txt", "kitti")["failure"] == "wrote no trajectory file"
    (tmp_path / "nan.txt").write_text("nan " * 12 + "\n")
    assert run(tmp_path / "nan.txt", "kitti")["failure"].startswith("malformed trajectory")
    gt = curved()
    write_kitti(tmp_path / "long.txt", Trajectory(np.concatenate([gt.T_world_cam] * 2), np.arange(2 * N)))
    assert "80 poses for 40 frames" in run(tmp_path / "long.txt", "kitti", gt)["failure"]


def test_a_straight_path_falls_back_to_the_first_pose_and_a_long_one_gets_the_kitti_metric(tmp_path):
    straight = Trajectory(np.array([se3(np.eye(3), (0, 0, -k * 1.0)) for k in range(N)]), np.arange(N) / RATE)
    write_kitti(tmp_path / "s.txt", straight)
    r = run(tmp_path / "s.txt", "kitti", straight)
    assert r["ok"] and r["alignment"].startswith("origin") and r["ape_trans_rmse"] < 1e-9
    long = curved(n=120, radius=300.0)                                # 178 m
    write_kitti(tmp_path / "l.txt", long)
    r = run(tmp_path / "l.txt", "kitti", long)
    assert r["kitti_t_err_pct"] < 1e-6 and "kitti_t_err_pct" not in run(tmp_path / "s.txt", "kitti", straight)


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
