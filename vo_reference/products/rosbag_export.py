"""Export target ``rosbag``: a ROS 2 bag (mcap storage by default; ``--opt storage=sqlite3``)
written with the ``rosbags`` library, carrying what the ROS wrappers of VINS-Fusion,
OpenVINS and ORB-SLAM3 subscribe to, on the render's timestamps:

    /cam0/image_raw  /cam1/image_raw     sensor_msgs/msg/Image (mono8; --opt encoding=rgb8)
    /cam0/camera_info /cam1/camera_info  sensor_msgs/msg/CameraInfo (K, D, R = I, P; the
                                         right camera's P carries -fx * B, as ROS stereo does)
    /imu0                                sensor_msgs/msg/Imu (the noisy stream; with an IMU)
    /tf                                  tf2_msgs/msg/TFMessage: world -> body ground truth
    /tf_static                           tf2_msgs/msg/TFMessage, once (transient-local, as tf2's
                                         static broadcaster): body -> cam0, cam0 -> cam1, body -> imu0
    /groundtruth/pose                    geometry_msgs/msg/PoseStamped: the same pose

Frames: ``world`` (the SES world, Y up), ``body`` (the IMU where the render has one, else
the left camera), ``cam0``/``cam1`` (OpenCV optical frames), ``imu0``. Stamps are integer
nanoseconds of the render's own stamps (``TIMING start`` + k / rate, the middle of the
exposure; never re-zeroed) and of the IMU samples; the ground truth is published at the
frame stamps (and at every IMU sample with an IMU), the static transforms at the bag's
first instant.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import rig
from ..errors import VoError

TOPICS = {"image": "/cam{}/image_raw", "info": "/cam{}/camera_info", "imu": "/imu0", "tf": "/tf",
          "tf_static": "/tf_static", "pose": "/groundtruth/pose"}


def _typestore():
    try:
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise VoError("the rosbag export needs the 'rosbags' package: pip install 'blender-sesgen[vo]'") from None
    return get_typestore(Stores.ROS2_HUMBLE)


def _quat_xyzw(R: np.ndarray) -> np.ndarray:
    from blender_sesgen.contract.se3 import R_to_quat_xyzw
    return R_to_quat_xyzw(np.asarray(R))


def export_rosbag(seq, out: Path, opts) -> None:
    from blender_sesgen.contract.timing import to_ns
    from .exports import image_gray, image_rgb
    extra = dict(opts.extra)
    encoding = extra.pop("encoding", "mono8")
    storage = extra.pop("storage", "mcap")
    if extra:
        raise VoError(f"rosbag export: unknown option(s) {', '.join(sorted(extra))} (encoding, storage)")
    if encoding not in ("mono8", "rgb8"):
        raise VoError(f"rosbag export: encoding must be mono8 or rgb8, got {encoding!r}")
    from rosbags.rosbag2 import StoragePlugin, Writer
    plugin = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}.get(storage)
    if plugin is None:
        raise VoError(f"rosbag export: storage must be mcap or sqlite3, got {storage!r}")
    ts = _typestore()
    T = ts.types
    Header, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]

    def header(t_ns: int, frame: str):
        return Header(stamp=Time(sec=int(t_ns // 1_000_000_000), nanosec=int(t_ns % 1_000_000_000)), frame_id=frame)

    frames = list(opts.frames)
    t_ns = to_ns(seq.timestamps_s[frames])
    bag = Path(out) / "bag"
    if bag.exists():
        raise VoError(f"{bag}: exists; choose another OUT")
    cams = [(0, "left")] + ([(1, "right")] if "right" in seq.views and seq.baseline_m > 0 else [])
    K = np.asarray(seq.K, dtype=float)
    W, H = seq.resolution
    lens = seq.lens
    d_model, D = ("plumb_bob", [0.0] * 5) if lens is None else (
        ("equidistant", list(lens.coeffs)) if lens.model == "kannala_brandt" else ("plumb_bob", list(lens.coeffs)))
    imu_entry = seq.imu_calibration()
    T_cam_imu = imu_entry.T_cam_imu_matrix if imu_entry is not None else np.eye(4)
    body = "body"
    with Writer(bag, version=9, storage_plugin=plugin) as w:
        conn = {}
        for i, _ in cams:
            conn[("image", i)] = w.add_connection(TOPICS["image"].format(i), "sensor_msgs/msg/Image", typestore=ts)
            conn[("info", i)] = w.add_connection(TOPICS["info"].format(i), "sensor_msgs/msg/CameraInfo", typestore=ts)
        conn["tf"] = w.add_connection(TOPICS["tf"], "tf2_msgs/msg/TFMessage", typestore=ts)
        conn["pose"] = w.add_connection(TOPICS["pose"], "geometry_msgs/msg/PoseStamped", typestore=ts)
        conn["tf_static"] = w.add_connection(TOPICS["tf_static"], "tf2_msgs/msg/TFMessage", typestore=ts,
                                             offered_qos_profiles=[_static_qos()])
        if imu_entry is not None:
            conn["imu"] = w.add_connection(TOPICS["imu"], "sensor_msgs/msg/Imu", typestore=ts)
        imu_rows = _imu_rows(seq, frames, imu_entry) if imu_entry is not None else []
        t_first = min([int(t_ns[0])] + [int(to_ns(t)) for t, _, _ in imu_rows[:1]])
        static = [_transform_stamped(ts, header(t_first, parent), child, T_pc)
                  for parent, child, T_pc in static_transforms(T_cam_imu if imu_entry is not None else None,
                                                               seq.baseline_m if len(cams) == 2 else None)]
        msg = T["tf2_msgs/msg/TFMessage"](transforms=static)
        w.write(conn["tf_static"], t_first, ts.serialize_cdr(msg, msg.__msgtype__))
        ROI = T["sensor_msgs/msg/RegionOfInterest"]
        for idx, k in enumerate(frames):
            tn = int(t_ns[idx])
            for i, view in cams:
                img = image_gray(seq, k, view, opts) if encoding == "mono8" else image_rgb(seq, k, view, opts)
                img = np.ascontiguousarray(img, dtype=np.uint8)
                msg = T["sensor_msgs/msg/Image"](header=header(tn, f"cam{i}"), height=H, width=W, encoding=encoding,
                                                 is_bigendian=0, step=int(img.strides[0]), data=img.reshape(-1))
                w.write(conn[("image", i)], tn, ts.serialize_cdr(msg, msg.__msgtype__))
                P = np.hstack([K, np.zeros((3, 1))])
                P[0, 3] = K[0, 0] * rig.T_view_left(view, seq.baseline_m)[0, 3]   # ROS: fx * Tx
                info = T["sensor_msgs/msg/CameraInfo"](
                    header=header(tn, f"cam{i}"), height=H, width=W, distortion_model=d_model,
                    d=np.array(D, dtype=np.float64), k=K.reshape(-1), r=np.eye(3).reshape(-1), p=P.reshape(-1),
                    binning_x=0, binning_y=0, roi=ROI(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
                w.write(conn[("info", i)], tn, ts.serialize_cdr(info, info.__msgtype__))
        gt = _groundtruth(seq, frames, t_ns, imu_entry, T_cam_imu)
        for tn, Tb in gt:
            _write_pose(w, conn, ts, header, int(tn), Tb, body)
        if imu_entry is not None:
            Imu, V3, Q = T["sensor_msgs/msg/Imu"], T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
            cov = np.zeros(9)
            for t, g, a in imu_rows:
                tn = int(to_ns(t))
                msg = Imu(header=header(tn, "imu0"), orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0),
                          orientation_covariance=np.array([-1.0] + [0.0] * 8),
                          angular_velocity=V3(x=float(g[0]), y=float(g[1]), z=float(g[2])),
                          angular_velocity_covariance=cov.copy(),
                          linear_acceleration=V3(x=float(a[0]), y=float(a[1]), z=float(a[2])),
                          linear_acceleration_covariance=cov.copy())
                w.write(conn["imu"], tn, ts.serialize_cdr(msg, msg.__msgtype__))
    from .slam_config import write_slam_configs
    write_slam_configs(seq, Path(out) / "slam", t_ns)   # the rig's SLAM/VIO settings beside the bag


def _imu_rows(seq, frames, imu_entry) -> list:
    """(t_s, gyro, accel) of the noisy IMU samples within the exported frames' span."""
    stream = seq.imu("noisy")
    lo, hi = seq.timestamps_s[frames[0]], seq.timestamps_s[frames[-1]]
    off = imu_entry.time_offset_s
    return [(t, g, a) for t, g, a in zip(stream["t_s"], stream["gyro"], stream["accel"])
            if lo - 1e-9 <= t - off <= hi + 1e-9]


def static_transforms(T_cam_imu: np.ndarray | None, baseline_m: float | None) -> list:
    """(parent, child, T_parent_child) of the rig's fixed frames (tf2: the child's pose in the
    parent): body -> cam0 (the inverse of T_cam_imu with an IMU, else the identity: the body
    is cam0), cam0 -> cam1 (trans(B, 0, 0)) for a stereo rig, body -> imu0 (identity)."""
    from blender_sesgen.contract.se3 import invert
    out = [("body", "cam0", np.eye(4) if T_cam_imu is None else invert(np.asarray(T_cam_imu, float)))]
    if baseline_m is not None:
        out.append(("cam0", "cam1", rig.T_left_right(baseline_m)))
    if T_cam_imu is not None:
        out.append(("body", "imu0", np.eye(4)))
    return out


def _static_qos():
    """tf2's static broadcaster's QoS: reliable, transient-local (late joiners get it), depth 1."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
    zero = QosTime(sec=0, nsec=0)
    return Qos(history=QosHistory.KEEP_LAST, depth=1, reliability=QosReliability.RELIABLE,
               durability=QosDurability.TRANSIENT_LOCAL, deadline=zero, lifespan=zero,
               liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=zero,
               avoid_ros_namespace_conventions=False)


def _groundtruth(seq, frames, t_ns, imu_entry, T_cam_imu):
    """(t_ns, T_world_body) pairs: at the frame stamps; with an IMU also at its instants."""
    T_left = seq.T_world_cam("left")[frames]
    pairs = [(int(t), Tl @ T_cam_imu) for t, Tl in zip(t_ns, T_left)]
    if imu_entry is not None:
        g = seq.imu_groundtruth()
        lo, hi = int(t_ns[0]), int(t_ns[-1])
        from blender_sesgen.contract.timing import to_ns
        for tn, p, q in zip(to_ns(g["t_s"]), g["p"], g["q_wxyz"]):
            if lo <= tn <= hi:
                w_, x, y, z = q
                R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w_ * z), 2 * (x * z + w_ * y)],
                              [2 * (x * y + w_ * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w_ * x)],
                              [2 * (x * z - w_ * y), 2 * (y * z + w_ * x), 1 - 2 * (x * x + y * y)]])
                Tb = np.eye(4)
                Tb[:3, :3], Tb[:3, 3] = R, p
                pairs.append((int(tn), Tb))
        pairs = sorted({t: T for t, T in pairs}.items())
    return pairs


def _transform_stamped(ts, header, child: str, T_parent_child: np.ndarray):
    T = ts.types
    q = _quat_xyzw(T_parent_child[:3, :3])
    p = T_parent_child[:3, 3]
    return T["geometry_msgs/msg/TransformStamped"](
        header=header, child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=float(p[0]), y=float(p[1]), z=float(p[2])),
            rotation=T["geometry_msgs/msg/Quaternion"](x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))))


def _write_pose(w, conn, ts, header, tn: int, T_world_body: np.ndarray, body: str) -> None:
    T = ts.types
    tf = _transform_stamped(ts, header(tn, "world"), body, T_world_body)
    r, p = tf.transform.rotation, T_world_body[:3, 3]
    pose = T["geometry_msgs/msg/PoseStamped"](
        header=header(tn, "world"),
        pose=T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]),
                                                                                z=float(p[2])), orientation=r))
    w.write(conn["pose"], tn, ts.serialize_cdr(pose, pose.__msgtype__))
    msg = T["tf2_msgs/msg/TFMessage"](transforms=[tf])
    w.write(conn["tf"], tn, ts.serialize_cdr(msg, msg.__msgtype__))


export_rosbag.keeps_lens = True   # a distorted render is written as it is, with its lens (docs/output-format.md)
