"""``--to vkitti2``: Virtual KITTI 2's files read back with the decoding of its README
(tests/format_readers.py) against the closed-form scene of tests/layout_scene.py."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.commands.main import main as cli_main
from vo_reference.io.render import RenderSequence

from format_readers import read_vkitti_colors, read_vkitti_depth_m, read_vkitti_png_flow, read_vkitti_table
from layout_scene import B, H, K, OBJECTS, W, export_layout, raycast, view_pose, write_layout_render

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 4
FLIP = np.diag([1.0, -1.0, -1.0, 1.0])   # vKITTI's world: y down
T_BOX = np.eye(4)
T_BOX[:3, :3] = [[np.cos(np.radians(30)), 0, np.sin(np.radians(30))], [0, 1, 0],
                 [-np.sin(np.radians(30)), 0, np.cos(np.radians(30))]]
T_BOX[:3, 3] = [0.0, 0.5, -3.0]
BOX = [[-0.6, -0.5, -0.25], [0.6, 0.5, 0.25]]     # width 1.2 (x), height 1 (y), length 0.5 (z, forward)


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    objects = [dict(o) for o in OBJECTS]
    # the box is a car: its frame as placed (origin mid-face, turned 30 deg) and its box
    objects[2].update({"class": "car", "T_world_obj_rest": T_BOX.tolist(), "box": BOX})
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
    expected = {0: "Sky", 1: "Road", 2: "Building", 3: "Car"}     # floor: road, wall: building, box: car
    for oid, name in expected.items():
        assert (ids == oid).any() and np.all(names[ids == oid] == name), oid
    inst = cv2.imread(str(exported / "frames/instanceSegmentation/Camera_0/instancegt_00001.png"), cv2.IMREAD_UNCHANGED)
    # vehicles only, as vKITTI 2: the car's trackID + 1 = its object id, everything else 0
    assert inst.dtype == np.uint8 and np.array_equal(inst, np.where(ids == 3, 3, 0))


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
    # the undistorted rig's K, as vKITTI users read it: unchanged here (pinhole render)
    assert np.allclose(intr[0, 2:], [K[0, 0], K[1, 1], K[0, 2], K[1, 2]])


def _seen(k, view):
    """ids == 3 (the car) as the closed-form scene sees it."""
    return raycast(view_pose(N, k, view))[1] == 3


def test_pose_bbox_and_info_tables(exported):
    """KITTI's 3-D box label of the car: dimensions from its box, bottom centre, heading as
    KITTI's ry (x forward, y down), in vKITTI's world and each camera; bbox.txt from the
    closed-form id map; info.txt names it a Car."""
    hdr, pose = read_vkitti_table(exported / "pose.txt")
    assert hdr[:7] == ["frame", "cameraID", "trackID", "alpha", "width", "height", "length"] and len(hdr) == 19
    seen = [(k, c) for k in range(N) for c in (0, 1) if _seen(k, "right" if c else "left").any()]
    assert len(seen) >= 2 and [tuple(r) for r in pose[:, :2].astype(int)] == seen
    assert np.all(pose[:, 2] == 2) and np.allclose(pose[:, 4:7], [1.2, 1.0, 0.5])
    assert np.allclose(pose[:, 7:10], [0.0, 0.0, 3.0])          # bottom centre (0, 0, -3), vKITTI world y down
    heading = T_BOX[:3, :3] @ [0, 0, 1.0]                       # the car faces its +Z
    h_vk = FLIP[:3, :3] @ heading
    assert np.allclose(pose[:, 10], np.arctan2(-h_vk[2], h_vk[0])) and np.allclose(pose[:, 11:13], 0)
    for row in pose:
        T = view_pose(N, int(row[0]), "right" if row[1] else "left")
        X = np.linalg.inv(T) @ [0.0, 0.0, -3.0, 1.0]
        h = T[:3, :3].T @ heading
        ry = np.arctan2(-h[2], h[0])                             # KITTI: heading (cos ry, 0, -sin ry)
        assert np.allclose(row[13:16], X[:3], atol=1e-6) and row[16] == pytest.approx(ry, abs=1e-6)
        assert row[3] == pytest.approx((ry - np.arctan2(X[0], X[2]) + np.pi) % (2 * np.pi) - np.pi, abs=1e-6)
    lines = (exported / "bbox.txt").read_text().splitlines()
    assert lines[0].split() == ["frame", "cameraID", "trackID", "left", "right", "top", "bottom", "number_pixels",
                                "truncation_ratio", "occupancy_ratio", "isMoving"]
    assert len(lines) == len(seen) + 1
    for line, (k, c) in zip(lines[1:], seen):
        f = line.split()
        on = _seen(k, "right" if c else "left")
        ys, xs = np.nonzero(on)
        assert [int(x) for x in f[:8]] == [k, c, 2, xs.min(), xs.max(), ys.min(), ys.max(), on.sum()]
        assert 0.0 <= float(f[8]) <= 1.0 and float(f[9]) == -1.0 and f[10] == "False"
    assert (exported / "info.txt").read_text().splitlines() == ["trackID label model color", "2 Car box Unknown"]


def test_truncation_of_a_box_half_out_of_the_image():
    from vo_reference.exporters.vkitti2 import truncation
    K_ = np.array([[100.0, 0, 49.5], [0, 100.0, 49.5], [0, 0, 1]])
    T = np.eye(4)
    T[:3, 3] = [0.0, 0.0, 10.0]                                   # a 2 m cube 10 m ahead, centred
    cube = {"box": [[-1, -1, -1], [1, 1, 1]]}
    assert truncation(cube, T, K_, 100, 100) == 0.0
    T[0, 3] = 5.0                          # moved right: x 4..6, from the far face's left to the near face's right
    t = truncation(cube, T, K_, 100, 100)
    u0, u1 = 100 * 4 / 11 + 49.5, 100 * 6 / 9 + 49.5
    assert t == pytest.approx(1 - (99.5 - u0) / (u1 - u0), abs=1e-9)
    assert truncation({}, T, K_, 100, 100) == -1.0


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


def test_a_moving_car_takes_its_pose_of_each_frame(tmp_path):
    objects = [dict(o) for o in OBJECTS]
    T = np.tile(T_BOX, (N, 1, 1))
    T[:, 0, 3] += 0.1 * np.arange(N)                     # drives along +x, 0.1 m a frame, until frame N-2
    T[-1] = T[-2]
    objects[2].update({"class": "car", "T_world_obj_rest": T_BOX.tolist(), "box": BOX, "moving": True,
                       "motion": "keys", "T_world_obj": T.tolist()})
    render = write_layout_render(tmp_path / "r", n=N, objects=objects)
    out = export_layout(render, tmp_path / "vk", "vkitti2")
    _, pose = read_vkitti_table(out / "pose.txt")
    for row in pose:
        assert row[7] == pytest.approx(0.1 * min(int(row[0]), N - 2))
    moving = {(int(f[0]), int(f[1])): f[10] for f in (ln.split() for ln in (out / "bbox.txt").read_text().splitlines()[1:])}
    assert all(v == ("True" if k < N - 2 else "False") for (k, _), v in moving.items())


def _bilinear(field: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """field (H, W, C) sampled at pixel-centre coordinates (x, y), as grid_sample with
    align_corners=True does in the loaders below."""
    x0 = np.clip(np.floor(x).astype(int), 0, W - 2)
    y0 = np.clip(np.floor(y).astype(int), 0, H - 2)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    return ((1 - fx) * (1 - fy) * field[y0, x0] + fx * (1 - fy) * field[y0, x0 + 1]
            + (1 - fx) * fy * field[y0 + 1, x0] + fx * fy * field[y0 + 1, x0 + 1])


def test_backward_flow_pairs_as_vkitti2_loaders_pair_it(exported):
    """Virtual KITTI 2's backwardFlow_%05d.png lives on its own frame and flows to the one
    before (there is no backwardFlow_00000): loaders pair by name — a forward/backward
    consistency check reads flow_t with backwardFlow_{t+1} and depth_{t+1} — or by position
    in sorted listings (forwardFlow[i] with backwardFlow[i]). Both readings must give the
    two directions between the same two frames: p + fwd_t(p) = q and bwd_{t+1}(q) = -fwd_t(p).
    A backward flow named by its target frame, or holding t -> t+1, fails this."""
    for c in (0, 1):
        fwd_files = sorted((exported / f"frames/forwardFlow/Camera_{c}").glob("*.png"))
        bwd_files = sorted((exported / f"frames/backwardFlow/Camera_{c}").glob("*.png"))
        assert len(fwd_files) == len(bwd_files) == N - 1
        for t, (f_sorted, b_sorted) in enumerate(zip(fwd_files, bwd_files)):
            f_named = exported / f"frames/forwardFlow/Camera_{c}/flow_{t:05d}.png"
            b_named = exported / f"frames/backwardFlow/Camera_{c}/backwardFlow_{t + 1:05d}.png"
            assert (f_sorted, b_sorted) == (f_named, b_named)          # both readings agree
            fwd, inv_f = read_vkitti_png_flow(f_named)
            bwd, inv_b = read_vkitti_png_flow(b_named)
            v, u = np.mgrid[0:H, 0:W].astype(float)
            x, y = u + fwd[..., 0], v + fwd[..., 1]
            inside = ~inv_f & (x >= 0) & (x <= W - 1) & (y >= 0) & (y <= H - 1)
            # the four backward samples around q must be valid (no sky, no edge mixing)
            x0 = np.clip(np.floor(x).astype(int), 0, W - 2)
            y0 = np.clip(np.floor(y).astype(int), 0, H - 2)
            ok = inside & ~(inv_b[y0, x0] | inv_b[y0, x0 + 1] | inv_b[y0 + 1, x0] | inv_b[y0 + 1, x0 + 1])
            err = np.linalg.norm(fwd + _bilinear(bwd, x, y), axis=-1)[ok]
            assert ok.sum() > 0.5 * H * W and np.abs(fwd[ok]).max() > 0.5   # the camera moves
            assert np.median(err) < 0.01 and np.mean(err < 0.05) > 0.9, (c, t, np.median(err), np.mean(err < 0.05))
