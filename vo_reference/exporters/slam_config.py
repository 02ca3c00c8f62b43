"""SLAM / VIO settings of a render's rig, so that a user runs ORB-SLAM3, VINS-Fusion,
OpenVINS, Kalibr-based tools or Basalt on the ``euroc`` or ``rosbag`` export without writing
a calibration by hand. Written into ``slam/`` beside those exports, or alone with
``--to slam``::

    README.md                          which file for which system, and what was left out
    orbslam3/stereo.yaml               ORB-SLAM3 (File.version "1.0"): stereo, or mono.yaml for a mono render
    orbslam3/stereo_inertial.yaml      ... with the IMU (mono_inertial.yaml), when the render has one
    orbslam3/times.txt                 the exported frames' stamps in ns (the EuRoC examples' times file)
    vins_fusion/config.yaml, cam0.yaml, cam1.yaml   VINS-Fusion (imu: 1 with an IMU, else stereo only)
    openvins/estimator_config.yaml, kalibr_imu_chain.yaml, kalibr_imucam_chain.yaml   (IMU only)
    kalibr/camchain-imucam.yaml, imu.yaml   Kalibr's formats (camchain.yaml without an IMU)
    basalt/calib.json                  Basalt's calibration (pinhole or kb4 cameras)

Everything comes from the manifest: K, the lens (a Brown-Conrady or Kannala-Brandt model in
each system's own names), the baseline (right = left . trans(B, 0, 0)), the IMU's
``T_cam_imu`` (the IMU in the left camera frame: p_cam = T_cam_imu p_imu), its noise
densities and random walks (continuous time, Kalibr units, used as such by every system
here), its rate and its clock offset (IMU stamp = camera stamp + offset: Kalibr's
``timeshift_cam_imu``, VINS-Fusion's ``td``, Basalt's ``cam_time_offset_ns``). Without an
IMU the body frame is the left camera. Topics are the rosbag export's (/cam0/image_raw,
/cam1/image_raw, /imu0). A file whose format cannot carry the render's lens (Kalibr and
OpenVINS have no k3; Basalt has no radial-tangential model) is not written; README.md
says which and why.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.rig import T_left_view, T_right_left
from blender_sesgen.contract.lens import opencv_matrix_text, real_text
from blender_sesgen.contract.se3 import R_to_quat_xyzw, invert
from blender_sesgen.contract.sensor_yaml import YAML_HEADER

from ..errors import VoError
from .driver import ExportOptions

__all__ = ["export_slam_config", "write_slam_configs", "slam_config_files", "Rig", "T_body_cam"]

TOPICS = {"cam0": "/cam0/image_raw", "cam1": "/cam1/image_raw", "imu": "/imu0"}


def T_body_cam(seq, cam: int) -> np.ndarray:
    """Camera ``cam``'s pose in the rig's body frame: the IMU where the render has one
    (T_imu_cam = inv(T_cam_imu), the right camera ``contract.rig``'s T_left_right further),
    else the left camera (the body of the EuRoC export and of every settings file here)."""
    T_cam_left = T_left_view("right" if cam == 1 else "left", seq.baseline_m)
    imu = seq.imu_calibration()
    if imu is None:
        return T_cam_left
    return invert(imu.T_cam_imu_matrix) @ T_cam_left


class Rig:
    """The rig as the settings files need it (all from the manifest)."""

    def __init__(self, seq):
        self.K = np.asarray(seq.K, dtype=float)
        self.W, self.H = (int(x) for x in seq.resolution)
        self.stereo = "right" in seq.views and seq.baseline_m > 0
        self.baseline_m = float(seq.baseline_m)
        lens = seq.lens
        self.lens = None if lens is None or lens.is_pinhole else lens
        self.fps = seq.rate_hz
        self.imu = seq.imu_calibration()     # contract.manifest_sections.ImuSection, or None
        self.cams = [0, 1] if self.stereo else [0]
        # camera i in the body frame (the IMU, else the left camera) and the IMU in camera i
        self.T_body_cam = [T_body_cam(seq, i) for i in self.cams]
        self.T_cam_body = [invert(T) for T in self.T_body_cam]
        self.T_cam1_cam0 = T_right_left(self.baseline_m)
        self.offset_s = self.imu.time_offset_s if self.imu is not None else 0.0

    @property
    def brown(self) -> tuple | None:
        return self.lens.coeffs if self.lens is not None and self.lens.model == "brown" else None

    @property
    def fisheye(self) -> bool:
        return self.lens is not None and self.lens.model == "kannala_brandt"

    @property
    def gravity(self) -> float:
        return float(np.linalg.norm(self.imu.gravity_world))


def _r(x) -> str:
    return real_text(x)


def _fx_fy_cx_cy(K) -> tuple[float, float, float, float]:
    return float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])


def _list(xs) -> str:
    return "[" + ", ".join(_r(x) for x in xs) + "]"


def _rows(T, indent: str) -> str:
    return "".join(f"{indent}- {_list(row)}\n" for row in np.asarray(T, dtype=float))


# --- ORB-SLAM3 ---------------------------------------------------------------------------

def orbslam3_yaml(rig: Rig, inertial: bool) -> str:
    """ORB-SLAM3 settings (File.version "1.0", read by its Settings.cc): the rectified
    pinhole stereo pair as ``Rectified`` + Stereo.b; with a lens ``PinHole`` + distortion (or
    ``KannalaBrandt8``) per camera + Stereo.T_c1_c2; matrices float32 as ORB-SLAM3 reads them."""
    fx, fy, cx, cy = _fx_fy_cx_cy(rig.K)
    mode = ("stereo" if rig.stereo else "monocular") + (" + IMU" if inertial else "")
    if rig.fisheye:
        cam_type = "KannalaBrandt8"
    elif rig.stereo and rig.brown is None:
        cam_type = "Rectified"
    else:
        cam_type = "PinHole"
    lines = ["%YAML:1.0", f"# ORB-SLAM3 settings ({mode}) of a sesgen render, from its manifest", "",
             'File.version: "1.0"', "", f'Camera.type: "{cam_type}"']
    for c in (1, 2) if (rig.stereo and cam_type != "Rectified") else (1,):
        lines += [f"Camera{c}.fx: {_r(fx)}", f"Camera{c}.fy: {_r(fy)}", f"Camera{c}.cx: {_r(cx)}", f"Camera{c}.cy: {_r(cy)}"]
        if rig.brown is not None:
            k1, k2, p1, p2, k3 = rig.brown
            lines += [f"Camera{c}.k1: {_r(k1)}", f"Camera{c}.k2: {_r(k2)}", f"Camera{c}.p1: {_r(p1)}",
                      f"Camera{c}.p2: {_r(p2)}"] + ([f"Camera{c}.k3: {_r(k3)}"] if k3 else [])
        if rig.fisheye:
            lines += [f"Camera{c}.k{i + 1}: {_r(k)}" for i, k in enumerate(rig.lens.coeffs)]
            if rig.stereo:   # a parallel rig: the two images overlap over their whole width
                lines += [f"Camera{c}.overlappingBegin: 0", f"Camera{c}.overlappingEnd: {rig.W - 1}"]
        lines.append("")
    lines += [f"Camera.width: {rig.W}", f"Camera.height: {rig.H}", f"Camera.fps: {max(1, int(round(rig.fps)))}",
              "Camera.RGB: 0   # colour images are read BGR by OpenCV", ""]
    if rig.stereo:
        if cam_type == "Rectified":
            lines.append(f"Stereo.b: {_r(rig.baseline_m)}")
        else:
            lines.append(opencv_matrix_text("Stereo.T_c1_c2", invert(rig.T_cam1_cam0), "f").rstrip())
        lines += ["Stereo.ThDepth: 60.0", ""]
    if inertial:
        lines += ["# camera 1 in the body (IMU) frame; continuous-time noise densities (Kalibr units)",
                  opencv_matrix_text("IMU.T_b_c1", rig.T_body_cam[0], "f").rstrip(),
                  f"IMU.NoiseGyro: {_r(rig.imu.gyroscope_noise_density)}",
                  f"IMU.NoiseAcc: {_r(rig.imu.accelerometer_noise_density)}",
                  f"IMU.GyroWalk: {_r(rig.imu.gyroscope_random_walk)}",
                  f"IMU.AccWalk: {_r(rig.imu.accelerometer_random_walk)}",
                  f"IMU.Frequency: {_r(rig.imu.rate_hz)}", ""]
    lines += ["ORBextractor.nFeatures: 1200", "ORBextractor.scaleFactor: 1.2", "ORBextractor.nLevels: 8",
              "ORBextractor.iniThFAST: 20", "ORBextractor.minThFAST: 7", "",
              "Viewer.KeyFrameSize: 0.05", "Viewer.KeyFrameLineWidth: 1.0", "Viewer.GraphLineWidth: 0.9",
              "Viewer.PointSize: 2.0", "Viewer.CameraSize: 0.08", "Viewer.CameraLineWidth: 3.0",
              "Viewer.ViewpointX: 0.0", "Viewer.ViewpointY: -0.7", "Viewer.ViewpointZ: -1.8",
              "Viewer.ViewpointF: 500.0"]
    return "\n".join(lines) + "\n"


# --- VINS-Fusion --------------------------------------------------------------------------

def vins_camera_yaml(rig: Rig, name: str) -> str:
    """A camodocal camera file: PINHOLE (k1 k2 p1 p2), PINHOLE_FULL (with k3) or
    KANNALA_BRANDT (its k2..k5 are Kannala-Brandt's k1..k4; mu mv u0 v0 = fx fy cx cy)."""
    fx, fy, cx, cy = _fx_fy_cx_cy(rig.K)
    head = f"%YAML:1.0\n---\nmodel_type: {{}}\ncamera_name: {name}\nimage_width: {rig.W}\nimage_height: {rig.H}\n"
    if rig.fisheye:
        k = rig.lens.coeffs
        return (head.format("KANNALA_BRANDT") + "projection_parameters:\n"
                + "".join(f"   k{i + 2}: {_r(c)}\n" for i, c in enumerate(k))
                + f"   mu: {_r(fx)}\n   mv: {_r(fy)}\n   u0: {_r(cx)}\n   v0: {_r(cy)}\n")
    k1, k2, p1, p2, k3 = rig.brown if rig.brown is not None else (0.0,) * 5
    dist = f"   k1: {_r(k1)}\n   k2: {_r(k2)}\n"
    if k3:
        dist += f"   k3: {_r(k3)}\n   k4: 0.0\n   k5: 0.0\n   k6: 0.0\n"
    dist += f"   p1: {_r(p1)}\n   p2: {_r(p2)}\n"
    return (head.format("PINHOLE_FULL" if k3 else "PINHOLE") + "distortion_parameters:\n" + dist
            + f"projection_parameters:\n   fx: {_r(fx)}\n   fy: {_r(fy)}\n   cx: {_r(cx)}\n   cy: {_r(cy)}\n")


def vins_config_yaml(rig: Rig) -> str:
    """VINS-Fusion's main settings (the keys its parameters.cpp reads)."""
    imu = rig.imu is not None
    out = ["%YAML:1.0", "# VINS-Fusion settings of a sesgen render, from its manifest", "",
           f"imu: {int(imu)}", f"num_of_cam: {len(rig.cams)}", "",
           f'imu_topic: "{TOPICS["imu"]}"', f'image0_topic: "{TOPICS["cam0"]}"',
           f'image1_topic: "{TOPICS["cam1"]}"', 'output_path: "~/output/"', "",
           'cam0_calib: "cam0.yaml"'] + (['cam1_calib: "cam1.yaml"'] if rig.stereo else []) + [
           f"image_width: {rig.W}", f"image_height: {rig.H}", "",
           "# cameras in the body frame (" + ("the IMU" if imu else "the left camera") + "); exact: not estimated",
           "estimate_extrinsic: 0"]
    out += [opencv_matrix_text(f"body_T_cam{i}", T).rstrip() for i, T in zip(rig.cams, rig.T_body_cam)]
    out += ["", "multiple_thread: 1", "max_cnt: 150", "min_dist: 30", "freq: 10", "F_threshold: 1.0",
            "show_track: 1", "flow_back: 1", "", "max_solver_time: 0.04", "max_num_iterations: 8",
            "keyframe_parallax: 10.0", ""]
    if imu:
        out += ["# continuous-time noise densities and random walks of the render's IMU (exact; VINS-Fusion's",
                "# own EuRoC settings inflate theirs about tenfold for robustness)",
                f"acc_n: {_r(rig.imu.accelerometer_noise_density)}",
                f"gyr_n: {_r(rig.imu.gyroscope_noise_density)}",
                f"acc_w: {_r(rig.imu.accelerometer_random_walk)}",
                f"gyr_w: {_r(rig.imu.gyroscope_random_walk)}",
                f"g_norm: {_r(rig.gravity)}", ""]
    out += ["# image clock + td = IMU clock", "estimate_td: 0", f"td: {_r(rig.offset_s)}", "",
            "load_previous_pose_graph: 0", 'pose_graph_save_path: "~/output/pose_graph/"', "save_image: 0"]
    return "\n".join(out) + "\n"


# --- Kalibr and OpenVINS (Kalibr's formats) -----------------------------------------------

def _kalibr_distortion(rig: Rig) -> tuple[str, list[float]]:
    if rig.fisheye:
        return "equidistant", list(rig.lens.coeffs)
    k1, k2, p1, p2, _ = rig.brown if rig.brown is not None else (0.0,) * 5
    return "radtan", [k1, k2, p1, p2]


def kalibr_camchain_yaml(rig: Rig, key: str = "T_cam_imu", header: str = "") -> str:
    """Kalibr's camchain(-imucam).yaml: per camera its model, intrinsics [fu, fv, pu, pv],
    distortion, resolution, topic, T_cn_cnm1 (camera n from camera n-1) and, with an IMU,
    T_cam_imu (IMU to camera) and timeshift_cam_imu (t_imu = t_cam + shift).
    ``key`` "T_imu_cam" writes OpenVINS's variant (camera to IMU)."""
    model, coeffs = _kalibr_distortion(rig)
    fx, fy, cx, cy = _fx_fy_cx_cy(rig.K)
    out = header
    for i in rig.cams:
        out += f"cam{i}:\n"
        if rig.imu is not None:
            T = rig.T_cam_body[i] if key == "T_cam_imu" else rig.T_body_cam[i]
            out += f"  {key}:\n" + _rows(T, "    ")
        if i == 1:
            out += "  T_cn_cnm1:\n" + _rows(rig.T_cam1_cam0, "    ")
        out += (f"  cam_overlaps: {[j for j in rig.cams if j != i]}\n  camera_model: pinhole\n"
                f"  distortion_coeffs: {_list(coeffs)}\n  distortion_model: {model}\n"
                f"  intrinsics: {_list([fx, fy, cx, cy])}\n  resolution: [{rig.W}, {rig.H}]\n"
                f"  rostopic: {TOPICS[f'cam{i}']}\n")
        if rig.imu is not None:
            out += f"  timeshift_cam_imu: {_r(rig.offset_s)}\n"
    return out


def kalibr_imu_yaml(rig: Rig) -> str:
    """Kalibr's imu.yaml (the input of kalibr_calibrate_imu_camera)."""
    return ("# Accelerometer: [ m / s^2 / sqrt(Hz) ] and [ m / s^3 / sqrt(Hz) ]\n"
            f"accelerometer_noise_density: {_r(rig.imu.accelerometer_noise_density)}\n"
            f"accelerometer_random_walk: {_r(rig.imu.accelerometer_random_walk)}\n"
            "# Gyroscope: [ rad / s / sqrt(Hz) ] and [ rad / s^2 / sqrt(Hz) ]\n"
            f"gyroscope_noise_density: {_r(rig.imu.gyroscope_noise_density)}\n"
            f"gyroscope_random_walk: {_r(rig.imu.gyroscope_random_walk)}\n"
            f"rostopic: {TOPICS['imu']}\nupdate_rate: {_r(rig.imu.rate_hz)}\n")


def openvins_imu_chain_yaml(rig: Rig) -> str:
    eye3 = _rows(np.eye(3), "    ")
    return (YAML_HEADER + "imu0:\n  T_i_b:\n" + _rows(np.eye(4), "    ")
            + f"  accelerometer_noise_density: {_r(rig.imu.accelerometer_noise_density)}\n"
            f"  accelerometer_random_walk: {_r(rig.imu.accelerometer_random_walk)}\n"
            f"  gyroscope_noise_density: {_r(rig.imu.gyroscope_noise_density)}\n"
            f"  gyroscope_random_walk: {_r(rig.imu.gyroscope_random_walk)}\n"
            f"  rostopic: {TOPICS['imu']}\n  time_offset: 0.0\n  update_rate: {_r(rig.imu.rate_hz)}\n"
            '  model: "kalibr"\n  Tw:\n' + eye3 + "  R_IMUtoGYRO:\n" + eye3 + "  Ta:\n" + eye3
            + "  R_IMUtoACC:\n" + eye3 + "  Tg:\n" + _rows(np.zeros((3, 3)), "    "))


def openvins_estimator_yaml(rig: Rig) -> str:
    """OpenVINS's estimator_config.yaml (every key its VioManagerOptions requires); the
    calibration is exact, so it is not estimated online."""
    values = [("verbosity", '"INFO"'), ("use_fej", "true"), ("integration", '"rk4"'),
              ("use_stereo", "true" if rig.stereo else "false"), ("max_cameras", str(len(rig.cams))),
              ("calib_cam_extrinsics", "false"), ("calib_cam_intrinsics", "false"),
              ("calib_cam_timeoffset", "false"), ("calib_imu_intrinsics", "false"),
              ("calib_imu_g_sensitivity", "false"),
              ("max_clones", "11"), ("max_slam", "50"), ("max_slam_in_update", "25"), ("max_msckf_in_update", "40"),
              ("dt_slam_delay", "1"), ("gravity_mag", _r(rig.gravity)),
              ("feat_rep_msckf", '"GLOBAL_3D"'), ("feat_rep_slam", '"ANCHORED_MSCKF_INVERSE_DEPTH"'),
              ("feat_rep_aruco", '"ANCHORED_MSCKF_INVERSE_DEPTH"'),
              ("try_zupt", "false"), ("zupt_chi2_multipler", "0"), ("zupt_max_velocity", "0.1"),
              ("zupt_noise_multiplier", "10"), ("zupt_max_disparity", "0.5"), ("zupt_only_at_beginning", "false"),
              ("init_window_time", "2.0"), ("init_imu_thresh", "1.5"), ("init_max_disparity", "10.0"),
              ("init_max_features", "50"), ("init_dyn_use", "false"), ("init_dyn_mle_opt_calib", "false"),
              ("init_dyn_mle_max_iter", "50"), ("init_dyn_mle_max_time", "0.05"), ("init_dyn_mle_max_threads", "6"),
              ("init_dyn_num_pose", "6"), ("init_dyn_min_deg", "10.0"), ("init_dyn_inflation_ori", "10"),
              ("init_dyn_inflation_vel", "100"), ("init_dyn_inflation_bg", "10"), ("init_dyn_inflation_ba", "100"),
              ("init_dyn_min_rec_cond", "1e-12"), ("init_dyn_bias_g", "[0.0, 0.0, 0.0]"),
              ("init_dyn_bias_a", "[0.0, 0.0, 0.0]"),
              ("record_timing_information", "false"), ("record_timing_filepath", '"/tmp/traj_timing.txt"'),
              ("save_total_state", "false"), ("filepath_est", '"/tmp/ov_estimate.txt"'),
              ("filepath_std", '"/tmp/ov_estimate_std.txt"'), ("filepath_gt", '"/tmp/ov_groundtruth.txt"'),
              ("use_klt", "true"), ("num_pts", "200"), ("fast_threshold", "20"), ("grid_x", "5"), ("grid_y", "5"),
              ("min_px_dist", "10"), ("knn_ratio", "0.70"), ("track_frequency", _r(rig.fps)),
              ("downsample_cameras", "false"), ("num_opencv_threads", "4"), ("histogram_method", '"HISTOGRAM"'),
              ("use_aruco", "false"), ("num_aruco", "1024"), ("downsize_aruco", "true"),
              ("up_msckf_sigma_px", "1"), ("up_msckf_chi2_multipler", "1"), ("up_slam_sigma_px", "1"),
              ("up_slam_chi2_multipler", "1"), ("up_aruco_sigma_px", "1"), ("up_aruco_chi2_multipler", "1"),
              ("use_mask", "false"),
              ("relative_config_imu", '"kalibr_imu_chain.yaml"'),
              ("relative_config_imucam", '"kalibr_imucam_chain.yaml"')]
    return (YAML_HEADER + "# OpenVINS settings of a sesgen render (exact calibration: not estimated)\n"
            + "".join(f"{k}: {v}\n" for k, v in values))


# --- Basalt -------------------------------------------------------------------------------

def basalt_calib_json(rig: Rig) -> str:
    """Basalt's calibration (cereal JSON ``value0``): T_imu_cam per camera (p_imu = T p_cam;
    px py pz qx qy qz qw), ``pinhole`` or ``kb4`` intrinsics, and the IMU's continuous-time
    noise (``*_noise_std``) and random walks (``*_bias_std``)."""
    fx, fy, cx, cy = _fx_fy_cx_cy(rig.K)
    poses, intr = [], []
    for T in rig.T_body_cam:
        q = R_to_quat_xyzw(T[:3, :3])
        poses.append(dict(zip(("px", "py", "pz"), (float(x) + 0.0 for x in T[:3, 3])))
                     | dict(zip(("qx", "qy", "qz", "qw"), (float(x) + 0.0 for x in q))))
        ci = {"fx": fx, "fy": fy, "cx": cx, "cy": cy}
        if rig.fisheye:
            ci.update(zip(("k1", "k2", "k3", "k4"), (float(k) for k in rig.lens.coeffs)))
        intr.append({"camera_type": "kb4" if rig.fisheye else "pinhole", "intrinsics": ci})
    if rig.imu is not None:
        rate = rig.imu.rate_hz
        noise = [rig.imu.accelerometer_noise_density, rig.imu.gyroscope_noise_density,
                 rig.imu.accelerometer_random_walk, rig.imu.gyroscope_random_walk]
    else:   # no IMU: basalt's defaults, unused with --use-imu 0
        rate, noise = 200.0, [0.016, 0.000282, 0.001, 0.0001]
    value = {"T_imu_cam": poses, "intrinsics": intr, "resolution": [[rig.W, rig.H]] * len(rig.cams),
             "calib_accel_bias": [0.0] * 9, "calib_gyro_bias": [0.0] * 12, "imu_update_rate": rate,
             "accel_noise_std": [noise[0]] * 3, "gyro_noise_std": [noise[1]] * 3,
             "accel_bias_std": [noise[2]] * 3, "gyro_bias_std": [noise[3]] * 3,
             "cam_time_offset_ns": int(round(rig.offset_s * 1e9)), "vignette": []}
    return json.dumps({"value0": value}, indent=4) + "\n"


# --- the set --------------------------------------------------------------------------------

def slam_config_files(seq, t_ns=None) -> tuple[dict[str, str], list[str]]:
    """({relative path: text} of every settings file the rig allows, [notes on the files
    left out]); ``t_ns``: the exported frames' stamps for ORB-SLAM3's times file."""
    rig = Rig(seq)
    files: dict[str, str] = {}
    left_out: list[str] = []
    base = "stereo" if rig.stereo else "mono"
    files[f"orbslam3/{base}.yaml"] = orbslam3_yaml(rig, inertial=False)
    if rig.imu is not None:
        files[f"orbslam3/{base}_inertial.yaml"] = orbslam3_yaml(rig, inertial=True)
    if t_ns is not None:
        files["orbslam3/times.txt"] = "".join(f"{int(t)}\n" for t in t_ns)
    files["vins_fusion/config.yaml"] = vins_config_yaml(rig)
    for i in rig.cams:
        files[f"vins_fusion/cam{i}.yaml"] = vins_camera_yaml(rig, f"cam{i}")
    if rig.brown is not None and rig.brown[4]:
        left_out.append("kalibr/, openvins/: their radial-tangential model has k1 k2 p1 p2 only and this lens "
                        "has k3 != 0 (export with --undistort)")
    else:
        if rig.imu is not None:
            files["kalibr/camchain-imucam.yaml"] = kalibr_camchain_yaml(rig)
            files["kalibr/imu.yaml"] = kalibr_imu_yaml(rig)
            files["openvins/estimator_config.yaml"] = openvins_estimator_yaml(rig)
            files["openvins/kalibr_imu_chain.yaml"] = openvins_imu_chain_yaml(rig)
            files["openvins/kalibr_imucam_chain.yaml"] = kalibr_camchain_yaml(rig, "T_imu_cam", YAML_HEADER)
        else:
            files["kalibr/camchain.yaml"] = kalibr_camchain_yaml(rig)
            left_out.append("openvins/: OpenVINS needs an IMU (add IMU to the script)")
    if rig.brown is not None:
        left_out.append("basalt/: Basalt has no radial-tangential camera model (export with --undistort)")
    else:
        files["basalt/calib.json"] = basalt_calib_json(rig)
    files["README.md"] = _readme(rig, files, left_out)
    return files, left_out


def _readme(rig: Rig, files: dict, left_out: list[str]) -> str:
    body = "the IMU" if rig.imu is not None else "the left camera (no IMU in the render)"
    lines = ["# SLAM / VIO settings of this render", "",
             "Written from the render's manifest (exact calibration). Body frame: " + body + ".",
             "Topics: /cam0/image_raw, /cam1/image_raw, /imu0 (the rosbag export's); images and IMU",
             "files: the euroc export's mav0/.", "", "| file | system |", "|---|---|"]
    what = {"orbslam3/": "ORB-SLAM3 (`stereo_euroc` / `stereo_inertial_euroc VOC SETTINGS EUROC_DIR times.txt`)",
            "vins_fusion/": "VINS-Fusion (`vins_node vins_fusion/config.yaml`)",
            "openvins/": "OpenVINS (`config_path:=openvins/estimator_config.yaml`)",
            "kalibr/": "Kalibr formats (camchain, imu) for tools that read them",
            "basalt/": "Basalt (`basalt_vio --cam-calib basalt/calib.json`)"}
    for path in sorted(files):
        sys_ = next((v for k, v in what.items() if path.startswith(k)), "")
        lines.append(f"| {path} | {sys_} |")
    if left_out:
        lines += ["", "Not written:"] + [f"- {note}" for note in left_out]
    return "\n".join(lines) + "\n"


def write_slam_configs(seq, folder: Path, t_ns=None) -> list[str]:
    """Write the settings into ``folder``; returns the notes on files left out."""
    files, left_out = slam_config_files(seq, t_ns)
    for rel, text in files.items():
        atomic.write_text(Path(folder) / rel, text)
    return left_out


def export_slam_config(seq, out: Path, opts: ExportOptions) -> None:
    if dict(opts.extra):
        raise VoError(f"slam export: unknown option(s) {', '.join(sorted(opts.extra))} (none)")
    from blender_sesgen.contract.timing import to_ns
    write_slam_configs(seq, out, to_ns(seq.timestamps_s[list(opts.frames)]))


export_slam_config.keeps_lens = True   # a distorted render is written as it is, with its lens (docs/output-format.md)
