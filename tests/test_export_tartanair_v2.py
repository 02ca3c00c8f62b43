"""``--to tartanair-v2``: the tree read by the rules of today's ``tartanair`` package
(tartanairpy). The package itself cannot be installed here: its wheel requires torch,
torchvision, cupy-cuda12x and numpy 2 (CUDA downloads), so tests/format_readers.py
re-implements its iterator walk, its TartanAirImageReader decoding and its data cacher's
file names from its source, and the values are compared with the closed-form scene of
tests/layout_scene.py."""
from __future__ import annotations

import json

import numpy as np
import pytest

from format_readers import read_tartanair_poses, read_tartanair_v2, tartanair_v2_entries
from layout_scene import (H, OBJECTS, W, YAW_DEG, analytic_flow, export_fixture, export_layout, raycast,
                          rig_poses, view_pose, write_layout_render)

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 4
TRAJ = "sesgen/Data_easy/P000"


exported = export_fixture("tartanair-v2")


def test_iterator_walk_finds_every_modality_of_both_cameras(exported):
    entries = tartanair_v2_entries(exported, ("lcam_front",), ("image", "depth", "seg", "flow"))
    assert len(entries) == N - 1                        # the iterator drops the last frame (no motion)
    right = tartanair_v2_entries(exported, ("rcam_front",), ("image", "depth", "seg"))
    assert len(right) == N - 1
    traj = exported / TRAJ
    # the data cacher's names: FRAME_lcam_front.png, FRAME_lcam_front_depth.png, FRAME_NEXT_flow.png, ...
    for i in range(N):
        for cam in ("lcam_front", "rcam_front"):
            for folder, suffix in (("image", ""), ("depth", "_depth"), ("seg", "_seg")):
                assert (traj / f"{folder}_{cam}" / f"{i:06d}_{cam}{suffix}.png").is_file()
    assert sorted(p.name for p in (traj / "flow_lcam_front").iterdir()) == [f"{i:06d}_{i + 1:06d}_flow.png"
                                                                          for i in range(N - 1)]
    assert np.loadtxt(traj / "pose_lcam_front.txt").shape == (N, 7)
    assert json.loads((traj / "export.json").read_text())["target"] == "tartanair-v2"


def test_depth_segmentation_and_images(exported, layout_render):
    from vo_reference.io.render import RenderSequence
    seq = RenderSequence(layout_render)
    for k in (0, N - 1):
        for view, cam in (("left", "lcam_front"), ("right", "rcam_front")):
            z, ids = raycast(view_pose(N, k, view))
            d = read_tartanair_v2(exported / TRAJ / f"depth_{cam}" / f"{k:06d}_{cam}_depth.png")
            sky = ~np.isfinite(z)
            assert d.dtype == np.float32 and d.shape == (H, W)
            assert np.array_equal(d[~sky], z[~sky]) and np.all(d[sky] == 10000.0)   # bit-exact float32
            seg = read_tartanair_v2(exported / TRAJ / f"seg_{cam}" / f"{k:06d}_{cam}_seg.png")
            assert seg.dtype == np.uint8 and np.array_equal(seg, ids)
            img = read_tartanair_v2(exported / TRAJ / f"image_{cam}" / f"{k:06d}_{cam}.png")
            assert np.array_equal(img, seq.image_rgb(k, view))


def test_png_flow_and_mask_against_the_closed_form_scene(exported):
    T = rig_poses(N)
    for e, k in zip(tartanair_v2_entries(exported), range(N - 1)):
        flow, mask = read_tartanair_v2(e["lcam_front"]["flow"])
        exp, zpt, inside, zmin, zmax = analytic_flow(T[k], T[k + 1])
        assert np.abs(flow - exp).max() <= 1 / 128 + 1e-6           # 1/64 px steps
        assert set(np.unique(mask)) <= {0, 1, 100} and np.array_equal(mask == 100, ~inside)
        assert np.all(mask[inside & (zmax < zpt * 0.98)] == 1)
        assert np.all(mask[inside & (zmin > zpt * 1.02) & np.isfinite(zpt)] == 0)


def test_npz_flow_both_directions(layout_render, tmp_path):
    export_layout(layout_render, tmp_path, "tartanair-v2", "--opt", "flow=npz", "--sequence", "office/Data_hard/P003")
    traj = tmp_path / "office/Data_hard/P003"
    T = rig_poses(N)
    entries = tartanair_v2_entries(tmp_path)
    assert len(entries) == N - 1
    for e, k in zip(entries, range(N - 1)):
        path = e["lcam_front"]["flow"]
        assert path.name == f"{k:06d}_{k + 1:06d}_lcam_front_flow.npz"
        fwd, _ = read_tartanair_v2(path)
        assert np.abs(fwd - analytic_flow(T[k], T[k + 1])[0]).max() < 1e-3
        with np.load(path) as data:
            assert data["flow_fwd"].shape == (1, 2, H, W) and data["fov_mask_fwd"].dtype == bool
            bwd_exp, _, inside_b, _, _ = analytic_flow(T[k + 1], T[k])
            assert np.abs(data["flow_bwd"][0].transpose(1, 2, 0) - bwd_exp).max() < 1e-3
            assert np.array_equal(data["fov_mask_bwd"][0], inside_b)
            assert not np.any(data["covisible_mask_fwd"] & ~data["fov_mask_fwd"])
    assert (traj / "seg_label_map.json").is_file()


def test_poses_are_ned(exported):
    from scipy.spatial.transform import Rotation
    P = read_tartanair_poses(exported / TRAJ / "pose_lcam_front.txt")
    yaw, pitch, roll = Rotation.from_matrix(P[:, :3, :3]).as_euler("ZYX", degrees=True).T
    assert np.allclose(yaw, YAW_DEG * np.arange(N), atol=1e-7) and np.allclose([pitch, roll], 0, atol=1e-7)
    assert np.allclose(P[:, 2, 3], -1.2, atol=1e-9)
    R = read_tartanair_poses(exported / TRAJ / "pose_rcam_front.txt")
    # the right camera sits B to the right (NED y) of the left one, in the left camera's body frame
    offs = np.einsum("nji,nj->ni", P[:, :3, :3], R[:, :3, 3] - P[:, :3, 3])
    assert np.allclose(offs, [0, 0.3, 0], atol=1e-9)
    labels = json.loads((exported / TRAJ / "seg_label_map.json").read_text())["name_map"]
    assert labels == {o["name"]: o["id"] for o in OBJECTS}


def test_user_errors(layout_render, tmp_path, capsys):
    from vo_reference.commands.main import main
    assert main(["export", str(layout_render), str(tmp_path / "a"), "--to", "tartanair-v2", "--sequence", "P000", "-q"]) == 2
    assert "ENV/Data_DIFFICULTY/TRAJECTORY" in capsys.readouterr().err
    assert main(["export", str(layout_render), str(tmp_path / "b"), "--to", "tartanair-v2", "--opt", "flow=exr", "-q"]) == 2
    big = write_layout_render(tmp_path / "big", n=2, objects=[dict(o, id=o["id"] + 300) for o in OBJECTS])
    assert main(["export", str(big), str(tmp_path / "c"), "--to", "tartanair-v2", "-q"]) == 2
    lens = write_layout_render(tmp_path / "lens", n=2, lens=("brown", (-0.1, 0.02, 0.0, 0.0, 0.0)))
    assert main(["export", str(lens), str(tmp_path / "d"), "--to", "tartanair-v2", "-q"]) == 2
    assert "--undistort" in capsys.readouterr().err
    assert not any((tmp_path / x).exists() and any((tmp_path / x).rglob("*.png")) for x in "abcd")


def test_byte_reproducible(layout_render, tmp_path):
    export_layout(layout_render, tmp_path / "a", "tartanair-v2", "--frames", "1:3")
    export_layout(layout_render, tmp_path / "b", "tartanair-v2", "--frames", "1:3")
    a, b = tmp_path / "a" / TRAJ, tmp_path / "b" / TRAJ
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert files and all((a / f).read_bytes() == (b / f).read_bytes() for f in files)
