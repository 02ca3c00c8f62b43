"""Lens models against OpenCV (an independent implementation of the same published models)."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.contract import timing
from blender_sesgen.contract.lens import (Lens, fold_problem, opencv_calibration_yaml, robotcar_lut_bytes,
                                        undistortion_maps)

cv2 = pytest.importorskip("cv2")

K = np.array([[458.654, 0, 367.215], [0, 457.296, 248.375], [0, 0, 1.0]])
EUROC_BROWN = (-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0)   # cam0 of EuRoC
KB = (-0.013, 0.021, -0.011, 0.0022)                                       # a typical fisheye (OpenCV)
W, H = 752, 480


def _points(n=500, seed=0, max_angle_deg=40.0):
    rng = np.random.default_rng(seed)
    th = np.radians(rng.uniform(0, max_angle_deg, n))
    ph = rng.uniform(0, 2 * np.pi, n)
    z = rng.uniform(0.5, 10, n)
    return np.stack([np.tan(th) * np.cos(ph) * z, np.tan(th) * np.sin(ph) * z, z], axis=1)


def test_brown_projection_equals_opencv():
    lens = Lens.from_K("brown", (-0.2, 0.05, 0.001, -0.002, 0.01), K)
    X = _points()
    ours = lens.project(X)
    ref, _ = cv2.projectPoints(X, np.zeros(3), np.zeros(3), K, np.array(lens.coeffs))
    assert np.abs(ours - ref[:, 0]).max() < 1e-9


def test_kannala_brandt_projection_equals_opencv_fisheye():
    lens = Lens.from_K("kannala_brandt", KB, K)
    X = _points(max_angle_deg=80.0)
    ours = lens.project(X)
    ref, _ = cv2.fisheye.projectPoints(X[:, None, :], np.zeros(3), np.zeros(3), K, np.array(KB))
    assert np.abs(ours - ref[:, 0]).max() < 1e-8


@pytest.mark.parametrize("model,coeffs", [("brown", EUROC_BROWN), ("kannala_brandt", KB), ("pinhole", ())])
def test_unprojection_inverts_projection(model, coeffs):
    lens = Lens.from_K(model, coeffs, K)
    v, u = np.mgrid[0:H:7, 0:W:7].astype(float)
    px = np.stack([u, v], axis=-1)
    rays = lens.unproject(px)
    assert np.allclose(np.linalg.norm(rays, axis=-1), 1.0)
    assert np.abs(lens.project(rays) - px).max() < 1e-7


def test_brown_unprojection_equals_opencv_undistort_points():
    lens = Lens.from_K("brown", EUROC_BROWN, K)
    px = np.array([[10.0, 12.0], [700.0, 470.0], [367.0, 248.0], [50.0, 400.0]])
    ref = cv2.undistortPointsIter(px[:, None, :], K, np.array(EUROC_BROWN), None, None,
                                  (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15))[:, 0]
    rays = lens.unproject(px)
    assert np.abs(rays[:, :2] / rays[:, 2:] - ref).max() < 1e-7


def test_undistortion_maps_equal_opencv_maps():
    for model, coeffs in (("brown", EUROC_BROWN), ("kannala_brandt", KB)):
        lens = Lens.from_K(model, coeffs, K)
        mx, my = undistortion_maps(lens, W, H)
        if model == "brown":
            rx, ry = cv2.initUndistortRectifyMap(K, np.array(coeffs), None, K, (W, H), cv2.CV_32FC1)
        else:
            rx, ry = cv2.fisheye.initUndistortRectifyMap(K, np.array(coeffs), np.eye(3), K, (W, H), cv2.CV_32FC1)
        assert np.abs(mx - rx).max() < 2e-3 and np.abs(my - ry).max() < 2e-3   # OpenCV maps are float32


def test_lut_has_the_robotcar_layout(tmp_path):
    from vo_reference.camera.undistort import read_lut
    lens = Lens.from_K("brown", EUROC_BROWN, K)
    mx, my = undistortion_maps(lens, W, H)
    p = tmp_path / "lut.bin"
    p.write_bytes(robotcar_lut_bytes(mx, my))
    rx, ry = read_lut(p, W, H)
    assert np.abs(rx - mx).max() < 1e-3 and np.abs(ry - my).max() < 1e-3


@pytest.mark.parametrize("model,coeffs", [("brown", EUROC_BROWN), ("kannala_brandt", KB)])
def test_opencv_reads_the_calibration_file(tmp_path, model, coeffs):
    lens = Lens.from_K(model, coeffs, K)
    p = tmp_path / "calib.yaml"
    p.write_text(opencv_calibration_yaml(lens, W, H, "left"))
    fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_READ)
    assert np.allclose(fs.getNode("camera_matrix").mat(), K)
    d = fs.getNode("distortion_coefficients").mat().ravel()
    assert np.allclose(d, lens.coeffs)
    assert int(fs.getNode("image_width").real()) == W
    assert fs.getNode("distortion_model").string() == ("plumb_bob" if model == "brown" else "equidistant")


def test_fold_check():
    assert fold_problem(Lens.from_K("brown", EUROC_BROWN, K), W, H) is None
    assert fold_problem(Lens.from_K("kannala_brandt", KB, K), W, H) is None
    # strong barrel distortion: r(1 + k1 r^2) peaks at r = 1/sqrt(3 |k1|) before the corners
    msg = fold_problem(Lens.from_K("brown", (-0.9, 0, 0, 0, 0), K), W, H)
    assert msg and "folds" in msg
    msg = fold_problem(Lens.from_K("kannala_brandt", (-0.5, 0, 0, 0), K), W, H)
    assert msg and "folds" in msg
    # a fisheye whose corners lie beyond 90 degrees
    wide = np.array([[120.0, 0, 376], [0, 120, 240], [0, 0, 1]])
    assert "90 degrees" in fold_problem(Lens.from_K("kannala_brandt", (0, 0, 0, 0), wide), W, H)


def test_row_times():
    off = timing.row_offsets_s(480, 0.03)
    assert off[0] == pytest.approx(-0.015 + 0.03 / 960) and off[-1] == pytest.approx(0.015 - 0.03 / 960)
    assert np.allclose(np.diff(off), 0.03 / 480)
    assert timing.row_time_s(1.0, 239.5, 480, 0.03) == pytest.approx(1.0)
    shutter, duration = timing.cycles_shutter(0.01, 0.03, 20.0)
    assert shutter == pytest.approx(0.8) and duration == pytest.approx(0.25)
    assert timing.to_ns(1.0000000004).item() == 1_000_000_000
