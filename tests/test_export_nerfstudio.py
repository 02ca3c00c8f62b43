"""``--to nerfstudio``: transforms.json read by the rules of nerfstudio's
``nerfstudio_dataparser.py`` and ``Cameras`` (nerfstudio itself pulls torch and is not
installed here): intrinsics keys, frames sorted by file name, depth through
``get_depth_image_from_path`` (``cv2.IMREAD_ANYDEPTH`` x depth_unit_scale_factor 1e-3),
masks through PIL as booleans, rays through pixel + 0.5 with directions
((x - cx)/fx, -(y - cy)/fy, -1) turned by the camera-to-world matrix. The points those
rays and depths give must be the closed-form scene's (tests/layout_scene.py), and a point
of one image must re-project into another where the ray cast sees it."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from layout_scene import (H, K, OBJECTS, PLANES, W, export_fixture, export_layout, raycast_pixels, view_pose,
                          write_layout_render)

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 4


exported = export_fixture("nerfstudio", "out")


def load_dataparser(root: Path, depth_unit_scale_factor: float = 1e-3) -> list[dict]:
    """What nerfstudio's dataparser and datasets make of the folder (their rules, by hand)."""
    from PIL import Image
    meta = json.loads((root / "transforms.json").read_text())
    for key in ("fl_x", "fl_y", "cx", "cy", "w", "h"):
        assert key in meta, key                         # fixed intrinsics for every frame
    frames = sorted(meta["frames"], key=lambda f: str(root / f["file_path"]))
    out = []
    for fr in frames:
        img = np.asarray(Image.open(root / fr["file_path"]))
        depth = cv2.imread(str(root / fr["depth_file_path"]), cv2.IMREAD_ANYDEPTH).astype(np.float32) \
            * depth_unit_scale_factor
        mask = np.asarray(Image.open(root / fr["mask_path"])).astype(bool)
        assert mask.ndim == 2                           # "The mask image should have 1 channel"
        out.append({"name": Path(fr["file_path"]).stem, "image": img, "depth": depth, "mask": mask,
                    "c2w": np.array(fr["transform_matrix"], dtype=float), "meta": meta})
    return out


def rays(meta: dict, c2w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """nerfstudio's perspective rays (origin, unnormalised direction with z = -1 in camera)."""
    y, x = np.meshgrid(np.arange(meta["h"]), np.arange(meta["w"]), indexing="ij")
    d_cam = np.stack([(x + 0.5 - meta["cx"]) / meta["fl_x"], -(y + 0.5 - meta["cy"]) / meta["fl_y"],
                      -np.ones(x.shape)], -1)
    return c2w[:3, 3], d_cam @ c2w[:3, :3].T


def test_dataparser_reads_images_poses_depth_and_masks(exported):
    frames = load_dataparser(exported)
    assert [f["name"] for f in frames] == sorted([f"{v}_{k:06d}" for k in range(N) for v in ("left", "right")])
    meta = frames[0]["meta"]
    assert meta["camera_model"] == "PINHOLE" and (meta["w"], meta["h"]) == (W, H)
    assert meta["cx"] == pytest.approx(K[0, 2] + 0.5) and meta["depth_unit_scale_factor"] == 1e-3
    for f in frames:
        assert f["image"].shape == (H, W, 3) and f["image"].dtype == np.uint8
        assert f["mask"].all()                          # nothing moves in this scene


def test_rays_and_depth_give_the_scene_points(exported):
    for f in load_dataparser(exported):
        view, k = f["name"].split("_")
        T = view_pose(N, int(k), view)
        o, d = rays(f["meta"], f["c2w"])
        X = o + d * f["depth"][..., None]                # z-depth along a direction with z_cam = -1
        yy, xx = np.mgrid[0:H, 0:W]
        z, ids = raycast_pixels(T, np.stack([xx, yy], -1).astype(float))
        seen = np.isfinite(z)
        X_true = (np.stack([(xx - K[0, 2]) / K[0, 0], (yy - K[1, 2]) / K[1, 1], np.ones(xx.shape)], -1)
                  * np.where(seen, z, 0.0)[..., None]) @ T[:3, :3].T + T[:3, 3]
        assert np.array_equal(f["depth"] > 0, seen)    # sky: 0 = no depth
        assert np.abs(X[seen] - X_true[seen]).max() < 1e-3    # millimetre depth steps


def test_a_point_reprojects_into_another_image_where_the_scene_shows_it(exported):
    frames = {f["name"]: f for f in load_dataparser(exported)}
    a, b = frames["left_000000"], frames["right_000002"]
    o, d = rays(a["meta"], a["c2w"])
    X = (o + d * a["depth"][..., None])[a["depth"] > 0]
    w2c = np.linalg.inv(b["c2w"])
    Xc = X @ w2c[:3, :3].T + w2c[:3, 3]                 # OpenGL camera: in front is z < 0
    m = b["meta"]
    x = m["fl_x"] * Xc[:, 0] / -Xc[:, 2] + m["cx"]
    y = -m["fl_y"] * Xc[:, 1] / -Xc[:, 2] + m["cy"]
    inside = (Xc[:, 2] < 0) & (x > 1) & (x < W - 1) & (y > 1) & (y < H - 1)
    z, _ = raycast_pixels(view_pose(N, 2, "right"), np.stack([x, y], -1)[inside] - 0.5)
    visible = np.abs(z + Xc[inside, 2]) < 2e-3          # the same surface point (else hidden)
    assert visible.sum() > 300
    assert np.median(np.abs(z + Xc[inside, 2])[visible]) < 5e-4


def test_ply_seed_points_read_by_colmaps_ply_reader(exported):
    pycolmap = pytest.importorskip("pycolmap", reason="pycolmap reads the PLY (COLMAP's reader)")
    rec = pycolmap.Reconstruction()
    rec.import_PLY(str(exported / "sparse_pc.ply"))
    xyz = np.array([p.xyz for p in rec.points3D.values()])
    assert len(xyz) > 100
    on_plane = np.min([np.abs(xyz @ n - d) for n, d, _, _ in PLANES], axis=0)
    assert on_plane.max() < 1e-4                        # float32 coordinates
    meta = json.loads((exported / "transforms.json").read_text())
    assert meta["ply_file_path"] == "sparse_pc.ply"


def test_moving_objects_are_masked_and_npy_depth_is_exact(tmp_path):
    objects = [dict(o) for o in OBJECTS]
    objects[2].update(moving=True, T_world_obj=[np.eye(4).tolist()] * 2)
    render = write_layout_render(tmp_path / "r", n=2, objects=objects)
    out = export_layout(render, tmp_path / "o", "nerfstudio", "--opt", "depth=npy")
    meta = json.loads((out / "transforms.json").read_text())
    assert meta["depth_unit_scale_factor"] == 1.0
    for fr in meta["frames"]:
        view, k = Path(fr["file_path"]).stem.split("_")
        z, ids = raycast_pixels(view_pose(2, int(k), view), np.stack(np.meshgrid(np.arange(W), np.arange(H)), -1)
                                .astype(float))
        from PIL import Image
        mask = np.asarray(Image.open(out / fr["mask_path"])).astype(bool)
        assert np.array_equal(~mask, ids == 3)
        d = np.load(out / fr["depth_file_path"]) * meta["depth_unit_scale_factor"]
        seen = np.isfinite(z)
        assert np.allclose(d[seen], z[seen], rtol=1e-6) and np.all(d[~seen] == 0)


def test_lens_is_carried_in_nerfstudios_opencv_model(tmp_path):
    lens = ("brown", (-0.12, 0.03, 0.001, -0.0005, 0.004))
    render = write_layout_render(tmp_path / "r", n=2, lens=lens)
    out = export_layout(render, tmp_path / "o", "nerfstudio")
    meta = json.loads((out / "transforms.json").read_text())
    assert meta["camera_model"] == "OPENCV"
    k1, k2, p1, p2, k3 = lens[1]
    assert (meta["k1"], meta["k2"], meta["k3"], meta["p1"], meta["p2"]) == (k1, k2, k3, p1, p2)
    # nerfstudio's distortion (camera_utils: d = 1 + k1 r + k2 r^2 + k3 r^3 + k4 r^4, r = x^2 + y^2;
    # xd = x d + 2 p1 x y + p2 (r + 2 x^2), yd = y d + 2 p2 x y + p1 (r + 2 y^2)) sends the ray
    # of each distorted pixel of the render back to that pixel
    from blender_sesgen.contract.lens import Lens
    px = np.array([[0.0, 0.0], [5.0, 4.0], [40.0, 27.0], [47.0, 31.0]])
    ray = Lens.from_K(lens[0], lens[1], K).unproject(px)
    x, y = ray[:, 0] / ray[:, 2], ray[:, 1] / ray[:, 2]
    r = x * x + y * y
    dd = 1 + r * (k1 + r * (k2 + r * k3))
    xd = x * dd + 2 * p1 * x * y + p2 * (r + 2 * x * x)
    yd = y * dd + 2 * p2 * x * y + p1 * (r + 2 * y * y)
    u = meta["fl_x"] * xd + meta["cx"] - 0.5
    v = meta["fl_y"] * yd + meta["cy"] - 0.5
    assert np.allclose(np.stack([u, v], -1), px, atol=1e-6)


def test_byte_reproducible(layout_render, tmp_path):
    a = export_layout(layout_render, tmp_path / "a", "nerfstudio", "--frames", "0:2")
    b = export_layout(layout_render, tmp_path / "b", "nerfstudio", "--frames", "0:2")
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert files and all((a / f).read_bytes() == (b / f).read_bytes() for f in files)
