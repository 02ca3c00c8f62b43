"""``--to tartanair``: the files a TartanAir loader reads, read back with a reader written from
tartanair_tools' README / data_type.md (tests/format_readers.py), against the closed-form
scene of tests/layout_scene.py (exact depth, analytic flow)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from vo_reference.commands.main import main as cli_main
from vo_reference.io.render import RenderSequence

from format_readers import read_tartanair_poses, tartanair_files
from layout_scene import (B, H, K, OBJECTS, STEP_M, W, YAW_DEG, analytic_flow, export_fixture, raycast, rig_poses,
                          write_layout_render)

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 4


exported = export_fixture("tartanair", "P000")


def test_file_names_and_types(layout_render, exported):
    seq = RenderSequence(layout_render)
    for kind, dtype, shape in (("depth_left", np.float32, (H, W)), ("depth_right", np.float32, (H, W)),
                               ("seg_left", np.uint8, (H, W)), ("seg_right", np.uint8, (H, W)),
                               ("flow", np.float32, (H, W, 2)), ("mask", np.uint8, (H, W))):
        files = tartanair_files(exported, kind)
        assert len(files) == (N - 1 if kind in ("flow", "mask") else N), kind
        a = np.load(files[0])
        assert a.dtype == dtype and a.shape == shape, kind
    assert [p.name for p in tartanair_files(exported, "flow")] == [f"{i:06d}_{i + 1:06d}_flow.npy" for i in range(N - 1)]
    for v in ("left", "right"):
        imgs = tartanair_files(exported, f"image_{v}")
        assert [p.name for p in imgs] == [f"{i:06d}_{v}.png" for i in range(N)]
        assert np.array_equal(cv2.imread(str(imgs[2]))[..., ::-1], seq.image_rgb(2, v))
    assert json.loads((exported / "export.json").read_text())["target"] == "tartanair"


def test_depth_metres_and_segmentation(exported):
    T = rig_poses(N)
    for k in (0, 3):
        for v, dx in (("left", 0.0), ("right", B)):
            Tv = T[k].copy()
            Tv[:3, 3] += Tv[:3, :3] @ np.array([dx, 0, 0])
            z, ids = raycast(Tv)
            d = np.load(exported / f"depth_{v}" / f"{k:06d}_{v}_depth.npy")
            sky = ~np.isfinite(z)
            assert sky.any() and (~sky).any()
            assert np.allclose(d[~sky], z[~sky], rtol=1e-6) and np.all(d[sky] == 10000.0)
            seg = np.load(exported / f"seg_{v}" / f"{k:06d}_{v}_seg.npy")
            assert np.array_equal(seg, ids) and set(np.unique(seg)) == {0, 1, 2, 3}
    # TartanAir's own recipe: disparity = fx·B / depth
    d = np.load(exported / "depth_left" / "000001_left_depth.npy")
    assert np.nanmax(K[0, 0] * B / d) > 0


def test_poses_are_ned_as_documented(layout_render, exported):
    """Level rig looking along -Z (north), driving forward and yawing right by YAW_DEG per frame:
    in NED that is +x translation, a pure +yaw about z (down), and z = -height."""
    from scipy.spatial.transform import Rotation
    P = read_tartanair_poses(exported / "pose_left.txt")
    assert P.shape == (N, 4, 4)
    yaw, pitch, roll = Rotation.from_matrix(P[:, :3, :3]).as_euler("ZYX", degrees=True).T
    assert np.allclose(yaw, YAW_DEG * np.arange(N), atol=1e-7)
    assert np.allclose(pitch, 0, atol=1e-7) and np.allclose(roll, 0, atol=1e-7)
    assert np.allclose(P[:, 2, 3], -1.2, atol=1e-9)                       # 1.2 m above the floor: z = -1.2
    steps = np.diff(P[:, :3, 3], axis=0)
    assert np.allclose(np.linalg.norm(steps, axis=1), STEP_M, atol=1e-9)
    heading = np.degrees(np.arctan2(steps[:, 1], steps[:, 0]))           # east of north
    assert np.allclose(heading, YAW_DEG * np.arange(N - 1), atol=1e-7)
    # each camera's NED body axes: x forward = its optical axis, y = its x (right), z = its y (down)
    T = RenderSequence(layout_render).T_world_cam("left")
    A = np.array([[0, 0, -1], [1, 0, 0], [0, -1, 0.0]])                  # north, east, down in SES axes
    for k in range(N):
        assert np.allclose(P[k, :3, 0], A @ T[k, :3, 2], atol=1e-9)
        assert np.allclose(P[k, :3, 1], A @ T[k, :3, 0], atol=1e-9)
        assert np.allclose(P[k, :3, 2], A @ T[k, :3, 1], atol=1e-9)
    # right camera: B metres to the right (east-ish) of the left one, same orientation
    Pr = read_tartanair_poses(exported / "pose_right.txt")
    rel = np.linalg.inv(P[2]) @ Pr[2]
    assert np.allclose(rel[:3, :3], np.eye(3), atol=1e-9) and np.allclose(rel[:3, 3], [0, B, 0], atol=1e-9)
    # DROID-SLAM's loader turns NED back into camera axes with columns [1, 2, 0, 4, 5, 3, 6]
    rows = np.loadtxt(exported / "pose_left.txt")[:, [1, 2, 0, 4, 5, 3, 6]]
    R = Rotation.from_quat(rows[:, 3:]).as_matrix()
    flip = np.diag([1.0, -1.0, -1.0])
    assert np.allclose(R, flip @ T[:, :3, :3], atol=1e-9) and np.allclose(rows[:, :3], T[:, :3, 3] @ flip.T)


def _analytic_flow(k: int):
    T = rig_poses(N)
    return analytic_flow(T[k], T[k + 1])


def test_flow_and_mask_against_the_closed_form_scene(exported):
    for k in range(N - 1):
        f = np.load(exported / "flow" / f"{k:06d}_{k + 1:06d}_flow.npy")
        m = np.load(exported / "flow" / f"{k:06d}_{k + 1:06d}_mask.npy")
        exp, zpt, inside, zmin, zmax = _analytic_flow(k)
        assert set(np.unique(m)) <= {0, 1, 100}
        assert np.abs(f - exp).max() < 1e-3, np.abs(f - exp).max()          # every pixel, sky included
        assert np.array_equal(m == 100, ~inside)
        # hidden: the next frame sees something nearer; check where the 3x3 neighbourhood agrees
        sure_hidden = inside & (zmax < zpt * 0.98)
        sure_visible = inside & (zmin > zpt * 1.02)
        assert np.all(m[sure_hidden] == 1) and np.all(m[sure_visible & np.isfinite(zpt)] == 0)
        assert np.all(m[inside & np.isinf(zpt) & np.isinf(zmin)] == 0)       # sky seen as sky: valid
    # the box hides part of the wall when the rig turns: some pixels are hidden
    masks = [np.load(p) for p in tartanair_files(exported, "mask")]
    assert sum(int((m == 1).sum()) for m in masks) > 0 and sum(int((m == 100).sum()) for m in masks) > 0


def test_options_sequence_slot_and_errors(layout_render, tmp_path, capsys):
    out = tmp_path / "tartan"
    assert cli_main(["export", str(layout_render), str(out), "--to", "tartanair", "--sequence", "office/Easy/P001",
                     "--opt", "background_depth=inf", "-q"]) == 0
    d = np.load(out / "office/Easy/P001/depth_left/000000_left_depth.npy")
    assert np.isinf(d).any() and (out / "office/Easy/P001/export.json").is_file()
    assert cli_main(["export", str(layout_render), str(out), "--to", "tartanair", "--opt", "colour=1", "-q"]) == 2
    assert "unknown option" in capsys.readouterr().err
    big = write_layout_render(tmp_path / "big", n=2, objects=[dict(o, id=o["id"] + 300) for o in OBJECTS])
    assert cli_main(["export", str(big), str(tmp_path / "b"), "--to", "tartanair", "-q"]) == 2
    assert "uint8" in capsys.readouterr().err and not (tmp_path / "b" / "image_left").exists()
