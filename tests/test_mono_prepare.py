"""Data preparation of the mono VO: Bayer demosaic, LUT / coefficient undistortion,
camera model files, masks, image-folder reading."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.errors import VoError
from vo_reference.camera.bayer import PATTERNS, demosaic, mosaic, opencv_code
from vo_reference.camera.camera_model import read_camera_model, write_camera_model
from vo_reference.mono.prepare import Preparation, build_mask
from vo_reference.camera.undistort import (distort_image, distort_normalised, distortion_maps,
                                         lut_from_distortion, read_lut, remap,
                                         undistort_normalised, write_lut)

cv2 = pytest.importorskip("cv2")


def hand_mosaic(rgb, pattern):
    """Independent oracle: sample the channel named by each letter of the 2x2 cell."""
    ch = {"r": 0, "g": 1, "b": 2}
    out = np.zeros(rgb.shape[:2], rgb.dtype)
    H, W = out.shape
    for y in range(H):
        for x in range(W):
            out[y, x] = rgb[y, x, ch[pattern[2 * (y % 2) + (x % 2)]]]
    return out


def test_opencv_codes_follow_the_second_row():
    # OpenCV names Bayer codes by row 1, columns 1-2: GBRG -> GR, RGGB -> BG (README, cv docs)
    assert opencv_code("gbrg") == cv2.COLOR_BayerGR2RGB
    assert opencv_code("rggb") == cv2.COLOR_BayerBG2RGB
    assert opencv_code("grbg") == cv2.COLOR_BayerGB2RGB
    assert opencv_code("bggr") == cv2.COLOR_BayerRG2RGB
    with pytest.raises(VoError):
        opencv_code("rgbg")


@pytest.mark.parametrize("pattern", PATTERNS)
def test_demosaic_of_a_constant_colour_mosaic_is_exact(pattern):
    rgb = np.empty((24, 32, 3), np.uint8)
    rgb[:] = (200, 90, 30)
    raw = hand_mosaic(rgb, pattern)
    assert np.array_equal(mosaic(rgb, pattern), raw)
    assert np.array_equal(demosaic(raw, pattern), rgb)
    # the wrong pattern does not give the colour back (so the test can fail)
    wrong = {"gbrg": "grbg", "grbg": "gbrg", "rggb": "bggr", "bggr": "rggb"}[pattern]
    assert not np.array_equal(demosaic(raw, wrong), rgb)


@pytest.mark.parametrize("pattern", PATTERNS)
def test_demosaic_of_blocks_and_ramps(pattern):
    # colour constant per 8x8 block: exact away from the block edges (bilinear needs a 1-px ring)
    rng = np.random.default_rng(0)
    blocks = rng.integers(0, 256, (6, 8, 3)).astype(np.uint8)
    rgb = np.kron(blocks, np.ones((8, 8, 1), np.uint8))
    out = demosaic(hand_mosaic(rgb, pattern), pattern)
    inner = np.zeros(rgb.shape[:2], bool)
    for by in range(6):
        for bx in range(8):
            inner[by * 8 + 2: by * 8 + 6, bx * 8 + 2: bx * 8 + 6] = True
    inner[:2] = inner[-2:] = False
    inner[:, :2] = inner[:, -2:] = False
    assert np.array_equal(out[inner], rgb[inner])
    # a smooth linear ramp is reproduced by bilinear interpolation within rounding
    y, x = np.mgrid[0:40, 0:48]
    ramp = np.stack([40 + 3 * x, 30 + 4 * y, 200 - 2 * x - y], -1).astype(np.uint8)
    out = demosaic(hand_mosaic(ramp, pattern), pattern).astype(int)
    assert np.abs(out[2:-2, 2:-2] - ramp[2:-2, 2:-2]).max() <= 1


def test_lut_roundtrip_in_the_robotcar_layout(tmp_path):
    W, H = 7, 5
    mx = np.arange(W * H, dtype=float).reshape(H, W) + 0.25
    my = -np.arange(W * H, dtype=float).reshape(H, W)
    write_lut(tmp_path / "lut.bin", mx, my)
    raw = np.fromfile(tmp_path / "lut.bin", dtype="<f8")
    # float64, all u (row-major) then all v
    assert raw.size == 2 * W * H and raw[0] == 0.25 and raw[W] == W + 0.25 and raw[W * H + 1] == -1
    rx, ry = read_lut(tmp_path / "lut.bin", W, H)
    assert np.array_equal(rx, mx.astype(np.float32)) and np.array_equal(ry, my.astype(np.float32))
    with pytest.raises(VoError):
        read_lut(tmp_path / "lut.bin", W + 1, H)


K = np.array([[300.0, 0.0, 159.5], [0.0, 300.0, 119.5], [0.0, 0.0, 1.0]])
DIST = (-0.28, 0.09, 0.0012, -0.0008, -0.01)


def test_distortion_model_matches_opencv():
    # our Brown-Conrady against cv2.projectPoints (independent implementation)
    rng = np.random.default_rng(1)
    xn = rng.uniform(-0.5, 0.5, (200, 2))
    ours = distort_normalised(xn, DIST)
    cvp, _ = cv2.projectPoints(np.column_stack([xn, np.ones(200)]), np.zeros(3), np.zeros(3), np.eye(3), np.array(DIST))
    assert np.abs(ours - cvp.reshape(-1, 2)).max() < 1e-12
    assert np.abs(undistort_normalised(ours, DIST) - xn).max() < 1e-9
    # the maps equal OpenCV's own undistortion maps
    mx, my = lut_from_distortion(K, DIST, 320, 240)
    cx, cy = cv2.initUndistortRectifyMap(K, np.array(DIST), None, K, (320, 240), cv2.CV_32FC1)
    assert max(np.abs(mx - cx).max(), np.abs(my - cy).max()) < 1e-3


def smooth_image(W=320, H=240):
    y, x = np.mgrid[0:H, 0:W].astype(float)
    img = 128 + 60 * np.sin(x / 9.0) * np.cos(y / 11.0) + 40 * np.sin((x + 2 * y) / 23.0)
    return np.clip(img, 0, 255).astype(np.float32)


def test_lut_undistortion_of_a_distorted_image_gives_the_original(tmp_path):
    W, H = 320, 240
    ideal = smooth_image(W, H)
    distorted = distort_image(ideal, K, DIST)
    mx, my = lut_from_distortion(K, DIST, W, H)
    write_lut(tmp_path / "cam_distortion_lut.bin", mx, my)
    restored = remap(distorted, *read_lut(tmp_path / "cam_distortion_lut.bin", W, H))
    # compare where both resamplings stayed inside the image (away from the border)
    valid = np.zeros((H, W), bool)
    valid[30:-30, 40:-40] = True
    err = np.abs(restored - ideal)[valid]
    assert err.max() < 2.0 and err.mean() < 0.3                   # two bilinear resamplings
    # without undistortion the images differ a lot (the test can fail)
    assert np.abs(distorted - ideal)[valid].mean() > 5
    # the inverse maps really invert: distorted pixel of an undistorted one maps back
    ix, iy = distortion_maps(K, DIST, W, H)
    back_x = cv2.remap(ix, mx, my, cv2.INTER_LINEAR)
    assert np.abs(back_x - np.arange(W)[None, :])[valid].max() < 0.05


def test_camera_model_file_roundtrip(tmp_path):
    write_camera_model(tmp_path / "cam.txt", K)
    m = read_camera_model(tmp_path / "cam.txt")
    assert np.allclose(m.K, K) and np.allclose(m.G_camera_image, np.eye(4))
    (tmp_path / "bad.txt").write_text("1 2 3\n")
    with pytest.raises(VoError):
        read_camera_model(tmp_path / "bad.txt")


def test_robotcar_model_file(shared_data):
    m = read_camera_model(shared_data / "robotcar/models/stereo_wide_left.txt")
    assert (m.fx, m.fy, m.cx, m.cy) == (983.044006, 983.044006, 643.646973, 493.378998)
    # G_camera_image permutes axes: image z (forward) is camera x
    assert np.allclose(np.abs(m.G_camera_image[:3, :3]).sum(axis=0), 1)


def test_mask_and_preparation():
    mask = build_mask(100, 80, bottom=0.25, rects=[(0, 0, 10, 80)])
    assert mask.shape == (80, 100) and mask.dtype == np.uint8
    assert (mask[60:] == 0).all() and (mask[:60, 10:] == 255).all() and (mask[:, :10] == 0).all()
    assert build_mask(100, 80) is None
    rgb = np.zeros((8, 8, 3), np.uint8)
    rgb[..., 1] = 100
    g = Preparation(bayer="gbrg").gray(mosaic(rgb, "gbrg"))
    assert g.shape == (8, 8) and g.dtype == np.uint8 and abs(int(g[4, 4]) - 59) <= 1  # 0.587*100
    with pytest.raises(VoError):
        Preparation(equalize="foo").gray(rgb)


def test_robotcar_demosaic_colours_are_plausible(shared_data):
    """RobotCar stereo is GBRG. The sky is saturated (255) in these frames, so the
    check uses what is not: a red car is red, the hedge is green, and foliage reflects more
    red than blue relative to the neutral-grey asphalt (the camera's cast cancels in the
    ratio). Every other pattern fails at least one of these."""
    path = shared_data / "robotcar/stereo_centre_bayer/1399381446267196.png"
    raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert raw.shape == (960, 1280) and raw.dtype == np.uint8

    def checks(rgb):
        m = lambda r: rgb[r].reshape(-1, 3).astype(float).mean(axis=0)  # noqa: E731
        car = m(np.s_[438:452, 712:730])
        hedge = m(np.s_[280:420, 40:350])
        road = m(np.s_[600:750, 500:800])
        return (car[0] > 1.3 * car[1] and car[0] > car[2],
                hedge[1] > hedge[0] and hedge[1] > hedge[2],
                (hedge[0] / hedge[2]) > (road[0] / road[2]))
    assert all(checks(demosaic(raw, "gbrg")))
    for wrong in ("grbg", "rggb", "bggr"):
        assert not all(checks(demosaic(raw, wrong))), wrong
