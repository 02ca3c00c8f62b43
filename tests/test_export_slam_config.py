"""SLAM / VIO settings (``--to slam``, and ``slam/`` beside the euroc and rosbag exports),
read back by the readers the systems use and compared with the manifest: OpenCV
``FileStorage`` with ORB-SLAM3's ``Settings.cc`` rules (types included: an int where it
reads an int) and VINS-Fusion's ``parameters.cpp`` keys; PyYAML for Kalibr's files (the
extrinsics must compose to the manifest's T_cam_imu and rig); OpenCV and PyYAML for
OpenVINS's; ``json`` with cereal's required keys for Basalt's."""
from __future__ import annotations

import json

import numpy as np
import pytest

from layout_scene import B, K, W, H, export_layout, write_layout_render

cv2 = pytest.importorskip("cv2")
yaml = pytest.importorskip("yaml", reason="PyYAML is the reader of Kalibr's files")
pytest.importorskip("OpenEXR")

RATE, OFFSET = 200.0, 0.002
DENS = {"gyroscope_noise_density": 1.6968e-04, "gyroscope_random_walk": 1.9393e-05,
        "accelerometer_noise_density": 2.0e-03, "accelerometer_random_walk": 3.0e-03}


def T_cam_imu() -> np.ndarray:
    from blender_sesgen.contract.se3 import euler_xyz_deg_to_R
    T = np.eye(4)
    T[:3, :3] = euler_xyz_deg_to_R(3.0, -2.0, 90.0)
    T[:3, 3] = (0.06, 0.01, -0.02)
    return T


def imu_render(root, n=3, stereo=True, lens=None):
    """The layout scene with an IMU entry in the manifest (and small IMU files for euroc)."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "imu").mkdir()
    t = np.arange(0, (n - 1) / 10 + 1e-9, 1 / RATE)
    rows = "".join(f"{int(round((x + OFFSET) * 1e9))},0,0,0,0,9.81,0\n" for x in t)
    (root / "imu" / "data.csv").write_text("#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n" + rows)
    (root / "imu" / "data_ideal.csv").write_text("#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n" + rows)
    gt = "".join(f"{int(round(x * 1e9))}" + ",0" * 3 + ",1,0,0,0" + ",0" * 9 + "\n" for x in t)
    (root / "imu" / "groundtruth.csv").write_text("#timestamp,p,q,v,bw,ba\n" + gt)
    (root / "imu" / "sensor.yaml").write_text("sensor_type: imu\n")
    imu = {"rate_hz": RATE, **DENS, "T_cam_imu": T_cam_imu().tolist(), "time_offset_s": OFFSET,
           "gravity_world": [0.0, -9.81, 0.0], "seed": 0,
           "files": {"noisy": "imu/data.csv", "ideal": "imu/data_ideal.csv", "groundtruth": "imu/groundtruth.csv",
                     "yaml": "imu/sensor.yaml"}}
    return write_layout_render(root, n=n, stereo=stereo, lens=lens, extra={"imu": imu})


def read_orbslam3(path, stereo: bool, inertial: bool) -> dict:
    """Settings.cc: readParameter<float> takes a real or an int, <int> only an int, <string>
    a string, <cv::Mat> a matrix; a missing required key aborts."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    out = {}

    def get(name, kind, required=True):
        node = fs.getNode(name)
        if node.empty():
            assert not required, f"{name} required parameter does not exist"
            return None
        ok = {"float": node.isReal() or node.isInt(), "int": node.isInt(), "str": node.isString(),
              "mat": node.isMap()}[kind]
        assert ok, f"{name}: not a {kind}"
        out[name] = {"float": node.real, "int": lambda: int(node.real()), "str": node.string, "mat": node.mat}[kind]()
        return out[name]

    assert get("File.version", "str") == "1.0"
    cam_type = get("Camera.type", "str")
    assert cam_type in ("PinHole", "Rectified", "KannalaBrandt8")
    cams = (1, 2) if stereo and cam_type != "Rectified" else (1,)
    for c in cams:
        for k in ("fx", "fy", "cx", "cy"):
            get(f"Camera{c}.{k}", "float")
        if cam_type == "PinHole" and get(f"Camera{c}.k1", "float", required=False) is not None:
            for k in ("k2", "p1", "p2"):
                get(f"Camera{c}.{k}", "float")
            get(f"Camera{c}.k3", "float", required=False)
        if cam_type == "KannalaBrandt8":
            for k in ("k1", "k2", "k3", "k4"):
                get(f"Camera{c}.{k}", "float")
            if stereo:
                get(f"Camera{c}.overlappingBegin", "int")
                get(f"Camera{c}.overlappingEnd", "int")
    if stereo:
        get("Stereo.b", "float") if cam_type == "Rectified" else get("Stereo.T_c1_c2", "mat")
        get("Stereo.ThDepth", "float")
    for k in ("Camera.height", "Camera.width", "Camera.fps", "Camera.RGB"):
        get(k, "int")
    if inertial:
        for k in ("IMU.NoiseGyro", "IMU.NoiseAcc", "IMU.GyroWalk", "IMU.AccWalk", "IMU.Frequency"):
            get(k, "float")
        assert fs.getNode("IMU.T_b_c1").mat().dtype == np.float32    # Converter reads it as float
        get("IMU.T_b_c1", "mat")
    for k, kind in (("ORBextractor.nFeatures", "int"), ("ORBextractor.scaleFactor", "float"),
                    ("ORBextractor.nLevels", "int"), ("ORBextractor.iniThFAST", "int"),
                    ("ORBextractor.minThFAST", "int")):
        get(k, kind)
    for k in ("KeyFrameSize", "KeyFrameLineWidth", "GraphLineWidth", "PointSize", "CameraSize", "CameraLineWidth",
              "ViewpointX", "ViewpointY", "ViewpointZ", "ViewpointF"):
        get(f"Viewer.{k}", "float")
    out["Camera.type"] = cam_type
    return out


def basalt_pose(p: dict) -> np.ndarray:
    from scipy.spatial.transform import Rotation
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat([p["qx"], p["qy"], p["qz"], p["qw"]]).as_matrix()
    T[:3, 3] = [p["px"], p["py"], p["pz"]]
    return T


def trans_x(b: float) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = b
    return T


@pytest.fixture(scope="module")
def stereo_imu(tmp_path_factory):
    d = tmp_path_factory.mktemp("slam")
    render = imu_render(d / "r")
    return export_layout(render, d / "out", "slam")


def test_orbslam3_settings_read_by_its_rules_equal_the_manifest(stereo_imu):
    s = read_orbslam3(stereo_imu / "orbslam3" / "stereo.yaml", stereo=True, inertial=False)
    assert s["Camera.type"] == "Rectified"
    assert [s[f"Camera1.{k}"] for k in ("fx", "fy", "cx", "cy")] == [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]
    assert s["Stereo.b"] == B and (s["Camera.width"], s["Camera.height"], s["Camera.fps"]) == (W, H, 10)
    si = read_orbslam3(stereo_imu / "orbslam3" / "stereo_inertial.yaml", stereo=True, inertial=True)
    assert np.allclose(si["IMU.T_b_c1"], np.linalg.inv(T_cam_imu()), atol=1e-7)
    assert si["IMU.NoiseGyro"] == DENS["gyroscope_noise_density"] and si["IMU.AccWalk"] == DENS["accelerometer_random_walk"]
    assert si["IMU.NoiseAcc"] == DENS["accelerometer_noise_density"] and si["IMU.GyroWalk"] == DENS["gyroscope_random_walk"]
    assert si["IMU.Frequency"] == RATE
    times = (stereo_imu / "orbslam3" / "times.txt").read_text().split()
    assert times == ["0", "100000000", "200000000"]


def test_vins_fusion_settings(stereo_imu):
    fs = cv2.FileStorage(str(stereo_imu / "vins_fusion" / "config.yaml"), cv2.FILE_STORAGE_READ)
    assert int(fs.getNode("imu").real()) == 1 and int(fs.getNode("num_of_cam").real()) == 2
    assert fs.getNode("image0_topic").string() == "/cam0/image_raw" and fs.getNode("imu_topic").string() == "/imu0"
    T_imu_cam0 = np.linalg.inv(T_cam_imu())
    assert np.allclose(fs.getNode("body_T_cam0").mat(), T_imu_cam0, atol=1e-15)
    assert np.allclose(fs.getNode("body_T_cam1").mat(), T_imu_cam0 @ trans_x(B), atol=1e-15)
    assert fs.getNode("acc_n").real() == DENS["accelerometer_noise_density"]
    assert fs.getNode("gyr_w").real() == DENS["gyroscope_random_walk"]
    assert fs.getNode("td").real() == OFFSET and fs.getNode("g_norm").real() == pytest.approx(9.81)
    for i in (0, 1):
        cam = cv2.FileStorage(str(stereo_imu / "vins_fusion" / fs.getNode(f"cam{i}_calib").string()),
                              cv2.FILE_STORAGE_READ)
        assert cam.getNode("model_type").string() == "PINHOLE"
        p = cam.getNode("projection_parameters")
        assert [p.getNode(k).real() for k in ("fx", "fy", "cx", "cy")] == [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]
        assert int(cam.getNode("image_width").real()) == W


def test_kalibr_extrinsics_compose_to_the_manifests_rig(stereo_imu):
    chain = yaml.safe_load((stereo_imu / "kalibr" / "camchain-imucam.yaml").read_text())
    T0 = np.array(chain["cam0"]["T_cam_imu"])
    T1 = np.array(chain["cam1"]["T_cam_imu"])
    Tn = np.array(chain["cam1"]["T_cn_cnm1"])
    assert np.allclose(T0, T_cam_imu(), atol=1e-15)
    assert np.allclose(Tn @ T0, T1, atol=1e-15)                    # cam1 <- cam0 <- imu
    assert np.allclose(np.linalg.inv(Tn), trans_x(B), atol=1e-15)  # right = left . trans(B, 0, 0)
    for c in ("cam0", "cam1"):
        assert chain[c]["intrinsics"] == [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]
        assert chain[c]["resolution"] == [W, H] and chain[c]["distortion_model"] == "radtan"
        assert chain[c]["timeshift_cam_imu"] == OFFSET and chain[c]["camera_model"] == "pinhole"
    imu = yaml.safe_load((stereo_imu / "kalibr" / "imu.yaml").read_text())
    assert {k: imu[k] for k in DENS} == DENS and imu["update_rate"] == RATE and imu["rostopic"] == "/imu0"


OPENVINS_REQUIRED = (   # the keys OpenVINS's VioManagerOptions / StateOptions / initializer parse as required
    "verbosity", "use_fej", "integration", "use_stereo", "max_cameras", "calib_cam_extrinsics",
    "calib_cam_intrinsics", "calib_cam_timeoffset", "calib_imu_intrinsics", "calib_imu_g_sensitivity",
    "max_clones", "max_slam", "max_slam_in_update", "max_msckf_in_update", "dt_slam_delay", "gravity_mag",
    "feat_rep_msckf", "feat_rep_slam", "feat_rep_aruco", "try_zupt", "zupt_chi2_multipler", "zupt_max_velocity",
    "zupt_noise_multiplier", "zupt_max_disparity", "zupt_only_at_beginning", "init_window_time",
    "init_imu_thresh", "init_max_disparity", "init_max_features", "init_dyn_use", "init_dyn_mle_opt_calib",
    "init_dyn_mle_max_iter", "init_dyn_mle_max_time", "init_dyn_mle_max_threads", "init_dyn_num_pose",
    "init_dyn_min_deg", "init_dyn_inflation_ori", "init_dyn_inflation_vel", "init_dyn_inflation_bg",
    "init_dyn_inflation_ba", "init_dyn_min_rec_cond", "init_dyn_bias_g", "init_dyn_bias_a",
    "record_timing_information", "record_timing_filepath", "use_klt", "num_pts", "fast_threshold", "grid_x",
    "grid_y", "min_px_dist", "knn_ratio", "track_frequency", "downsample_cameras", "num_opencv_threads",
    "histogram_method", "use_aruco", "num_aruco", "downsize_aruco", "up_msckf_sigma_px",
    "up_msckf_chi2_multipler", "up_slam_sigma_px", "up_slam_chi2_multipler", "up_aruco_sigma_px",
    "up_aruco_chi2_multipler", "use_mask", "relative_config_imu", "relative_config_imucam")


def test_openvins_settings_read_by_opencv_and_pyyaml(stereo_imu):
    d = stereo_imu / "openvins"
    fs = cv2.FileStorage(str(d / "estimator_config.yaml"), cv2.FILE_STORAGE_READ)
    missing = [k for k in OPENVINS_REQUIRED if fs.getNode(k).empty()]
    assert not missing
    assert fs.getNode("max_cameras").real() == 2 and fs.getNode("use_stereo").string() == "true"
    chain = cv2.FileStorage(str(d / fs.getNode("relative_config_imucam").string()), cv2.FILE_STORAGE_READ)
    T = np.array([[chain.getNode("cam1").getNode("T_imu_cam").at(r).at(c).real() for c in range(4)] for r in range(4)])
    assert np.allclose(T, np.linalg.inv(T_cam_imu()) @ trans_x(B), atol=1e-15)
    assert chain.getNode("cam0").getNode("timeshift_cam_imu").real() == OFFSET
    imu = yaml.safe_load((d / "kalibr_imu_chain.yaml").read_text())["imu0"]
    assert {k: imu[k] for k in DENS} == DENS and imu["update_rate"] == RATE
    assert yaml.safe_load((d / "kalibr_imucam_chain.yaml").read_text())["cam0"]["distortion_model"] == "radtan"


def test_basalt_calibration(stereo_imu):
    v = json.loads((stereo_imu / "basalt" / "calib.json").read_text())["value0"]
    for key in ("T_imu_cam", "intrinsics", "resolution", "calib_accel_bias", "calib_gyro_bias", "imu_update_rate",
                "accel_noise_std", "gyro_noise_std", "accel_bias_std", "gyro_bias_std", "cam_time_offset_ns",
                "vignette"):
        assert key in v, key                                      # cereal reads every one of them
    T0, T1 = (basalt_pose(p) for p in v["T_imu_cam"])
    assert np.allclose(T0, np.linalg.inv(T_cam_imu()), atol=1e-12)
    assert np.allclose(np.linalg.inv(T0) @ T1, trans_x(B), atol=1e-12)
    assert v["intrinsics"][0] == {"camera_type": "pinhole", "intrinsics": {"fx": K[0, 0], "fy": K[1, 1],
                                                                            "cx": K[0, 2], "cy": K[1, 2]}}
    assert v["resolution"] == [[W, H], [W, H]] and v["imu_update_rate"] == RATE
    assert v["accel_noise_std"] == [DENS["accelerometer_noise_density"]] * 3
    assert v["gyro_bias_std"] == [DENS["gyroscope_random_walk"]] * 3
    assert v["cam_time_offset_ns"] == 2_000_000 and len(v["calib_gyro_bias"]) == 12


def test_lens_models_in_each_systems_names(tmp_path):
    brown = ("brown", (-0.12, 0.03, 0.001, -0.0005, 0.0))
    out = export_layout(imu_render(tmp_path / "b" / "r", lens=brown), tmp_path / "b" / "o", "slam")
    s = read_orbslam3(out / "orbslam3" / "stereo_inertial.yaml", stereo=True, inertial=True)
    assert s["Camera.type"] == "PinHole" and s["Camera2.k1"] == -0.12 and s["Camera1.p2"] == -0.0005
    assert "Camera1.k3" not in s
    assert np.allclose(s["Stereo.T_c1_c2"], trans_x(B), atol=1e-7)
    chain = yaml.safe_load((out / "kalibr" / "camchain-imucam.yaml").read_text())
    assert chain["cam1"]["distortion_coeffs"] == [-0.12, 0.03, 0.001, -0.0005]
    assert not (out / "basalt").exists() and "Basalt has no radial-tangential" in (out / "README.md").read_text()
    cam = cv2.FileStorage(str(out / "vins_fusion" / "cam1.yaml"), cv2.FILE_STORAGE_READ)
    assert cam.getNode("model_type").string() == "PINHOLE"
    assert cam.getNode("distortion_parameters").getNode("k2").real() == 0.03

    k3 = ("brown", (-0.12, 0.03, 0.001, -0.0005, 0.004))
    out = export_layout(imu_render(tmp_path / "k" / "r", lens=k3), tmp_path / "k" / "o", "slam")
    s = read_orbslam3(out / "orbslam3" / "stereo.yaml", stereo=True, inertial=False)
    assert s["Camera1.k3"] == 0.004 and s["Camera2.k3"] == 0.004
    cam = cv2.FileStorage(str(out / "vins_fusion" / "cam0.yaml"), cv2.FILE_STORAGE_READ)
    assert cam.getNode("model_type").string() == "PINHOLE_FULL"
    assert cam.getNode("distortion_parameters").getNode("k3").real() == 0.004
    assert not (out / "kalibr").exists() and not (out / "openvins").exists()
    assert "k3 != 0" in (out / "README.md").read_text()

    kb = ("kannala_brandt", (0.02, -0.01, 0.003, -0.001))
    out = export_layout(imu_render(tmp_path / "f" / "r", lens=kb), tmp_path / "f" / "o", "slam")
    s = read_orbslam3(out / "orbslam3" / "stereo_inertial.yaml", stereo=True, inertial=True)
    assert s["Camera.type"] == "KannalaBrandt8" and s["Camera2.k4"] == -0.001
    assert (s["Camera1.overlappingBegin"], s["Camera1.overlappingEnd"]) == (0, W - 1)
    cam = cv2.FileStorage(str(out / "vins_fusion" / "cam0.yaml"), cv2.FILE_STORAGE_READ)
    pp = cam.getNode("projection_parameters")
    assert cam.getNode("model_type").string() == "KANNALA_BRANDT"
    assert [pp.getNode(k).real() for k in ("k2", "k3", "k4", "k5", "mu", "u0")] == [0.02, -0.01, 0.003, -0.001,
                                                                                      K[0, 0], K[0, 2]]
    chain = yaml.safe_load((out / "kalibr" / "camchain-imucam.yaml").read_text())
    assert chain["cam0"]["distortion_model"] == "equidistant"
    v = json.loads((out / "basalt" / "calib.json").read_text())["value0"]
    assert v["intrinsics"][1]["camera_type"] == "kb4" and v["intrinsics"][1]["intrinsics"]["k3"] == 0.003


def test_without_imu_and_mono(tmp_path):
    out = export_layout(write_layout_render(tmp_path / "s", n=2), tmp_path / "so", "slam")
    assert not (out / "orbslam3" / "stereo_inertial.yaml").exists() and not (out / "openvins").exists()
    fs = cv2.FileStorage(str(out / "vins_fusion" / "config.yaml"), cv2.FILE_STORAGE_READ)
    assert int(fs.getNode("imu").real()) == 0
    assert np.allclose(fs.getNode("body_T_cam1").mat(), trans_x(B))    # body = the left camera
    chain = yaml.safe_load((out / "kalibr" / "camchain.yaml").read_text())
    assert "T_cam_imu" not in chain["cam0"] and np.allclose(np.array(chain["cam1"]["T_cn_cnm1"]), trans_x(-B))
    out = export_layout(write_layout_render(tmp_path / "m", n=2, stereo=False), tmp_path / "mo", "slam")
    s = read_orbslam3(out / "orbslam3" / "mono.yaml", stereo=False, inertial=False)
    assert s["Camera.type"] == "PinHole" and "Camera2.fx" not in s
    fs = cv2.FileStorage(str(out / "vins_fusion" / "config.yaml"), cv2.FILE_STORAGE_READ)
    assert int(fs.getNode("num_of_cam").real()) == 1 and not (out / "vins_fusion" / "cam1.yaml").exists()


def test_written_beside_the_euroc_and_rosbag_exports(tmp_path):
    render = imu_render(tmp_path / "r")
    out = export_layout(render, tmp_path / "e", "euroc")
    stamps = [ln.split(",")[0] for ln in (out / "mav0" / "cam0" / "data.csv").read_text().splitlines()[1:]]
    assert (out / "slam" / "orbslam3" / "times.txt").read_text().split() == stamps
    read_orbslam3(out / "slam" / "orbslam3" / "stereo_inertial.yaml", stereo=True, inertial=True)
    pytest.importorskip("rosbags")
    out = export_layout(render, tmp_path / "b", "rosbag")
    assert (out / "bag").is_dir() and (out / "slam" / "kalibr" / "camchain-imucam.yaml").is_file()


def test_byte_reproducible(tmp_path):
    render = imu_render(tmp_path / "r")
    a = export_layout(render, tmp_path / "a", "slam")
    b = export_layout(render, tmp_path / "b", "slam")
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert len(files) > 10 and all((a / f).read_bytes() == (b / f).read_bytes() for f in files)
