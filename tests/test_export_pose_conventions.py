"""Every export that writes camera poses, read back by a reader written from its format's
words, against the rig's known poses -- with rotations that are NOT their own inverse.

The layout scene's rig (tests/layout_scene.py) is a yaw times the level camera's
diag(1, -1, -1): a 180-degree rotation about a horizontal axis, a symmetric matrix, so
R == R^T and a quaternion equals its conjugate up to sign. Pose checks built on it cannot
see a transposed rotation, a conjugated quaternion or an inverted orientation. Here the
rig yaws, pitches and rolls by generic angles each frame, and the truth is the array the
test made (not the manifest), the exported frames a subset (--frames 1:), so that a pose of
another frame or of the other camera fails too.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from format_readers import quat_xyzw_to_matrix
from synthetic_render import write_render

pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")

W, H, F, B = 16, 12, 14.0, 0.25
K = np.array([[F, 0.0, W / 2 - 0.5], [0.0, F, H / 2 - 0.5], [0.0, 0.0, 1.0]])
N, FIRST = 3, 1                     # render 3 frames, export frames 1: (two)
START_S, FPS = 0.5, 10.0


def _rot(axis: str, deg: float) -> np.ndarray:
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def rig_truth() -> np.ndarray:
    """(N, 4, 4) T_world_cam of the left camera: generic yaw, pitch and roll, not symmetric."""
    T = np.tile(np.eye(4), (N, 1, 1))
    for k in range(N):
        T[k, :3, :3] = _rot("y", 20.0 + 17.0 * k) @ _rot("x", -12.0 + 5.0 * k) @ _rot("z", 9.0 - 7.0 * k) \
            @ np.diag([1.0, -1.0, -1.0])
        T[k, :3, 3] = [0.4 + 0.3 * k, 1.5 - 0.1 * k, -2.0 - 0.7 * k]
    assert not any(np.allclose(t[:3, :3], t[:3, :3].T, atol=1e-3) for t in T)
    return T


def right_truth(T: np.ndarray) -> np.ndarray:
    """The right camera: B along the left camera's own x axis (DESIGN.md)."""
    out = T.copy()
    out[:, :3, 3] += B * T[:, :3, 0]
    return out


TRUTH = rig_truth()
TRUTH_VIEW = {"left": TRUTH[FIRST:], "right": right_truth(TRUTH)[FIRST:]}
STAMPS_S = START_S + np.arange(N)[FIRST:] / FPS


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    root = tmp_path_factory.mktemp("poses") / "r"
    rng = np.random.default_rng(3)
    frames = [{v: (rng.uniform(0.05, 0.9, (H, W, 3)).astype(np.float32), np.full((H, W), 5.0, np.float32),
                   np.ones((H, W), np.int32)) for v in ("left", "right")} for _ in range(N)]
    return write_render(root, K=K, baseline_m=B, T_world_left=TRUTH, frames=frames,
                        objects=[{"id": 1, "name": "wall", "shape": "QUAD", "class": "building"}],
                        extra={"timestamps": list(START_S + np.arange(N) / FPS), "fps": FPS})


def _export(render, tmp_path, target: str):
    from vo_reference.exporters.driver import export
    return export(render, target, tmp_path / target, frames=f"{FIRST}:", noise=None, progress=False)


def _pose(R, t) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def _rows(path, comments="#", delimiter=None) -> np.ndarray:
    return np.loadtxt(path, comments=comments, delimiter=delimiter, ndmin=2)


def _close(a, b, atol=1e-7):
    assert np.allclose(np.asarray(a, float), np.asarray(b, float), atol=atol), (np.asarray(a), np.asarray(b))


def test_tum_groundtruth(render, tmp_path):
    """TUM: 'timestamp tx ty tz qx qy qz qw', the camera's pose in the world."""
    rows = _rows(_export(render, tmp_path, "tum") / "groundtruth.txt")
    _close(rows[:, 0], STAMPS_S, 1e-9)
    _close([_pose(quat_xyzw_to_matrix(r[4:8]), r[1:4]) for r in rows], TRUTH_VIEW["left"])


@pytest.mark.parametrize("target, path", [("kitti-folder", "poses.txt"), ("kitti-odometry", "../../poses/00.txt")])
def test_kitti_poses_and_times(render, tmp_path, target, path):
    """KITTI odometry: 12 numbers a line, the 3x4 pose of camera k in the first camera's frame;
    times.txt from the first exported frame."""
    out = _export(render, tmp_path, target)
    rows = _rows(out / path)
    T0 = TRUTH_VIEW["left"][0]
    _close([np.vstack([r.reshape(3, 4), [0, 0, 0, 1]]) for r in rows], np.linalg.inv(T0) @ TRUTH_VIEW["left"])
    _close(_rows(out / "times.txt")[:, 0], STAMPS_S - STAMPS_S[0], 1e-9)


def test_euroc_groundtruth(render, tmp_path):
    """EuRoC: 'timestamp [ns], p_RS_R xyz, q_RS w x y z, ...': the body (left camera) in R."""
    rows = _rows(_export(render, tmp_path, "euroc") / "mav0/state_groundtruth_estimate0/data.csv", delimiter=",")
    assert [int(round(t)) for t in rows[:, 0]] == [int(round(t * 1e9)) for t in STAMPS_S]
    _close([_pose(quat_xyzw_to_matrix([r[5], r[6], r[7], r[4]]), r[1:4]) for r in rows], TRUTH_VIEW["left"])


def _ned(v) -> np.ndarray:
    """A SES-world vector in TartanAir's NED world: north = -Z, east = +X, down = -Y."""
    x, y, z = v
    return np.array([-z, x, -y])


@pytest.mark.parametrize("target, files", [
    ("tartanair", {"left": "pose_left.txt", "right": "pose_right.txt"}),
    ("tartanair-v2", {"left": "pose_lcam_front.txt", "right": "pose_rcam_front.txt"})])
def test_tartanair_ned_poses(render, tmp_path, target, files):
    """TartanAir: 'tx ty tz qx qy qz qw', NED: the camera's body axes are x forward (the
    optical axis), y right, z down (its image's x and y), in a NED world."""
    out = _export(render, tmp_path, target)
    for view, name in files.items():
        rows = _rows(out / name)
        for r, T in zip(rows, TRUTH_VIEW[view]):
            R = quat_xyzw_to_matrix(r[3:7])
            _close(R[:, 0], _ned(T[:3, 2]))     # forward
            _close(R[:, 1], _ned(T[:3, 0]))     # right
            _close(R[:, 2], _ned(T[:3, 1]))     # down
            _close(r[:3], _ned(T[:3, 3]))


@pytest.mark.parametrize("target, name", [("tartanair", "pose_left.txt"), ("tartanair-v2", "pose_lcam_front.txt")])
def test_tartanair_tools_ned2cam(render, tmp_path, target, name):
    """TartanAir's own evaluation recipe (castacks/tartanair_tools evaluation/
    trajectory_transform.py: pos_quats2SE_matrices, then ned2cam = T·pose·T^-1 with
    T = [[0,1,0],[0,0,1],[1,0,0]]) turns our NED file into camera-axis poses: the SES world
    turned 180 degrees about x, so every relative motion is the rig's own."""
    T_axes = np.eye(4)
    T_axes[:3, :3] = [[0, 1, 0], [0, 0, 1], [1, 0, 0]]
    cam = [T_axes @ _pose(quat_xyzw_to_matrix(r[3:7]), r[:3]) @ np.linalg.inv(T_axes)
           for r in _rows(_export(render, tmp_path, target) / name)]
    _close(cam, [np.diag([1.0, -1.0, -1.0, 1.0]) @ T for T in TRUTH_VIEW["left"]])
    _close(np.linalg.inv(cam[0]) @ cam[1], np.linalg.inv(TRUTH_VIEW["left"][0]) @ TRUTH_VIEW["left"][1])


def test_vkitti2_extrinsics(render, tmp_path):
    """vKITTI 2: extrinsic.txt is world -> camera (4x4) per frame and camera, its world the
    SES world turned 180 degrees about x (y down): a world point (x, y, z) is (x, -y, -z) there."""
    rows = _rows(_export(render, tmp_path, "vkitti2") / "extrinsic.txt", comments="f")
    X = np.array([[0.3, -1.2, 4.0, 1.0], [-2.0, 0.5, -1.0, 1.0], [1.0, 2.0, 3.0, 1.0]]).T
    X_vk = X * np.array([[1.0], [-1.0], [-1.0], [1.0]])
    assert [(int(r[0]), int(r[1])) for r in rows] == [(i, c) for i in range(N - FIRST) for c in (0, 1)]
    for r in rows:
        T = TRUTH_VIEW[("left", "right")[int(r[1])]][int(r[0])]
        _close(r[2:].reshape(4, 4) @ X_vk, np.linalg.inv(T) @ X)


def _colmap_images(path) -> dict[str, np.ndarray]:
    """COLMAP images.txt: 'IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME' (cam_from_world), then
    a line of observations."""
    lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")]
    out = {}
    for ln in lines[0::2]:
        v = ln.split()
        qw, qx, qy, qz, tx, ty, tz = map(float, v[1:8])
        out[v[9]] = _pose(quat_xyzw_to_matrix([qx, qy, qz, qw]), [tx, ty, tz])
    return out


def test_colmap_cam_from_world(render, tmp_path):
    images = _colmap_images(_export(render, tmp_path, "colmap") / "sparse/0/images.txt")
    assert sorted(images) == sorted(f"{v}_{i:06d}.png" for v in ("left", "right") for i in range(N - FIRST))
    for name, T_cam_world in images.items():
        view, i = name[:-4].split("_")
        _close(T_cam_world, np.linalg.inv(TRUTH_VIEW[view][int(i)]))


def test_eth3d_pair_cam_from_world(render, tmp_path):
    out = _export(render, tmp_path, "eth3d")
    for i in range(N - FIRST):
        images = _colmap_images(out / "two_view_training" / f"sesgen_{i:06d}" / "images.txt")
        _close(images["im0.png"], np.linalg.inv(TRUTH_VIEW["left"][i]))
        _close(images["im1.png"], np.linalg.inv(TRUTH_VIEW["right"][i]))


def test_nerfstudio_opengl_camera_to_world(render, tmp_path):
    """nerfstudio: transform_matrix is camera-to-world with OpenGL axes (x right, y up, z back)."""
    meta = json.loads((_export(render, tmp_path, "nerfstudio") / "transforms.json").read_text())
    assert len(meta["frames"]) == 2 * (N - FIRST)
    for fr in meta["frames"]:
        view, i = fr["file_path"].split("/")[1][:-4].split("_")
        T, M = TRUTH_VIEW[view][int(i)], np.array(fr["transform_matrix"])
        _close(M[:3, 0], T[:3, 0])
        _close(M[:3, 1], -T[:3, 1])
        _close(M[:3, 2], -T[:3, 2])
        _close(M[:3, 3], T[:3, 3])


def test_sintel_cam_files(render, tmp_path):
    """Sintel's cam_read: float32 tag, M (3x3 float64), N (3x4 float64) = [R | t] world -> camera."""
    out = _export(render, tmp_path, "sintel")
    for i in range(N - FIRST):
        raw = (out.parent.parent / "camdata_left" / "sesgen" / f"frame_{i + 1:04d}.cam").read_bytes()
        M = np.frombuffer(raw[4:76], "<f8").reshape(3, 3)
        Nm = np.frombuffer(raw[76:172], "<f8").reshape(3, 4)
        _close(M, K)
        _close(np.vstack([Nm, [0, 0, 0, 1]]), np.linalg.inv(TRUTH_VIEW["left"][i]))


def test_bayer_poses(render, tmp_path):
    """RobotCar-style folder: poses.txt holds each frame's T_world_cam (3x4), names the us stamps."""
    out = _export(render, tmp_path, "bayer")
    rows = _rows(out / "poses.txt")
    _close([np.vstack([r.reshape(3, 4), [0, 0, 0, 1]]) for r in rows], TRUTH_VIEW["left"])
    assert sorted(p.stem for p in out.glob("*.png")) == [f"{int(round(t * 1e6)):016d}" for t in STAMPS_S]


def test_rosbag_tf_world_to_body(render, tmp_path):
    """ROS tf: the child's pose in the parent (world -> body = cam0 without an IMU), stamps in ns."""
    pytest.importorskip("rosbags")
    from test_export_rosbag import matrix, read_bag
    msgs, _ = read_bag(_export(render, tmp_path, "rosbag") / "bag")
    assert [t for t, _ in msgs["/tf"]] == [int(round(t * 1e9)) for t in STAMPS_S]
    _close([matrix(m.transforms[0].transform) for _, m in msgs["/tf"]], TRUTH_VIEW["left"])


@pytest.mark.parametrize("stamps, why", [([-0.1, 0.0, 0.1], ">= 0"), ([0.0, 0.1, 0.1000004], "increasing")])
def test_bayer_refuses_times_its_names_cannot_hold(tmp_path, capsys, stamps, why):
    """The microsecond names are the layout's only stamps: negative times were shifted and
    repeated ones nudged by 1 us before, silently; now exit 2, nothing written."""
    from vo_reference.commands.main import main
    rng = np.random.default_rng(5)
    frames = [{"left": (rng.uniform(0.05, 0.9, (H, W, 3)).astype(np.float32), np.full((H, W), 5.0, np.float32),
                        np.ones((H, W), np.int32))} for _ in range(3)]
    root = write_render(tmp_path / "r", K=K, baseline_m=0.0, T_world_left=TRUTH, frames=frames,
                        extra={"timestamps": stamps, "fps": 10.0})
    assert main(["export", str(root), str(tmp_path / "b"), "--to", "bayer", "-q"]) == 2
    err = capsys.readouterr().err
    assert why in err and len(err.strip().splitlines()) == 1 and not (tmp_path / "b").exists()
