"""Exports: layouts, contents against the library products, and readability by the tools
people use (OpenCV for images, evo for poses)."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vo_reference.cli import main as cli_main
from vo_reference.errors import VoError
from vo_reference.io.kitti import KittiSequence
from vo_reference.io.render import RenderSequence
from synthetic_render import write_render
from vo_reference.products.disparity import disparity_to_png16
from vo_reference.products.exports import EXPORTERS, export, parse_frames, register_exporter
from vo_reference.products.flow import read_kitti_flow_png, stereo_occlusion

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
EVO_BIN = Path(sys.executable).parent

W, H, F, B = 48, 32, 40.0, 0.3
K = np.array([[F, 0, W / 2 - 0.5], [0, F, H / 2 - 0.5], [0, 0, 1.0]])


def _depth_and_ids(T_world_cam):
    """A wall at z = 6 (id 1) and a near post x in [-0.2, 0.2] at z = 2 (id 2), beyond
    which nothing: the top rows see sky (y < -1.2 on the wall -> inf)."""
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    rx, ry = (u - K[0, 2]) / F, (v - K[1, 2]) / F
    c = T_world_cam[:3, 3]  # cameras translate only
    z = np.full((H, W), np.inf)
    ids = np.zeros((H, W), np.int32)
    for zp, cond, oid in ((6.0, lambda x, y: y > -1.2, 1), (2.0, lambda x, y: (abs(x) < 0.2) & (y > -0.8), 2)):
        t = zp - c[2]
        x, y = c[0] + rx * t, c[1] + ry * t
        hit = cond(x, y) & (t < z)
        z[hit], ids[hit] = t, oid
    return z.astype(np.float32), ids


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    root = tmp_path_factory.mktemp("render") / "r"
    n = 4
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, 0, 3] = np.linspace(0, 0.3, n)
    T[:, 2, 3] = np.linspace(0, 0.4, n)
    rng = np.random.default_rng(0)
    frames = []
    for k in range(n):
        fr = {}
        for view, dx in (("left", 0.0), ("right", B)):
            Tv = T[k].copy()
            Tv[0, 3] += dx
            z, ids = _depth_and_ids(Tv)
            fr[view] = (rng.uniform(0.02, 0.8, (H, W, 3)).astype(np.float32), z, ids)
        frames.append(fr)
    write_render(root, K=K, baseline_m=B, T_world_left=T, frames=frames, noise=(4.0, 9),
                 extra={"fps": 10})
    return root


def _fxb_over_z(z):
    """Reference disparity, NaN where no depth."""
    z = z.astype(np.float64)
    return np.where(np.isfinite(z), F * B / z, np.nan)


def _cli(*args) -> int:
    return cli_main(["export", *map(str, args), "-q"])


def test_kitti_folder_layout(render, tmp_path):
    out = tmp_path / "kitti"
    assert _cli(render, out, "--to", "kitti-folder", "--noise", "0") == 0
    seq = RenderSequence(render)
    for d, ch in (("image_0", 2), ("image_1", 2), ("image_2", 3), ("image_3", 3)):
        files = sorted((out / d).glob("*.png"))
        assert [f.name for f in files] == [f"{i:06d}.png" for i in range(4)]
        img = cv2.imread(str(files[2]), cv2.IMREAD_UNCHANGED)
        assert img.dtype == np.uint8 and img.ndim == ch and img.shape[:2] == (H, W)
    assert np.array_equal(cv2.imread(str(out / "image_3/000002.png"))[..., ::-1], seq.image_rgb(2, "right"))
    assert np.array_equal(cv2.imread(str(out / "image_0/000001.png"), cv2.IMREAD_GRAYSCALE), seq.image_gray(1))
    # our own KITTI reader reads it back: same K, baseline, poses relative to frame 0
    ks = KittiSequence(out)
    assert ks.num_frames == 4 and ks.views == ("left", "right")
    assert np.allclose(ks.K, K) and ks.baseline_m == pytest.approx(B)
    T = seq.T_world_cam("left")
    assert np.allclose(ks.T_world_cam("left"), np.linalg.inv(T[0]) @ T, atol=1e-9)
    assert np.allclose(ks.timestamps_s, [0, 0.1, 0.2, 0.3])
    calib = (out / "calib.txt").read_text().splitlines()
    assert [line.split(":")[0] for line in calib] == ["P0", "P1", "P2", "P3", "Tr"]


def test_evo_reads_kitti_and_tum_poses(render, tmp_path):
    if not (EVO_BIN / "evo_traj").exists():
        pytest.skip("evo not installed in this environment")
    kitti, tum = tmp_path / "k", tmp_path / "t"
    export(render, "kitti-folder", kitti, progress=False)
    export(render, "tum", tum, progress=False)
    env = dict(os.environ, HOME=str(tmp_path))  # evo writes its settings under $HOME
    for fmt, path in (("kitti", kitti / "poses.txt"), ("tum", tum / "groundtruth.txt")):
        r = subprocess.run([str(EVO_BIN / "evo_traj"), fmt, str(path), "--full_check"],
                           capture_output=True, text=True, env=env, timeout=120)
        assert r.returncode == 0, r.stderr
        assert "4 poses" in r.stdout or "nr. of poses\t4" in r.stdout, r.stdout
    from evo.tools import file_interface
    tk = file_interface.read_kitti_poses_file(str(kitti / "poses.txt"))
    tt = file_interface.read_tum_trajectory_file(str(tum / "groundtruth.txt"))
    T = RenderSequence(render).T_world_cam("left")
    assert np.allclose(np.array(tk.poses_se3), np.linalg.inv(T[0]) @ T, atol=1e-9)
    assert np.allclose(np.array(tt.poses_se3), T, atol=1e-6)
    assert np.allclose(tt.timestamps, [0, 0.1, 0.2, 0.3])


def test_tum_layout(render, tmp_path):
    out = export(render, "tum", tmp_path / "tum", noise=None, progress=False)
    seq = RenderSequence(render)
    lines = [l for l in (out / "depth.txt").read_text().splitlines() if not l.startswith("#")]
    assert len(lines) == 4 and lines[1] == "0.100000 depth/0.100000.png"
    d16 = cv2.imread(str(out / "depth/0.100000.png"), cv2.IMREAD_UNCHANGED)
    assert d16.dtype == np.uint16
    z = seq.depth(1)
    ok = np.isfinite(z)
    assert np.all(d16[~ok] == 0) and ok.any() and (~ok).any()
    assert np.abs(d16[ok] / 5000.0 - z[ok]).max() <= 0.5 / 5000 + 1e-7
    rgb = cv2.imread(str(out / "rgb/0.300000.png"))[..., ::-1]
    assert np.array_equal(rgb, seq.image_rgb(3))
    assert (out / "associations.txt").read_text().splitlines()[0] == "0.000000 rgb/0.000000.png 0.000000 depth/0.000000.png"


def test_kitti_stereo_layout_disparity_and_flow(render, tmp_path):
    out = export(render, "kitti-stereo", tmp_path / "ks", noise=None, progress=False)
    seq = RenderSequence(render)
    occ = cv2.imread(str(out / "disp_occ_0/000001_10.png"), cv2.IMREAD_UNCHANGED)
    noc = cv2.imread(str(out / "disp_noc_0/000001_10.png"), cv2.IMREAD_UNCHANGED)
    assert occ.dtype == np.uint16 == noc.dtype
    z = seq.depth(1, "left")
    assert np.array_equal(occ, disparity_to_png16(_fxb_over_z(z)))
    # noc = occ without the left pixels hidden from the right camera (beside the post)
    mask = stereo_occlusion(z, seq.depth(1, "right"), K, B)
    assert mask.sum() > 10
    assert np.array_equal(noc, np.where(mask, 0, occ))
    # the occluded pixels are wall pixels just left of the post
    ids = seq.ids(1, "left")
    assert set(np.unique(ids[mask])) == {1}
    # flow for frame pairs; the last frame has no successor
    assert (out / "image_2/000002_11.png").is_file() and not (out / "image_2/000003_11.png").exists()
    f, valid = read_kitti_flow_png(out / "flow_occ/000000_10.png")
    f_noc, valid_noc = read_kitti_flow_png(out / "flow_noc/000000_10.png")
    assert valid.sum() > valid_noc.sum() > 0.5 * W * H
    assert np.all(valid >= valid_noc) and np.allclose(f[valid_noc], f_noc[valid_noc])


def test_kitti_stereo_calib_cam_to_cam_read_by_pykitti(render, tmp_path):
    """KITTI 2015 ships calib_cam_to_cam/NNNNNN.txt (no odometry calib.txt); pykitti's reader
    of that file gives the rig back: P_rect_02 = K[I|0], P_rect_03 = K[I|(-B,0,0)], sizes."""
    utils = pytest.importorskip("pykitti.utils")
    out = export(render, "kitti-stereo", tmp_path / "ks", noise=None, progress=False)
    assert not (out / "calib.txt").exists()
    names = sorted(p.name for p in (out / "calib_cam_to_cam").iterdir())
    assert names == [f"{i:06d}.txt" for i in range(RenderSequence(render).num_frames)]
    c = utils.read_calib_file(str(out / "calib_cam_to_cam" / "000001.txt"))
    P2, P3 = c["P_rect_02"].reshape(3, 4), c["P_rect_03"].reshape(3, 4)
    assert np.allclose(P2, np.hstack([K, np.zeros((3, 1))]), rtol=1e-12)
    assert np.allclose(P3[:, :3], K, rtol=1e-12) and P3[0, 3] / -P3[0, 0] == pytest.approx(B, rel=1e-12)
    assert np.allclose(c["K_02"].reshape(3, 3), K) and np.allclose(c["T_03"], [-B, 0, 0])
    assert np.allclose(c["R_rect_00"].reshape(3, 3), np.eye(3)) and not c["D_02"].any()
    assert list(c["S_rect_02"]) == [W, H] and np.allclose(c["P_rect_00"], c["P_rect_02"])


def test_png_layout_noise_from_manifest_and_override(render, tmp_path):
    a = export(render, "png", tmp_path / "a", progress=False)              # manifest NOISE 4, seed 9
    b = export(render, "png", tmp_path / "b", progress=False)
    c = export(render, "png", tmp_path / "c", noise=(4.0, 10), progress=False)
    clean = export(render, "png", tmp_path / "clean", noise=None, progress=False)
    seq = RenderSequence(render)
    pa = (a / "left/rgb/000002.png").read_bytes()
    assert pa == (b / "left/rgb/000002.png").read_bytes()
    assert pa != (c / "left/rgb/000002.png").read_bytes()
    img = cv2.imread(str(a / "left/rgb/000002.png"))[..., ::-1].astype(float)
    ref = cv2.imread(str(clean / "left/rgb/000002.png"))[..., ::-1]
    assert np.array_equal(ref, seq.image_rgb(2))
    assert 3.0 < (img - ref).std() < 5.0
    ids16 = cv2.imread(str(a / "right/ids/000001.png"), cv2.IMREAD_UNCHANGED)
    assert ids16.dtype == np.uint16 and np.array_equal(ids16, seq.ids(1, "right"))
    col = cv2.imread(str(a / "right/ids_colour/000001.png"))
    assert col.dtype == np.uint8 and np.all(col[ids16 == 0] == 0) and len(np.unique(col.reshape(-1, 3), axis=0)) == 3
    d = cv2.imread(str(a / "right/disparity/000001.png"), cv2.IMREAD_UNCHANGED)
    assert np.array_equal(d, disparity_to_png16(_fxb_over_z(seq.depth(1, "right"))))
    info = json.loads((a / "export.json").read_text())
    assert info["noise"] == {"sigma": 4.0, "seed": 9} and info["source_frames"] == [0, 1, 2, 3]


def test_frame_range_keeps_each_frames_noise(render, tmp_path):
    full = export(render, "png", tmp_path / "full", progress=False)
    part = export(render, "png", tmp_path / "part", frames="2:4", progress=False)
    assert sorted(p.name for p in (part / "left/rgb").iterdir()) == ["000000.png", "000001.png"]
    assert (part / "left/rgb/000000.png").read_bytes() == (full / "left/rgb/000002.png").read_bytes()
    k = export(render, "kitti-folder", tmp_path / "k", frames="1:", progress=False)
    T = np.array([[float(x) for x in l.split()] for l in (k / "poses.txt").read_text().splitlines()])
    assert T.shape == (3, 12) and np.allclose(T[0], np.eye(4)[:3].ravel())


def test_parse_frames():
    assert parse_frames("2:5", 10) == range(2, 5)
    assert parse_frames(":3", 10) == range(0, 3)
    assert parse_frames("7:", 10) == range(7, 10)
    assert parse_frames("4", 10) == range(4, 5)
    assert parse_frames(None, 3) == range(3)
    for bad in ("5:2", "x:y", "12"):
        with pytest.raises(VoError):
            parse_frames(bad, 10)


def test_errors_exit_2_with_one_line(render, tmp_path, capsys):
    assert _cli(tmp_path / "none", tmp_path / "o", "--to", "png") == 2
    assert "no manifest.json" in capsys.readouterr().err
    broken = tmp_path / "broken"
    shutil.copytree(render, broken)
    (broken / "exr/left/000002.exr").unlink()
    assert _cli(broken, tmp_path / "o", "--to", "kitti-odometry") == 2
    assert "1 frame(s) not rendered completely (2)" in capsys.readouterr().err
    assert _cli(broken, tmp_path / "o2", "--to", "kitti-odometry", "--frames", "0:2") == 0
    assert _cli(render, render, "--to", "png") == 2
    assert _cli(render, tmp_path / "o3", "--to", "png", "--opt", "novalue") == 2


def test_registry_accepts_a_new_target(render, tmp_path):
    seen = {}

    def fake(seq, out, opts):
        seen["frames"], seen["noise"], seen["extra"] = list(opts.frames), opts.noise, opts.extra

    register_exporter("fake-test", fake, "test only")
    try:
        export(render, "fake-test", tmp_path / "f", frames="1:3", noise=(2.0, 3), extra={"a": "b"})
        assert seen == {"frames": [1, 2], "noise": (2.0, 3), "extra": {"a": "b"}}
    finally:
        del EXPORTERS["fake-test"]


def test_progress_in_a_pipe_is_plain_lines_and_json_parses(render, tmp_path):
    """stderr is a pipe here: whole lines with ETA, never a carriage return; json: one object a line."""
    r = subprocess.run([sys.executable, "-m", "vo_reference", "export", str(render), str(tmp_path / "o"),
                        "--to", "png"], capture_output=True, timeout=120)
    err = r.stderr.decode()
    assert r.returncode == 0, err
    assert "\r" not in err and err.endswith("\n")
    lines = err.splitlines()
    assert lines[-1].startswith("export png: 8/8 (100%)") and all(l.startswith("export png: ") for l in lines)
    r = subprocess.run([sys.executable, "-m", "vo_reference", "export", str(render), str(tmp_path / "j"),
                        "--to", "kitti-folder", "--progress", "json"], capture_output=True, timeout=120)
    assert r.returncode == 0, r.stderr.decode()
    events = [json.loads(line) for line in r.stderr.decode().splitlines()]
    assert [e["event"] for e in events] == ["start"] + ["progress"] * 4 + ["end"]
    assert events[-1]["status"] == "ok" and events[-2]["done"] == events[-2]["total"] == 4
    assert "exported" in r.stdout.decode()


def test_mono_render_exports(tmp_path):
    from synthetic_render import plane_scene
    root = plane_scene(tmp_path / "mono", stereo=False, frames=2)
    out = export(root, "kitti-folder", tmp_path / "k", progress=False)
    assert (out / "image_0/000001.png").is_file() and not (out / "image_1").exists()
    out = export(root, "kitti-odometry", tmp_path / "kd", progress=False)
    assert (out / "image_0/000001.png").is_file() and not (out / "image_1").exists()
    export(root, "png", tmp_path / "p", progress=False)
    assert not (tmp_path / "p/left/disparity").exists()
    with pytest.raises(VoError, match="needs a stereo render"):
        export(root, "kitti-stereo", tmp_path / "s", progress=False)
