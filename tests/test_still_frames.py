"""A still camera's frames hold the path tracer's noise (``TIMING still on``,
render/sensor/still.py): the stretch finding, the reprojection against analytic images and
scipy's splines, and a render whose held frames differ by far less than fresh ones while its
ground truth is byte for byte a render's without it, whatever the frame range."""
from __future__ import annotations

import json

import numpy as np
import pytest

from blender_sesgen.render.sensor import still

K = np.array([[60.0, 0, 39.3], [0, 60.0, 29.6], [0, 0, 1]])
W, H = 80, 60


def _R(axis, deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def _T(R=np.eye(3), c=(0.0, 0.0, 0.0)):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, c
    return T


def test_bspline_interpolation_equals_scipys_cubic_spline():
    """The prefilter and evaluation are scipy.ndimage's order-3 spline with mirror boundaries
    (spline_filter + map_coordinates), an independent implementation."""
    nd = pytest.importorskip("scipy.ndimage")
    rng = np.random.default_rng(3)
    img = rng.random((37, 53))
    assert np.abs(still.bspline_coefficients(img) - nd.spline_filter(img, order=3, mode="mirror")).max() < 1e-12
    y, x = np.mgrid[0:37, 0:53].astype(float)
    x, y = np.clip(x + 0.37 * np.sin(y / 4), 0, 52), np.clip(y - 0.21 * np.cos(x / 3), 0, 36)
    ours = still._evaluate(still.bspline_coefficients(img), still._taps(x, y, img.shape))
    assert np.abs(ours - nd.map_coordinates(img, [y, x], order=3, mode="mirror")).max() < 1e-12



def test_reprojecting_a_frame_wakes_no_blas_threads(monkeypatch):
    """A held frame's reprojection calls no BLAS product (issue 29): a dot of 40 x >= 231
    values is threaded by OpenBLAS, whose threads then spin ~0.1 s for more work (by that
    reckoning the hall's +11 CPU s a stereo frame on 16 cores in session 16's GPU run), and
    the values could depend on the machine's core count. The map of a 480 x 752 image (the
    hall's full size, rows and columns both past OpenBLAS's threshold) with numpy's products
    forbidden, against scipy's cubic spline."""
    nd = pytest.importorskip("scipy.ndimage")
    rng = np.random.default_rng(4)
    img = rng.random((480, 752))
    want = nd.spline_filter(img, order=3, mode="mirror")

    def forbidden(*a, **k):
        raise AssertionError("a BLAS product in the still frames' reprojection")
    for name in ("dot", "tensordot", "inner", "vdot", "einsum", "matmul"):
        monkeypatch.setattr(np, name, forbidden)
    y, x = np.mgrid[0:480, 0:752].astype(float)
    taps = still._taps(np.clip(x + 0.3, 0, 751), np.clip(y - 0.2, 0, 479), img.shape)
    coeffs = still.bspline_coefficients(img)
    still._evaluate(coeffs, taps)
    monkeypatch.undo()
    assert np.abs(coeffs - want).max() < 1e-12

def test_still_stretches_follow_the_centres_the_turns_and_the_world():
    """Frames join their stretch's first frame while every view's centre stays within 0.1 mm
    and its turn moves no image corner by more than 2 px; a moved centre, a large turn or a
    moving world starts a stretch of its own."""
    small = [_T(_R(1, 0.01 * k) @ _R(0, -0.005 * k)) for k in range(5)]
    poses = {"left": np.array(small), "right": np.array([_T(T[:3, :3], T[:3, :3] @ [0.1, 0, 0]) for T in small])}
    # the right camera's centre swings by 0.1 m x 0.01 deg/frame = 17 um a frame: within 0.1 mm
    assert still.still_references(poses, K, W, H) == (0, 0, 0, 0, 0)
    assert still.stretches((0, 0, 0, 0, 0)) == [[0, 4]]
    moved = {v: p.copy() for v, p in poses.items()}
    moved["right"][3, 0, 3] += 0.001                           # one camera's centre moves 1 mm at frame 3
    assert still.still_references(moved, K, W, H) == (0, 0, 0, 3, 4)
    turned = {v: p.copy() for v, p in poses.items()}
    turned["left"][2, :3, :3] = _R(1, 2.0)                     # 2 deg: 2.1 px at the centre, more at the corners
    assert still.still_references(turned, K, W, H) == (0, 0, 2, 3, 3)
    assert still.still_references(poses, K, W, H, world_moves=True) == (0, 1, 2, 3, 4)
    assert still.stretches((0, 0, 2, 3, 3)) == [[0, 1], [3, 4]]


def _plane_image(T_world_cam, wall_z=-3.0):
    """A camera's image of the wall z = wall_z (world; the camera looks down -z with OpenCV axes
    turned by diag(1, -1, -1)) painted with a smooth pattern, and its planar depth: analytic."""
    u, v = np.meshgrid((np.arange(W) - K[0, 2]) / K[0, 0], (np.arange(H) - K[1, 2]) / K[1, 1])
    rays = np.stack([u, v, np.ones((H, W))], axis=-1)
    R, c = T_world_cam[:3, :3], T_world_cam[:3, 3]
    d = rays @ R.T                                             # world directions
    s = (wall_z - c[2]) / d[..., 2]                            # along the ray (z = 1 in the camera)
    X = c + s[..., None] * d
    img = 0.5 + 0.2 * np.sin(X[..., 0] * 5.0) * np.cos(X[..., 1] * 4.0) + 0.1 * np.sin(X[..., 0] * 13 + X[..., 1] * 7)
    return img, s


def test_reprojection_of_a_wall_equals_its_analytic_image():
    """Frame r's image of a painted wall, reprojected to a camera turned by 0.3 deg about two
    axes whose centre moved 0.08 mm, equals that camera's analytic image (within the spline's
    interpolation error, far below the change the turn makes); the turn's transpose fails."""
    down = np.diag([1.0, -1.0, -1.0])                          # OpenCV camera looking down -z
    turn = _R(1, 0.3) @ _R(0, -0.2)
    T_r = _T(down, (0.1, 0.4, 0.0))
    T_k = _T(turn @ down, (0.1 + 8e-5, 0.4, 0.0))
    img_r, _ = _plane_image(T_r)
    img_k, depth_k = _plane_image(T_k)
    out = still.reproject({"Y": img_r}, depth_k.astype(np.float32), K, T_r, T_k)["Y"]
    inner = (slice(4, -4), slice(4, -4))
    err = np.abs(out - img_k)[inner].max()
    assert err < 2e-3, err
    assert np.abs(img_r - img_k)[inner].max() > 0.05           # the turn moves the image by ~0.3 px
    T_wrong = _T(turn.T @ down, T_k[:3, 3])                    # the turn the other way
    wrong = still.reproject({"Y": img_r}, depth_k.astype(np.float32), K, T_r, T_wrong)["Y"]
    assert np.abs(wrong - img_k)[inner].max() > 10 * err


SCENE = """CAMERA resolution 64 48 focal 44 principal 31.7 23.4 baseline 0.1 near 0.05 far 100
QUAD id 1 texture 4 vertices -3 0 -4  3 0 -4  3 0 4  -3 0 4
QUAD id 2 texture 3 vertices -3 0 -4  -3 3 -4  3 3 -4  3 0 -4
CUBOID id 4 texture 2 position 0.6 0.55 -1.2 25 40 -15 dim 0.7 0.5 0.9
SPHERE id 6 texture 9 position 0.9 1.35 -2.2 dim 0.4
TIMING rate 20 exposure 0.01 {still}
SENSOR seed 1
AUTOEXPOSURE speed 20
RENDER samples 4 denoise off
POSE 0.2 1.3 3.0 -10 6 3
POSE 0.2 1.3 3.0 -10.02 6.01 3
POSE 0.2 1.3 3.0 -10.04 6.02 3.01
"""


def test_a_still_camera_holds_its_noise_and_keeps_its_ground_truth(tmp_path):
    """Three frames of a stereo rig turning by hundredths of a degree about its left camera: with ``still on`` frames 1-2
    show frame 0's beauty reprojected through their own depth to their own poses (the manifest
    says so; drawn with frame 0's exposure, so bit for bit frame 0's beauty reprojected while the
    auto-exposure moves), so consecutive beauties differ by a small fraction of what fresh
    renders do; depth and ids are byte for byte those of a render
    with ``still off``; frames 1:3 rendered alone equal the whole render's (the reference is
    drawn again, with its own seed)."""
    pytest.importorskip("bpy")
    from render_support import render_here, read_exr
    for name, flag in (("on", "still on"), ("off", "still off")):
        (tmp_path / f"{name}.ses").write_text(SCENE.format(still=flag))
        render_here(tmp_path / f"{name}.ses", tmp_path / name, "--quiet")
    render_here(tmp_path / "on.ses", tmp_path / "part", "--frames", "1:3", "--quiet")
    assert json.loads((tmp_path / "on" / "manifest.json").read_text())["timing"]["still_frames"] == [[0, 2]]
    assert json.loads((tmp_path / "off" / "manifest.json").read_text())["timing"]["still_frames"] is None
    exr = {(n, k): read_exr(tmp_path / n / "exr" / "left" / f"{k:06d}.exr") for n in ("on", "off") for k in range(3)}
    beauty = [c for c in exr["on", 0] if ".Combined." in c and not c.endswith(".A")]
    for k in range(3):
        for c, a in exr["on", k].items():
            if ".Combined." not in c and "Noisy" not in c:
                assert np.array_equal(a, exr["off", k][c]), (k, c)
    assert all(np.array_equal(exr["on", 0][c], exr["off", 0][c]) for c in beauty)

    from blender_sesgen.render.plan import RenderPlan
    sensor = RenderPlan.from_file(tmp_path / "on.ses").sensor
    T = sensor.camera_poses("left", np.arange(3.0))
    depth = next(c for c in exr["on", 2] if c.endswith(".Depth.Z") or c.endswith("Depth.V"))
    held = still.reproject({c: exr["on", 0][c] for c in beauty}, exr["on", 2][depth], sensor.K, T[0], T[2])
    assert all(np.array_equal(held[c], exr["on", 2][c]) for c in beauty)
    assert not all(np.array_equal(exr["on", 0][c], exr["on", 2][c]) for c in beauty)   # it moved

    def step(name, k):
        return np.mean([np.abs(exr[name, k][c] - exr[name, k - 1][c]).mean() for c in beauty])
    for k in (1, 2):
        assert step("on", k) < 0.25 * step("off", k), (k, step("on", k), step("off", k))
    for k in (1, 2):
        for sub in (f"exr/left/{k:06d}.exr", f"exr/right/{k:06d}.exr", f"sensor/left/raw/{k:06d}.png"):
            assert (tmp_path / "part" / sub).read_bytes() == (tmp_path / "on" / sub).read_bytes(), sub


def test_the_command_line_overrides_the_scripts_still(tmp_path):
    """``--still`` / ``--no-still`` replace the script's ``TIMING still``: a render with the flag is byte for
    byte (every EXR, the manifest's still stretches) the render of the script that says it."""
    pytest.importorskip("bpy")
    from render_support import render_here
    for name, flag in (("on", "still on"), ("off", "still off")):
        (tmp_path / f"{name}.ses").write_text(SCENE.format(still=flag))
    for out, script, args in (("on", "on", ()), ("off", "off", ()), ("cli_on", "off", ("--still",)),
                              ("cli_off", "on", ("--no-still",))):
        render_here(tmp_path / f"{script}.ses", tmp_path / out, *args, "--quiet")
    for cli, script in (("cli_on", "on"), ("cli_off", "off")):
        stretches = [json.loads((tmp_path / n / "manifest.json").read_text())["timing"]["still_frames"]
                     for n in (cli, script)]
        assert stretches[0] == stretches[1] == ([[0, 2]] if script == "on" else None), (cli, stretches)
        for k in range(3):
            for view in ("left", "right"):
                sub = f"exr/{view}/{k:06d}.exr"
                assert (tmp_path / cli / sub).read_bytes() == (tmp_path / script / sub).read_bytes(), (cli, sub)
    held, fresh = ((tmp_path / n / "exr/left/000002.exr").read_bytes() for n in ("on", "off"))
    assert held != fresh
