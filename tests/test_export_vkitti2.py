"""``--to vkitti2``: Virtual KITTI 2's files read back with the decoding of its README
(tests/format_readers.py) against the closed-form scene of tests/layout_scene.py."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.cli import main as cli_main
from vo_reference.io.render import RenderSequence

from format_readers import read_vkitti_colors, read_vkitti_depth_m, read_vkitti_png_flow, read_vkitti_table
from layout_scene import B, H, K, OBJECTS, W, export_layout, raycast, view_pose, write_layout_render

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 4
FLIP = np.diag([1.0, -1.0, -1.0, 1.0])   # vKITTI's world: y down


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    objects = [dict(o) for o in OBJECTS]
    # the box carries a pose (as moving objects will): origin at its face centre, turned 30 deg
    a = np.radians(30.0)
    T_box = np.eye(4)
    T_box[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
    T_box[:3, 3] = [0.0, 0.5, -3.0]
    objects[2]["T_world_obj"] = T_box.tolist()
    objects[2]["dim"] = [1.2, 1.0, 0.5]
    return write_layout_render(tmp_path_factory.mktemp("vk") / "r", n=N, objects=objects)


@pytest.fixture(scope="module")
def exported(render, tmp_path_factory):
    out = tmp_path_factory.mktemp("vk_out") / "Scene01" / "clone"
    return export_layout(render, out, "vkitti2")


def test_layout_names_and_images(render, exported):
    fr = exported / "frames"
    for c in (0, 1):
        cam = f"Camera_{c}"
        assert sorted(p.name for p in (fr / "rgb" / cam).iterdir()) == [f"rgb_{i:05d}.jpg" for i in range(N)]
        assert sorted(p.name for p in (fr / "forwardFlow" / cam).iterdir()) == [f"flow_{i:05d}.png" for i in range(N - 1)]
        assert sorted(p.name for p in (fr / "backwardFlow" / cam).iterdir()) == \
            [f"backwardFlow_{i:05d}.png" for i in range(1, N)]
        for kind, prefix in (("depth", "depth"), ("classSegmentation", "classgt"), ("instanceSegmentation", "instancegt")):
            assert sorted(p.name for p in (fr / kind / cam).iterdir()) == [f"{prefix}_{i:05d}.png" for i in range(N)]
    seq = RenderSequence(render)
    jpg = cv2.imread(str(fr / "rgb/Camera_1/rgb_00002.jpg"))[..., ::-1].astype(float)
    assert np.abs(jpg - seq.image_rgb(2, "right")).mean() < 4.0          # JPEG, as vKITTI 2 ships it


def test_depth_centimetres(exported):
    for k, view, c in ((0, "left", 0), (3, "right", 1)):
        z, _ = raycast(view_pose(N, k, view))
        d = read_vkitti_depth_m(exported / f"frames/depth/Camera_{c}/depth_{k:05d}.png")
        sky = ~np.isfinite(z)
        assert np.abs(d[~sky] - z[~sky]).max() <= 0.005 + 1e-9 and np.all(d[sky] == 655.35)


def test_class_and_instance_segmentation(exported):
    colours = read_vkitti_colors(exported / "colors.txt")
    assert len(colours) == 15 and colours[(90, 200, 255)] == "Sky"
    _, ids = raycast(view_pose(N, 1, "left"))
    cls = cv2.imread(str(exported / "frames/classSegmentation/Camera_0/classgt_00001.png"))[..., ::-1]
    names = np.array([[colours[tuple(int(x) for x in px)] for px in row] for row in cls])
    expected = {0: "Sky", 1: "Road", 2: "Building", 3: "Undefined"}     # floor: road, wall: building, box: none
    for oid, name in expected.items():
        assert (ids == oid).any() and np.all(names[ids == oid] == name), oid
    inst = cv2.imread(str(exported / "frames/instanceSegmentation/Camera_0/instancegt_00001.png"), cv2.IMREAD_UNCHANGED)
    assert inst.dtype == np.uint8 and np.array_equal(inst, ids)      # trackID + 1 = object id, 0 = none


def _expected_flow(k_src, k_tgt, view):
    Ts, Tt = view_pose(N, k_src, view), view_pose(N, k_tgt, view)
    z, _ = raycast(Ts)
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    r = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1)
    X = Ts[:3, 3] + (r * np.where(np.isfinite(z), z, 0)[..., None]) @ Ts[:3, :3].T
    Xt = (X - Tt[:3, 3]) @ Tt[:3, :3]
    p = Xt @ K.T
    return np.stack([p[..., 0] / p[..., 2] - u, p[..., 1] / p[..., 2] - v], -1), np.isfinite(z)


def test_forward_and_backward_flow_16_bit(exported):
    step = np.array([(W - 1), (H - 1)]) / (2 ** 16 - 1)                 # one code step in pixels
    for kind, name, k, kt in (("forwardFlow", "flow", 0, 1), ("backwardFlow", "backwardFlow", 2, 1),
                              ("forwardFlow", "flow", 2, 3)):
        for c, view in ((0, "left"), (1, "right")):
            flow, invalid = read_vkitti_png_flow(exported / f"frames/{kind}/Camera_{c}/{name}_{k:05d}.png")
            exp, surface = _expected_flow(k, kt, view)
            assert np.array_equal(invalid, ~surface)                      # sky: invalid, as in vKITTI 2
            err = np.abs(flow - exp)[surface]
            assert np.all(err <= step + 1e-5), err.max()


def test_intrinsic_extrinsic_and_pose_tables(exported, render):
    hdr, intr = read_vkitti_table(exported / "intrinsic.txt")
    assert hdr == ["frame", "cameraID", "K[0,0]", "K[1,1]", "K[0,2]", "K[1,2]"]
    assert intr.shape == (2 * N, 6) and np.array_equal(intr[:, :2], [[i, c] for i in range(N) for c in (0, 1)])
    assert np.allclose(intr[:, 2:], [K[0, 0], K[1, 1], K[0, 2], K[1, 2]])
    hdr, extr = read_vkitti_table(exported / "extrinsic.txt")
    assert hdr[:3] == ["frame", "cameraID", "r1,1"] and hdr[-4:] == ["0", "0", "0", "1"] and extr.shape == (2 * N, 18)
    for (i, c), row in zip(extr[:, :2].astype(int), extr):
        w2c = row[2:].reshape(4, 4)
        T = view_pose(N, i, "right" if c else "left")
        assert np.allclose(np.linalg.inv(w2c), FLIP @ T, atol=1e-7)       # world -> camera, y-down world
    # the baseline from the two extrinsics, as vKITTI users compute it
    c0, c1 = np.linalg.inv(extr[0, 2:].reshape(4, 4)), np.linalg.inv(extr[1, 2:].reshape(4, 4))
    assert np.linalg.norm(c1[:3, 3] - c0[:3, 3]) == pytest.approx(B)
    hdr, pose = read_vkitti_table(exported / "pose.txt")
    assert hdr[:7] == ["frame", "cameraID", "trackID", "alpha", "width", "height", "length"] and len(hdr) == 19
    assert pose.shape == (2 * N, 19) and np.all(pose[:, 2] == 2)          # the box only (id 3 -> trackID 2)
    assert np.allclose(pose[:, 4:7], [1.2, 1.0, 0.5])
    assert np.allclose(pose[:, 7:10], [0.0, -0.5, 3.0])                   # world, y down
    # a yaw of +30 deg about up is -30 deg about vKITTI's y (down)
    assert np.allclose(pose[:, 10], -np.radians(30.0)) and np.allclose(pose[:, 11:13], 0)
    for row in pose:
        T_cam_obj = np.linalg.inv(view_pose(N, int(row[0]), "right" if row[1] else "left")) @ np.array(
            [[np.cos(np.radians(30)), 0, np.sin(np.radians(30)), 0], [0, 1, 0, 0.5],
             [-np.sin(np.radians(30)), 0, np.cos(np.radians(30)), -3.0], [0, 0, 0, 1]]) @ FLIP
        x, y, z = T_cam_obj[:3, 3]
        assert np.allclose(row[13:16], [x, y, z], atol=1e-6)
        from scipy.spatial.transform import Rotation
        ry = Rotation.from_matrix(T_cam_obj[:3, :3]).as_euler("YXZ")[0]
        assert row[16] == pytest.approx(ry, abs=1e-6)
        assert row[3] == pytest.approx((ry - np.arctan2(x, z) + np.pi) % (2 * np.pi) - np.pi, abs=1e-6)


def test_png_option_and_mono(render, tmp_path):
    out = tmp_path / "vk"
    assert cli_main(["export", str(render), str(out), "--to", "vkitti2", "--opt", "rgb=png", "--noise", "0",
                     "--frames", "1:3", "-q"]) == 0
    png = cv2.imread(str(out / "frames/rgb/Camera_0/rgb_00000.png"))[..., ::-1]
    assert np.array_equal(png, RenderSequence(render).image_rgb(1, "left"))
    mono = write_layout_render(tmp_path / "mono", n=2, stereo=False)
    assert cli_main(["export", str(mono), str(tmp_path / "vm"), "--to", "vkitti2", "-q"]) == 0
    assert not (tmp_path / "vm/frames/rgb/Camera_1").exists()
    assert read_vkitti_table(tmp_path / "vm/intrinsic.txt")[1].shape == (2, 6)
