"""The new layouts on a real Cycles render with a distorting lens and an IMU (tiny: 64x48,
1 sample, 3 frames): COLMAP and nerfstudio carry the lens in their own models (pycolmap
reprojects every observation to <= 1e-3 px and every point lies on the script's planes),
the SLAM settings carry the script's LENS and IMU, and the layouts that describe pinhole
images refuse the render with one line naming --undistort and write nothing."""
from __future__ import annotations

import json

import numpy as np
import pytest

from render_support import render_text

pytestmark = pytest.mark.render

K1, K2, P1, P2 = -0.18, 0.04, 0.0008, -0.0004
SCENE = f"""CAMERA resolution 64 48 focal 50 baseline 0.12
POSE 0 1 2.5 0 0 0
POSE 0.06 1.01 2.4 1 3 0
POSE 0.12 1.0 2.3 2 6 0
QUAD id 1 texture 3 vertices -4 0 -2  4 0 -2  4 3 -2  -4 3 -2
QUAD id 2 texture 8 vertices -4 0 3  4 0 3  4 0 -2  -4 0 -2
LENS brown {K1} {K2} {P1} {P2}
IMU rate 200 position 0.05 0.01 0 0 0 90 offset 0.002 seed 1
"""
PLANES = ((np.array([0.0, 0.0, 1.0]), -2.0), (np.array([0.0, 1.0, 0.0]), 0.0))   # the wall z = -2, the floor y = 0


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    pytest.importorskip("bpy")
    pytest.importorskip("OpenEXR")
    return render_text(tmp_path_factory.mktemp("lensrender"), SCENE, "--samples", "1")


def _export(render, out, target, *extra) -> int:
    from vo_reference.commands.main import main
    return main(["export", str(render), str(out), "--to", target, "-q", *extra])


def test_colmap_carries_the_lens_and_reprojects(render, tmp_path):
    pycolmap = pytest.importorskip("pycolmap")
    assert _export(render, tmp_path / "c", "colmap") == 0
    rec = pycolmap.Reconstruction(str(tmp_path / "c" / "sparse" / "0"))
    cam = rec.cameras[1]
    assert cam.model_name == "OPENCV" and np.allclose(cam.params[4:], [K1, K2, P1, P2])
    assert rec.num_points3D() > 100
    errs, off_plane = [], []
    for p in rec.points3D.values():
        off_plane.append(min(abs(n @ p.xyz - d) for n, d in PLANES))
        for el in p.track.elements:
            im = rec.images[el.image_id]
            errs.append(np.linalg.norm(im.project_point(p.xyz) - im.points2D[el.point2D_idx].xy))
    assert max(errs) <= 1e-3 and len(errs) > 3 * rec.num_points3D()
    assert max(off_plane) < 1e-4            # Cycles' depth through the lens's rays: on the script's planes


def test_nerfstudio_and_slam_carry_the_lens_and_imu(render, tmp_path):
    assert _export(render, tmp_path / "n", "nerfstudio") == 0
    meta = json.loads((tmp_path / "n" / "transforms.json").read_text())
    assert meta["camera_model"] == "OPENCV" and (meta["k1"], meta["p2"], meta["k3"]) == (K1, P2, 0.0)
    assert _export(render, tmp_path / "s", "slam") == 0
    import cv2
    fs = cv2.FileStorage(str(tmp_path / "s" / "orbslam3" / "stereo_inertial.yaml"), cv2.FILE_STORAGE_READ)
    assert fs.getNode("Camera.type").string() == "PinHole"
    assert [fs.getNode(f"Camera2.{k}").real() for k in ("k1", "k2", "p1", "p2")] == [K1, K2, P1, P2]
    m = json.loads((render / "manifest.json").read_text())
    assert np.allclose(fs.getNode("IMU.T_b_c1").mat(), np.linalg.inv(np.array(m["imu"]["T_cam_imu"])), atol=1e-7)
    assert "Basalt has no radial-tangential" in (tmp_path / "s" / "README.md").read_text()


@pytest.mark.parametrize("target", ["tartanair-v2", "middlebury", "eth3d", "sintel"])
def test_pinhole_layouts_refuse_the_lens(render, tmp_path, capsys, target):
    assert _export(render, tmp_path / target, target) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--undistort" in err[0] and "brown lens" in err[0]
    assert not (tmp_path / target).exists() or not any((tmp_path / target).rglob("*.*"))
