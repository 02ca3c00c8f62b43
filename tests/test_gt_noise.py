"""bench/gt_noise.py: a real ground truth's own step error, measured with VOs that never saw it
(the three-cornered hat, corrected for the VOs' error correlation; the poses' heading against
the images'; the smoothness bound), against analytic oracles: synthetic errors of known size
and KITTI sequence_1's real poses with a known noise or turn added."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
import gt_noise as gn  # noqa: E402


def _drive(n: int, rng) -> np.ndarray:
    """n steps of a car at 10 Hz in camera k's frame (m): ~1.2 m forward, a little lateral and vertical."""
    return np.stack([0.01 * np.sin(np.arange(n) / 7.0), 0.002 * rng.normal(size=n),
                     1.2 + 0.01 * np.cos(np.arange(n) / 11.0)], axis=1)


def _correlated(n: int, sd_a, sd_b, rho, rng):
    """Two VOs' step errors (n, 3): per axis standard deviations sd_a, sd_b and correlation rho."""
    z1, z2 = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    return np.asarray(sd_a) * z1, np.asarray(sd_b) * (rho * z1 + np.sqrt(1 - rho ** 2) * z2)


def test_the_hat_finds_a_known_truth_error_and_the_correlation_bias():
    rng = np.random.default_rng(1)
    n, sd_g, sd_a, sd_b, rho = 40000, np.array([3e-3, 1e-3, 5e-3]), [4e-3, 2e-3, 10e-3], [8e-3, 3e-3, 14e-3], 0.35
    t = _drive(n, rng)
    g = t + sd_g * rng.normal(size=(n, 3))
    ea, eb = _correlated(n, sd_a, sd_b, rho, rng)
    cov = rho * np.asarray(sd_a) * np.asarray(sd_b)
    # independent VOs: the plain rule is the truth's error variance
    eb_ind = np.asarray(sd_b) * rng.normal(size=(n, 3))
    assert np.allclose(gn.cornered_hat(g, t + ea, t + eb_ind), sd_g ** 2, rtol=0.08, atol=2e-7)
    # correlated VOs: the plain rule adds their covariance; the corrected one does not
    assert np.allclose(gn.cornered_hat(g, t + ea, t + eb), sd_g ** 2 + cov, rtol=0.08, atol=2e-7)
    assert np.allclose(gn.cornered_hat(g, t + ea, t + eb, rho), sd_g ** 2, rtol=0.1, atol=3e-7)
    # exact poses (a render): plain = the covariance, corrected ~0, and the correlation is measured
    assert np.allclose(gn.cornered_hat(t, t + ea, t + eb), cov, rtol=0.08)
    assert np.all(np.abs(gn.cornered_hat(t, t + ea, t + eb, rho)) < 0.05 * cov)
    assert np.allclose(gn.vo_correlation([t[:n // 2], t[n // 2:]], [(t + ea)[:n // 2], (t + ea)[n // 2:]],
                                         [(t + eb)[:n // 2], (t + eb)[n // 2:]]), rho, atol=0.02)


def test_the_bootstrap_interval_holds_the_truth_error():
    rng = np.random.default_rng(2)
    n, sd_g = 300, np.array([3e-3, 2e-3, 6e-3])
    t = _drive(n, rng)
    h = gn.hat_with_interval(t + sd_g * rng.normal(size=(n, 3)), t + 2e-3 * rng.normal(size=(n, 3)),
                             t + 4e-3 * rng.normal(size=(n, 3)), boot=400)
    assert h["lo"] < float(np.sum(sd_g ** 2)) < h["hi"]
    assert h["lo"] > 0.3 * np.sum(sd_g ** 2)         # an error this size is resolved from 0


def test_heading_offset_reads_a_turn_of_the_poses_and_turned_takes_it_out():
    rng = np.random.default_rng(3)
    n, psi = 50, np.radians(0.35)
    t = _drive(n, rng)
    vos = [t + s * rng.normal(size=(n, 3)) for s in (4e-3, 20e-3, 3e-3)]
    poses = gn.turned(t, -psi)                       # the poses' frame turned by psi: their step lies right
    assert gn.heading_offset_rad(poses, vos) == pytest.approx(psi, abs=np.radians(0.03))
    assert abs(gn.heading_offset_rad(t, vos)) < np.radians(0.03)      # exact poses: ~0
    acc = vos[2]
    assert np.median(gn.rpe_pct(poses, acc)) > 1.5 * np.median(gn.rpe_pct(t, acc))
    back = gn.turned(poses, gn.heading_offset_rad(poses, vos))
    assert np.median(gn.rpe_pct(back, acc)) == pytest.approx(np.median(gn.rpe_pct(t, acc)), rel=0.1)


def test_smoothness_bound_on_kittis_poses_sees_an_added_white_noise(shared_data):
    T = gn.load_kitti_poses(shared_data / "kitti" / "sequence_1" / "poses.txt")
    assert len(T) == 51
    base = gn.smoothness_bound(T)
    assert np.all(base < 3e-3)                       # KITTI's poses: smooth to ~2 mm a step forward
    rng = np.random.default_rng(4)
    noisy = T.copy()
    noisy[:, :3, 3] += 3e-3 * rng.normal(size=(len(T), 3))
    # a white noise of 3 mm per pose: 4.2 mm a step; the bound reads it (within the 48 third differences' scatter)
    assert np.all(gn.smoothness_bound(noisy) > 0.7 * 3e-3 * np.sqrt(2))
    # the steps in camera k's frame: KITTI's ~1.2 m forward steps
    s = gn.step_vectors(T)
    assert np.all(np.abs(np.linalg.norm(s, axis=1) - 1.2) < 0.05) and np.all(s[:, 2] > 1.1)


def test_twin_prints_the_ground_truth_lines(shared_data):
    twin = pytest.importorskip("twin")
    T = gn.load_kitti_poses(shared_data / "kitti" / "sequence_1" / "poses.txt")[:20]
    n, rng = len(T), np.random.default_rng(5)
    img = [np.zeros((8, 8), np.uint8)] * n
    real = twin.Frames(img, img, np.eye(3), 0.5, T)
    ours = twin.Frames(img, img, np.eye(3), 0.5, T)
    g = gn.step_vectors(T)
    psi = np.radians(0.35)
    seen = gn.turned(g, psi)                         # the images' steps: the poses' turned by -psi relative to them

    rot = gn.step_rotations(T)

    def figs(truth_steps, sd, truth_rot, sd_rad):
        out = {f"{vo}/steps_m": truth_steps + s * rng.normal(size=truth_steps.shape)
               for vo, s in zip(twin.VOS, (sd, 5 * sd, sd))}
        out.update({f"{vo}/steps_rad": truth_rot + sd_rad * rng.normal(size=truth_rot.shape) for vo in twin.VOS})
        return out
    # the real VOs disagree in rotation twice as much as the render's (0.02 vs 0.01 deg a step per axis)
    real_figs = figs(seen, 2e-3, rot, np.radians(0.02))
    draws = [figs(g, 2e-3, rot, np.radians(0.01)) for _ in range(3)]
    lines = twin.gt_error_lines("real", real, ours, real_figs, draws, n, boot=50)
    import re
    real_deg, ours_deg = (float(x) for x in re.search(r"deg\): real ([-+][0-9.]+) .*render ([-+][0-9.]+) \(draws",
                                                      lines[0]).groups())
    assert real_deg == pytest.approx(0.35, abs=0.05) and abs(ours_deg) <= 0.05
    # the accurate VO's real RPE falls to the render's once the turn is out: the ratio goes to ~1
    before, after = (float(x) for x in re.search(r"accurate real [^;]*render / real ([0-9.]+) -> ([0-9.]+)",
                                                  lines[0]).groups())
    assert before < 0.7 and after == pytest.approx(1.0, abs=0.3)
    # and the other way round: the render against its poses given the real turn reads as the real one
    assert float(re.search(r"instead .*accurate [0-9.]+ % \(([0-9.]+)\)", lines[0]).group(1)) == pytest.approx(1.0, abs=0.3)
    assert "three-cornered hat" in lines[1] and "rho x/y/z" in lines[1]
    ratio = float(re.search(r"disagreement [^;]* render / real ([0-9.]+)", lines[2]).group(1))
    assert ratio == pytest.approx(0.5, abs=0.12)
    # in translation the VOs disagree alike on both (2 mm a step per axis, the same steps' length)
    t_ratio = float(re.search(r"in translation .* render / real ([0-9.]+)", lines[2]).group(1))
    assert t_ratio == pytest.approx(1.0, abs=0.3)
    # each VO's own rotation error: 0.02 deg per axis on the real side, 0.01 on the render's
    own = re.findall(r"render / real ([0-9.]+)", lines[3])
    assert len(own) == 2 and all(float(x) == pytest.approx(0.5, abs=0.15) for x in own)


def test_rotvec_is_rodrigues_and_exact_for_small_angles(shared_data):
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(7)
    for angle in (1e-7, 1e-4, 0.01, 0.5, 2.5):
        v = rng.normal(size=3)
        v *= angle / np.linalg.norm(v)
        R = cv2.Rodrigues(v)[0]
        assert np.allclose(gn.rotvec(R), v, rtol=1e-6, atol=1e-12)
    # the steps' rotations of KITTI s1's real poses: the car turns ~0.05 deg a step, and the
    # rotation vectors compose back to the relative rotations
    T = gn.load_kitti_poses(shared_data / "kitti" / "sequence_1" / "poses.txt")
    r = gn.step_rotations(T)
    assert np.degrees(np.median(np.linalg.norm(r, axis=1))) < 0.2
    assert np.allclose(cv2.Rodrigues(r[0])[0], T[0, :3, :3].T @ T[1, :3, :3], atol=1e-9)


def test_vo_errors_keep_each_steps_translation(shared_data):
    twin = pytest.importorskip("twin")
    from vo_reference.io.sequence import open_sequence
    seq = twin.resized(open_sequence(shared_data / "kitti" / "sequence_1"), 4, (613, 185))
    e = twin.vo_errors(seq, "orb", 4)
    g = gn.step_vectors(seq.T_world_cam("left")[:4])
    assert e["steps_m"].shape == (3, 3)
    assert np.median(gn.rpe_pct(g, e["steps_m"])) == pytest.approx(e["t_rpe_pct"], rel=1e-6)


def test_rpe_without_truth_error_removes_the_truths_share_in_quadrature():
    rng = np.random.default_rng(6)
    n = 20000
    t = _drive(n, rng)
    est = t + 6e-3 * rng.normal(size=(n, 3))
    noisy = t + 8e-3 * rng.normal(size=(n, 3))        # a truth with its own error: 10 mm against 6 mm
    own = np.median(gn.rpe_pct(t, est))
    assert np.median(gn.rpe_pct(noisy, est)) == pytest.approx(own * 10 / 6, rel=0.05)
    assert gn.rpe_without_truth_error(noisy, est, 3 * 8e-3 ** 2) == pytest.approx(own, rel=0.05)
    assert gn.rpe_without_truth_error(noisy, est, -1e-4) == pytest.approx(np.median(gn.rpe_pct(noisy, est)))
    assert gn.rpe_with_drawn_truth_error(t, est, [8e-3 ** 2] * 3, draws=5) == pytest.approx(own * 10 / 6, rel=0.05)


def test_bad_input_exits_2(shared_data, tmp_path, capsys):
    assert gn.main(["--frames", "3"]) == 2
    assert gn.main(["--render", str(tmp_path / "none")]) == 2
    import klt_causes
    assert klt_causes.main(["--out", str(tmp_path / "none")]) == 2
    err = capsys.readouterr().err
    assert "--frames 8 or more" in err and "not a render folder" in err and "Traceback" not in err
