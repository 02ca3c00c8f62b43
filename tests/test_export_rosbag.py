"""``--to rosbag`` read back with rosbags (the reader ROS 2 users run without ROS): the rig's
fixed frames on /tf_static, and every stamp on the render's own clock (TIMING start)."""
from __future__ import annotations

import numpy as np
import pytest

from format_readers import quat_xyzw_to_matrix
from layout_scene import B, write_layout_render
from synthetic_render import add_imu

pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
pytest.importorskip("rosbags")
START_S = 1_700_000_000.25     # a render with TIMING start 1700000000.25 rate 10
T_CAM_IMU = np.array([[0.0, -1.0, 0.0, 0.06], [1.0, 0.0, 0.0, 0.01], [0.0, 0.0, 1.0, -0.02], [0, 0, 0, 1.0]])


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    import json
    root = write_layout_render(tmp_path_factory.mktemp("ros") / "r", n=3)
    m = json.loads((root / "manifest.json").read_text())
    m["timestamps"] = [START_S + k / 10 for k in range(3)]
    (root / "manifest.json").write_text(json.dumps(m))
    add_imu(root, T_CAM_IMU, time_offset_s=0.002)
    return root


def read_bag(path):
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore
    ts = get_typestore(Stores.ROS2_HUMBLE)
    out = {}
    with Reader(path) as r:
        qos = {c.topic: c.ext.offered_qos_profiles for c in r.connections}
        for c, t, raw in r.messages():
            out.setdefault(c.topic, []).append((t, ts.deserialize_cdr(raw, c.msgtype)))
    return out, qos


def matrix(transform) -> np.ndarray:
    T = np.eye(4)
    r, p = transform.rotation, transform.translation
    T[:3, :3] = quat_xyzw_to_matrix([r.x, r.y, r.z, r.w])
    T[:3, 3] = [p.x, p.y, p.z]
    return T


def test_tf_static_holds_the_rig_extrinsics(render, tmp_path):
    from vo_reference.exporters.driver import export
    msgs, qos = read_bag(export(render, "rosbag", tmp_path / "b", progress=False) / "bag")
    (t, tf), = msgs["/tf_static"]
    edges = {(x.header.frame_id, x.child_frame_id): matrix(x.transform) for x in tf.transforms}
    assert sorted(edges) == [("body", "cam0"), ("body", "imu0"), ("cam0", "cam1")]
    # body = the IMU: cam0's pose in it is inv(T_cam_imu); cam1 is B along cam0's x
    assert np.allclose(edges[("body", "cam0")], np.linalg.inv(T_CAM_IMU), atol=1e-12)
    assert np.allclose(edges[("cam0", "cam1")], np.array([[1, 0, 0, B], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]))
    assert np.allclose(edges[("body", "imu0")], np.eye(4))
    # the headers' frames (cam0, cam1, imu0) and the ground truth's (world -> body) form one tree
    assert {m.header.frame_id for _, m in msgs["/cam1/image_raw"]} == {"cam1"}
    assert {m.transforms[0].child_frame_id for _, m in msgs["/tf"]} == {"body"}
    # latched as tf2's static broadcaster does: transient local, so late subscribers get it
    assert qos["/tf_static"][0].durability.name == "TRANSIENT_LOCAL"
    assert t == min(tt for topic in msgs for tt, _ in msgs[topic])


def test_stamps_are_the_renders_clock(render, tmp_path):
    from vo_reference.exporters.driver import export
    msgs, _ = read_bag(export(render, "rosbag", tmp_path / "b", frames="1:", progress=False) / "bag")
    frame_ns = [int(round((START_S + k / 10) * 1e9)) for k in (1, 2)]
    assert [t for t, _ in msgs["/cam0/image_raw"]] == frame_ns
    assert [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m in msgs["/cam0/camera_info"]] == frame_ns
    imu_ns = [t for t, _ in msgs["/imu0"]]
    # the IMU clock runs 2 ms ahead (the fixture steps seconds near 1.7e9 in float64: us-level)
    assert abs(imu_ns[0] - (frame_ns[0] + 2_000_000)) < 10_000 and imu_ns[-1] <= frame_ns[-1] + 2_010_000
    assert msgs["/tf_static"][0][0] == frame_ns[0]


def test_a_rig_without_imu_has_body_at_cam0(tmp_path):
    from vo_reference.exporters.driver import export
    root = write_layout_render(tmp_path / "r", n=2)
    msgs, _ = read_bag(export(root, "rosbag", tmp_path / "b", progress=False) / "bag")
    (_, tf), = msgs["/tf_static"]
    edges = {(x.header.frame_id, x.child_frame_id): matrix(x.transform) for x in tf.transforms}
    assert sorted(edges) == [("body", "cam0"), ("cam0", "cam1")] and np.allclose(edges[("body", "cam0")], np.eye(4))


def test_message_values_are_the_rigs_ground_truth(tmp_path):
    """The values, not only the frames and stamps: /tf and /groundtruth/pose are the layout
    scene's known rig poses (world -> cam0, composed here from rig_poses, not the manifest);
    each /camN/image_raw is the grey image of its own frame and view; CameraInfo holds K, the
    identity R, zero D (plumb_bob's five) and P with -fx*B for cam1 only, so that ROS's own
    baseline rule (stereo_image_proc: B = -P[0,3]/P[0,0]) gives +B; the frames are the
    selected ones (--frames 1:)."""
    from layout_scene import K, W, H, rig_poses
    from vo_reference.exporters.driver import export
    from vo_reference.io.render import RenderSequence
    root = write_layout_render(tmp_path / "r", n=3)
    msgs, _ = read_bag(export(root, "rosbag", tmp_path / "b", frames="1:", noise=None, progress=False) / "bag")
    seq = RenderSequence(root)
    truth = rig_poses(3)[1:]
    for topic in ("/tf", "/groundtruth/pose"):
        assert len(msgs[topic]) == 2
        for (t, m), T_ref in zip(msgs[topic], truth):
            if topic == "/tf":
                (x,) = m.transforms
                assert (x.header.frame_id, x.child_frame_id) == ("world", "body")
                T = matrix(x.transform)
            else:
                assert m.header.frame_id == "world"
                T = np.eye(4)
                o, p = m.pose.orientation, m.pose.position
                T[:3, :3] = quat_xyzw_to_matrix([o.x, o.y, o.z, o.w])
                T[:3, 3] = [p.x, p.y, p.z]
            assert np.allclose(T, T_ref, atol=1e-9), topic
    for cam, view in ((0, "left"), (1, "right")):
        images = msgs[f"/cam{cam}/image_raw"]
        infos = msgs[f"/cam{cam}/camera_info"]
        assert [t for t, _ in images] == [t for t, _ in infos] == [t for t, _ in msgs["/tf"]]
        for (_, img), k in zip(images, (1, 2)):
            a = np.frombuffer(bytes(img.data), np.uint8).reshape(img.height, img.step)[:, :img.width]
            assert (img.height, img.width, img.step) == (H, W, W)
            assert np.array_equal(a, seq.image_gray(k, view)), (cam, k)
        for _, info in infos:
            P = np.asarray(info.p, float).reshape(3, 4)
            assert np.allclose(np.asarray(info.k).reshape(3, 3), K) and np.allclose(P[:, :3], K)
            assert np.allclose(np.asarray(info.r).reshape(3, 3), np.eye(3))
            assert info.distortion_model == "plumb_bob" and list(info.d) == [0.0] * 5
            assert (info.height, info.width) == (H, W)
            assert -P[0, 3] / P[0, 0] == pytest.approx(B if cam == 1 else 0.0, abs=1e-15)
            assert P[1, 3] == 0 and P[2, 3] == 0
