"""Pose math against independent computations (scipy, matrix exponential, hand geometry)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from blender_sesgen.contract.frames import (blender_to_cv_camera, blender_to_ses_world, camera_matrix_world,
                                            cv_to_blender_camera, ses_to_blender_world, start_pose)
from blender_sesgen.contract.rig import right_from_left
from blender_sesgen.contract.motion import ego_from_poses, ego_step, integrate_ego
from blender_sesgen.contract.se3 import R_to_euler_xyz_deg, euler_xyz_deg_to_R, invert, se3_exp, skew
from blender_sesgen.ses import parse_string

rng = np.random.default_rng(0)
RANDOM_ANGLES = rng.uniform(-180, 180, size=(50, 3))
RANDOM_STEPS = np.hstack([rng.uniform(-0.5, 0.5, (50, 3)), rng.uniform(-20, 20, (50, 3))])


@pytest.mark.parametrize("angles", RANDOM_ANGLES[:20])
def test_euler_matches_scipy_extrinsic_xyz(angles):
    # X then Y then Z about the fixed world axes = scipy's lower-case (extrinsic) "xyz"
    expected = Rotation.from_euler("xyz", angles, degrees=True).as_matrix()
    np.testing.assert_allclose(euler_xyz_deg_to_R(*angles), expected, atol=1e-12)


def test_euler_round_trip():
    for angles in RANDOM_ANGLES:
        R = euler_xyz_deg_to_R(*angles)
        np.testing.assert_allclose(euler_xyz_deg_to_R(*R_to_euler_xyz_deg(R)), R, atol=1e-9)


def _twist_matrix(omega, v):
    X = np.zeros((4, 4))
    X[:3, :3] = skew(omega)
    X[:3, 3] = v
    return X


@pytest.mark.parametrize("step", RANDOM_STEPS[:20])
def test_se3_exp_matches_matrix_exponential(step):
    omega = np.radians(step[3:])
    np.testing.assert_allclose(se3_exp(omega, step[:3]), expm(_twist_matrix(omega, step[:3])), atol=1e-12)


def test_se3_exp_tiny_rotation_branch():
    omega = np.array([1e-10, -2e-10, 3e-10])
    np.testing.assert_allclose(se3_exp(omega, [1, 2, 3]), expm(_twist_matrix(omega, [1, 2, 3])), atol=1e-15)


def _subdivided(step, S):
    """SESGen's scheme: S in-between steps, each a rotation by omega/S then a move by v/S."""
    T = np.eye(4)
    small = np.eye(4)
    small[:3, :3] = Rotation.from_rotvec(np.radians(step[3:]) / S).as_matrix()
    small[:3, 3] = np.asarray(step[:3]) / S
    for _ in range(S):
        T = T @ small
    return T


def test_ego_step_is_the_limit_of_sesgen_subdivision():
    step = (0.3, -0.2, 0.5, 12.0, -7.0, 20.0)
    exact = ego_step(*step)
    errors = [np.abs(_subdivided(step, S) - exact).max() for S in (4, 16, 64, 256, 1024)]
    assert all(b < a for a, b in zip(errors, errors[1:]))   # converges monotonically
    assert errors[-1] < 1e-4 and errors[0] / errors[-1] > 100  # first-order: error ~ 1/S


def test_ego_axes_and_signs_in_the_camera_frame():
    # alpha about camera x (right), beta about y (down), gamma about z (forward): right-hand rule
    for axis in range(3):
        angles = np.zeros(3)
        angles[axis] = 30.0
        T = ego_step(0, 0, 0, *angles)
        expected = Rotation.from_rotvec(np.radians(angles)).as_matrix()
        np.testing.assert_allclose(T[:3, :3], expected, atol=1e-12)
    np.testing.assert_allclose(ego_step(1, 2, 3, 0, 0, 0)[:3, 3], [1, 2, 3])


def test_ego_round_trip_through_poses():
    T0 = start_pose((1, 2, 3), (10, -20, 30))
    T = integrate_ego(T0, RANDOM_STEPS)
    assert T.shape == (51, 4, 4)
    recovered = np.array([ego_from_poses(T[k], T[k + 1]) for k in range(50)])
    np.testing.assert_allclose(recovered, RANDOM_STEPS, atol=1e-9)


def test_integration_is_right_multiplication_in_the_body_frame():
    # 90 deg about camera y (which points down) turns the view right, from world -Z to world +X:
    # camera z after the turn = R_start @ Ry(90) @ e_z = diag(1,-1,-1) @ (1, 0, 0) = (1, 0, 0);
    # the next forward step follows the new heading.
    T = parse_string("CUBOID id 1 position 0 0 0 dim 1 1 1\nEGO 0 0 0 0 90 0\nEGO 0 0 1 0 0 0\n").timeline.left()
    np.testing.assert_allclose(T[2][:3, 3], [1.0, 0.0, 0.0], atol=1e-12)


def test_start_convention_no_rotation_looks_along_minus_z_with_y_up():
    T = start_pose((0, 0, 0))
    x_cam, y_cam, z_cam = T[:3, 0], T[:3, 1], T[:3, 2]
    np.testing.assert_allclose(z_cam, [0, 0, -1])   # optical axis
    np.testing.assert_allclose(-y_cam, [0, 1, 0])   # image "up" (-y in OpenCV) is world +Y
    np.testing.assert_allclose(x_cam, [1, 0, 0])    # image right is world +X
    # a point 5 units ahead lands on the principal point; one above it lands above (smaller v)
    K = np.array([[389.0, 0, 319.5], [0, 389.0, 239.5], [0, 0, 1]])
    for P_world, v_cmp in (([0, 0, -5], 0), ([0, 1, -5], -1)):
        p = K @ (invert(T) @ [*P_world, 1])[:3]
        assert np.sign(p[1] / p[2] - 239.5) == v_cmp and np.isclose(p[0] / p[2], 319.5)


def test_start_rotation_follows_object_euler_rule():
    T = start_pose((1, 2, 3), (0, 90, 0))
    np.testing.assert_allclose(T[:3, 2], [-1, 0, 0], atol=1e-12)  # turned left: looks along -X
    R = Rotation.from_euler("xyz", [10, 20, 30], degrees=True).as_matrix() @ np.diag([1, -1, -1])
    np.testing.assert_allclose(start_pose((0, 0, 0), (10, 20, 30))[:3, :3], R, atol=1e-12)


def test_right_camera_is_left_translated_along_its_x():
    T_left = start_pose((1, 2, 3), (0, 90, 0))
    T_right = right_from_left(T_left, 0.12)
    np.testing.assert_allclose(T_right[:3, :3], T_left[:3, :3])
    np.testing.assert_allclose(T_right[:3, 3], np.array([1, 2, 3]) + 0.12 * T_left[:3, 0])
    scene = parse_string("CUBOID id 1 position 0 0 0 dim 1 1 1\nCAMERA resolution 64 48 focal 40 baseline 0.3\n"
                         "EGO 0.1 0 0.2 5 10 15\n")
    right = scene.timeline.right(scene.rig.baseline)
    for k, T in enumerate(scene.timeline.left()):
        np.testing.assert_allclose(right[k], right_from_left(T, 0.3), atol=1e-12)
    # a world point in the right camera sits B to the left of where the left camera has it
    P = np.array([0.3, -0.2, -4.0, 1.0])
    p_left = invert(scene.timeline.left()[0]) @ P
    p_right = invert(right[0]) @ P
    np.testing.assert_allclose(p_right[:3], p_left[:3] - [0.3, 0, 0], atol=1e-12)


def test_ses_to_blender_world_is_y_up_to_z_up():
    T = np.eye(4)
    T[:3, 3] = (1, 2, 3)  # SES: 2 up, 3 toward the viewer
    np.testing.assert_allclose(ses_to_blender_world(T)[:3, 3], [1, -3, 2])
    np.testing.assert_allclose(blender_to_ses_world(ses_to_blender_world(T)), T)


def test_blender_camera_of_start_default_is_the_standard_camera():
    # SES -Z (ahead) is Blender +Y; SES +Y (up) is Blender +Z: a Blender camera with Euler (90, 0, 0)
    M = camera_matrix_world(start_pose((0, 0, 0)))
    expected = Rotation.from_euler("xyz", [90, 0, 0], degrees=True).as_matrix()
    np.testing.assert_allclose(M[:3, :3], expected, atol=1e-12)
    np.testing.assert_allclose(-M[:3, 2], [0, 1, 0], atol=1e-12)  # a Blender camera looks along its -z
    np.testing.assert_allclose(blender_to_cv_camera(cv_to_blender_camera(M)), M)
