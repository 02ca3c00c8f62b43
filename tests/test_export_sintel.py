"""``--to sintel``: the MPI-Sintel tree read by OpenCV's ``readOpticalFlow`` (.flo), readers
written from Sintel's SDK (.dpt, .cam) and RAFT's loader rule (sorted frames of a scene
paired consecutively with its sorted flows), against the closed-form scene's flow, depth and
poses (tests/layout_scene.py)."""
from __future__ import annotations

import numpy as np
import pytest

from format_readers import read_sintel_cam, read_sintel_dpt
from layout_scene import (H, K, W, analytic_flow, export_fixture, export_layout, raycast, rig_poses,
                          write_layout_render)

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 4


exported = export_fixture("sintel", part="training")


def test_raft_loader_pairs_frames_with_their_flow(exported):
    scenes = sorted(p.name for p in (exported / "clean").iterdir())
    assert scenes == ["sesgen"]
    for dstype in ("clean", "final"):
        images = sorted((exported / dstype / "sesgen").glob("*.png"))
        assert [p.name for p in images] == [f"frame_{i:04d}.png" for i in range(1, N + 1)]
    flows = sorted((exported / "flow" / "sesgen").glob("*.flo"))
    assert [p.stem for p in flows] == [f"frame_{i:04d}" for i in range(1, N)]     # image i, i+1 <-> flow i
    assert (exported / "clean" / "sesgen" / "export.json").is_file()


def test_flow_occlusions_and_invalid_against_the_closed_form_scene(exported):
    T = rig_poses(N)
    for i in range(N - 1):
        f = cv2.readOpticalFlow(str(exported / "flow" / "sesgen" / f"frame_{i + 1:04d}.flo"))
        exp, zpt, inside, zmin, zmax = analytic_flow(T[i], T[i + 1])
        assert f.shape == (H, W, 2) and np.abs(f - exp).max() < 1e-3
        occ = cv2.imread(str(exported / "occlusions" / "sesgen" / f"frame_{i + 1:04d}.png"), cv2.IMREAD_UNCHANGED) > 0
        assert np.all(occ[~inside]) and np.all(occ[inside & (zmax < zpt * 0.98)])
        assert not np.any(occ[inside & (zmin > zpt * 1.02) & np.isfinite(zpt)])
        inv = cv2.imread(str(exported / "invalid" / "sesgen" / f"frame_{i + 1:04d}.png"), cv2.IMREAD_UNCHANGED)
        assert not inv.any()                     # no point goes behind the camera here


def test_depth_and_camera_files(exported):
    T = rig_poses(N)
    for i in range(N):
        z, _ = raycast(T[i])
        d = read_sintel_dpt(exported / "depth" / "sesgen" / f"frame_{i + 1:04d}.dpt")
        sky = ~np.isfinite(z)
        assert np.array_equal(d[~sky], z[~sky]) and np.all(d[sky] == 10000.0)
        M, Nmat = read_sintel_cam(exported / "camdata_left" / "sesgen" / f"frame_{i + 1:04d}.cam")
        assert np.array_equal(M, K)
        # N maps world points into the camera: a scene point projects where the ray cast saw it
        v, u = 20, 30
        Xw = T[i][:3, :3] @ (np.linalg.inv(K) @ [u, v, 1.0] * z[v, u]) + T[i][:3, 3]
        p = M @ (Nmat @ np.append(Xw, 1.0))
        assert np.allclose(p[:2] / p[2], [u, v], atol=1e-9)


def test_scene_slot_options_and_refusals(layout_render, tmp_path, capsys):
    from vo_reference.commands.main import main
    assert main(["export", str(layout_render), str(tmp_path), "--to", "sintel", "--sequence", "alley_9", "--frames", "0:2",
                 "--opt", "background_depth=inf", "-q"]) == 0
    d = read_sintel_dpt(tmp_path / "training" / "depth" / "alley_9" / "frame_0001.dpt")
    assert np.isinf(d).any() and len(list((tmp_path / "training" / "flow" / "alley_9").iterdir())) == 1
    lens = write_layout_render(tmp_path / "lens", n=2, lens=("brown", (-0.1, 0.02, 0.0, 0.0, 0.0)))
    assert main(["export", str(lens), str(tmp_path / "l"), "--to", "sintel", "-q"]) == 2
    assert "--undistort" in capsys.readouterr().err
    assert main(["export", str(layout_render), str(tmp_path / "o"), "--to", "sintel", "--opt", "x=1", "-q"]) == 2


def test_byte_reproducible(layout_render, tmp_path):
    export_layout(layout_render, tmp_path / "a", "sintel")
    export_layout(layout_render, tmp_path / "b", "sintel")
    a, b = tmp_path / "a", tmp_path / "b"
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert files and all((a / f).read_bytes() == (b / f).read_bytes() for f in files)
