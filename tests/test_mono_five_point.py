"""The calibrated 5-point solver (our own Nistér / Stewénius implementation) and its RANSAC."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vo_reference.errors import VoError
from blender_sesgen.contract.se3 import skew
from vo_reference.mono.five_point import (constraint_matrix, essential_residuals, five_point,
                                          five_point_batch, ransac_essential)
from vo_reference.mono.fundamental import sampson_distance
from vo_reference.mono.motion_errors import direction_difference_deg, rotation_difference_deg
from vo_reference.mono.relative_pose import estimate_relative_pose
from vo_reference.mono.triangulation import project, projection_matrix

K = np.array([[700.0, 0.0, 620.0], [0.0, 705.0, 185.0], [0.0, 0.0, 1.0]])
W, H = 1240, 376


def scene(rng, n, forward):
    """Points in front of both cameras, normalised and pixel coordinates, true E (unit norm)."""
    R = Rotation.from_rotvec(rng.normal(0, 0.05 if forward else 0.3, 3)).as_matrix()
    C = np.array([0.1, -0.05, 1.0]) + rng.normal(0, 0.1, 3) if forward else rng.normal(0, 1, 3)
    C = C / np.linalg.norm(C) * rng.uniform(0.5, 1.5)
    t = -R @ C
    X = np.column_stack([rng.uniform(-8, 8, 4 * n), rng.uniform(-3, 3, 4 * n), rng.uniform(4, 40, 4 * n)])
    X = X[X @ R[2] + t[2] > 1.0][:n]
    x1 = project(projection_matrix(K, np.eye(3), np.zeros(3)), X)
    x2 = project(projection_matrix(K, R, t), X)
    Kinv = np.linalg.inv(K)
    q1, q2 = x1 @ Kinv[:2, :2].T + Kinv[:2, 2], x2 @ Kinv[:2, :2].T + Kinv[:2, 2]
    E = skew(t) @ R
    return q1, q2, x1, x2, E / np.linalg.norm(E), R, t


def dist_up_to_sign(A, B):
    return min(np.abs(A - B).max(), np.abs(A + B).max())


@pytest.mark.parametrize("forward", [False, True])
def test_five_point_returns_the_true_E_on_random_scenes(forward):
    rng = np.random.default_rng(11 + forward)
    counts = []
    for _ in range(100):
        q1, q2, *_, E_true, _, _ = scene(rng, 5, forward)
        Es = five_point(q1, q2)
        counts.append(len(Es))
        assert 1 <= len(Es) <= 10
        assert min(dist_up_to_sign(E, E_true) for E in Es) <= 1e-8       # unit norm: relative
        for E in Es:                                                     # every solution is essential
            det, trace_c = essential_residuals(E)
            assert det < 1e-9 and trace_c < 1e-8
            assert np.abs(np.einsum("ni,ij,nj->n", np.c_[q2, np.ones(5)], E, np.c_[q1, np.ones(5)])).max() < 1e-9
    assert np.all(np.array(counts) % 2 == 0)          # real roots of a degree-10 system come in even numbers


def test_five_point_non_minimal_is_exact_on_many_points():
    rng = np.random.default_rng(3)
    q1, q2, *_, E_true, _, _ = scene(rng, 60, True)
    assert min(dist_up_to_sign(E, E_true) for E in five_point(q1, q2)) <= 1e-8


def test_batch_solver_matches_single_calls():
    rng = np.random.default_rng(4)
    samples = [scene(rng, 5, False) for _ in range(8)]
    q1 = np.stack([s[0] for s in samples])
    q2 = np.stack([s[1] for s in samples])
    E, valid = five_point_batch(q1, q2, polish=True)
    Er, valid_r = five_point_batch(q1, q2)                  # RANSAC's: eigenvectors, not polished
    assert np.array_equal(valid, valid_r)
    for b, s in enumerate(samples):
        assert min(dist_up_to_sign(e, s[4]) for e in E[b][valid[b]]) <= 1e-8
        assert min(dist_up_to_sign(e, s[4]) for e in Er[b][valid[b]]) <= 1e-6
        assert valid[b].sum() == len(five_point(s[0], s[1]))


def test_constraint_matrix_vanishes_at_the_solution():
    # E = xX + yY + zZ + W with a known (x, y, z): the ten cubics evaluate to zero there
    rng = np.random.default_rng(5)
    *_, E_true, _, _ = scene(rng, 5, False)
    N = rng.normal(size=(4, 3, 3))
    x, y, z = rng.normal(size=3)
    N[3] = E_true - x * N[0] - y * N[1] - z * N[2]
    from vo_reference.mono.five_point import MONOMIALS
    mono = np.array([x**a * y**b * z**c for a, b, c in MONOMIALS])
    assert np.abs(constraint_matrix(N) @ mono).max() < 1e-10


def test_degenerate_input_raises_a_clear_error():
    rng = np.random.default_rng(6)
    q1, q2, *_ = scene(rng, 5, False)
    with pytest.raises(VoError, match="at least 5"):
        five_point(q1[:4], q2[:4])
    line = np.column_stack([np.linspace(-0.3, 0.3, 5), 0.1 + 0.5 * np.linspace(-0.3, 0.3, 5)])
    with pytest.raises(VoError, match="collinear"):
        five_point(line, q2)
    with pytest.raises(VoError, match="collinear"):
        five_point(q1, line + 0.01)
    with pytest.raises(VoError, match="rank < 5"):                     # a repeated point
        five_point(np.vstack([q1[:4], q1[0]]), np.vstack([q2[:4], q2[0]]))
    with pytest.raises(VoError, match="at least 5"):
        ransac_essential(np.zeros((4, 2)), np.zeros((4, 2)), K)


def test_ransac_5pt_with_outliers_recovers_the_motion():
    rng = np.random.default_rng(7)
    q1, q2, x1, x2, E_true, R, t = scene(rng, 300, True)
    x1 = x1 + rng.normal(0, 0.3, x1.shape)
    x2 = x2 + rng.normal(0, 0.3, x2.shape)
    n_out = 200                                                         # 40 % outliers
    o1 = np.column_stack([rng.uniform(0, W, n_out), rng.uniform(0, H, n_out)])
    o2 = np.column_stack([rng.uniform(0, W, n_out), rng.uniform(0, H, n_out)])
    X1, X2 = np.vstack([x1, o1]), np.vstack([x2, o2])
    truth = np.r_[np.ones(len(x1), bool), np.zeros(n_out, bool)]
    a = ransac_essential(X1, X2, K, threshold_px=1.0, seed=3)
    b = ransac_essential(X1, X2, K, threshold_px=1.0, seed=3)
    assert np.array_equal(a.E, b.E) and np.array_equal(a.inliers, b.inliers)      # seeded
    assert a.inliers[truth].mean() > 0.95 and a.inliers[~truth].mean() < 0.05
    assert dist_up_to_sign(a.E, E_true) < 0.01
    assert np.allclose(np.linalg.svd(a.E, compute_uv=False)[2], 0, atol=1e-9)
    assert a.iterations < 5000
    # exact inliers: the winner fits them to numerical precision
    q1, q2, x1, x2, E_true, R, t = scene(rng, 200, False)
    X1, X2 = np.vstack([x1, o1[:100]]), np.vstack([x2, o2[:100]])
    r = ransac_essential(X1, X2, K, seed=1)
    assert sampson_distance(r.F, x1, x2).max() < 1e-6
    assert dist_up_to_sign(r.E, E_true) < 1e-8
    # and through the whole two-view solver (cheirality, refinement): the true pose
    rel = estimate_relative_pose(X1, X2, K, solver="5pt")
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R.T, -R.T @ t / np.linalg.norm(t)
    assert rotation_difference_deg(rel.T_c1_c2, T) < 1e-5 and direction_difference_deg(rel.T_c1_c2, T) < 1e-4


def test_unknown_solver_and_score_are_errors():
    rng = np.random.default_rng(8)
    _, _, x1, x2, *_ = scene(rng, 50, True)
    with pytest.raises(VoError, match="solver"):
        estimate_relative_pose(x1, x2, K, solver="7pt")
    with pytest.raises(VoError, match="score"):
        estimate_relative_pose(x1, x2, K, select="lmeds")
