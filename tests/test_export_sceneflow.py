"""``--to sceneflow``: FlyingThings3D's tree, PFMs read with a reader written from the PFM
definition (tests/format_readers.py), against the closed-form scene of tests/layout_scene.py."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vo_reference.commands.main import main as cli_main
from vo_reference.io.render import RenderSequence

from format_readers import read_pfm
from layout_scene import B, H, K, W, export_fixture, export_layout, raycast, view_pose

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 3
SEQ = "TRAIN/A/0000"


exported = export_fixture("sceneflow", "FlyingThings3D")


def test_tree_and_names(exported, layout_render):
    seq = RenderSequence(layout_render)
    for view, L in (("left", "L"), ("right", "R")):
        assert sorted(p.name for p in (exported / "frames_cleanpass" / SEQ / view).iterdir()) == ["0000.png", "0001.png", "0002.png"]
        assert sorted(p.name for p in (exported / "disparity" / SEQ / view).iterdir()) == ["0000.pfm", "0001.pfm", "0002.pfm"]
        fut = exported / "optical_flow" / SEQ / "into_future" / view
        past = exported / "optical_flow" / SEQ / "into_past" / view
        # one file per frame in both directions, as FlyingThings3D ships them
        assert sorted(p.name for p in fut.iterdir()) == [f"OpticalFlowIntoFuture_{i:04d}_{L}.pfm" for i in range(N)]
        assert sorted(p.name for p in past.iterdir()) == [f"OpticalFlowIntoPast_{i:04d}_{L}.pfm" for i in range(N)]
        for when in ("into_future", "into_past"):
            assert sorted(p.name for p in (exported / "disparity_change" / SEQ / when / view).iterdir()) == \
                [f"{i:04d}.pfm" for i in range(N)]
        img = cv2.imread(str(exported / "frames_cleanpass" / SEQ / view / "0001.png"))[..., ::-1]
        assert np.array_equal(img, seq.image_rgb(1, view))
    assert (exported / "frames_cleanpass" / SEQ / "export.json").is_file()
    assert (exported / "disparity" / SEQ / "left/0000.pfm").read_bytes()[:3] == b"Pf\n"
    assert (exported / "optical_flow" / SEQ / "into_future/left/OpticalFlowIntoFuture_0000_L.pfm").read_bytes()[:3] == b"PF\n"


def test_disparity_both_views(exported):
    for k in range(N):
        zl, _ = raycast(view_pose(N, k, "left"))
        zr, _ = raycast(view_pose(N, k, "right"))
        dl = read_pfm(exported / "disparity" / SEQ / "left" / f"{k:04d}.pfm")
        dr = read_pfm(exported / "disparity" / SEQ / "right" / f"{k:04d}.pfm")
        for d, z in ((dl, zl), (dr, zr)):
            exp = np.where(np.isfinite(z), K[0, 0] * B / np.where(np.isfinite(z), z, 1), 0.0)
            assert d.shape == (H, W) and np.allclose(d, exp, rtol=1e-5, atol=1e-6)
        # the right view's disparity is positive and points back to the left image: x_left = x_right + d
        y, x = H - 3, W // 2
        xl = int(round(x + dr[y, x]))
        assert dr[y, x] > 0 and abs(dl[y, xl] - dr[y, x]) < 0.05


def closed_form_flow(k: int, kt: int, view: str, n: int = N):
    """(flow (H, W, 2), depth of the moved point, source depth) from the ray-cast scene."""
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    r = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1)
    Ts, Tt = view_pose(n, k, view), view_pose(n, kt, view)
    z, _ = raycast(Ts)
    fin = np.isfinite(z)
    Xt = np.where(fin[..., None], (Ts[:3, 3] + (r * np.where(fin, z, 0)[..., None]) @ Ts[:3, :3].T - Tt[:3, 3]) @ Tt[:3, :3],
                  (r @ Ts[:3, :3].T) @ Tt[:3, :3])
    p = Xt @ K.T
    return np.stack([p[..., 0] / p[..., 2] - u, p[..., 1] / p[..., 2] - v], -1), Xt[..., 2], z


def test_flow_and_disparity_change_into_future_and_past(exported):
    for view, L in (("left", "L"), ("right", "R")):
        for k, kt, when, word in ((0, 1, "into_future", "Future"), (2, 1, "into_past", "Past")):
            exp, zt, z = closed_form_flow(k, kt, view)
            fin = np.isfinite(z)
            f = read_pfm(exported / "optical_flow" / SEQ / when / view / f"OpticalFlowInto{word}_{k:04d}_{L}.pfm")
            assert f.shape == (H, W, 3) and np.all(f[..., 2] == 0)
            assert np.abs(f[..., :2] - exp).max() < 1e-3                   # dense: sky flows with the rotation
            dc = read_pfm(exported / "disparity_change" / SEQ / when / view / f"{k:04d}.pfm")
            fB = K[0, 0] * B
            exp_dc = np.where(fin, fB / np.where(fin, zt, 1) - fB / np.where(fin, z, 1), 0.0)
            assert np.allclose(dc, exp_dc, rtol=1e-4, atol=1e-5) and np.abs(dc[fin]).max() > 0


def position_indexed_pairs(root, direction: str, camera: str = "left"):
    """torchvision's FlyingThings3D (taken from RAFT): image and flow files of each sequence
    sorted by name and paired by position, ``len(flows) - 1`` pairs per direction."""
    from glob import glob
    out = []
    for seq_dir in sorted(glob(str(root / "frames_cleanpass" / "TRAIN" / "*" / "*"))):
        rel = seq_dir[len(str(root / "frames_cleanpass")) + 1:]
        images = sorted(glob(f"{seq_dir}/{camera}/*.png"))
        flows = sorted(glob(str(root / "optical_flow" / rel / direction / camera / "*.pfm")))
        for i in range(len(flows) - 1):
            if direction == "into_future":
                out.append((images[i], images[i + 1], flows[i]))
            else:
                out.append((images[i + 1], images[i], flows[i + 1]))
    return out


@pytest.mark.parametrize("camera", ["left", "right"])
def test_loaders_that_pair_files_by_position_get_the_right_flow(exported, camera):
    """The bug of a sparse export: without the boundary files the into-past flow of frame
    k+2 was paired with the images k+1 -> k. Every pair must carry the flow of its own two
    frames (the closed-form scene's)."""
    for direction in ("into_future", "into_past"):
        pairs = position_indexed_pairs(exported, direction, camera)
        assert len(pairs) == N - 1
        for img1, img2, flo in pairs:
            k1, k2 = int(Path(img1).stem), int(Path(img2).stem)
            exp, _, _ = closed_form_flow(k1, k2, camera)
            assert np.abs(read_pfm(flo)[..., :2] - exp).max() < 1e-3, (direction, img1, img2, flo)


def test_boundary_files_flow_to_the_rendered_neighbour_or_hold_nan(layout_render, tmp_path):
    """The last exported frame flows into the next rendered frame (not exported, as
    FlyingThings3D's own boundary files); at the ends of the render there is no frame:
    NaN (never read by position-indexed loaders)."""
    out = export_layout(layout_render, tmp_path / "ft", "sceneflow", "--frames", "0:2")
    fut = read_pfm(out / "optical_flow" / SEQ / "into_future/left/OpticalFlowIntoFuture_0001_L.pfm")
    exp, _, _ = closed_form_flow(1, 2, "left")
    assert np.abs(fut[..., :2] - exp).max() < 1e-3
    past = read_pfm(out / "optical_flow" / SEQ / "into_past/left/OpticalFlowIntoPast_0000_L.pfm")
    assert np.isnan(past[..., :2]).all()
    assert np.isnan(read_pfm(out / "disparity_change" / SEQ / "into_past/left/0000.pfm")).all()
    dc = read_pfm(out / "disparity_change" / SEQ / "into_future/left/0001.pfm")
    assert np.isfinite(dc).all()


def test_several_sequences_share_one_tree(layout_render, exported, tmp_path, capsys):
    out = tmp_path / "ft"
    assert cli_main(["export", str(layout_render), str(out), "--to", "sceneflow", "-q"]) == 0
    before = (out / "disparity" / SEQ / "left/0000.pfm").read_bytes()
    assert cli_main(["export", str(layout_render), str(out), "--to", "sceneflow", "--sequence", "TRAIN/A/0001",
                     "--frames", "1:", "-q"]) == 0
    assert (out / "disparity" / SEQ / "left/0000.pfm").read_bytes() == before
    assert len(list((out / "disparity/TRAIN/A/0001/left").iterdir())) == 2
    # exporting the same slot again replaces it; a foreign folder in a slot is refused
    assert cli_main(["export", str(layout_render), str(out), "--to", "sceneflow", "--frames", "0:2", "-q"]) == 0
    assert len(list((out / "disparity" / SEQ / "left").iterdir())) == 2
    (out / "disparity/TRAIN/B/0000/left").mkdir(parents=True)
    (out / "disparity/TRAIN/B/0000/left/0006.pfm").write_bytes(b"real data")
    assert cli_main(["export", str(layout_render), str(out), "--to", "sceneflow", "--sequence", "TRAIN/B/0000", "-q"]) == 2
    assert "not an export of ours" in capsys.readouterr().err
    assert (out / "disparity/TRAIN/B/0000/left/0006.pfm").read_bytes() == b"real data"
    assert not (out / "frames_cleanpass/TRAIN/B/0000").exists()
    assert not [p for p in out.rglob(".*part*")]
