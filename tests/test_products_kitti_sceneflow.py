"""The ``kitti-sceneflow`` export: KITTI scene flow 2015 layout, read back by a reader written
from the KITTI devkit's readme (below, independent of vo_reference) and by our own readers,
and compared with the ray-cast oracle of tests/dynamic_scene.py.

From the devkit readme (stereo/flow/scene flow 2015): disparity maps are uint16 PNGs,
``disp = I / 256``, ``valid = I > 0``; flow maps are 3-channel uint16 PNGs with
``flow_u = (I[...,1] - 2^15) / 64``, ``flow_v = (I[...,2] - 2^15) / 64``, ``valid = I[...,3]``
(channels 1..3 = R, G, B; OpenCV loads them as B, G, R); ``disp_1`` is the second pair's
disparity mapped into the reference frame via the flow; the evaluation code reads
``obj_map`` as an 8-bit map, 0 = background, > 0 = foreground. Files ``xxxxxx_10.png`` /
``xxxxxx_11.png``.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

import dynamic_scene as ds
import raycast
from test_products_scene_flow import _near_edge, _oracle

from vo_reference.products.disparity import read_disparity_png16
from vo_reference.products.exports import export
from vo_reference.products.flow import read_kitti_flow_png

REPO = Path(__file__).resolve().parents[1]
FOLDERS = ("image_2", "image_3", "disp_occ_0", "disp_noc_0", "disp_occ_1", "disp_noc_1", "flow_occ", "flow_noc",
           "obj_map", "instance_map", "motion_mask")


# --- an independent reader, from the devkit's readme --------------------------------------

def devkit_disp(path):
    I = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert I.dtype == np.uint16 and I.ndim == 2
    return I.astype(np.float64) / 256.0, I > 0


def devkit_flow(path):
    I = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert I.dtype == np.uint16 and I.shape[2] == 3
    R, G, B = I[..., 2].astype(np.float64), I[..., 1].astype(np.float64), I[..., 0]
    return np.stack([(R - 2**15) / 64.0, (G - 2**15) / 64.0], axis=-1), B.astype(bool)


def devkit_obj_map(path):
    I = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert I.dtype == np.uint8 and I.ndim == 2
    return I


# --- the export ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    d = tmp_path_factory.mktemp("ksf")
    scene = ds.make_scene()
    root = ds.write(d / "render", scene)
    out = export(root, "kitti-sceneflow", d / "kitti", progress=False, noise=None)
    return scene, root, out


def test_layout(exported):
    _, _, out = exported
    for folder in FOLDERS:
        names = sorted(p.name for p in (out / folder).iterdir())
        if folder.startswith("image_"):
            assert names == ["000000_10.png", "000000_11.png", "000001_10.png", "000001_11.png"]
        else:
            assert names == ["000000_10.png", "000001_10.png"], folder
    assert sorted(p.name for p in (out / "calib_cam_to_cam").iterdir()) == ["000000.txt", "000001.txt"]
    assert (out / "export.json").is_file() and not (out / "calib.txt").exists()
    assert (out / "pairs.txt").read_text().splitlines()[1:] == ["000000 0 1", "000001 1 2"]
    # the _11 images are the _10 images of the next pair's source frame
    a = cv2.imread(str(out / "image_2" / "000000_11.png"))
    b = cv2.imread(str(out / "image_2" / "000001_10.png"))
    assert np.array_equal(a, b)


@pytest.mark.slow
@pytest.mark.parametrize("pair", [0, 1])
def test_ground_truth_read_back_matches_the_oracle(exported, pair):
    scene, _, out = exported
    k = pair
    n10 = f"{pair:06d}_10.png"
    flow, _, z_t, ids, hit, inside, vis, u, v = _oracle(scene, k, k + 1)
    fB = ds.K[0, 0] * ds.BASELINE
    z0 = ds.truth(scene, k)[0]
    # disparity of frame k
    d0, ok0 = devkit_disp(out / "disp_occ_0" / n10)
    assert np.array_equal(ok0, hit)
    assert np.abs(d0[hit] - fB / z0[hit]).max() <= 1 / 512 + 1e-6
    # disparity at k+1 of each frame-k pixel's (moved) point, in the reference frame
    d1, ok1 = devkit_disp(out / "disp_occ_1" / n10)
    assert np.array_equal(ok1, hit & (z_t > 0))
    assert np.abs(d1[ok1] - fB / z_t[ok1]).max() <= 1 / 512 + 1e-6
    dyn = np.isin(ids, [3, 4]) & hit
    assert np.abs(d1[dyn] - d0[dyn]).max() > 0.05      # the movers change their disparity
    # flow k -> k+1
    f, okf = devkit_flow(out / "flow_occ" / n10)
    assert np.array_equal(okf, hit)
    assert np.abs(f[okf] - flow[okf]).max() <= 1 / 128 + 1e-6
    # noc: visible at k+1 (flow) and, for disp_1, in the right image at k+1 too
    _, ok_noc = devkit_flow(out / "flow_noc" / n10)
    _, ok_d1noc = devkit_disp(out / "disp_noc_1" / n10)
    assert not (ok_d1noc & ~ok_noc).any()
    T_r = scene.T_right()[k + 1]
    ids_r = ds.truth(scene, k + 1, "right")[1]
    vv, uu = np.mgrid[0:ds.H, 0:ds.W].astype(float)
    X, _ = raycast.hit_point(scene.prims(k), ds.K, scene.T_left[k], uu, vv)
    checked = disagree = 0
    for y, x in zip(*np.nonzero(ok_noc)):
        M = scene.M[ids[y, x]][k + 1] @ np.linalg.inv(scene.M[ids[y, x]][k]) if ids[y, x] in scene.M else np.eye(4)
        Xw = M[:3, :3] @ X[y * ds.W + x] + M[:3, 3]
        Xc = np.linalg.inv(T_r) @ np.append(Xw, 1.0)
        ur = ds.K[0, 0] * Xc[0] / Xc[2] + ds.K[0, 2]
        vr = ds.K[1, 1] * Xc[1] / Xc[2] + ds.K[1, 2]
        inside_r = -0.5 <= ur < ds.W - 0.5 and -0.5 <= vr < ds.H - 0.5
        if inside_r and _near_edge(ids_r, ur, vr):
            continue
        truth = inside_r and bool(raycast.visible(scene.prims(k + 1), T_r, Xw[None])[0])
        checked += 1
        disagree += truth != bool(ok_d1noc[y, x])
    assert checked > 0.7 * ok_noc.sum() and disagree == 0
    # object map (0 background, rank of the mover), instance ids, motion mask
    obj = devkit_obj_map(out / "obj_map" / n10)
    expected = np.where(hit & (ids == 3), 1, np.where(hit & (ids == 4), 2, 0))
    assert np.array_equal(obj, expected)
    assert np.array_equal(cv2.imread(str(out / "instance_map" / n10), cv2.IMREAD_UNCHANGED), ids)
    assert np.array_equal(cv2.imread(str(out / "motion_mask" / n10), cv2.IMREAD_UNCHANGED) == 255, dyn)


def test_our_readers_agree_with_the_devkit_reader(exported):
    _, _, out = exported
    for name in ("000000_10.png", "000001_10.png"):
        f_ours, ok_ours = read_kitti_flow_png(out / "flow_occ" / name)
        f_dk, ok_dk = devkit_flow(out / "flow_occ" / name)
        assert np.array_equal(ok_ours, ok_dk) and np.array_equal(f_ours[ok_ours], f_dk[ok_dk].astype(np.float32))
        for folder in ("disp_occ_0", "disp_occ_1", "disp_noc_1"):
            d_ours = read_disparity_png16(out / folder / name)
            d_dk, ok = devkit_disp(out / folder / name)
            assert np.array_equal(np.isfinite(d_ours), ok) and np.array_equal(d_ours[ok], d_dk[ok].astype(np.float32))


def test_cli_and_errors(exported, tmp_path):
    _, root, _ = exported
    r = subprocess.run([sys.executable, "-m", "vo_reference", "export", str(root), str(tmp_path / "k"),
                        "--to", "kitti-sceneflow", "--frames", "1:", "-q"], cwd=REPO, capture_output=True, text=True,
                       env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in (tmp_path / "k" / "flow_occ").iterdir()) == ["000000_10.png"]
    r = subprocess.run([sys.executable, "-m", "vo_reference", "export", str(root), str(tmp_path / "k2"),
                        "--to", "kitti-sceneflow", "--frames", "2:", "-q"], cwd=REPO, capture_output=True, text=True,
                       env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 2 and "no rendered successor" in r.stderr and "Traceback" not in r.stderr
