"""Renders with a distorting lens in every layout: the layouts with a lens model carry it,
the others refuse without ``--undistort``, and ``--undistort`` writes the pinhole camera's
images and ground truth. The oracle is tests/raycast.py: the distorted render is ray-cast
through the lens at its pixel centres, and the undistorted export must equal the same scene
ray-cast through a pinhole camera (depth, ids, disparity, flow)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import raycast
from blender_sesgen.contract.lens import Lens, robotcar_lut_bytes, undistortion_maps
from format_readers import read_pfm
from render_support import ORACLE_PRIMS
from synthetic_render import write_render

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
W, H, F, B, N = 80, 60, 60.0, 0.15, 3
K = np.array([[F, 0.0, 40.3], [0.0, F, 28.6], [0.0, 0.0, 1.0]])
BARREL = ("brown", (-0.25, 0.06, 0.001, -0.0005, 0.0))     # sensors.ses-like
PINCUSHION = ("brown", (0.12, 0.02, 0.0, 0.0, 0.0))


def rig_poses(n: int = N) -> np.ndarray:
    """Left camera poses: looking at the oracle scene from (0.2, 1.3, 3), pitched down, yawing."""
    def rot(axis, deg):
        a = np.radians(deg)
        c, s = np.cos(a), np.sin(a)
        return {"x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]), "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])}[axis]
    T = np.tile(np.eye(4), (n, 1, 1))
    for k in range(n):
        T[k, :3, :3] = rot("y", 4.0 - 3.0 * k) @ rot("x", -12.0) @ np.diag([1.0, -1.0, -1.0])
        T[k, :3, 3] = [0.2 + 0.05 * k, 1.3, 3.0 - 0.15 * k]
    return T


def view_pose(k: int, view: str) -> np.ndarray:
    T = rig_poses()[k].copy()
    if view == "right":
        T[:3, 3] += T[:3, :3] @ [B, 0, 0]
    return T


def texture(X: np.ndarray, hit: np.ndarray) -> np.ndarray:
    rgb = 0.45 + 0.4 * np.stack([np.sin(7.1 * X[..., 0]), np.sin(5.3 * X[..., 1] + 1), np.sin(6.7 * X[..., 2])], -1)
    rgb[~hit] = (0.2, 0.4, 0.8)
    return rgb.astype(np.float32)


def cast_rays(prims, T_world_cam, rays):
    """(planar depth, ids, world points) along camera rays (..., 3): the ray caster takes
    pinhole pixel coordinates, so each ray is given as its pixel under K."""
    r = rays / rays[..., 2:3]
    z, ids = raycast.cast(prims, K, T_world_cam, K[0, 0] * r[..., 0] + K[0, 2], K[1, 1] * r[..., 1] + K[1, 2])
    z, ids = z.reshape(rays.shape[:-1]), ids.reshape(rays.shape[:-1])
    X = T_world_cam[:3, 3] + (r * np.where(np.isfinite(z), z, 0)[..., None]) @ T_world_cam[:3, :3].T
    return z, ids.astype(np.int32), X


def lens_render(root, model_coeffs=BARREL):
    """A render folder whose images, depth and ids are those of a camera with this lens."""
    lens = Lens.from_K(*model_coeffs, K)
    rays = lens.pixel_rays(W, H)
    frames = []
    for k in range(N):
        fr = {}
        for view in ("left", "right"):
            z, ids, X = cast_rays(ORACLE_PRIMS, view_pose(k, view), rays)
            fr[view] = (texture(X, np.isfinite(z)), z.astype(np.float32), ids)
        frames.append(fr)
    objects = [{"id": p.id, "name": f"o{p.id}", "shape": "quad"} for p in ORACLE_PRIMS]
    return write_render(root, K=K, baseline_m=B, T_world_left=rig_poses(), frames=frames, objects=objects,
                        extra={"fps": 10, "lens": {"model": lens.model, "coeffs": list(lens.coeffs), **{
                            k: v for k, v in lens.to_json().items() if k in ("fx", "fy", "cx", "cy")}}})


def box_faces(box: raycast.BoxP, first_id: int) -> list:
    """The six faces of a box as quads with their own ids (to find its creases)."""
    R = raycast.euler_xyz_deg(*box.rotation_deg)
    h = np.asarray(box.size, dtype=float) / 2
    out = []
    for axis in range(3):
        a, b = [i for i in range(3) if i != axis]
        for sign in (-1, 1):
            corners = []
            for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = np.zeros(3)
                p[axis], p[a], p[b] = sign * h[axis], sa * h[a], sb * h[b]
                corners.append(box.centre + R @ p)
            out.append(raycast.QuadP(first_id + len(out), np.array(corners)))
    return out


FACES = [f for p in ORACLE_PRIMS for f in ([p] if not isinstance(p, raycast.BoxP) else box_faces(p, 100 * p.id))]
SPHERES = {p.id for p in ORACLE_PRIMS if isinstance(p, raycast.SphereP)}


def pinhole_truth(K_new, T):
    """(depth, ids, interior) of the pinhole camera: interior = the pixel and its 8
    neighbours see one face of one object (no silhouette, no crease within a pixel)."""
    v, u = np.mgrid[0:H, 0:W].astype(float)
    rays = np.stack([(u - K_new[0, 2]) / K_new[0, 0], (v - K_new[1, 2]) / K_new[1, 1], np.ones_like(u)], -1)
    z, ids, _ = cast_rays(ORACLE_PRIMS, T, rays)
    _, faces, _ = cast_rays(FACES, T, rays)
    pad = np.pad(faces, 1, constant_values=-1)            # the border has unknown neighbours
    interior = np.ones((H, W), bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            interior &= pad[1 + dy:H + 1 + dy, 1 + dx:W + 1 + dx] == faces
    return z, ids, interior


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    return lens_render(tmp_path_factory.mktemp("lens") / "r")


def _export(render, out, target, *extra):
    from vo_reference.commands.main import main
    return main(["export", str(render), str(out), "--to", target, "--noise", "0", "-q", *extra])


def test_layouts_without_a_lens_model_refuse_and_name_the_option(render, tmp_path, capsys):
    from vo_reference.exporters.driver import EXPORTERS, get_exporter
    keep = {t for t in EXPORTERS if getattr(get_exporter(t), "keeps_lens", False)}
    assert {"bayer", "cityscapes", "euroc", "rosbag"} <= keep
    refuse = sorted(set(EXPORTERS) - keep)
    assert {"kitti-odometry", "kitti-folder", "kitti-stereo", "kitti-sceneflow", "tum", "tartanair", "vkitti2",
            "sceneflow", "png"} <= set(refuse)
    for target in refuse:
        assert _export(render, tmp_path / target, target) == 2, target
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--undistort" in err[0] and "lens" in err[0], err
        assert not (tmp_path / target).exists()


@pytest.mark.parametrize("target", ["tartanair", "sceneflow"])
def test_undistorted_depth_ids_and_disparity_are_the_pinhole_cameras(render, tmp_path, target):
    """Depth (TartanAir's .npy) and disparity (SceneFlow's PFM) of both views against the
    pinhole ray cast: exact on every face (planes to 1e-5; the sphere, ~10 px across, to 1e-3
    relative in the median and 1e-2 at worst next to its limb: a plane through neighbouring
    samples is second-order on a curve), ids
    exact away from silhouettes; the nearest sample decides only within a pixel of them."""
    assert _export(render, tmp_path / "o", target, "--undistort") == 0
    root = tmp_path / "o" / ("frames_cleanpass/TRAIN/A/0000" if target == "sceneflow" else "")
    info = json.loads((root / "export.json").read_text())
    K_new = np.array(info["undistorted"]["K"])
    assert np.allclose(K_new, K)                          # a barrel lens covers the pinhole view
    for k in range(N):
        for view in ("left", "right"):
            z, ids, interior = pinhole_truth(K_new, view_pose(k, view))
            if target == "tartanair":
                got = np.load(root / f"depth_{view}" / f"{k:06d}_{view}_depth.npy")
                got_ids = np.load(root / f"seg_{view}" / f"{k:06d}_{view}_seg.npy")
                assert np.array_equal(got_ids[interior], ids[interior])
                assert (got_ids != ids).mean() < 0.05
                want = np.where(np.isfinite(z), z, 10000.0)
            else:
                got = read_pfm(Path(str(root).replace("frames_cleanpass", "disparity")) / view / f"{k:04d}.pfm")
                want = np.where(np.isfinite(z), K_new[0, 0] * B / np.where(np.isfinite(z), z, 1.0), 0.0)
            rel = np.abs(got - want) / np.maximum(np.abs(want), 1e-9)
            planes = interior & ~np.isin(ids, list(SPHERES)) & np.isfinite(z)
            assert planes.sum() > 0.5 * W * H and rel[planes].max() < 1e-5, rel[planes].max()
            sphere = interior & np.isin(ids, list(SPHERES))
            assert sphere.sum() > 20 and rel[sphere].max() < 1e-2 and np.median(rel[sphere]) < 1e-3, rel[sphere]
            assert np.array_equal(got[interior & ~np.isfinite(z)], want[interior & ~np.isfinite(z)])


def test_undistorted_flow_is_the_pinhole_cameras(render, tmp_path):
    """SceneFlow's into-future flow of the undistorted export against the flow of the pinhole
    ray cast's points (closed form), on the faces seen by both frames."""
    assert _export(render, tmp_path / "o", "sceneflow", "--undistort") == 0
    v, u = np.mgrid[0:H, 0:W].astype(float)
    r = np.stack([(u - K[0, 2]) / F, (v - K[1, 2]) / F, np.ones_like(u)], -1)
    for view, L in (("left", "L"), ("right", "R")):
        Ts, Tt = view_pose(0, view), view_pose(1, view)
        z, ids, interior = pinhole_truth(K, Ts)
        X = Ts[:3, 3] + (r * np.where(np.isfinite(z), z, 0)[..., None]) @ Ts[:3, :3].T
        Xt = (X - Tt[:3, 3]) @ Tt[:3, :3]
        exp = np.stack([F * Xt[..., 0] / Xt[..., 2] + K[0, 2] - u, F * Xt[..., 1] / Xt[..., 2] + K[1, 2] - v], -1)
        f = read_pfm(tmp_path / f"o/optical_flow/TRAIN/A/0000/into_future/{view}/OpticalFlowIntoFuture_0000_{L}.pfm")
        ok = interior & np.isfinite(z) & ~np.isin(ids, list(SPHERES))
        assert np.abs(f[..., :2] - exp)[ok].max() < 1e-3


def test_undistorted_images_are_the_pinhole_view(render, tmp_path):
    """The resampled image against the texture ray-cast through the pinhole camera: the
    bilinear resampling of a smooth texture, off by a few levels away from silhouettes."""
    assert _export(render, tmp_path / "o", "tartanair", "--undistort") == 0
    from vo_reference.io.render import RenderSequence
    from blender_sesgen.contract.colour import linear_to_srgb8
    v, u = np.mgrid[0:H, 0:W].astype(float)
    rays = np.stack([(u - K[0, 2]) / F, (v - K[1, 2]) / F, np.ones_like(u)], -1)
    z, _, X = cast_rays(ORACLE_PRIMS, view_pose(1, "left"), rays)
    _, _, interior = pinhole_truth(K, view_pose(1, "left"))
    want = linear_to_srgb8(texture(X, np.isfinite(z))).astype(float)
    got = cv2.imread(str(tmp_path / "o/image_left/000001_left.png"))[..., ::-1].astype(float)
    distorted = RenderSequence(render).image_rgb(1, "left").astype(float)
    err = np.abs(got - want)[interior]
    assert err.mean() < 3.0 and np.abs(distorted - want)[interior].mean() > 4 * err.mean()


def test_a_pincushion_lens_zooms_the_pinhole_camera_in(tmp_path):
    """The distorted image of a pincushion lens does not cover its own K's pinhole view:
    the pinhole K is scaled up just enough that every pixel has data."""
    render = lens_render(tmp_path / "r", PINCUSHION)
    assert _export(render, tmp_path / "o", "tartanair", "--undistort") == 0
    K_new = np.array(json.loads((tmp_path / "o/export.json").read_text())["undistorted"]["K"])
    s = K_new[0, 0] / K[0, 0]
    assert 1.0 < s < 1.2 and K_new[1, 1] / K[1, 1] == pytest.approx(s) and np.allclose(K_new[:2, 2], K[:2, 2])
    lens = Lens.from_K(*PINCUSHION, K)

    def border_inside(focal_scale):        # the pinhole image's border pixels land in the distorted image
        u = np.concatenate([np.arange(W), np.arange(W), np.zeros(H), np.full(H, W - 1)])
        v = np.concatenate([np.zeros(W), np.full(W, H - 1), np.arange(H), np.arange(H)])
        px = lens.project(np.stack([(u - K[0, 2]) / (F * focal_scale), (v - K[1, 2]) / (F * focal_scale),
                                    np.ones(len(u))], -1))
        return np.all((px >= -0.5) & (px <= [W - 0.5, H - 0.5]))
    assert not border_inside(1.0) and border_inside(s) and not border_inside(s * (1 - 1e-4))
    z, ids, interior = pinhole_truth(K_new, view_pose(0, "left"))
    got = np.load(tmp_path / "o/depth_left/000000_left_depth.npy")
    planes = interior & ~np.isin(ids, list(SPHERES)) & np.isfinite(z)
    assert np.abs(got - z)[planes].max() < 1e-5 * np.nanmax(z[planes])


def test_layouts_with_a_lens_model_carry_the_lens(render, tmp_path):
    lens = Lens.from_K(*BARREL, K)
    assert _export(render, tmp_path / "bayer", "bayer") == 0
    info = json.loads((tmp_path / "bayer/bayer.json").read_text())
    assert info["distortion"] == {"model": "brown", "coeffs": list(BARREL[1])}
    lut = (tmp_path / "bayer/model_distortion_lut.bin").read_bytes()
    assert lut == robotcar_lut_bytes(*undistortion_maps(lens, W, H))
    # the table undistorts the mosaic's source image into the pinhole view (as mono-vo --lut does)
    from vo_reference.camera.undistort import read_lut, remap
    from vo_reference.io.render import RenderSequence
    und = remap(RenderSequence(render).image_rgb(0, "left"), *read_lut(tmp_path / "bayer/model_distortion_lut.bin", W, H))
    v, u = np.mgrid[0:H, 0:W].astype(float)
    z, _, X = cast_rays(ORACLE_PRIMS, view_pose(0, "left"), np.stack([(u - K[0, 2]) / F, (v - K[1, 2]) / F,
                                                                       np.ones_like(u)], -1))
    from blender_sesgen.contract.colour import linear_to_srgb8
    _, _, interior = pinhole_truth(K, view_pose(0, "left"))
    assert np.abs(und.astype(float) - linear_to_srgb8(texture(X, np.isfinite(z))))[interior].mean() < 3.0
    assert _export(render, tmp_path / "b2", "bayer", "--opt", "dist=0.1,0,0,0") == 2
    assert _export(render, tmp_path / "euroc", "euroc") == 0
    yaml = pytest.importorskip("yaml")
    y = yaml.safe_load((tmp_path / "euroc/mav0/cam0/sensor.yaml").read_text())
    assert y["distortion_model"] == "radial-tangential" and y["distortion_coefficients"] == list(BARREL[1][:4])
    # --undistort on a layout with a lens model writes the pinhole camera
    assert _export(render, tmp_path / "euroc_u", "euroc", "--undistort") == 0
    y = yaml.safe_load((tmp_path / "euroc_u/mav0/cam0/sensor.yaml").read_text())
    assert y["distortion_coefficients"] == [0, 0, 0, 0]


@pytest.mark.render
def test_a_cycles_lens_render_undistorts_to_the_pinhole_ray_cast(tmp_path):
    """The oracle scene rendered by Cycles through a sensors.ses-like Brown-Conrady lens
    (80x60, 1 sample), exported with --undistort: depth and disparity against the scene
    ray-cast through the pinhole camera, on every face away from silhouettes and creases."""
    pytest.importorskip("bpy")
    from render_support import oracle_script, rendered
    script = tmp_path / "lens.ses"
    script.write_text(oracle_script(80, 60, F, (K[0, 2], K[1, 2]), B, extra_lines=[
        "LENS brown " + " ".join(str(c) for c in BARREL[1][:4])]))
    rendered(script, tmp_path / "r", "--samples", "1", "--frames", "0:2")
    assert _export(tmp_path / "r", tmp_path / "ta", "tartanair", "--undistort", "--frames", "0:2") == 0
    assert _export(tmp_path / "r", tmp_path / "sf", "sceneflow", "--undistort", "--frames", "0:2") == 0
    m = json.loads((tmp_path / "r/manifest.json").read_text())
    K_new = np.array(json.loads((tmp_path / "ta/export.json").read_text())["undistorted"]["K"])
    assert np.allclose(K_new, m["K"])
    for k in range(2):
        for view in ("left", "right"):
            z, ids, interior = pinhole_truth(K_new, np.array(m["poses"][view][k]))
            faces = interior & np.isfinite(z) & ~np.isin(ids, list(SPHERES))
            depth = np.load(tmp_path / f"ta/depth_{view}/{k:06d}_{view}_depth.npy")
            seg = np.load(tmp_path / f"ta/seg_{view}/{k:06d}_{view}_seg.npy")
            disp = read_pfm(tmp_path / f"sf/disparity/TRAIN/A/0000/{view}/{k:04d}.pfm")
            with np.errstate(invalid="ignore"):
                rel = np.abs(depth - z) / z
            assert faces.sum() > 0.4 * W * H and np.median(rel[faces]) < 1e-4 and rel[faces].max() < 1e-3, \
                (np.median(rel[faces]), rel[faces].max())
            d_true = K_new[0, 0] * B / z
            assert np.abs(disp - d_true)[faces].max() < 2e-3 * d_true[faces].max()
            assert np.array_equal(seg[interior], ids[interior])
