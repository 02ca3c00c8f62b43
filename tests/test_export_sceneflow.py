"""``--to sceneflow``: FlyingThings3D's tree, PFMs read with a reader written from the PFM
definition (tests/format_readers.py), against the closed-form scene of tests/layout_scene.py."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.cli import main as cli_main
from vo_reference.io.render import RenderSequence

from format_readers import read_pfm
from layout_scene import B, H, K, W, export_layout, raycast, view_pose

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 3
SEQ = "TRAIN/A/0000"


@pytest.fixture(scope="module")
def render(layout_render):
    return layout_render


@pytest.fixture(scope="module")
def exported(render, tmp_path_factory):
    out = tmp_path_factory.mktemp("sf_out") / "FlyingThings3D"
    return export_layout(render, out, "sceneflow")


def test_tree_and_names(exported, render):
    seq = RenderSequence(render)
    for view, L in (("left", "L"), ("right", "R")):
        assert sorted(p.name for p in (exported / "frames_cleanpass" / SEQ / view).iterdir()) == ["0000.png", "0001.png", "0002.png"]
        assert sorted(p.name for p in (exported / "disparity" / SEQ / view).iterdir()) == ["0000.pfm", "0001.pfm", "0002.pfm"]
        fut = exported / "optical_flow" / SEQ / "into_future" / view
        past = exported / "optical_flow" / SEQ / "into_past" / view
        assert sorted(p.name for p in fut.iterdir()) == [f"OpticalFlowIntoFuture_{i:04d}_{L}.pfm" for i in (0, 1)]
        assert sorted(p.name for p in past.iterdir()) == [f"OpticalFlowIntoPast_{i:04d}_{L}.pfm" for i in (1, 2)]
        assert sorted(p.name for p in (exported / "disparity_change" / SEQ / "into_future" / view).iterdir()) == ["0000.pfm", "0001.pfm"]
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


def test_flow_and_disparity_change_into_future_and_past(exported):
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    r = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1)
    for view, L in (("left", "L"), ("right", "R")):
        for k, kt, when, word in ((0, 1, "into_future", "Future"), (2, 1, "into_past", "Past")):
            Ts, Tt = view_pose(N, k, view), view_pose(N, kt, view)
            z, _ = raycast(Ts)
            fin = np.isfinite(z)
            Xt = np.where(fin[..., None], (Ts[:3, 3] + (r * np.where(fin, z, 0)[..., None]) @ Ts[:3, :3].T - Tt[:3, 3]) @ Tt[:3, :3],
                          (r @ Ts[:3, :3].T) @ Tt[:3, :3])
            p = Xt @ K.T
            exp = np.stack([p[..., 0] / p[..., 2] - u, p[..., 1] / p[..., 2] - v], -1)
            f = read_pfm(exported / "optical_flow" / SEQ / when / view / f"OpticalFlowInto{word}_{k:04d}_{L}.pfm")
            assert f.shape == (H, W, 3) and np.all(f[..., 2] == 0)
            assert np.abs(f[..., :2] - exp).max() < 1e-3                   # dense: sky flows with the rotation
            dc = read_pfm(exported / "disparity_change" / SEQ / when / view / f"{k:04d}.pfm")
            fB = K[0, 0] * B
            exp_dc = np.where(fin, fB / np.where(fin, Xt[..., 2], 1) - fB / np.where(fin, z, 1), 0.0)
            assert np.allclose(dc, exp_dc, rtol=1e-4, atol=1e-5) and np.abs(dc[fin]).max() > 0


def test_several_sequences_share_one_tree(render, exported, tmp_path, capsys):
    out = tmp_path / "ft"
    assert cli_main(["export", str(render), str(out), "--to", "sceneflow", "-q"]) == 0
    before = (out / "disparity" / SEQ / "left/0000.pfm").read_bytes()
    assert cli_main(["export", str(render), str(out), "--to", "sceneflow", "--sequence", "TRAIN/A/0001",
                     "--frames", "1:", "-q"]) == 0
    assert (out / "disparity" / SEQ / "left/0000.pfm").read_bytes() == before
    assert len(list((out / "disparity/TRAIN/A/0001/left").iterdir())) == 2
    # exporting the same slot again replaces it; a foreign folder in a slot is refused
    assert cli_main(["export", str(render), str(out), "--to", "sceneflow", "--frames", "0:2", "-q"]) == 0
    assert len(list((out / "disparity" / SEQ / "left").iterdir())) == 2
    (out / "disparity/TRAIN/B/0000/left").mkdir(parents=True)
    (out / "disparity/TRAIN/B/0000/left/0006.pfm").write_bytes(b"real data")
    assert cli_main(["export", str(render), str(out), "--to", "sceneflow", "--sequence", "TRAIN/B/0000", "-q"]) == 2
    assert "not an export of ours" in capsys.readouterr().err
    assert (out / "disparity/TRAIN/B/0000/left/0006.pfm").read_bytes() == b"real data"
    assert not (out / "frames_cleanpass/TRAIN/B/0000").exists()
    assert not [p for p in out.rglob(".*part*")]
