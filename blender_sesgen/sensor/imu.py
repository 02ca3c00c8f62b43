"""An accelerometer + gyroscope rigidly attached to the rig (numpy only).

Conventions (the one home; docs/output-format.md):

- IMU frame = body frame. ``T_cam_imu`` is the IMU's pose in the left camera frame
  (OpenCV axes), so ``T_world_imu(t) = T_world_cam(t) @ T_cam_imu``.
- Gravity: the SES world is Y up, ``g_world = (0, -g, 0)`` with g = 9.81 m/s^2 by default.
- Accelerometer: specific force ``f = R_world_imu^T (a_world - g_world)`` of the IMU's
  origin (at rest it reads +g along the body's up axis); gyroscope: the body angular rate
  ``omega = R_cam_imu^T omega_cam`` (rad/s).
- Clocks: a sample describing the true instant t (the camera clock) is stamped
  ``t + time_offset_s`` (Kalibr's ``timeshift_cam_imu``: t_imu = t_cam + shift). Samples are
  taken at ``t_stamp = start + i / rate`` covering the camera's first to last frame stamp.
- Noise (EuRoC/Kalibr continuous-time model): white noise of density sigma (per sqrt(Hz))
  becomes sigma * sqrt(rate) per sample; a bias random walk of density sigma_b (per
  s*sqrt(Hz)) steps by sigma_b * sqrt(1 / rate) per sample, starting at 0. Defaults: the
  ADIS16448 of EuRoC (gyro 1.6968e-04 rad/s/sqrt(Hz), 1.9393e-05 rad/s^2/sqrt(Hz);
  accelerometer 2.0e-3 m/s^2/sqrt(Hz), 3.0e-3 m/s^3/sqrt(Hz)).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..contract.rig_motion import RigMotion

GRAVITY = 9.81
ADIS16448 = {"gyro_noise": 1.6968e-04, "gyro_walk": 1.9393e-05, "accel_noise": 2.0e-3, "accel_walk": 3.0e-3}


@dataclass(frozen=True)
class ImuParams:
    rate_hz: float = 200.0
    gyro_noise: float = ADIS16448["gyro_noise"]      # rad/s/sqrt(Hz)
    gyro_walk: float = ADIS16448["gyro_walk"]        # rad/s^2/sqrt(Hz)
    accel_noise: float = ADIS16448["accel_noise"]    # m/s^2/sqrt(Hz)
    accel_walk: float = ADIS16448["accel_walk"]      # m/s^3/sqrt(Hz)
    T_cam_imu: tuple = field(default_factory=lambda: tuple(map(tuple, np.eye(4))))
    time_offset_s: float = 0.0
    gravity: float = GRAVITY
    seed: int = 0

    @property
    def T(self) -> np.ndarray:
        return np.array(self.T_cam_imu, dtype=float)


@dataclass(frozen=True)
class ImuStream:
    """Samples: ``t_s`` stamps (IMU clock), ``gyro`` (n, 3) rad/s, ``accel`` (n, 3) m/s^2;
    for noisy streams the true biases ``gyro_bias``/``accel_bias`` (n, 3) that were added."""
    t_s: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    gyro_bias: np.ndarray | None = None
    accel_bias: np.ndarray | None = None


def sample_times(t_first_s: float, t_last_s: float, params: ImuParams) -> np.ndarray:
    """IMU stamps ``t_first + offset + i / rate`` up to ``t_last + offset`` (inclusive to 1 ns)."""
    n = int(np.floor((t_last_s - t_first_s) * params.rate_hz + 1e-6)) + 1
    return t_first_s + params.time_offset_s + np.arange(max(n, 1)) / params.rate_hz


def imu_state(motion: RigMotion, t_true_s, params: ImuParams):
    """(T_world_imu (n,4,4), v_world (n,3), specific force (n,3), body rate (n,3)) at true times."""
    kin = motion.kinematics(t_true_s)
    T_ci = params.T
    R_ci, t_ci = T_ci[:3, :3], T_ci[:3, 3]
    R_wi = kin.R @ R_ci
    p_wi = kin.p + kin.R @ t_ci
    v_wi = kin.v + kin.R_dot @ t_ci
    a_wi = kin.a + kin.R_ddot @ t_ci
    g_world = np.array([0.0, -params.gravity, 0.0])
    f = np.einsum("nji,nj->ni", R_wi, a_wi - g_world)
    w = kin.omega_body @ R_ci            # R_ci^T omega for each row
    T = np.tile(np.eye(4), (len(p_wi), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R_wi, p_wi
    return T, v_wi, f, w


def ideal_stream(motion: RigMotion, stamps_s: np.ndarray, params: ImuParams) -> ImuStream:
    _, _, f, w = imu_state(motion, np.asarray(stamps_s) - params.time_offset_s, params)
    return ImuStream(np.asarray(stamps_s, dtype=float), w, f)


def add_noise(ideal: ImuStream, params: ImuParams, seed: int | None = None) -> ImuStream:
    """White noise plus bias random walks (discrete form of the continuous model)."""
    rng = np.random.default_rng([int(params.seed if seed is None else seed), 0x1A0])
    n = len(ideal.t_s)
    dt = 1.0 / params.rate_hz
    gw = rng.standard_normal((n, 3)) * params.gyro_noise / np.sqrt(dt)
    aw = rng.standard_normal((n, 3)) * params.accel_noise / np.sqrt(dt)
    gb = np.cumsum(rng.standard_normal((n, 3)) * params.gyro_walk * np.sqrt(dt), axis=0)
    ab = np.cumsum(rng.standard_normal((n, 3)) * params.accel_walk * np.sqrt(dt), axis=0)
    gb -= gb[0]
    ab -= ab[0]
    return ImuStream(ideal.t_s, ideal.gyro + gb + gw, ideal.accel + ab + aw, gb, ab)


def csv_text(stream: ImuStream) -> str:
    """EuRoC ``imu0/data.csv``: ns stamp, gyro x y z (rad/s), accelerometer x y z (m/s^2)."""
    from ..contract.timing import to_ns
    lines = ["#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
             "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]"]
    for tn, w, a in zip(to_ns(stream.t_s), stream.gyro, stream.accel):
        lines.append(f"{int(tn)}," + ",".join(f"{x:.17g}" for x in (*w, *a)))
    return "\n".join(lines) + "\n"
