"""MOVE and FRAMES: the per-frame object poses against independent computations, and the
error table (file:line:col) of bad motion statements.

Oracles: scipy's matrix exponential (twists), scipy's Slerp (keyframe orientation), plain
linear interpolation (keyframe position), a hand-written replay of a TUM file.
"""
from __future__ import annotations


import numpy as np
import pytest
from scipy.linalg import expm
from scipy.spatial.transform import Rotation, Slerp

from blender_sesgen.scene import dynamics
from blender_sesgen.errors import ScriptError
from blender_sesgen.ses import parse_string

from script_errors import parse_error

STILL = "FRAMES 11\n"
BOX = "CUBOID id 1 position 1 2 3 10 20 30 dim 1 1 1\n"
BALL = "SPHERE id 2 position 0 1 0 dim 0.5\n"


def _euler(rx, ry, rz):
    return Rotation.from_euler("xyz", [rx, ry, rz], degrees=True).as_matrix()


def _pose(p, r=(0, 0, 0)):
    T = np.eye(4)
    T[:3, :3] = _euler(*r)
    T[:3, 3] = p
    return T


def _twist_hat(v, w_deg):
    X = np.zeros((4, 4))
    w = np.radians(w_deg)
    X[:3, :3] = [[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]
    X[:3, 3] = v
    return X


def test_frames_holds_a_still_rig():
    s = parse_string(STILL + BOX)
    assert s.frames == 11 and s.moving_ids == ()
    assert np.array_equal(s.timeline.left(), np.repeat(s.timeline.left()[:1], 11, axis=0))


def test_twist_is_the_matrix_exponential_in_the_objects_own_frame():
    s = parse_string(STILL + BOX + "MOVE id 1 twist 0.3 -0.1 0.2 4 -6 9 from 2 to 7\n")
    T = s.motion_of(1).poses()
    T0 = _pose((1, 2, 3), (10, 20, 30))
    step = expm(_twist_hat((0.3, -0.1, 0.2), (4, -6, 9)))
    for k in range(11):
        n = min(max(k - 2, 0), 5)  # steps 2->3 .. 6->7 move, others hold
        np.testing.assert_allclose(T[k], T0 @ np.linalg.matrix_power(step, n), atol=1e-12)


def test_twist_segments_follow_each_other():
    s = parse_string(STILL + BOX + "MOVE id 1 twist 1 0 0 0 0 0 to 3\nMOVE id 1 twist 0 0 0 0 10 0 from 3 to 5\n"
                     "MOVE id 1 twist 0 0 -1 0 0 0 from 8\n")
    T = s.motion_of(1).poses()
    R0 = _euler(10, 20, 30)
    np.testing.assert_allclose(T[3, :3, 3], np.array([1, 2, 3]) + 3 * R0[:, 0], atol=1e-12)
    np.testing.assert_allclose(T[5, :3, :3], R0 @ _euler(0, 20, 0), atol=1e-12)
    np.testing.assert_array_equal(T[5], T[8])
    np.testing.assert_allclose(T[10, :3, 3], T[8, :3, 3] - 2 * T[8, :3, 2], atol=1e-12)


def test_keyframes_interpolate_position_linearly_and_orientation_by_slerp():
    s = parse_string(STILL + BOX + "MOVE id 1 frame 4 position 5 2 -1 0 90 0\nMOVE id 1 frame 8 position 5 6 -1 0 90 45\n")
    T = s.motion_of(1).poses()
    keys_t = np.array([0, 4, 8])
    keys_p = np.array([[1, 2, 3], [5, 2, -1], [5, 6, -1]], float)
    slerp = Slerp(keys_t, Rotation.from_euler("xyz", [[10, 20, 30], [0, 90, 0], [0, 90, 45]], degrees=True))
    for k in range(11):
        kk = min(k, 8)
        np.testing.assert_allclose(T[k, :3, 3], [np.interp(kk, keys_t, keys_p[:, i]) for i in range(3)], atol=1e-12)
        np.testing.assert_allclose(T[k, :3, :3], slerp([kk]).as_matrix()[0], atol=1e-12)


def test_quad_object_frame_is_its_centroid():
    s = parse_string(STILL + "QUAD id 3 vertices 0 0 0  2 0 0  2 2 0  0 2 0\nMOVE id 3 frame 10 position 1 1 -5\n")
    T = s.motion_of(3).poses()
    np.testing.assert_allclose(T[0], _pose((1, 1, 0)), atol=1e-15)
    np.testing.assert_allclose(T[5, :3, 3], (1, 1, -2.5), atol=1e-12)


def test_trajectory_is_replayed_relative_to_the_rest_pose(tmp_path):
    # TUM file: a yaw of 10 deg per sample about the file's z and a move along its x
    lines = []
    for j in range(4):
        q = Rotation.from_euler("z", 10 * j, degrees=True).as_quat()  # x y z w
        lines.append(f"{j * 0.1} {2 + j} 5 7 " + " ".join(map(str, q)))
    (tmp_path / "car.tum").write_text("\n".join(lines) + "\n")
    s = parse_string(STILL + BOX + "MOVE id 1 file car.tum format tum from 3\n", base_dir=str(tmp_path))
    m = s.motion_of(1)
    assert m.kind == "trajectory" and m.trajectory_first == 3 and m.trajectory_path.endswith("car.tum")
    T = m.poses()
    T0 = _pose((1, 2, 3), (10, 20, 30))
    P = [_pose((2 + j, 5, 7), (0, 0, 10 * j)) for j in range(4)]
    for k in range(11):
        expected = T0 if k <= 3 else T0 @ np.linalg.inv(P[0]) @ P[min(k - 3, 3)]
        np.testing.assert_allclose(T[k], expected, atol=1e-9)


def test_sub_frame_poses_follow_each_kind_rule():
    s = parse_string(STILL + BOX + BALL + "MOVE id 1 twist 0.5 0 0 0 30 0\nMOVE id 2 frame 10 position 10 1 0 0 0 100\n")
    Tt, Tk = s.motion_of(1).poses(), s.motion_of(2).poses()
    half = expm(0.5 * _twist_hat((0.5, 0, 0), (0, 30, 0)))
    np.testing.assert_allclose(dynamics.pose_at(Tt, 3.5, "twist"), Tt[3] @ half, atol=1e-12)
    mid = dynamics.pose_at(Tk, 3.25, "keys")
    np.testing.assert_allclose(mid[:3, 3], (3.25, 1, 0), atol=1e-12)
    np.testing.assert_allclose(mid[:3, :3], _euler(0, 0, 32.5), atol=1e-12)
    np.testing.assert_array_equal(dynamics.pose_at(Tk, 4.0, "keys"), Tk[4])
    # the shutter of frame 0 may open before it: the first step is extrapolated
    np.testing.assert_allclose(dynamics.pose_at(Tt, -0.5, "twist"), Tt[0] @ np.linalg.inv(half), atol=1e-12)


def test_moving_mesh_keeps_its_scale_out_of_the_pose(tmp_path):
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    s = parse_string(STILL + "MESH id 5 file m.obj position 1 0 0 0 45 0 scale 3\nMOVE id 5 twist 0 0 1 0 0 0\n",
                     base_dir=str(tmp_path))
    T = s.motion_of(5).poses()
    np.testing.assert_allclose(T[0], _pose((1, 0, 0), (0, 45, 0)), atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(T[7, :3, :3]), 1.0, atol=1e-12)


def test_static_script_has_no_object_motion():
    s = parse_string("CUBOID id 1 position 0 0 0 dim 1 1 1\nEGO 0 0 0.1 0 0 0\n")
    assert s.object_motions == () and s.motion_of(1) is None


# --- errors ------------------------------------------------------------------------------

CASES = {
    "unknown id": (STILL + BOX + "MOVE id 9 twist 0 0 1 0 0 0\n", 3, "9 ", r"MOVE 'id' 9: no object has this id"),
    "no kind": (STILL + BOX + "MOVE id 1 frame 3\n", 3, None, r"MOVE needs one of 'position'"),
    "two kinds": (STILL + BOX + "MOVE id 1 frame 3 position 0 0 0 twist 0 0 1 0 0 0\n", 3, "twist",
                  r"not both 'position' and 'twist'"),
    "keyframe without frame": (STILL + BOX + "MOVE id 1 position 0 0 0\n", 3, None, r"needs 'frame F'"),
    "frame with twist": (STILL + BOX + "MOVE id 1 twist 0 0 1 0 0 0 frame 3\n", 3, "frame",
                         r"MOVE 'frame' does not go with 'twist'"),
    "to with a file": (STILL + BOX + "MOVE id 1 file a.txt format tum to 3\n", 3, "to",
                       r"MOVE 'to' does not go with 'file'"),
    "file without format": (STILL + BOX + "MOVE id 1 file a.txt\n", 3, None, r"needs 'format tum\|kitti'"),
    "keyframe at frame 0": (STILL + BOX + "MOVE id 1 frame 0 position 0 0 0\n", 3, "0 position",
                            r"'frame' must lie in 1\.\.10 \(frame 0 is the object's own position\)"),
    "keyframe past the end": (STILL + BOX + "MOVE id 1 frame 11 position 0 0 0\n", 3, "11",
                              r"must lie in 1\.\.10 .*got 11 \(the sequence has 11 frames"),
    "keyframe in a one-frame scene": (BOX + "MOVE id 1 frame 1 position 0 0 0\n", 2, "1 position",
                                      r"the sequence has 1 frame, too few to move in"),
    "keyframes out of order": (STILL + BOX + "MOVE id 1 frame 6 position 0 0 0\nMOVE id 1 frame 4 position 1 0 0\n",
                               4, "4 ", r"keyframe for frame 4 comes after frame 6 \(line 3\)"),
    "keyframe twice": (STILL + BOX + "MOVE id 1 frame 6 position 0 0 0\nMOVE id 1 frame 6 position 1 0 0\n",
                       4, "6 ", r"second keyframe for frame 6 \(the first is on line 3\)"),
    "two ways": (STILL + BOX + "MOVE id 1 frame 6 position 0 0 0\nMOVE id 1 twist 0 0 1 0 0 0\n", 4, None,
                 r"object 1 already moves by keyframes \(line 3\): an object moves one way only"),
    "twist to before from": (STILL + BOX + "MOVE id 1 twist 0 0 1 0 0 0 from 5 to 5\n", 3, "5\n",
                             r"'to' \(5\) must be greater than 'from' \(5\)"),
    "twist from out of range": (STILL + BOX + "MOVE id 1 twist 0 0 1 0 0 0 from 10\n", 3, "10",
                                r"'from' must lie in 0\.\.9"),
    "overlapping twists": (STILL + BOX + "MOVE id 1 twist 0 0 1 0 0 0 to 6\nMOVE id 1 twist 1 0 0 0 0 0 from 4\n",
                           4, "4\n", r"twist from frame 4 to 10 of object 1 overlaps .* from 0 to 6 \(line 3\)"),
    "twist too fast a turn": (STILL + BOX + "MOVE id 1 twist 0 0 0 0 190 0\n", 3, "twist",
                              r"turns by 190\.0 degrees per frame"),
    "keyframes half a turn apart": (STILL + "SPHERE id 2 position 0 1 0 dim 1\nMOVE id 2 frame 2 position 0 1 0 0 180 0\n",
                                    3, "position", r"turns by 180\.0 degrees between frames 0 and 2: add a keyframe"),
    "twist in a one-frame scene": (BOX + "MOVE id 1 twist 0 0 1 0 0 0\n", 2, None, r"needs a sequence of 2 frames"),
    "missing trajectory file": (STILL + BOX + "MOVE id 1 file car.txt format kitti\n", 3, "car.txt",
                                r"MOVE 'file' file 'car\.txt' not found"),
    "FRAMES with EGO": (BOX + "EGO 0 0 1 0 0 0\nFRAMES 4\n", 3, None, r"FRAMES cannot be mixed with EGO"),
    "FRAMES zero": (BOX + "FRAMES 0\n", 2, "0", r"FRAMES must be a whole number in 1\.\.1000000, got 0"),
    "FRAMES fractional": (BOX + "FRAMES 2.5\n", 2, "2.5", r"whole number"),
    "FRAMES twice": (BOX + "FRAMES 2\nFRAMES 3\n", 3, None, r"only one FRAMES statement"),
    "FRAMES without a number": (BOX + "FRAMES\n", 2, None, r"FRAMES needs 1 number \(FRAMES N\), got 0"),
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_error_table(case, tmp_path):
    script, line, marker, pattern = CASES[case]
    parse_error(tmp_path, script, line, marker, pattern)


def test_bad_trajectory_file_names_the_line(tmp_path):
    (tmp_path / "car.txt").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0\n")
    with pytest.raises(ScriptError, match=r"MOVE 'file' 'car\.txt' line 2: a KITTI pose has 12 numbers, got 3"):
        parse_string(STILL + BOX + "MOVE id 1 file car.txt format kitti\n", base_dir=str(tmp_path))


def test_move_of_a_faulty_object_reports_only_the_object():
    with pytest.raises(ScriptError) as info:
        parse_string(STILL + "CUBOID id 1 position 0 0 0 dim 1 -1 1\nMOVE id 1 twist 0 0 1 0 0 0\n")
    assert [e.line for e in info.value.errors] == [2]


def test_check_summary_names_the_movers():
    from blender_sesgen.scene.summary import summary
    s = parse_string(STILL + BOX + BALL + "MOVE id 2 twist 0.5 0 0 0 0 0\n")
    line = next(ln for ln in summary(s).splitlines() if ln.startswith("moving"))
    assert line.split(None, 1)[1] == "2 (twist, 5)"
    assert "none (static scene)" in summary(parse_string(BOX))


def test_blender_key_instants_hold_every_frame_exactly():
    t = dynamics.key_times(11)
    assert t[0] == -0.5 and t[-1] == 10.5 and np.allclose(np.diff(t), 1 / dynamics.KEYS_PER_FRAME)
    assert set(range(11)) <= set(t.tolist())
    s = parse_string(STILL + BOX + "MOVE id 1 twist 0.5 0 0.1 3 20 -5\n")
    T = s.motion_of(1).poses()
    P = dynamics.poses_at(T, t, "twist")
    for k in range(11):
        np.testing.assert_array_equal(P[t.tolist().index(float(k))], T[k])
