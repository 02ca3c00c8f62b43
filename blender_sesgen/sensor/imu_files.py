"""IMU files of a render folder in the EuRoC / Kalibr layouts (text only)."""
from __future__ import annotations

import numpy as np

from ..contract.timing import to_ns

EUROC_GT_HEADER = ("#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
                   "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], "
                   "b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], "
                   "b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]")


def groundtruth_csv(t_s, T_world_imu, v_world, gyro_bias=None, accel_bias=None) -> str:
    """EuRoC ``state_groundtruth_estimate0/data.csv``: body (IMU) position, quaternion
    (w first, w >= 0), world velocity and the true biases of the noisy stream."""
    from ..contract.se3 import R_to_quat_xyzw
    n = len(t_s)
    gb = np.zeros((n, 3)) if gyro_bias is None else gyro_bias
    ab = np.zeros((n, 3)) if accel_bias is None else accel_bias
    lines = [EUROC_GT_HEADER]
    for tn, T, v, bw, ba in zip(to_ns(t_s), T_world_imu, v_world, gb, ab):
        x, y, z, w = R_to_quat_xyzw(T[:3, :3])
        vals = (*T[:3, 3], w, x, y, z, *v, *bw, *ba)
        lines.append(f"{int(tn)}," + ",".join(f"{v:.17g}" for v in vals))
    return "\n".join(lines) + "\n"
