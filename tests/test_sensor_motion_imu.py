"""Continuous rig motion and the IMU: exact twists, the C2 spline, specific force, integration
of the ideal stream back to the trajectory, Allan deviation of the noise model."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.contract import frames, motion, se3
from blender_sesgen.sensor import imu
from blender_sesgen.contract.rig_motion import RigMotion
from vo_reference.evaluate.allan import allan_deviation, fit_noise_densities

RATE = 20.0


def _ego_poses(steps, start=((0.3, 1.2, 2.0), (5.0, -10.0, 3.0))):
    return motion.integrate_ego(frames.start_pose(*start), steps)


def _keyframes(n=12, seed=3):
    rng = np.random.default_rng(seed)
    T = [frames.start_pose((0, 1.5, 3), (0, 0, 0))]
    for _ in range(n - 1):
        step = np.concatenate([rng.normal(0, 0.05, 3), rng.normal(0, 6.0, 3)])
        T.append(T[-1] @ motion.ego_step(*step))
    return np.array(T)


def test_ego_twist_is_the_exact_ego_motion():
    steps = [(0.05, -0.01, 0.2, 2.0, -3.0, 1.0), (0.02, 0.03, 0.1, -1.0, 4.0, 0.5)]
    T = _ego_poses(steps)
    m = RigMotion(T, RATE, 1.5, "ego_twist")
    assert np.allclose(m.T_world_cam(1.5 + np.arange(3) / RATE), T, atol=1e-12)
    half = T[0] @ motion.ego_step(*(np.array(steps[0]) * 0.5))     # constant twist: half the step
    assert np.allclose(m.T_world_cam(1.5 + 0.5 / RATE)[0], half, atol=1e-12)
    kin = m.kinematics(1.5 + 0.3 / RATE)
    assert np.allclose(kin.omega_body[0], np.radians(steps[0][3:]) * RATE)


def _finite_difference_check(m, ts, h=1e-5):
    kin = m.kinematics(ts)
    kp, km = m.kinematics(ts + h), m.kinematics(ts - h)
    assert np.abs((kp.p - km.p) / (2 * h) - kin.v).max() < 1e-6
    assert np.abs((kp.p - 2 * kin.p + km.p) / h**2 - kin.a).max() < 1e-3
    assert np.abs((kp.R - km.R) / (2 * h) - kin.R_dot).max() < 1e-6
    assert np.abs((kp.R - 2 * kin.R + km.R) / h**2 - kin.R_ddot).max() < 1e-3
    W = np.einsum("nji,njk->nik", kin.R, kin.R_dot)
    assert np.allclose(W, -np.transpose(W, (0, 2, 1)), atol=1e-9)   # R^T R_dot is skew


@pytest.mark.parametrize("kind", ["ego_twist", "c2_spline"])
def test_derivatives_match_finite_differences(kind):
    T = _keyframes()
    m = RigMotion(T, RATE, 0.0, kind)
    _finite_difference_check(m, np.array([0.013, 0.21, 0.333, 0.49]))


def test_spline_interpolates_keyframes_and_is_c2():
    T = _keyframes()
    m = RigMotion(T, RATE, 0.25, "c2_spline")
    t_k = 0.25 + np.arange(len(T)) / RATE
    assert np.allclose(m.T_world_cam(t_k), T, atol=1e-12)
    eps = 1e-9
    left, right = m.kinematics(t_k[1:-1] - eps), m.kinematics(t_k[1:-1] + eps)
    for name in ("p", "v", "a", "R", "R_dot", "R_ddot", "omega_body"):
        assert np.abs(getattr(left, name) - getattr(right, name)).max() < 1e-5, name
    R = m.kinematics(np.linspace(0.2, 1.0, 101)).R
    assert np.allclose(np.einsum("nij,nkj->nik", R, R), np.eye(3), atol=1e-12)


def test_accelerometer_at_rest_reads_gravity_up():
    T = frames.start_pose((0, 1, 0), (0, 0, 0))[None]
    m = RigMotion(np.repeat(T, 3, axis=0), RATE, 0.0, "ego_twist")
    s = imu.ideal_stream(m, np.array([0.0, 0.01]), imu.ImuParams())
    # the camera's y axis points down (OpenCV) = world -Y: up is -y in the body frame
    assert np.allclose(s.accel, [[0, -9.81, 0]] * 2) and np.allclose(s.gyro, 0)


def _integrate(stream, T0, v0, g=9.81):
    """RK4 on (R, p, v) driven by the samples; steps of two sample periods (midpoint = the
    sample between them). An independent integrator: rotation by the exact exponential of
    the RK4 increment of the body rate."""
    t, w, f = stream.t_s, stream.gyro, stream.accel
    gw = np.array([0.0, -g, 0.0])
    R, p, v = T0[:3, :3].copy(), T0[:3, 3].copy(), v0.copy()
    out = [(t[0], R.copy(), p.copy())]
    for i in range(0, len(t) - 2, 2):
        h = t[i + 2] - t[i]

        def deriv(Rc, vc, j):
            return vc, Rc @ f[j] + gw

        def rot(Rc, wj, dt):
            return Rc @ se3.se3_exp(wj * dt, np.zeros(3))[:3, :3]
        # rotation: Magnus/RK-style midpoint estimates
        R_mid = rot(R, (5 * w[i] + 8 * w[i + 1] - w[i + 2]) / 24.0, h)
        R_end = rot(R, (w[i] + 4 * w[i + 1] + w[i + 2]) / 6.0, h)
        k1p, k1v = deriv(R, v, i)
        k2p, k2v = deriv(R_mid, v + k1v * h / 2, i + 1)
        k3p, k3v = deriv(R_mid, v + k2v * h / 2, i + 1)
        k4p, k4v = deriv(R_end, v + k3v * h, i + 2)
        p = p + h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p)
        v = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        R = R_end
        out.append((t[i + 2], R.copy(), p.copy()))
    return out


def test_integrating_the_ideal_stream_recovers_ten_seconds_of_ego_motion():
    step = (0.03, -0.01, 0.12, 1.5, 4.0, -2.0)                   # units/frame, deg/frame
    T = _ego_poses([step] * 200)                                  # 10 s at 20 Hz
    m = RigMotion(T, RATE, 0.0, "ego_twist")
    params = imu.ImuParams(T_cam_imu=tuple(map(tuple, frames.object_pose((0.05, -0.03, 0.02), (10, -20, 30)))))
    stamps = imu.sample_times(0.0, 10.0, params)
    stream = imu.ideal_stream(m, stamps, params)
    T_wi, v_wi, _, _ = imu.imu_state(m, stamps[:1], params)
    track = _integrate(stream, T_wi[0], v_wi[0])
    T_true, _, _, _ = imu.imu_state(m, np.array([x[0] for x in track]), params)
    err = np.linalg.norm(np.array([x[2] for x in track]) - T_true[:, :3, 3], axis=1)
    rot_err = max(np.linalg.norm(se3.se3_log(np.block([[R.T @ Tt[:3, :3], np.zeros((3, 1))],
                                                          [np.zeros((1, 3)), np.ones((1, 1))]]))[0])
                  for (_, R, _), Tt in zip(track, T_true))
    assert stamps[-1] == pytest.approx(10.0) and len(stamps) == 2001
    print("integration error m", err.max(), "rad", rot_err)
    assert err.max() < 1e-3, err.max()                            # <= 1 mm over 10 s
    assert rot_err < 1e-6


@pytest.mark.slow
def test_allan_deviation_of_the_noisy_stream_matches_the_configured_densities():
    params = imu.ImuParams(seed=11)
    n = int(3 * 3600 * params.rate_hz)                            # three hours at rest
    ideal = imu.ImuStream(np.arange(n) / params.rate_hz, np.zeros((n, 3)), np.zeros((n, 3)))
    noisy = imu.add_noise(ideal, params)
    for data, N_true, K_true in ((noisy.gyro, params.gyro_noise, params.gyro_walk),
                                 (noisy.accel, params.accel_noise, params.accel_walk)):
        taus, adev = allan_deviation(data, params.rate_hz, points=60)
        keep = taus <= 3 * 3600 / 10                               # at least 10 clusters
        fits = [fit_noise_densities(taus[keep], adev[keep, c]) for c in range(3)]
        N_est, K_est = np.mean(fits, axis=0)
        print("allan", N_est / N_true, K_est / K_true)
        assert abs(N_est / N_true - 1) < 0.10, (N_est, N_true)
        assert abs(K_est / K_true - 1) < 0.10, (K_est, K_true)


def test_same_seed_same_noise_and_white_noise_scaling():
    params = imu.ImuParams(seed=5)
    ideal = imu.ImuStream(np.arange(1000) / 200.0, np.zeros((1000, 3)), np.zeros((1000, 3)))
    a, b = imu.add_noise(ideal, params), imu.add_noise(ideal, params)
    assert np.array_equal(a.gyro, b.gyro) and np.array_equal(a.accel, b.accel)
    assert not np.array_equal(a.gyro, imu.add_noise(ideal, imu.ImuParams(seed=6)).gyro)
