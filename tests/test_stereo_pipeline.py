"""Stereo VO end to end on exactly ray-cast synthetic stereo images (tests/stereo_synth.py)."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.errors import VoError
from vo_reference.stereo.blockmatch import sad_disparity, sad_track
from vo_reference.stereo.groundtruth import GroundTruthStep
from vo_reference.stereo.pipeline import parse_frames, run_stereo_vo

import stereo_synth as S


@pytest.fixture(scope="module")
def seq():
    frames, T = S.sequence(S.smooth_twists(5))
    return S.ArraySequence(frames, T)


def test_sad_tracking_finds_integer_shifts():
    rng = np.random.default_rng(0)
    import cv2
    img = cv2.GaussianBlur(rng.integers(0, 255, (120, 160)).astype(np.uint8), (5, 5), 1)
    moved = np.roll(img, (3, -5), axis=(0, 1))          # content moves by dx=-5, dy=+3
    pts = np.stack([rng.integers(30, 130, 50), rng.integers(30, 90, 50)], axis=1)
    p1, cost = sad_track(img, moved, pts, block=9, search=8)
    np.testing.assert_array_equal(p1 - pts, np.tile([-5, 3], (50, 1)))
    assert np.all(cost == 0)
    right = np.roll(img, -7, axis=1)                     # x_right = x_left - 7
    d, ok = sad_disparity(img, right, pts, block=9, d_max=20)
    assert ok.all() and np.all(d == 7)


def test_sad_disparity_rejects_points_that_round_outside_the_image():
    # sub-pixel tracks may sit within half a pixel of the border and round outside it
    rng = np.random.default_rng(1)
    img = rng.integers(0, 255, (40, 60)).astype(np.uint8)
    right = np.roll(img, -3, axis=1)
    pts = np.array([[59.6, 20.0], [30.0, 39.7], [-0.6, 10.0], [30.0, 20.0]])
    d, ok = sad_disparity(img, right, pts, block=5, d_max=10)
    assert ok.tolist() == [False, False, False, True] and d[3] == 3


def test_sad_disparity_matches_ground_truth_to_a_pixel(seq):
    from vo_reference.stereo.keypoints import shi_tomasi
    left, right, depth = seq.image_gray(0), seq.image_gray(0, "right"), seq.depth(0)
    pts = shi_tomasi(left, 300, 0.01, 7, 10)
    d, ok = sad_disparity(left, right, pts, 9, 40)
    d_true = S.F * S.B / depth[pts[:, 1].astype(int), pts[:, 0].astype(int)]
    assert ok.mean() > 0.8
    assert np.all(np.abs(d[ok] - d_true[ok]) <= 1.0)


def test_ground_truth_correspondences_follow_the_images(seq):
    """The GT projection (depth + K + pose) lands where the next image shows the same texture."""
    T = seq.T_world_cam()
    gt = GroundTruthStep(seq.depth(0), S.K, S.B, np.linalg.inv(T[0]) @ T[1])
    from vo_reference.stereo.keypoints import shi_tomasi
    pts = shi_tomasi(seq.image_gray(0), 100, 0.01, 7, 20)
    l1, _ = gt.correspondences(pts)
    p1, _ = sad_track(seq.image_gray(0), seq.image_gray(1), pts, 9, 8)
    assert np.median(np.linalg.norm(p1 - l1, axis=1)) < 0.75


def rmse(res):
    e = res.twists - res.gt_twists
    e[:, 3:] = np.degrees(e[:, 3:])
    return np.sqrt((e ** 2).mean(0))


def test_paper_method_on_images(seq):
    r = run_stereo_vo(seq, "paper")
    e = rmse(r)
    paper = np.array([0.0049, 0.0101, 0.0062, 0.101, 0.091, 0.057])   # its Table 1 RMSE
    assert np.all(e < 3 * paper), e                                   # the paper's order of magnitude


def test_accurate_method_on_images(seq):
    r = run_stereo_vo(seq, "accurate")
    e = rmse(r)
    assert np.all(e[:3] < 5e-4) and np.all(e[3:] < 0.01), e   # >= 10x below the paper's Table 1


def test_accurate_with_gt_depth_and_flow_is_exact(seq):
    r = run_stereo_vo(seq, "accurate", gt_depth=True, gt_flow=True)
    err = np.linalg.norm(r.twists - r.gt_twists, axis=1) / np.linalg.norm(r.gt_twists, axis=1)
    assert err.max() < 1e-3
    np.testing.assert_allclose(r.trajectory.T_world_cam, seq.T_world_cam(), atol=1e-5)


def test_paper_with_gt_depth_and_flow_has_only_the_linearisation_error(seq):
    r = run_stereo_vo(seq, "paper", gt_depth=True, gt_flow=True)
    err = np.abs(r.twists - r.gt_twists)
    assert np.all(err[:, :3] < 1e-3) and np.all(np.degrees(err[:, 3:]) < 0.02)   # < 1/3 of Table 1
    assert err.max() > 1e-7


def test_gt_switches_need_ground_truth(seq):
    class NoGT(S.ArraySequence):
        def depth(self, k, view="left"):
            return None
    s = NoGT(seq.frames, seq.T_world_cam())
    with pytest.raises(VoError):
        run_stereo_vo(s, "paper", gt_depth=True)


def test_run_stereo_vo_takes_frames_half_open_as_everywhere():
    from vo_reference.stereo.pipeline import frame_span
    assert frame_span("2:5", 10) == frame_span(range(2, 5), 10) == (2, 4)
    assert frame_span(None, 10) == (0, 9)
    with pytest.raises(VoError, match="A:B"):
        frame_span((2, 4), 10)      # an inclusive pair is no longer a frame range


def test_parse_frames():
    assert parse_frames(None, 10) == (0, 9)
    assert parse_frames("2:5", 10) == (2, 4)
    assert parse_frames(":-1", 10) == (0, 8)
    with pytest.raises(VoError):
        parse_frames("5:6", 10)
    with pytest.raises(VoError):
        parse_frames("x", 10)
    with pytest.raises(VoError, match="the sequence has 1 frame.*at least 2"):
        parse_frames(None, 1)


@pytest.mark.parametrize("method", ["accurate", "paper", "opencv-baseline"])
def test_a_blank_frame_keeps_the_previous_motion_and_is_reported(method):
    frames, T = S.sequence(S.smooth_twists(6))
    blank = {**frames[3], "left": np.full_like(frames[3]["left"], 128), "right": np.full_like(frames[3]["right"], 128)}
    frames = frames[:3] + [blank] + frames[4:]
    res = run_stereo_vo(S.ArraySequence(frames, T), method)
    # the paper's SAD tracker has no check against a featureless target, so only the step out
    # of the blank frame (no keypoints) fails there
    assert [k for k, _ in res.failed] == ([3] if method == "paper" else [2, 3]) and all(w for _, w in res.failed)
    np.testing.assert_array_equal(res.twists[3], res.twists[2])     # constant velocity
    good = [0, 1, 4, 5]
    err = np.abs(res.twists[good] - res.gt_twists[good]).max()
    assert err < (0.05 if method == "paper" else 5e-3)
    assert len(res.trajectory) == 7


def test_a_sequence_where_no_step_works_is_an_error():
    frames, T = S.sequence(S.smooth_twists(2))
    blank = [{**f, "left": np.full_like(f["left"], 128), "right": np.full_like(f["right"], 128)} for f in frames]
    with pytest.raises(VoError, match="no frame step could be estimated"):
        run_stereo_vo(S.ArraySequence(blank, T), "accurate")


def test_progress_and_summary_name_the_failed_steps():
    import io
    from vo_reference.stereo.cli import failed_summary, vo_progress
    frames, T = S.sequence(S.smooth_twists(3))
    frames[2] = {**frames[2], "left": np.full_like(frames[2]["left"], 128), "right": np.full_like(frames[2]["right"], 128)}
    out = io.StringIO()
    bar, show = vo_progress("accurate", (0, 3), "plain", stream=out)
    with bar:
        res = run_stereo_vo(S.ArraySequence(frames, T), "accurate", progress=show)
    lines = out.getvalue().splitlines()
    # a plain line per step (a third of the work each), and a note for each failed step
    assert [l.split(":")[0] for l in lines] == ["stereo-vo accurate", "[accurate] frame 1->2", "stereo-vo accurate",
                                                 "[accurate] frame 2->3", "stereo-vo accurate"], lines
    assert "FAILED" in lines[1] and "FAILED" in lines[3] and "FAILED" not in lines[0]
    assert failed_summary(res.failed).startswith("warning: 2 step(s)") and "1->2, 2->3" in failed_summary(res.failed)
