"""EuRoC / Kalibr sensor YAML files (``sensor.yaml`` of a camera, an IMU, the ground truth):
one writer for the renderer and the exports (text only).

Every file opens with ``%YAML 1.0`` and ``---``, the one header both PyYAML
(``yaml.safe_load``: Kalibr, most Python loaders) and OpenCV's ``cv::FileStorage`` accept.
EuRoC's own files open with ``%YAML:1.0``, which OpenCV reads and PyYAML refuses.
"""
from __future__ import annotations

import numpy as np

from .manifest_sections import ImuSection

YAML_HEADER = "%YAML 1.0\n---\n"


def yaml_matrix(T) -> str:
    """A 4x4 matrix as EuRoC's ``T_BS`` block (cols, rows, row-major data), indented 2."""
    rows = [", ".join(f"{x:.17g}" for x in r) for r in np.asarray(T, dtype=float)]
    return "  cols: 4\n  rows: 4\n  data: [" + ",\n         ".join(rows) + "]\n"


def imu_sensor_yaml(imu: ImuSection, T_BS=None) -> str:
    """EuRoC ``imu0/sensor.yaml`` (Kalibr's imu.yaml keys included) of the manifest's ``imu``
    section (rate, the four densities under their Kalibr names, T_cam_imu, time offset,
    gravity); ``T_BS`` the IMU in the body frame (identity: the body is the IMU)."""
    T = np.eye(4) if T_BS is None else T_BS
    g = imu.gravity_world
    return (YAML_HEADER + "# General sensor definitions.\nsensor_type: imu\ncomment: sesgen IMU (body frame = IMU)\n\n"
            "# Sensor extrinsics wrt. the body-frame.\nT_BS:\n" + yaml_matrix(T)
            + f"rate_hz: {imu.rate_hz:.9g}\n\n# inertial sensor noise model parameters (static)\n"
            f"gyroscope_noise_density: {imu.gyroscope_noise_density:.9g}     # [ rad / s / sqrt(Hz) ]\n"
            f"gyroscope_random_walk: {imu.gyroscope_random_walk:.9g}       # [ rad / s^2 / sqrt(Hz) ]\n"
            f"accelerometer_noise_density: {imu.accelerometer_noise_density:.9g}  # [ m / s^2 / sqrt(Hz) ]\n"
            f"accelerometer_random_walk: {imu.accelerometer_random_walk:.9g}    # [ m / s^3 / sqrt(Hz) ]\n"
            f"update_rate: {imu.rate_hz:.9g}\n"
            f"time_offset_s: {imu.time_offset_s:.9g}   # IMU stamp = camera time + offset\n"
            f"gravity_world: [{g[0]:.9g}, {g[1]:.9g}, {g[2]:.9g}]   # SES world, Y up\n"
            "T_cam_imu:\n" + yaml_matrix(imu.T_cam_imu_matrix))
