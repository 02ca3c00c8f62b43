"""``--to colmap``: the COLMAP text model read by pycolmap (COLMAP's own reader and camera
models), against the closed-form scene of tests/layout_scene.py: every observation
reprojects to <= 1e-3 px, every point lies on the surface it was taken from, every
observation is a place where the analytic ray cast sees that very point, and every point
the ray cast shows well inside its object in an image is observed there."""
from __future__ import annotations

import json

import numpy as np
import pytest

from layout_scene import (B, H, OBJECTS, PLANES, W, export_fixture, export_layout, raycast_pixels, view_pose,
                          write_layout_render)

pycolmap = pytest.importorskip("pycolmap", reason="pycolmap (PyPI) is the reader under test")
pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 4


exported = export_fixture("colmap", "out")


def _reprojection_errors(rec) -> np.ndarray:
    errs = []
    for p in rec.points3D.values():
        for el in p.track.elements:
            im = rec.images[el.image_id]
            errs.append(np.linalg.norm(im.project_point(p.xyz) - im.points2D[el.point2D_idx].xy))
    return np.array(errs)


def _image_pose(name: str) -> np.ndarray:
    view, file = name.split("_")
    return view_pose(N, int(file[:6]), view)


def test_pycolmap_reads_the_model_and_reprojects_every_observation(exported):
    rec = pycolmap.Reconstruction(str(exported / "sparse" / "0"))
    assert rec.num_cameras() == 2 and rec.num_images() == 2 * N and rec.num_points3D() > 100
    errs = _reprojection_errors(rec)
    assert len(errs) > 4 * rec.num_points3D() and errs.max() <= 1e-3
    cam = rec.cameras[1]
    assert cam.model_name == "PINHOLE" and (cam.width, cam.height) == (W, H)
    # COLMAP's pixel convention: the top-left pixel's centre is (0.5, 0.5)
    assert cam.principal_point_x == pytest.approx(W / 2) and cam.principal_point_y == pytest.approx(H / 2)
    for im in rec.images.values():
        assert (exported / "images" / im.name).is_file()
        T_cam_world = np.vstack([im.cam_from_world().matrix(), [0, 0, 0, 1]])
        assert np.allclose(T_cam_world @ _image_pose(im.name), np.eye(4), atol=1e-12)
    # the rig: the right camera sits B to the right of the left one in every frame
    assert rec.num_rigs() == 1 and rec.num_frames() == N
    by_name = {im.name: im for im in rec.images.values()}
    for k in range(N):
        cl, cr = by_name[f"left_{k:06d}.png"].projection_center(), by_name[f"right_{k:06d}.png"].projection_center()
        assert np.allclose(cr - cl, view_pose(N, k, "left")[:3, 0] * B, atol=1e-12)


def test_points_lie_on_their_surfaces_and_are_seen_where_the_ray_cast_sees_them(exported):
    rec = pycolmap.Reconstruction(str(exported / "sparse" / "0"))
    planes = {oid: (n, d) for n, d, _, oid in PLANES}
    for p in rec.points3D.values():
        # the surface the point came from: exactly one plane holds it
        on = [oid for oid, (n, d) in planes.items() if abs(n @ p.xyz - d) < 2e-6]  # float32 depth
        assert len(on) == 1
        for el in p.track.elements:
            im = rec.images[el.image_id]
            T = _image_pose(im.name)
            uv = im.points2D[el.point2D_idx].xy - 0.5            # back to OpenCV pixels
            z, ids = raycast_pixels(T, uv[None])
            z_point = (np.linalg.inv(T) @ np.append(p.xyz, 1.0))[2]
            assert ids[0] == on[0] and z[0] == pytest.approx(z_point, rel=1e-6)


def test_every_clearly_visible_point_is_observed(exported):
    """Completeness: a point the ray cast shows in an image, with the 3x3 pixels around its
    projection on the same object at the same depth, is in that image's observations."""
    rec = pycolmap.Reconstruction(str(exported / "sparse" / "0"))
    missing = checked = 0
    for im in rec.images.values():
        T = _image_pose(im.name)
        seen = {im.points2D[i].point3D_id for i in range(im.num_points2D())}
        for pid, p in rec.points3D.items():
            Xc = (np.linalg.inv(T) @ np.append(p.xyz, 1.0))[:3]
            if Xc[2] <= 0:
                continue
            uv = im.camera.img_from_cam(Xc) - 0.5
            if not (1 <= uv[0] <= W - 2 and 1 <= uv[1] <= H - 2):
                continue
            grid = np.stack(np.meshgrid(np.floor(uv[0]) + np.arange(-1, 3), np.floor(uv[1]) + np.arange(-1, 3)), -1)
            z, ids = raycast_pixels(T, grid)
            zc, idc = raycast_pixels(T, uv[None])
            if not (np.isfinite(zc[0]) and abs(zc[0] - Xc[2]) < 1e-6 * Xc[2] and np.all(ids == idc[0])):
                continue
            checked += 1
            missing += pid not in seen
    assert checked > 500 and missing == 0


def test_points_avoid_moving_objects_sky_and_take_the_image_colour(tmp_path):
    objects = [dict(o) for o in OBJECTS]
    objects[2].update(moving=True, T_world_obj=[np.eye(4).tolist()] * N)   # the box "moves" (stays put)
    render = write_layout_render(tmp_path / "r", n=N, objects=objects)
    out = export_layout(render, tmp_path / "out", "colmap", "--opt", "stride=3")
    rec = pycolmap.Reconstruction(str(out / "sparse" / "0"))
    assert rec.num_points3D() > 50
    box_n, box_d = PLANES[2][0], PLANES[2][1]
    on_box = [p for p in rec.points3D.values()
              if abs(box_n @ p.xyz - box_d) < 2e-6 and abs(p.xyz[0]) <= 0.6 and p.xyz[1] > 1e-9]
    assert not on_box
    import cv2
    stride = 3
    for p in rec.points3D.values():
        # the point was taken at a grid-cell centre of one image: that pixel holds its colour
        src = []
        for el in p.track.elements:
            im = rec.images[el.image_id]
            uv = im.points2D[el.point2D_idx].xy - 0.5
            if np.allclose(uv, np.rint(uv), atol=1e-6) and np.all(np.rint(uv) % stride == stride // 2):
                bgr = cv2.imread(str(out / "images" / im.name))
                u, v = np.rint(uv).astype(int)
                src.append(np.array_equal(bgr[v, u, ::-1], p.color))
        assert any(src)


def test_lens_renders_keep_their_lens_in_colmaps_models(tmp_path):
    for lens, model in ((("brown", (-0.12, 0.03, 0.001, -0.0005, 0.004)), "FULL_OPENCV"),
                        (("brown", (-0.12, 0.03, 0.001, -0.0005, 0.0)), "OPENCV"),
                        (("kannala_brandt", (0.02, -0.01, 0.003, -0.001)), "OPENCV_FISHEYE")):
        render = write_layout_render(tmp_path / model / "r", n=3, lens=lens)
        out = export_layout(render, tmp_path / model / "out", "colmap")
        rec = pycolmap.Reconstruction(str(out / "sparse" / "0"))
        assert rec.cameras[1].model_name == model and rec.num_points3D() > 100
        errs = _reprojection_errors(rec)
        assert errs.max() <= 1e-3, model
        from blender_sesgen.contract.lens import Lens
        from layout_scene import K
        cam = Lens.from_K(lens[0], lens[1], K)
        # an observation is where the lens sees the point: the ray cast through it hits the point
        for p in list(rec.points3D.values())[:40]:
            for el in p.track.elements:
                im = rec.images[el.image_id]
                T = _image_pose(im.name)
                z, _ = raycast_pixels(T, (im.points2D[el.point2D_idx].xy - 0.5)[None], cam)
                assert z[0] == pytest.approx((np.linalg.inv(T) @ np.append(p.xyz, 1.0))[2], rel=1e-7)


def test_export_is_byte_reproducible_and_frames_renumbered(layout_render, tmp_path):
    a = export_layout(layout_render, tmp_path / "a", "colmap", "--frames", "1:3")
    b = export_layout(layout_render, tmp_path / "b", "colmap", "--frames", "1:3")
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    assert all((a / f).read_bytes() == (b / f).read_bytes() for f in files)
    assert json.loads((a / "export.json").read_text())["source_frames"] == [1, 2]
    rec = pycolmap.Reconstruction(str(a / "sparse" / "0"))
    names = sorted(im.name for im in rec.images.values())
    assert names == ["left_000000.png", "left_000001.png", "right_000000.png", "right_000001.png"]
    by_name = {im.name: im for im in rec.images.values()}
    T = np.vstack([by_name["left_000000.png"].cam_from_world().matrix(), [0, 0, 0, 1]])
    assert np.allclose(T @ view_pose(N, 1, "left"), np.eye(4), atol=1e-12)


def test_bad_stride_is_a_user_error(layout_render, tmp_path, capsys):
    from vo_reference.commands.main import main
    assert main(["export", str(layout_render), str(tmp_path / "o"), "--to", "colmap", "--opt", "stride=0", "-q"]) == 2
    assert "stride" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
