"""EuRoC MAV / ASL export: layout, images readable by OpenCV, ground truth read back by our
reader and by evo's, sensor.yaml parseable with K as intrinsics."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.io.render import RenderSequence
from synthetic_render import add_imu, write_render
from vo_reference.io.trajectory import read_euroc
from vo_reference.exporters.driver import export

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")

W, H, F, B = 40, 24, 30.0, 0.25
K = np.array([[F, 0, W / 2 - 0.5], [0, 1.01 * F, H / 2 - 0.5], [0, 0, 1.0]])
TS = [1403636579.763555584, 1403636579.813555456, 1403636579.863555584, 1403636579.913555456, 1403636579.963555584]


def _rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def _poses(n):
    T = np.tile(np.eye(4), (n, 1, 1))
    for k in range(n):
        T[k, :3, :3] = _rot(1, 0.3 * k) @ _rot(0, -0.1 * k) @ _rot(2, 2.5 + 0.05 * k)  # incl. w < 0 cases
        T[k, :3, 3] = [12.5 + 0.4 * k, -3.0 + 0.1 * k * k, 101.25 - 0.2 * k]
    return T


def _render(root, stereo=True, n=len(TS)):
    rng = np.random.default_rng(1)
    z = np.full((H, W), 5.0, np.float32)
    ids = np.ones((H, W), np.int32)
    views = ("left", "right") if stereo else ("left",)
    frames = [{v: (rng.uniform(0.02, 0.8, (H, W, 3)).astype(np.float32), z, ids) for v in views} for _ in range(n)]
    return write_render(root, K=K, baseline_m=B if stereo else 0.0, T_world_left=_poses(n), frames=frames,
                        noise=(3.0, 5), extra={"timestamps": TS[:n]})


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    return _render(tmp_path_factory.mktemp("euroc") / "r")


def _t_ns(ts):
    return [int(round(t * 1e9)) for t in ts]


def test_euroc_layout_images_and_csv(render, tmp_path):
    out = export(render, "euroc", tmp_path / "e", noise=None, progress=False)
    seq = RenderSequence(render)
    names = [f"{t}.png" for t in _t_ns(seq.timestamps_s)]
    for cam, view in (("cam0", "left"), ("cam1", "right")):
        d = out / "mav0" / cam
        assert (d / "sensor.yaml").is_file()
        lines = (d / "data.csv").read_text().splitlines()
        assert lines[0] == "#timestamp [ns],filename"
        rows = [l.split(",") for l in lines[1:]]
        assert [r[1] for r in rows] == names and [r[0] + ".png" for r in rows] == names
        assert sorted(p.name for p in (d / "data").iterdir()) == sorted(names)
        for k, name in enumerate(names):
            img = cv2.imread(str(d / "data" / name), cv2.IMREAD_UNCHANGED)
            assert img.dtype == np.uint8 and img.shape == (H, W)
            assert np.array_equal(img, seq.image_gray(k, view))
    header = (out / "mav0/state_groundtruth_estimate0/data.csv").read_text().splitlines()[0]
    assert header.startswith("#timestamp, p_RS_R_x [m],") and header.endswith("b_a_RS_S_z [m s^-2]")
    assert len(header.split(",")) == 17


def test_euroc_groundtruth_read_back_by_us_and_evo(render, tmp_path):
    out = export(render, "euroc", tmp_path / "e", progress=False)
    seq = RenderSequence(render)
    T = seq.T_world_cam("left")
    path = out / "mav0/state_groundtruth_estimate0/data.csv"
    a = np.loadtxt(path, delimiter=",", comments="#")
    assert a.shape == (len(TS), 17)
    assert [int(x) for x in np.loadtxt(path, delimiter=",", comments="#", usecols=0, dtype=np.int64)] == _t_ns(TS)
    assert np.all(a[:, 11:] == 0)
    p, t = T[:, :3, 3], np.array(_t_ns(TS)) * 1e-9
    assert np.allclose(a[2, 8:11], (p[3] - p[1]) / (t[3] - t[1]), atol=1e-6)   # central difference
    assert np.allclose(a[0, 8:11], (p[1] - p[0]) / (t[1] - t[0]), atol=1e-6)
    ours = read_euroc(path)
    assert np.abs(ours.T_world_cam - T).max() <= 1e-6
    assert np.allclose(ours.timestamps_s, seq.timestamps_s, atol=1e-6)
    file_interface = pytest.importorskip("evo.tools.file_interface")
    tr = file_interface.read_euroc_csv_trajectory(str(path))
    assert np.abs(np.array(tr.poses_se3) - T).max() <= 1e-6
    assert np.allclose(tr.timestamps, seq.timestamps_s, atol=1e-6)


def test_euroc_sensor_yaml(render, tmp_path):
    yaml = pytest.importorskip("yaml")
    out = export(render, "euroc", tmp_path / "e", progress=False)
    for cam, tx in (("cam0", 0.0), ("cam1", B)):
        y = yaml.safe_load((out / "mav0" / cam / "sensor.yaml").read_text())
        assert y["sensor_type"] == "camera" and y["camera_model"] == "pinhole"
        assert y["distortion_model"] == "radial-tangential" and y["distortion_coefficients"] == [0, 0, 0, 0]
        assert y["resolution"] == [W, H]
        assert y["intrinsics"] == [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]
        assert y["rate_hz"] == pytest.approx(20.0, rel=1e-5)  # median step of TS
        T_BS = np.array(y["T_BS"]["data"], dtype=float).reshape(y["T_BS"]["rows"], y["T_BS"]["cols"])
        ref = np.eye(4)
        ref[0, 3] = tx
        assert np.array_equal(T_BS, ref)
    gt = yaml.safe_load((out / "mav0/state_groundtruth_estimate0/sensor.yaml").read_text())
    assert np.array_equal(np.array(gt["T_BS"]["data"]).reshape(4, 4), np.eye(4))


def test_euroc_frames_noise_and_mono(render, tmp_path):
    full = export(render, "euroc", tmp_path / "full", progress=False)        # manifest noise (3, 5)
    part = export(render, "euroc", tmp_path / "part", frames="2:4", progress=False)
    names = [f"{t}.png" for t in _t_ns(TS[2:4])]
    assert sorted(p.name for p in (part / "mav0/cam1/data").iterdir()) == names
    assert (part / "mav0/cam0/data" / names[0]).read_bytes() == (full / "mav0/cam0/data" / names[0]).read_bytes()
    seq = RenderSequence(render)
    noisy = cv2.imread(str(full / "mav0/cam0/data" / names[1]), cv2.IMREAD_GRAYSCALE).astype(float)
    assert 2.0 < (noisy - seq.image_gray(3)).std() < 4.0
    gt = read_euroc(part / "mav0/state_groundtruth_estimate0/data.csv")
    assert len(gt) == 2 and np.abs(gt.T_world_cam - seq.T_world_cam("left")[2:4]).max() <= 1e-6
    mono = _render(tmp_path / "mono", stereo=False, n=2)
    m = export(mono, "euroc", tmp_path / "m", progress=False)
    assert (m / "mav0/cam0/data.csv").is_file() and not (m / "mav0/cam1").exists()


def test_every_euroc_yaml_loads_with_pyyaml_and_opencv(tmp_path):
    """PyYAML (Kalibr and most Python loaders) and OpenCV's FileStorage both read every
    sensor.yaml of the export, the IMU's included (written from the manifest, not copied)."""
    yaml = pytest.importorskip("yaml")
    root = _render(tmp_path / "r")
    # an old render's imu/sensor.yaml opens with EuRoC's "%YAML:1.0", which PyYAML refuses
    imu = add_imu(root, [[0, -1, 0, 0.05], [1, 0, 0, 0.0], [0, 0, 1, 0.01], [0, 0, 0, 1]],
                  yaml_text="%YAML:1.0\nsensor_type: imu\nrate_hz: 200\n")
    out = export(root, "euroc", tmp_path / "e", progress=False)
    files = sorted((out / "mav0").rglob("*.yaml"))
    assert [p.parent.name for p in files] == ["cam0", "cam1", "imu0", "state_groundtruth_estimate0"]
    for p in files:
        y = yaml.safe_load(p.read_text())
        fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_READ)
        assert fs.getNode("sensor_type").string() == y["sensor_type"]
        data = fs.getNode("T_BS").getNode("data")
        T_cv = np.array([data.at(i).real() for i in range(data.size())]).reshape(4, 4)
        assert np.array_equal(T_cv, np.array(y["T_BS"]["data"], float).reshape(4, 4))
        fs.release()
    y = yaml.safe_load((out / "mav0/imu0/sensor.yaml").read_text())
    assert y["sensor_type"] == "imu" and y["rate_hz"] == 200
    for key in ("gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density",
                "accelerometer_random_walk"):
        assert y[key] == imu[key]
    assert np.array_equal(np.array(y["T_BS"]["data"]).reshape(4, 4), np.eye(4))
    assert np.array_equal(np.array(y["T_cam_imu"]["data"]).reshape(4, 4), np.array(imu["T_cam_imu"], float))


def test_camera_T_BS_is_the_camera_pose_in_the_body(tmp_path):
    """EuRoC's camN/sensor.yaml T_BS ("Sensor extrinsics wrt. the body-frame") is the camera's
    pose in the body (IMU) frame, p_B = T_BS·p_S: EuRoC's own cam0 T_BS holds the camera's
    position in the IMU frame, and Kimera-VIO reads it as body_Pose_cam and its stereo pair as
    camL_Pose_camR = inv(T_BS0)·T_BS1 (right camera at +B along the left camera's x). With
    a non-symmetric T_cam_imu, the world pose of the body T_world_cam0·inv(T_BS0) must be the
    IMU's, T_world_cam0·T_cam_imu; a T_BS written as T_cam_imu (uninverted) fails."""
    yaml = pytest.importorskip("yaml")
    root = _render(tmp_path / "r")
    T_cam_imu = np.eye(4)
    T_cam_imu[:3, :3] = _rot(2, 0.7) @ _rot(0, -0.4)
    T_cam_imu[:3, 3] = [0.05, -0.02, 0.01]
    add_imu(root, T_cam_imu)
    mav = export(root, "euroc", tmp_path / "e", progress=False) / "mav0"

    def T_BS(cam):
        y = yaml.safe_load((mav / cam / "sensor.yaml").read_text())
        return np.array(y["T_BS"]["data"], dtype=float).reshape(4, 4)

    body_pose_cam0, body_pose_cam1 = T_BS("cam0"), T_BS("cam1")
    T_world_cam0 = _poses(len(TS))[2]
    assert np.allclose(T_world_cam0 @ np.linalg.inv(body_pose_cam0), T_world_cam0 @ T_cam_imu, atol=1e-12)
    camL_pose_camR = np.linalg.inv(body_pose_cam0) @ body_pose_cam1
    assert np.allclose(camL_pose_camR, [[1, 0, 0, B], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], atol=1e-12)
