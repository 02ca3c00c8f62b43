"""``--to middlebury`` and ``--to eth3d``: read back with readers written from the formats'
documentation (Middlebury 2014's calib.txt and PFM disparity, with Z = baseline·f/(d + doffs);
RAFT-Stereo's and the benchmarks' rules: disparity valid where finite, mask0nocc == 255 the
non-occluded pixels) and compared with the exact disparity f·B/Z of the closed-form scene."""
from __future__ import annotations

import re

import numpy as np
import pytest

from format_readers import read_pfm
from layout_scene import B, H, K, W, export_layout, raycast, raycast_pixels, view_pose, write_layout_render

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 3


def read_calib(path) -> dict:
    """Middlebury 2014 calib.txt: key=value lines; camN=[a b c; d e f; g h i]."""
    out = {}
    for line in path.read_text().splitlines():
        key, _, value = line.partition("=")
        if value.startswith("["):
            out[key] = np.array([[float(x) for x in row.split()] for row in value.strip("[]").split(";")])
        else:
            out[key] = float(value)
    return out


def _stereo_visibility(k: int):
    """(d_true, sure_visible, sure_occluded) of the left view from the ray cast alone: a
    pixel's point is surely seen by the right camera when the ray through its partner
    x - d hits it and both right pixels around x - d show the same object (no outline
    between them), surely not when the right image there shows something 2 % nearer or
    the partner falls outside the image."""
    z, ids = raycast(view_pose(N, k, "left"))
    d = np.where(np.isfinite(z), K[0, 0] * B / np.where(np.isfinite(z), z, 1.0), np.nan)   # nan: nothing seen
    yy, xx = np.mgrid[0:H, 0:W].astype(float)
    xr = np.where(np.isfinite(d), xx - d, -np.inf)
    fin = np.isfinite(z)
    inside = fin & (xr >= -0.5) & (xr < W - 0.5)
    zr = np.full((H, W), np.inf)
    zr[inside], _ = raycast_pixels(view_pose(N, k, "right"), np.stack([xr[inside], yy[inside]], -1))
    _, ids_r = raycast(view_pose(N, k, "right"))
    x0 = np.clip(np.floor(np.where(inside, xr, 0)), 0, W - 2).astype(int)
    y = yy.astype(int)
    same = (ids_r[y, x0] == ids) & (ids_r[y, x0 + 1] == ids)
    with np.errstate(invalid="ignore"):
        vis = inside & same & (np.abs(zr - z) < 1e-6 * z)
        occ = fin & (~inside | (zr < 0.98 * z))
    return d, vis, occ


def _cvkit_points(cal: dict, disp: np.ndarray) -> np.ndarray:
    """Camera-frame points (mm) of every left pixel as Middlebury's viewer cvkit builds them
    (roboception/cvkit gimage/view.cc reads calib.txt's cam0 as camera.A with the origin at
    the image corner; gvr/model.cc back-projects pixel (i, k) at (i + 0.5, k + 0.5))."""
    A = cal["cam0"]
    Z = cal["baseline"] * A[0, 0] / (disp + cal["doffs"])
    k, i = np.mgrid[0:disp.shape[0], 0:disp.shape[1]].astype(float)
    return np.stack([(i + 0.5 - A[0, 2]) / A[0, 0] * Z, (k + 0.5 - A[1, 2]) / A[1, 1] * Z, Z], -1)


def _true_points_mm(k: int) -> tuple[np.ndarray, np.ndarray]:
    """The closed-form scene's point at each left pixel centre, camera frame, mm."""
    z, _ = raycast(view_pose(N, k, "left"))
    fin = np.isfinite(z)
    zz = np.where(fin, z, 1.0) * 1000.0
    v, u = np.mgrid[0:H, 0:W].astype(float)
    return np.stack([(u - K[0, 2]) / K[0, 0] * zz, (v - K[1, 2]) / K[1, 1] * zz, zz], -1), fin


def test_calib_principal_point_as_the_datasets_read_it(layout_render, tmp_path):
    """Middlebury's and ETH3D's calib.txt put (0, 0) at the image corner: cvkit's
    reconstruction from our calib.txt and disp0 lands on the scene's points, and ETH3D's
    calib.txt holds its cameras.txt numbers (as in ETH3D's own two-view download). An
    OpenCV principal point (the code before) puts every point 0.5 px·Z/f aside."""
    mb = export_layout(layout_render, tmp_path / "mb", "middlebury")
    eth = export_layout(layout_render, tmp_path / "eth", "eth3d")
    for k in range(N):
        X_true, fin = _true_points_mm(k)
        for cal, disp in ((read_calib(mb / f"sesgen_{k:06d}/calib.txt"), read_pfm(mb / f"sesgen_{k:06d}/disp0.pfm")),
                          (read_calib(eth / f"two_view_training/sesgen_{k:06d}/calib.txt"),
                           read_pfm(eth / f"two_view_training_gt/sesgen_{k:06d}/disp0GT.pfm"))):
            X = _cvkit_points(cal, disp)
            err = np.abs(X - X_true)[fin]
            assert np.all(err <= 1e-6 * X_true[fin][:, 2:3]), err.max()
        cams = [ln.split() for ln in (eth / f"two_view_training/sesgen_{k:06d}/cameras.txt").read_text().splitlines()
                if ln and not ln.startswith("#")]
        cal = read_calib(eth / f"two_view_training/sesgen_{k:06d}/calib.txt")
        for c in cams:                      # PINHOLE fx fy cx cy == calib.txt's f, f, cx, cy
            assert c[1] == "PINHOLE" and np.allclose([float(x) for x in c[4:8]],
                                                     [cal["cam0"][0, 0], cal["cam0"][1, 1], cal["cam0"][0, 2], cal["cam0"][1, 2]])


def test_middlebury_scene_folders(layout_render, tmp_path):
    out = export_layout(layout_render, tmp_path / "mb", "middlebury")
    scenes = sorted(p.name for p in out.iterdir() if p.is_dir())
    assert scenes == [f"sesgen_{i:06d}" for i in range(N)]
    for k, scene in enumerate(scenes):
        s = out / scene
        cal = read_calib(s / "calib.txt")
        K_corner = K + [[0, 0, 0.5], [0, 0, 0.5], [0, 0, 0]]      # (0, 0) at the image corner
        assert np.allclose(cal["cam0"], K_corner) and np.allclose(cal["cam1"], K_corner) and cal["doffs"] == 0
        assert (cal["width"], cal["height"], cal["isint"], cal["dyavg"], cal["dymax"]) == (W, H, 0, 0, 0)
        assert cal["baseline"] == pytest.approx(B * 1000)
        d0, d1 = read_pfm(s / "disp0.pfm"), read_pfm(s / "disp1.pfm")
        z0, _ = raycast(view_pose(N, k, "left"))
        z1, _ = raycast(view_pose(N, k, "right"))
        for d, z in ((d0, z0), (d1, z1)):
            fin = np.isfinite(z)
            assert np.array_equal(np.isfinite(d), fin) and np.all(np.isinf(d[~fin]))
            # Middlebury's depth formula gives back the planar depth (mm)
            Z_mm = cal["baseline"] * cal["cam0"][0, 0] / (d[fin] + cal["doffs"])
            assert np.allclose(Z_mm, z[fin] * 1000, rtol=1e-6)
        assert cal["vmin"] <= np.nanmin(np.where(np.isfinite(d0), d0, np.nan))
        assert np.nanmax(np.where(np.isfinite(d0), d0, np.nan)) <= cal["vmax"] < cal["ndisp"]
        assert cal["ndisp"] % 16 == 0
        img0 = cv2.imread(str(s / "im0.png"))
        assert img0.shape == (H, W, 3)
        mask = cv2.imread(str(s / "mask0nocc.png"), cv2.IMREAD_UNCHANGED)
        d_true, vis, occ = _stereo_visibility(k)
        assert set(np.unique(mask)) <= {0, 128, 255}
        assert np.all(mask[vis] == 255) and np.all(mask[occ] == 128) and np.all(mask[~np.isfinite(d_true)] == 0)
        assert occ.any() and vis.any()


def test_eth3d_tree_and_colmap_pair(layout_render, tmp_path):
    out = export_layout(layout_render, tmp_path / "eth", "eth3d", "--opt", "name=room", "--frames", "1:3")
    # the RAFT-Stereo / IGEV ETH3D loader: sorted globs, paired by position
    im0 = sorted(out.glob("two_view_training/*/im0.png"))
    im1 = sorted(out.glob("two_view_training/*/im1.png"))
    gt = sorted(out.glob("two_view_training_gt/*/disp0GT.pfm"))
    assert [p.parent.name for p in im0] == [p.parent.name for p in gt] == ["room_000000", "room_000001"]
    for i, (a, b, g) in enumerate(zip(im0, im1, gt)):
        k = i + 1
        assert cv2.imread(str(a), cv2.IMREAD_UNCHANGED).shape == (H, W)           # grey, as ETH3D's
        assert cv2.imread(str(b), cv2.IMREAD_UNCHANGED).shape == (H, W)
        disp = read_pfm(g)
        valid = (disp > 0) & (disp < 1e3)                                        # readDispETH3D
        d_true, vis, occ = _stereo_visibility(k)
        assert np.array_equal(valid, np.isfinite(d_true))
        assert np.allclose(disp[valid], d_true[valid], rtol=1e-6)
        nocc = cv2.imread(str(g.parent / "mask0nocc.png"), cv2.IMREAD_UNCHANGED) == 255
        assert np.all(nocc[vis]) and not np.any(nocc[occ])
        cal = read_calib(a.parent / "calib.txt")
        assert cal["baseline"] == pytest.approx(B * 1000)
        assert np.allclose(cal["cam0"], K + [[0, 0, 0.5], [0, 0, 0.5], [0, 0, 0]])
    pycolmap = pytest.importorskip("pycolmap")
    rec = pycolmap.Reconstruction(str(im0[0].parent))
    by = {im.name: im for im in rec.images.values()}
    assert set(by) == {"im0.png", "im1.png"}
    assert np.allclose(by["im1.png"].projection_center() - by["im0.png"].projection_center(),
                       view_pose(N, 1, "left")[:3, 0] * B, atol=1e-12)


def test_refusals(layout_render, tmp_path, capsys):
    from vo_reference.commands.main import main
    mono = write_layout_render(tmp_path / "mono", n=2, stereo=False)
    assert main(["export", str(mono), str(tmp_path / "a"), "--to", "middlebury", "-q"]) == 2
    assert "stereo" in capsys.readouterr().err
    lens = write_layout_render(tmp_path / "lens", n=2, lens=("kannala_brandt", (0.01, 0.0, 0.0, 0.0)))
    for target in ("middlebury", "eth3d"):
        assert main(["export", str(lens), str(tmp_path / target), "--to", target, "-q"]) == 2
        err = capsys.readouterr().err
        assert "--undistort" in err and re.search(r"kannala_brandt lens", err)
        assert not (tmp_path / target).exists()
    assert main(["export", str(layout_render), str(tmp_path / "b"), "--to", "eth3d", "--opt", "name=a/b", "-q"]) == 2


def test_byte_reproducible(layout_render, tmp_path):
    for target in ("middlebury", "eth3d"):
        a = export_layout(layout_render, tmp_path / target / "a", target)
        b = export_layout(layout_render, tmp_path / target / "b", target)
        files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
        assert files and all((a / f).read_bytes() == (b / f).read_bytes() for f in files)
