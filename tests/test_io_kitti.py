"""KITTI odometry reader: real data from ../shared/data and small synthetic folders."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.errors import VoError
from vo_reference.io.kitti import KittiSequence, read_kitti_calib
from vo_reference.io.sequence import Sequence, open_sequence


@pytest.mark.data
def test_real_kitti_sequence_1(shared_data):
    seq = open_sequence(shared_data / "kitti" / "sequence_1")
    assert isinstance(seq, KittiSequence) and isinstance(seq, Sequence)
    assert seq.num_frames == 51 and seq.views == ("left", "right")
    assert seq.resolution == (1226, 370)
    assert seq.K[0, 0] == pytest.approx(707.0912) and seq.K[1, 1] == pytest.approx(707.0912)
    assert seq.K[0, 2] == pytest.approx(601.8873) and seq.K[1, 2] == pytest.approx(183.1104)
    assert seq.baseline_m == pytest.approx(379.8145 / 707.0912) and round(seq.baseline_m, 3) == 0.537
    T = seq.T_world_cam("left")
    assert T.shape == (51, 4, 4) and np.allclose(T[0], np.eye(4), atol=1e-9)
    assert np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1).sum() == pytest.approx(60, rel=0.1)
    Tr = seq.T_world_cam("right")
    assert np.allclose(np.linalg.inv(T[10]) @ Tr[10], [[1, 0, 0, seq.baseline_m], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    g = seq.image_gray(50, "right")
    assert g.dtype == np.uint8 and g.shape == (370, 1226) and g.std() > 10
    rgb = seq.image_rgb(0)
    assert rgb.shape == (370, 1226, 3) and np.array_equal(rgb[..., 0], seq.image_gray(0))
    assert seq.depth(0) is None and seq.ids(0) is None
    assert seq.timestamps_s.shape == (51,)


def _kitti_folder(root, *, prefixes: bool, pair=("image_0", "image_1"), n=3, colour=False, poses=True, times=True):
    import cv2
    f, cx, cy, B = 700.0, 20.5, 10.5, 0.54
    P = {"P0": [[f, 0, cx, 0], [0, f, cy, 0], [0, 0, 1, 0]],
         "P1": [[f, 0, cx, -f * B], [0, f, cy, 0], [0, 0, 1, 0]],
         "P2": [[f, 0, cx, f * 0.06], [0, f, cy, 0], [0, 0, 1, 0]],
         "P3": [[f, 0, cx, -f * 0.47], [0, f, cy, 0], [0, 0, 1, 0]]}
    lines = [(f"{k}: " if prefixes else "") + " ".join(f"{x:.12e}" for x in np.ravel(v)) for k, v in P.items()]
    if prefixes:
        lines.append("Tr: " + " ".join(["1", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1", "0"]))
    root.mkdir(parents=True)
    (root / "calib.txt").write_text("\n".join(lines) + "\n")
    rng = np.random.default_rng(0)
    for d in pair:
        (root / d).mkdir()
        for k in range(n):
            img = rng.integers(0, 255, (22, 42, 3) if colour else (22, 42), dtype=np.uint8)
            cv2.imwrite(str(root / d / f"{k:06d}.png"), img)
    if poses:
        T = np.tile(np.eye(4), (n, 1, 1))
        T[:, 2, 3] = np.arange(n) * 1.5
        (root / "poses.txt").write_text("\n".join(" ".join(map(str, t[:3].ravel())) for t in T) + "\n")
    if times:
        (root / "times.txt").write_text("\n".join(f"{0.1037 * k:.6e}" for k in range(n)) + "\n")
    return root


def test_calib_with_prefixes_and_grey_pair(tmp_path):
    seq = open_sequence(_kitti_folder(tmp_path / "s", prefixes=True))
    assert seq.K[0, 0] == 700.0 and seq.baseline_m == pytest.approx(0.54)
    assert seq.timestamps_s[2] == pytest.approx(0.2074)
    assert seq.image_rgb(1).shape == (22, 42, 3)
    assert "Tr" in read_kitti_calib(tmp_path / "s" / "calib.txt")


def test_colour_pair_uses_p2_p3(tmp_path):
    seq = open_sequence(_kitti_folder(tmp_path / "s", prefixes=False, pair=("image_2", "image_3"), colour=True))
    assert seq.baseline_m == pytest.approx(0.53)
    T = seq.T_world_cam("left")
    # poses.txt is cam0; cam2 sits 0.06 m to its left (P2[0,3] = +f*0.06)
    assert np.allclose(T[1][:3, 3], [-0.06, 0, 1.5])
    import cv2
    bgr = cv2.imread(str(tmp_path / "s/image_2/000001.png"))
    assert np.array_equal(seq.image_rgb(1), bgr[..., ::-1])
    assert np.array_equal(seq.image_gray(1), cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY))


def test_development_kit_layout_finds_its_poses(tmp_path):
    # dataset/sequences/07/{image_0,image_1,calib.txt} with dataset/poses/07.txt
    root = _kitti_folder(tmp_path / "dataset" / "sequences" / "07", prefixes=True)
    (tmp_path / "dataset" / "poses").mkdir()
    (root / "poses.txt").rename(tmp_path / "dataset" / "poses" / "07.txt")
    seq = open_sequence(root)
    assert seq.poses_path == tmp_path / "dataset" / "poses" / "07.txt"
    assert np.allclose(seq.T_world_cam("left")[2][:3, 3], [0, 0, 3.0])
    other = _kitti_folder(tmp_path / "elsewhere" / "07", prefixes=True, poses=False)  # not under sequences/
    assert KittiSequence(other).T_world_cam() is None


def test_without_poses_and_times(tmp_path):
    seq = KittiSequence(_kitti_folder(tmp_path / "s", prefixes=False, poses=False, times=False))
    assert seq.T_world_cam() is None
    assert np.allclose(seq.timestamps_s, [0, 0.1, 0.2])


def test_errors(tmp_path):
    root = _kitti_folder(tmp_path / "s", prefixes=True)
    (root / "image_1" / "000002.png").unlink()
    with pytest.raises(VoError, match="3 left images but 2 right"):
        KittiSequence(root)
    root = _kitti_folder(tmp_path / "t", prefixes=True)
    (root / "poses.txt").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n")
    with pytest.raises(VoError, match="1 poses for 3 frames"):
        KittiSequence(root)
    root = _kitti_folder(tmp_path / "u", prefixes=True)
    (root / "calib.txt").write_text("P0: 1 2 3\n")
    with pytest.raises(VoError, match="no P0"):
        KittiSequence(root)
    root = _kitti_folder(tmp_path / "v", prefixes=True)
    (root / "image_0" / "000001.png").write_bytes(b"garbage")
    with pytest.raises(VoError, match="000001.png: not a readable image"):
        KittiSequence(root).image_gray(1)


@pytest.mark.parametrize("second", ["P0: 800 0 300 0 0 800 200 0 0 0 1 0", "800 0 300 0 0 800 200 0 0 0 1 0"])
def test_a_calibration_that_names_a_matrix_twice_is_refused(tmp_path, second):
    """A second ``P0:`` used to win silently (the baseline then came from the wrong pair);
    a bare line after the four named ones would be a second P0 too."""
    root = _kitti_folder(tmp_path / "s", prefixes=True)
    lines = (root / "calib.txt").read_text().splitlines()
    (root / "calib.txt").write_text("\n".join(lines + [second]) + "\n")
    with pytest.raises(VoError, match=rf"calib.txt:{len(lines) + 1}: P0 is given twice \(first on line 1\)"):
        KittiSequence(root)
