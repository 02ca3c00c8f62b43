"""Intrinsics <-> Blender camera settings: round trip and the pixel-centre convention."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.contract.camera import (K_from_blender, K_matrix, blender_camera_settings, default_principal_point,
                                            field_of_view_deg)

rng = np.random.default_rng(1)
CASES = [(int(w), int(h), float(f), float(cx), float(cy))
         for w, h, f, cx, cy in zip(rng.integers(16, 4000, 30), rng.integers(16, 3000, 30),
                                    rng.uniform(10, 5000, 30), rng.uniform(-0.2, 1.2, 30), rng.uniform(-0.2, 1.2, 30))]
CASES = [(w, h, f, cx * w, cy * h) for w, h, f, cx, cy in CASES] + [(640, 480, 389.0, 319.5, 239.5)]


@pytest.mark.parametrize("w,h,f,cx,cy", CASES)
def test_round_trip(w, h, f, cx, cy):
    settings = blender_camera_settings(w, h, f, cx, cy, near=0.1, far=100.0)
    np.testing.assert_allclose(K_from_blender(settings), K_matrix(f, cx, cy), rtol=1e-12)
    assert settings.sensor_fit == "HORIZONTAL" and (settings.resolution_x, settings.resolution_y) == (w, h)


def _blender_project(settings, P_blender_cam):
    """Where Blender's view plane puts a camera-space point (Blender axes: looks along -z, y up),
    in OpenCV pixel coordinates. Blender's frame spans [-sensor/2, sensor/2] mm at ``lens`` mm
    (horizontal fit), shifted by shift * sensor; pixel edges run 0..W, so centres are at +0.5."""
    X, Y, Z = P_blender_cam
    x_mm = settings.lens_mm * X / -Z
    y_mm = settings.lens_mm * Y / -Z
    s = settings.sensor_width_mm
    u_edge = settings.resolution_x / 2 + (x_mm / s - settings.shift_x) * settings.resolution_x
    v_edge = settings.resolution_y / 2 - (y_mm / s - settings.shift_y) * settings.resolution_x
    return np.array([u_edge - 0.5, v_edge - 0.5])


@pytest.mark.parametrize("w,h,f,cx,cy", CASES[:10] + CASES[-1:])
def test_pixel_centre_convention(w, h, f, cx, cy):
    settings = blender_camera_settings(w, h, f, cx, cy, near=0.1, far=100.0)
    K = K_matrix(f, cx, cy)
    for P_cv in rng.uniform([-2, -2, 1], [2, 2, 10], size=(5, 3)):
        p = K @ P_cv
        P_blender = P_cv * [1, -1, -1]  # OpenCV camera -> Blender camera axes
        np.testing.assert_allclose(p[:2] / p[2], _blender_project(settings, P_blender), atol=1e-9)


def test_default_principal_point_is_the_image_centre():
    assert default_principal_point(640, 480) == (319.5, 239.5)
    settings = blender_camera_settings(640, 480, 389.0, 319.5, 239.5, 0.1, 100)
    assert settings.shift_x == 0.0 and settings.shift_y == 0.0  # centred: no lens shift


def test_field_of_view():
    fov_h, fov_v = field_of_view_deg(640, 480, 320.0)
    assert np.isclose(fov_h, 90.0) and np.isclose(fov_v, 2 * np.degrees(np.arctan(0.75)))
