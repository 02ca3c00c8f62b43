"""bench/still_split.py's motion reading (``turns_of_images``, ``turns_of_poses``) against
oracles that do not share its code: a real EuRoC frame moved by the homography of a known
rotation (K R^T K^-1, with another frame's sensor noise on top) and V1_01's two cameras, which
ride one rigid rig."""
from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
still_split = pytest.importorskip("still_split")


@pytest.fixture(scope="module")
def euroc(shared_data):
    from realism import euroc_frames
    _, L, R = euroc_frames(95)
    return L, R


@pytest.mark.parametrize("turn_deg", [(0.03, 0, 0), (0, 0.03, 0), (0, 0, 0.03), (0.01, -0.02, 0.015), (-0.1, 0.12, 0.0)])
def test_turns_of_images_and_of_poses_read_a_rotation_alike(euroc, turn_deg):
    """A pure rotation of the camera (poses I -> R, OpenCV frame) moves the image by the
    homography K R^T K^-1: V1_01's frame 1 (rotors off) so moved, read against frame 0 (another
    draw of the sensor's noise), gives the poses' turn within 0.001 deg (0.008 px at 436 px;
    the shake to read is 0.004-0.03 deg a frame) about each axis (the warp: float, bilinear)."""
    L, _ = euroc
    K = still_split.euroc_rectified_P()[:, :3]
    R = cv2.Rodrigues(np.radians(np.asarray(turn_deg, float)))[0]
    H = K @ R.T @ np.linalg.inv(K)
    moved = cv2.warpPerspective(L[1].astype(np.float32), H, (L[0].shape[1], L[0].shape[0]), flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_REFLECT)
    T = np.stack([np.eye(4), np.eye(4)])
    T[1, :3, :3] = R
    want = still_split.turns_of_poses(T)[0]
    assert want == pytest.approx(turn_deg, abs=1e-9)
    got = still_split.turns_of_images([L[0], moved], K)[0]
    assert got == pytest.approx(want, abs=0.001), (got, want)


def test_both_cameras_of_the_rig_read_the_same_shake(euroc):
    """V1_01's cam0 and cam1 are one rigid rig: the turns read from each camera's own frames
    (independent images, noise and view) agree within 0.003 deg (0.02 px) at the median
    where the shake itself is 0.006-0.009 deg; with the rotors off (frames 0-5) both read
    under 0.005 deg."""
    L, R = euroc
    K = still_split.euroc_rectified_P()[:, :3]
    a, b = still_split.turns_of_images(L, K), still_split.turns_of_images(R, K)
    k = still_split.EUROC_ROTORS_FRAME - 1
    assert np.abs(a[:k]).max() < 0.005 and np.abs(b[:k]).max() < 0.005
    assert np.all(np.median(np.abs(a[k:] - b[k:]), axis=0) < 0.003)
    assert np.all(np.median(np.abs(a[k:]), axis=0) > 0.004)             # and there is a shake to read


def test_bad_input_exits_2(tmp_path, capsys):
    assert still_split.main([str(tmp_path)]) == 2
    assert still_split.main(["--motion", str(tmp_path / "none.ses")]) == 2
    assert "--motion" in capsys.readouterr().err


def test_rotation_warp_moves_an_image_by_the_poses_turn(euroc):
    """``rotation_warp`` (the stand's frames as one render moved by the poses' turns) read back
    by ``image_turn`` (Gauss-Newton, another code path) gives the turn between the two poses,
    within 0.001 deg, for a turn about all three axes and a stand pitched 21.5 deg."""
    from blender_sesgen.generators.builtin.hall import STAND_PITCH_DEG
    L, _ = euroc
    K = still_split.euroc_rectified_P()[:, :3]
    Ta, Tb = np.eye(4), np.eye(4)
    Ta[:3, :3] = cv2.Rodrigues(np.array([np.radians(STAND_PITCH_DEG), 0.0, 0.0]))[0]
    Tb[:3, :3] = Ta[:3, :3] @ cv2.Rodrigues(np.radians([0.02, -0.015, 0.03]))[0]
    moved = still_split.rotation_warp(L[1], Ta, Tb, K)
    got = still_split.turns_of_images([L[0], moved], K)[0]
    assert got == pytest.approx(still_split.turns_of_poses(np.stack([Ta, Tb]))[0], abs=0.001)
    assert got == pytest.approx([0.02, -0.015, 0.03], abs=0.001)
