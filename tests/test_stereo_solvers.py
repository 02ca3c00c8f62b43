"""The stereo VO solvers against exact synthetic correspondences (independent oracle: projection
of known 3-D points under a known rigid motion, T_k_k1 = exp([omega, v]) as an SES EGO line)."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.errors import VoError
from blender_sesgen.contract.se3 import invert as se3_inverse, se3_exp
from vo_reference.stereo.accurate import estimate_motion
from vo_reference.stereo.motion_field import (T_to_twist, motion_field, motion_field_coefficients,
                                              normal_equations, solve_egomotion, twist_to_T)

F = 389.0
K = np.array([[F, 0, 319.5], [0, F, 239.5], [0, 0, 1.0]])
B = 0.12
# Table 1, frame 1 of the paper: U V W (units) and alpha beta gamma (deg)
PAPER_FRAME1 = np.array([0.020, 0.020, 0.025, np.radians(-0.400), np.radians(0.325), np.radians(0.200)])


def scene_points(n=300, seed=0):
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(-2, 2, n), rng.uniform(-1.5, 1.5, n), rng.uniform(1.5, 6, n)], axis=1)


def project(P):
    return np.stack([K[0, 0] * P[:, 0] / P[:, 2] + K[0, 2], K[1, 1] * P[:, 1] / P[:, 2] + K[1, 2]], axis=1)


def move(P, X):
    """Points of camera k seen from camera k+1 after the motion T_k_k1 = exp(X)."""
    T = se3_inverse(twist_to_T(X))
    return P @ T[:3, :3].T + T[:3, 3]


def paper_inputs(P, X):
    p0, p1 = project(P), project(move(P, X))
    c = K[:2, 2]
    return p0[:, 0] - c[0], p0[:, 1] - c[1], P[:, 2], p1[:, 0] - c[0], p1[:, 1] - c[1]


def test_motion_field_is_the_derivative_of_the_exact_motion():
    """Eq. 2 equals d/dt of the projection under exp(t X) at t = 0 (numerical derivative)."""
    P = scene_points(50)
    X = np.array([0.3, -0.2, 0.5, 0.04, -0.03, 0.02])
    c = K[:2, 2]
    h = 1e-6
    flow = (project(move(P, h * X)) - project(move(P, -h * X))) / (2 * h)
    p0 = project(P) - c
    u, v = motion_field(X, p0[:, 0], p0[:, 1], P[:, 2], F)
    np.testing.assert_allclose(u, flow[:, 0], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(v, flow[:, 1], rtol=1e-6, atol=1e-6)


def test_coefficients_of_eq5():
    a, b = motion_field_coefficients(np.array([10.0]), np.array([-20.0]), np.array([2.0]), F)
    np.testing.assert_allclose(a[0], [-F / 2, 0, 5.0, -200 / F, -(100 / F + F), -20.0])
    np.testing.assert_allclose(b[0], [0, -F / 2, -10.0, 400 / F + F, 200 / F, -10.0])


def test_normal_equations_match_lstsq():
    P = scene_points(40, seed=3)
    x, y, Z, x1, y1 = paper_inputs(P, PAPER_FRAME1)
    H, Kv = normal_equations(x, y, Z, x1, y1, F)
    a, b = motion_field_coefficients(x, y, Z, F)
    A = np.vstack([a, b])
    rhs = np.concatenate([x1 - x, y1 - y])
    np.testing.assert_allclose(np.linalg.solve(H, Kv), np.linalg.lstsq(A, rhs, rcond=None)[0], rtol=1e-8)


@pytest.mark.parametrize("scale", [1e-3, 1e-2, 1e-1])
def test_paper_solver_is_first_order_exact(scale):
    """Small motions are recovered nearly exactly; the error shrinks like the motion squared."""
    X = PAPER_FRAME1 * scale
    Xe = solve_egomotion(*paper_inputs(scene_points(), X), F)
    rel = np.abs(Xe - X).max() / np.abs(X).max()
    assert rel < 0.05 * scale   # first-order model: relative error O(|X|)


def test_paper_solver_at_the_paper_s_motion_size():
    """With exact flow and depth, the first-order model alone errs by ~5e-4 units and ~0.003 deg
    at the paper's motion size: about a tenth of the paper's Table 1 RMSE, not more."""
    Xe = solve_egomotion(*paper_inputs(scene_points(), PAPER_FRAME1), F)
    err = np.abs(Xe - PAPER_FRAME1)
    assert np.all(err[:3] < 1e-3) and np.all(np.degrees(err[3:]) < 5e-3)
    assert np.all(err[:3] > 1e-5)   # ... and it is not exact: the model is linearised


def test_paper_solver_needs_three_points():
    with pytest.raises(VoError):
        solve_egomotion(np.zeros(2), np.zeros(2), np.ones(2), np.zeros(2), np.zeros(2), F)


@pytest.mark.parametrize("X", [PAPER_FRAME1,
                               np.array([0.3, -0.1, 0.8, np.radians(5), np.radians(-8), np.radians(10)]),
                               np.array([-0.5, 0.2, -0.3, np.radians(-15), np.radians(12), np.radians(-20)])])
def test_accurate_solver_is_exact_for_large_motions(X):
    P = scene_points()
    Q = move(P, X)
    T, inl = estimate_motion(P, project(Q), project(Q - [B, 0, 0]), K, B, robust=True)
    assert inl.all()
    np.testing.assert_allclose(T_to_twist(T), X, atol=1e-9 * max(1.0, np.abs(X).max()))


def test_accurate_solver_rejects_outliers():
    rng = np.random.default_rng(5)
    X = np.array([0.1, 0.05, 0.3, np.radians(2), np.radians(-3), np.radians(1)])
    P = scene_points(400)
    Q = move(P, X)
    obs = project(Q)
    bad = rng.choice(len(P), 80, replace=False)
    obs[bad] += rng.uniform(-30, 30, (80, 2))
    T, inl = estimate_motion(P, obs, None, K, B, robust=True)
    assert not inl[bad].any() or inl[bad].mean() < 0.05
    np.testing.assert_allclose(T_to_twist(T), X, atol=1e-8)


def test_accurate_solver_with_noise_is_unbiased():
    rng = np.random.default_rng(7)
    X = PAPER_FRAME1
    P = scene_points(500)
    Q = move(P, X)
    obs_l = project(Q) + rng.normal(0, 0.1, (500, 2))
    obs_r = project(Q - [B, 0, 0]) + rng.normal(0, 0.1, (500, 2))
    T, _ = estimate_motion(P, obs_l, obs_r, K, B)
    err = T_to_twist(T) - X
    assert np.all(np.abs(err[:3]) < 2e-3) and np.all(np.degrees(np.abs(err[3:])) < 0.01)


def test_twist_convention_matches_ego_integration():
    """T(k+1) = T(k) exp([omega, v]); T_to_twist inverts twist_to_T."""
    X = np.array([0.1, -0.2, 0.3, 0.2, -0.1, 0.05])
    np.testing.assert_allclose(T_to_twist(twist_to_T(X)), X, atol=1e-12)
    np.testing.assert_allclose(twist_to_T(X), se3_exp(X[3:], X[:3]), atol=1e-15)
