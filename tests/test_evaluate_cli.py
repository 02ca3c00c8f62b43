"""Command-line smoke tests (subprocess): exit codes, printed table, JSON keys, report folder."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from vo_reference.evaluate.disparity_io import read_mask
from vo_reference.io.pfm import write_pfm
from vo_reference.groundtruth.disparity import read_disparity

pytestmark = pytest.mark.slow   # subprocesses and end-to-end runs (left out of make test-fast)

HEADLINE = {"ape_trans_rmse", "ape_rot_rmse_deg", "rpe_trans_rmse", "rpe_rot_rmse_deg"}


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "vo_reference", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.mark.data
def test_evaluate_kitti_with_json_and_report(shared_data, tmp_path):
    d = shared_data / "trajectories"
    out = tmp_path / "m.json"
    r = run_cli("evaluate", "--gt", d / "KITTI_00_gt.txt", "--est", d / "KITTI_00_ORB.txt", "--align", "se3",
                "--kitti", "--json", out, "--report", tmp_path / "report")
    assert r.returncode == 0, r.stderr
    assert "APE translation" in r.stdout and "KITTI odometry" in r.stdout
    m = json.loads(out.read_text())
    assert HEADLINE | {"kitti_t_err_pct", "kitti_r_err_deg_per_100m"} <= set(m)
    assert "scale" not in m  # se3 alignment
    assert m["ape_trans_rmse"] == pytest.approx(1.303450, abs=5e-7)
    assert m["kitti_t_err_pct"] == pytest.approx(0.6997, abs=5e-4)
    for name in ("metrics.json", "summary.md", "trajectories.png", "ape.png", "rpe.png", "kitti_errors.png"):
        assert (tmp_path / "report" / name).stat().st_size > 0, name


@pytest.mark.data
def test_evaluate_tum_sim3_with_rpe_options(shared_data, tmp_path):
    d = shared_data / "trajectories"
    out = tmp_path / "m.json"
    r = run_cli("evaluate", "--gt", d / "freiburg1_xyz-groundtruth.txt", "--est", d / "freiburg1_xyz-ORB_kf_mono.txt",
                "--format", "tum", "--align", "sim3", "--delta", "2", "--delta-unit", "f", "--all-pairs",
                "--egomotion", "--json", out)
    assert r.returncode == 0, r.stderr
    m = json.loads(out.read_text())
    assert HEADLINE | {"scale"} <= set(m) and "kitti_t_err_pct" not in m
    assert m["rpe"]["all_pairs"] is True and m["rpe"]["delta"] == 2
    assert 0.5 < m["scale"] < 2.0
    assert "Egomotion per frame" in r.stdout


def test_evaluate_render_folder_as_ground_truth(tmp_path):
    from test_evaluate_core import _random_trajectory, write_manifest
    from vo_reference.io.trajectory import write_kitti
    gt = _random_trajectory(40)
    folder = write_manifest(tmp_path / "render", gt.T_world_cam, fps=10)
    write_kitti(tmp_path / "est.txt", gt)  # KITTI: no timestamps, paired by index
    r = run_cli("evaluate", "--gt", folder, "--est", tmp_path / "est.txt", "--align", "none",
                "--json", tmp_path / "m.json")
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "m.json").read_text())
    assert m["n_poses"] == 40 and m["ape_trans_rmse"] < 1e-6


@pytest.mark.parametrize("args", [
    ("--gt", "does-not-exist.txt", "--est", "also-missing.txt"),
    ("--gt", "{bad}", "--est", "{bad}"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, args):
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3\nhello world\n")
    r = run_cli("evaluate", *(a.replace("{bad}", str(bad)) for a in args))
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert r.stderr.startswith("error:") and len(r.stderr.strip().splitlines()) == 1


def test_mismatched_kitti_lengths_exit_2(tmp_path):
    from vo_reference.io.trajectory import Trajectory, write_kitti
    T = np.tile(np.eye(4), (10, 1, 1))
    T[:, 0, 3] = np.arange(10)
    write_kitti(tmp_path / "a.txt", Trajectory.from_poses(T))
    write_kitti(tmp_path / "b.txt", Trajectory.from_poses(T[:8]))
    r = run_cli("evaluate", "--gt", tmp_path / "a.txt", "--est", tmp_path / "b.txt")
    assert r.returncode == 2 and "Traceback" not in r.stderr and "8 poses" in r.stderr


def test_disparity_readers_round_trip(tmp_path):
    import cv2
    d = np.array([[0.0, 1.5, 20.25], [100.0, 3.0, 0.5]])
    cv2.imwrite(str(tmp_path / "d.png"), np.round(d * 256).astype(np.uint16))
    got = read_disparity(tmp_path / "d.png")
    assert np.isnan(got[0, 0])  # 0 = no data in KITTI PNG16
    np.testing.assert_allclose(got[~np.isnan(got)], d[d > 0])
    write_pfm(tmp_path / "d.pfm", d)
    np.testing.assert_allclose(read_disparity(tmp_path / "d.pfm"), d, rtol=1e-7)
    np.save(tmp_path / "d.npy", d)
    np.testing.assert_array_equal(read_disparity(tmp_path / "d.npy"), d)
    cv2.imwrite(str(tmp_path / "m.png"), np.array([[255, 0, 255], [0, 255, 255]], np.uint8))
    assert read_mask(tmp_path / "m.png").tolist() == [[True, False, True], [False, True, True]]


def test_evaluate_disparity_cli(tmp_path):
    gt = np.full((20, 30), 10.0)
    est = gt + 0.25
    est[:5] += 4.0  # a quarter of the image 4.25 px off: bad-3 = D1 = 25 %
    write_pfm(tmp_path / "gt.pfm", gt)
    np.save(tmp_path / "est.npy", est)
    mask = np.full((20, 30), 255, np.uint8)
    mask[:5] = 0
    import cv2
    cv2.imwrite(str(tmp_path / "noc.png"), mask)
    r = run_cli("evaluate-disparity", "--gt", tmp_path / "gt.pfm", "--est", tmp_path / "est.npy",
                "--mask", tmp_path / "noc.png", "--json", tmp_path / "d.json", "--report", tmp_path / "plots")
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "d.json").read_text())
    assert m["all"]["d1_pct"] == pytest.approx(25.0) and m["noc"]["d1_pct"] == 0.0
    assert m["noc"]["epe_px"] == pytest.approx(0.25)
    assert (tmp_path / "plots" / "disparity_error.png").stat().st_size > 0
    r = run_cli("evaluate-disparity", "--gt", tmp_path / "gt.pfm", "--est", tmp_path / "nope.pfm")
    assert r.returncode == 2 and "Traceback" not in r.stderr


def _short_drive(tmp_path, n=40):
    """A render's ground truth (a nearly straight forward drive, 5 cm per frame at 10 Hz) and
    an estimate of its frames 5..8 that yaws 0.1 deg more per frame and is 3 mm noisy."""
    from scipy.spatial.transform import Rotation
    from test_evaluate_core import write_manifest
    from vo_reference.io.trajectory import Trajectory
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, 2, 3] = -0.05 * np.arange(n)
    T[:, 0, 3] = 2e-4 * np.arange(n) ** 2
    folder = write_manifest(tmp_path / "render", T, fps=10)
    est = T[5:9].copy()
    yaw_deg = 0.1 * np.arange(4)
    est[:, :3, :3] = Rotation.from_euler("y", yaw_deg[:, None], degrees=True).as_matrix()
    est[:, :3, 3] += np.random.default_rng(1).normal(0, 0.003, (4, 3))
    return folder, Trajectory(est, np.arange(5, 9) / 10.0), yaw_deg


def test_evaluate_takes_frames_for_an_estimate_of_part_of_the_sequence(tmp_path):
    from vo_reference.io.trajectory import write_kitti, write_tum
    folder, est, yaw_deg = _short_drive(tmp_path)
    write_kitti(tmp_path / "est.txt", est)      # no timestamps: which frames it covers must be given
    r = run_cli("evaluate", "--gt", folder, "--est", tmp_path / "est.txt")
    assert r.returncode == 2 and "--frames 0:4" in r.stderr and "Traceback" not in r.stderr, r.stderr
    r = run_cli("evaluate", "--gt", folder, "--est", tmp_path / "est.txt", "--frames", "5:9",
                "--json", tmp_path / "k.json")
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "k.json").read_text())
    assert m["n_poses"] == 4 and m["alignment"]["method"] == "origin"
    # origin: the first poses made equal, so the rotation error is the yaw added since frame 5
    assert m["ape_rot_rmse_deg"] == pytest.approx(np.sqrt(np.mean(yaw_deg ** 2)), rel=1e-6)
    assert run_cli("evaluate", "--gt", folder, "--est", tmp_path / "est.txt", "--frames", "5:10").returncode == 2
    write_tum(tmp_path / "est.tum", est)        # timestamps: paired with frames 5..8 by themselves
    r = run_cli("evaluate", "--gt", folder, "--est", tmp_path / "est.tum", "--json", tmp_path / "t.json")
    assert r.returncode == 0, r.stderr
    t = json.loads((tmp_path / "t.json").read_text())
    assert t["n_poses"] == 4 and t["ape_rot_rmse_deg"] == pytest.approx(m["ape_rot_rmse_deg"], rel=1e-6)


def test_evaluate_aligns_as_run_does_and_says_when_an_se3_fit_is_ill_posed(tmp_path):
    import argparse
    from vo_reference.commands import evaluate as evaluate_cli
    from vo_reference.io.trajectory import write_tum
    from vo_reference.commands import run as vo_run_cli
    defaults = []
    for module, argv in ((evaluate_cli, ["--gt", "a", "--est", "b"]), (vo_run_cli, ["INPUT"])):
        p = argparse.ArgumentParser()
        module.add_arguments(p)
        defaults.append(p.parse_args(argv).align)
    assert defaults == ["origin", "origin"]
    folder, est, yaw_deg = _short_drive(tmp_path)
    write_tum(tmp_path / "est.tum", est)
    r = run_cli("evaluate", "--gt", folder, "--est", tmp_path / "est.tum")
    assert r.returncode == 0 and "alignment origin" in r.stdout and "note:" not in r.stdout, r.stdout
    r = run_cli("evaluate", "--gt", folder, "--est", tmp_path / "est.tum", "--json", tmp_path / "o.json")
    assert json.loads((tmp_path / "o.json").read_text())["alignment_ill_posed"] is False
    # four poses on a straight line: an SE(3) fit cannot fix the rotation about it, and says so
    r = run_cli("evaluate", "--gt", folder, "--est", tmp_path / "est.tum", "--align", "se3", "--json", tmp_path / "s.json")
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["alignment"]["rotation_sigma_deg"] > s["ape_rot_rmse_deg"] and s["alignment_ill_posed"] is True
    assert "note: on this short or nearly straight path the se3 fit" in r.stdout, r.stdout
