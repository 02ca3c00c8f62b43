"""``--to kitti-odometry``: the odometry development kit's tree, read back by pykitti (the
reader KITTI users run) and by our own KITTI reader; several renders in one dataset."""
from __future__ import annotations

import datetime as dt
import json

import numpy as np
import pytest

from vo_reference.commands.main import main as cli_main
from vo_reference.io.render import RenderSequence
from vo_reference.io.sequence import open_sequence
from vo_reference.exporters.driver import export

from layout_scene import B, K, export_fixture, write_layout_render

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 4


dataset = export_fixture("kitti-odometry", ".", "--sequence", "7", part="dataset", name="dataset")


def test_pykitti_reads_the_tree(layout_render, dataset):
    pykitti = pytest.importorskip("pykitti", reason="pykitti is in the test extra")
    seq = RenderSequence(layout_render)
    data = pykitti.odometry(str(dataset), "07")
    assert len(data) == N
    for Kc in (data.calib.K_cam0, data.calib.K_cam1, data.calib.K_cam2, data.calib.K_cam3):
        assert np.allclose(Kc, K)
    assert data.calib.b_gray == pytest.approx(B) and data.calib.b_rgb == pytest.approx(B)
    assert data.timestamps == [dt.timedelta(seconds=0.1 * k) for k in range(N)]
    T = seq.T_world_cam("left")
    assert len(data.poses) == N
    assert np.allclose(np.array(data.poses), np.linalg.inv(T[0]) @ T, atol=1e-9)
    assert np.array_equal(np.array(data.get_cam0(2)), seq.image_gray(2, "left"))
    assert np.array_equal(np.array(data.get_cam1(3)), seq.image_gray(3, "right"))
    assert np.array_equal(np.array(data.get_cam2(1)), seq.image_rgb(1, "left"))
    assert np.array_equal(np.array(data.get_cam3(0)), seq.image_rgb(0, "right"))


def test_our_reader_finds_the_kit_poses(layout_render, dataset):
    ks = open_sequence(dataset / "sequences" / "07")
    T = RenderSequence(layout_render).T_world_cam("left")
    assert ks.num_frames == N and ks.baseline_m == pytest.approx(B)
    assert np.allclose(ks.T_world_cam("left"), np.linalg.inv(T[0]) @ T, atol=1e-9)
    info = json.loads((dataset / "sequences/07/export.json").read_text())
    assert info["target"] == "kitti-odometry" and info["sequence"] == "7" and info["source_frames"] == [0, 1, 2, 3]


def test_several_renders_into_one_dataset(layout_render, tmp_path, capsys):
    out = tmp_path / "kitti"
    mono = write_layout_render(tmp_path / "mono", n=2, stereo=False)
    assert cli_main(["export", str(layout_render), str(out), "--to", "kitti-odometry", "-q"]) == 0          # 00
    assert cli_main(["export", str(mono), str(out), "--to", "kitti-odometry", "--sequence", "03", "-q"]) == 0
    seqs = out / "dataset" / "sequences"
    assert sorted(p.name for p in seqs.iterdir()) == ["00", "03"]
    assert sorted(p.name for p in (out / "dataset" / "poses").iterdir()) == ["00.txt", "03.txt"]
    assert not (seqs / "03" / "image_1").exists() and len(list((seqs / "03" / "image_0").iterdir())) == 2
    kept = {p: p.read_bytes() for p in (seqs / "03").rglob("*") if p.is_file()}
    # re-exporting 00 with fewer frames replaces 00 whole and leaves 03 alone
    assert cli_main(["export", str(layout_render), str(out), "--to", "kitti-odometry", "--sequence", "00",
                     "--frames", "1:3", "-q"]) == 0
    assert len(list((seqs / "00" / "image_0").iterdir())) == 2
    assert len((out / "dataset/poses/00.txt").read_text().splitlines()) == 2
    assert {p: p.read_bytes() for p in (seqs / "03").rglob("*") if p.is_file()} == kept
    # real data in a slot is never replaced
    (seqs / "05" / "image_0").mkdir(parents=True)
    (seqs / "05" / "calib.txt").write_text("P0: real\n")
    assert cli_main(["export", str(layout_render), str(out), "--to", "kitti-odometry", "--sequence", "5", "-q"]) == 2
    assert "not an export of ours" in capsys.readouterr().err and (seqs / "05/calib.txt").read_text() == "P0: real\n"
    for bad in ("x1", "-2"):
        assert cli_main(["export", str(layout_render), str(out), "--to", "kitti-odometry", "--sequence", bad, "-q"]) == 2
    assert cli_main(["export", str(layout_render), str(out / "t"), "--to", "tum", "--sequence", "1", "-q"]) == 2
    assert "does not apply" in capsys.readouterr().err


def test_an_interrupted_export_leaves_the_old_sequence(layout_render, tmp_path, monkeypatch):
    out = tmp_path / "kitti"
    export(layout_render, "kitti-odometry", out, progress=False)
    old = (out / "dataset/sequences/00/image_2/000003.png").read_bytes()
    old_poses = (out / "dataset/poses/00.txt").read_text()
    import vo_reference.exporters.kitti_odometry as ko
    calls = {"n": 0}
    real = ko.write_png_rgb

    def failing(path, img):
        calls["n"] += 1
        if calls["n"] == 5:
            raise KeyboardInterrupt
        return real(path, img)

    monkeypatch.setattr(ko, "write_png_rgb", failing)
    with pytest.raises(KeyboardInterrupt):
        export(layout_render, "kitti-odometry", out, noise=(9.0, 1), progress=False)
    assert (out / "dataset/sequences/00/image_2/000003.png").read_bytes() == old
    assert (out / "dataset/poses/00.txt").read_text() == old_poses
    assert sorted(p.name for p in (out / "dataset/sequences").iterdir()) == ["00"]
    assert not list((out / "dataset").rglob(".*"))
