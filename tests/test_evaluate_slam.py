"""Evaluating SLAM outputs against place-recognition ground truth: loop-closure detections
(precision, recall per pair and per query, the score curve's average precision, counted by
hand here), a trajectory's consistency at loop closures (zero for any rigid copy of the truth,
exactly the jump of a trajectory that jumps between the two visits), keyframe trajectories
associated by time, and the two command lines end to end on a ray-cast render."""
from __future__ import annotations

import json

import numpy as np
import pytest

from vo_reference.cli import main as vo
from vo_reference.errors import VoError
from vo_reference.evaluate.loops import Detections, evaluate_loops, read_detections
from vo_reference.evaluate.slam import evaluate_slam
from vo_reference.evaluate.trajectory_eval import EvaluationOptions
from vo_reference.io.trajectory import Trajectory
from vo_reference.products.covisibility import Covisibility, CovisibilityParams


def _cov():
    """10 frames 10 s apart; true loop closures (c >= 0.3, >= 30 s): (5, 0), (6, 1), (9, 2)."""
    t = np.arange(10) * 10.0
    pairs = np.array([[0, 5, 0.5, 0.6], [1, 6, 0.2, 0.4], [2, 9, 0.1, 0.31], [3, 4, 0.9, 0.9],   # 3-4: too close
                      [0, 8, 0.3, 0.25], [4, 7, 0.1, 0.06]])                     # c(8 -> 0), c(7 -> 4) too low
    return Covisibility(pairs=pairs, timestamps_s=t, params=CovisibilityParams(threshold=0.05, loop_threshold=0.3,
                                                                               min_gap_s=30.0), points=np.ones(10))


def test_loop_detections_precision_and_recall_by_hand():
    cov = _cov()
    assert {tuple(x) for x in cov.positives()} == {(5, 0), (6, 1), (9, 2)}
    # detections: (5,0) right, (0,6) wrong way round but the pair (6,0) is not a closure, (1,6) right
    # (given earlier first), (8,0) wrong (c 0.25), (4,3) too close, (9,2) right, (5,0) again
    det = Detections(np.array([5, 0, 1, 8, 4, 9, 5]), np.array([0, 6, 6, 0, 3, 2, 0]),
                     np.array([0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3]))
    ev = evaluate_loops(cov, det)
    assert (ev.detections, ev.true_detections, ev.positives, ev.positives_found) == (7, 4, 3, 3)
    assert ev.pair_precision == pytest.approx(4 / 7) and ev.pair_recall == 1.0
    # queries (best score each): 5 -> 0 right, 6 -> 0 (0.8, above 6 -> 1 at 0.7) wrong, 8 wrong, 4 wrong, 9 right
    assert (ev.queries_detected, ev.queries_correct, ev.query_positives) == (5, 2, 3)
    assert ev.query_precision == pytest.approx(2 / 5) and ev.query_recall == pytest.approx(2 / 3)
    # the score curve: precision 1, 1/2, 2/3, 2/4, 2/5, 3/6, 4/7 at recall 1/3, 1/3, 2/3, 2/3, 2/3, 1, 1
    assert ev.average_precision == pytest.approx(1 / 3 * 1 + 1 / 3 * 2 / 3 + 1 / 3 * 3 / 6)
    assert ev.recall_at_full_precision == pytest.approx(1 / 3)
    # a stricter threshold drops (9, 2) (c 0.31)
    strict = evaluate_loops(cov, det, threshold=0.35)
    assert strict.positives == 2 and strict.positives_found == 2
    with pytest.raises(VoError, match="below"):
        evaluate_loops(cov, det, threshold=0.01)


def test_detections_files(tmp_path):
    f = tmp_path / "det.txt"
    f.write_text("# query match score\n5 0 0.9\n9,2,0.4\n\n6 1\n")
    with pytest.raises(VoError):       # scores on some lines only are still read; a third column of text is not
        (tmp_path / "bad.txt").write_text("5 0 x\n")
        read_detections(tmp_path / "bad.txt")
    d = read_detections(f, np.arange(10) * 10.0)
    assert d.query.tolist() == [5, 9, 6] and d.match.tolist() == [0, 2, 1]
    g = tmp_path / "t.txt"
    g.write_text("50.004 0.0\n90 20\n")
    d = read_detections(g, np.arange(10) * 10.0, by_time=True)
    assert d.query.tolist() == [5, 9] and d.score is None
    with pytest.raises(VoError, match="outside"):
        (tmp_path / "far.txt").write_text("12 0\n")
        read_detections(tmp_path / "far.txt", np.arange(10) * 10.0)


def _loop_truth(n=120):
    """A drive around a 40 x 20 m rectangle and on, 1 s per frame, with its yaw."""
    s = np.arange(n) * 1.0
    per = 120.0
    u = s % per
    pts = np.where(u[:, None] < 40, np.stack([u, 0 * u], 1),
                   np.where(u[:, None] < 60, np.stack([40 + 0 * u, u - 40], 1),
                            np.where(u[:, None] < 100, np.stack([140 - u, 20 + 0 * u], 1),
                                     np.stack([0 * u, 120 - u], 1))))
    T = np.tile(np.eye(4), (n, 1, 1))
    for k in range(n):
        d = pts[min(k + 1, n - 1)] - pts[max(k - 1, 0)]
        yaw = np.arctan2(-d[0], -d[1])
        c, si = np.cos(yaw), np.sin(yaw)
        T[k, :3, :3] = np.array([[c, 0, si], [0, 1, 0], [-si, 0, c]]) @ np.diag([1.0, -1.0, -1.0])
        T[k, :3, 3] = (pts[k, 0], 1.5, pts[k, 1])
    return Trajectory(T, s)


def test_loop_consistency_is_zero_for_rigid_copies_and_the_jump_otherwise():
    gt = _loop_truth()
    pairs = np.array([[110, 5], [100, 10], [60, 20]])          # query, match
    rigid = np.eye(4)
    rigid[:3, :3] = np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]])
    rigid[:3, 3] = (5, -2, 7)
    est = Trajectory(rigid @ gt.T_world_cam, gt.timestamps_s)
    ev = evaluate_slam(gt, est, pairs, EvaluationOptions(align="none"))
    assert ev.loops.trans.max < 1e-9 and ev.loops.rot_deg.max < 1e-6
    assert ev.trajectory.ape.trans.rmse > 1.0                 # unaligned: far off, yet consistent
    jump = np.eye(4)
    jump[:3, 3] = (1.0, 0.0, 0.0)
    T = gt.T_world_cam.copy()
    T[50:] = jump @ T[50:]                                    # the estimate jumps by 1 m at frame 50
    ev = evaluate_slam(gt, Trajectory(T, gt.timestamps_s), pairs)
    assert ev.loops.trans_errors == pytest.approx([1.0, 1.0, 1.0], abs=1e-9)
    T = gt.T_world_cam.copy()
    T[115:] = jump @ T[115:]                                  # after every pair: no effect
    assert evaluate_slam(gt, Trajectory(T, gt.timestamps_s), pairs).loops.trans.max < 1e-9


def test_keyframes_are_associated_by_time():
    gt = _loop_truth()
    keep = np.arange(0, 120, 7)
    est = Trajectory(gt.T_world_cam[keep], gt.timestamps_s[keep] + 0.004)      # within 10 ms
    ev = evaluate_slam(gt, est, np.array([[112, 0], [105, 7], [99, 14]]))
    assert len(ev.trajectory.gt) == len(keep)
    assert ev.trajectory.ape.trans.rmse < 1e-9
    assert ev.loops is not None and len(ev.loops.pairs) == 2    # frame 99 is no keyframe: (99, 14) left out
    assert ev.coverage == pytest.approx((keep[-1] + 1) / 120)
    assert ev.poses_per_s == pytest.approx((len(keep) - 1) / (keep[-1] - keep[0]))


def test_command_lines_end_to_end(tmp_path, capsys):
    """covisibility then evaluate-slam on the ray-cast render of test_covisibility."""
    from test_covisibility import H, K, N, POSES, W, _mover_poses, _prims
    import raycast as rc
    from synthetic_render import write_render
    from blender_sesgen.contract.manifest import object_motion_fields
    frames = []
    for k, T in enumerate(POSES):
        depth, ids, _ = rc.render_truth(_prims(k), K, T, W, H)
        frames.append({"left": (np.zeros((H, W, 3), np.float32), depth.astype(np.float32), ids)})
    objects = [{"id": 7, "name": "mover", "shape": "cuboid", **object_motion_fields("keys", _mover_poses())}]
    r = write_render(tmp_path / "r", K=K, baseline_m=0.0, T_world_left=np.array(POSES), frames=frames,
                     objects=objects, extra={"fps": 0.5})
    assert vo(["covisibility", str(r), "--stride", "2", "--min-gap", "5", "-q"]) == 0
    out = capsys.readouterr().out
    assert "loop-closure pairs" in out and (r / "covisibility" / "loop_closures.csv").is_file()
    est = tmp_path / "est.tum"
    from blender_sesgen.contract.trajectory_files import format_tum
    est.write_text(format_tum(np.arange(N) * 2.0, np.array(POSES)))
    det = tmp_path / "det.txt"
    det.write_text("6 0 0.9\n5 1 0.2\n")
    js = tmp_path / "m.json"
    assert vo(["evaluate-slam", "--gt", str(r), "--est", str(est), "--detections", str(det), "--min-gap", "5",
               "--json", str(js)]) == 0
    m = json.loads(js.read_text())
    assert m["trajectory"]["ape_trans_rmse"] < 1e-6 and m["trajectory"]["loop_trans_rmse"] < 1e-6
    assert m["loops"]["true_detections"] >= 1
    assert vo(["evaluate-slam", "--gt", str(tmp_path)]) == 2          # nothing to evaluate / no covisibility
    assert vo(["covisibility", str(r), "--stride", "0"]) == 2
