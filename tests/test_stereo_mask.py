"""The ground truth behind ``--mask-dynamic-gt`` and ``--gt-flow`` with moving objects
(pure: the analytic scene of tests/dynamic_scene.py, no Blender)."""
from __future__ import annotations


import numpy as np
import pytest

import dynamic_scene as ds
import stereo_synth

from vo_reference.errors import VoError
from vo_reference.io.render import RenderSequence
from vo_reference.stereo.pipeline import ground_truth_step, run_stereo_vo


@pytest.fixture(scope="module")
def seq(tmp_path_factory):
    return RenderSequence(ds.write(tmp_path_factory.mktemp("mask") / "r", ds.make_scene()))


def test_static_and_dynamic_keypoints(seq):
    gt = ground_truth_step(seq, 0, seq.T_world_cam())
    ids = seq.ids(0)
    ys, xs = np.mgrid[2:ds.H - 2:3, 2:ds.W - 2:3]
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(float)
    on = np.isin(ids[pts[:, 1].astype(int), pts[:, 0].astype(int)], [3, 4])
    exact = gt.static(pts, margin_px=0)
    assert np.array_equal(exact, ~on) and on.sum() > 10
    # the default margin drops a keypoint next to a mover too, never keeps one on it
    grown = gt.static(pts)
    assert not (grown & on).any() and (~grown & ~on).any()
    assert gt.dynamic_share() == pytest.approx(np.isin(ids, [3, 4]).mean())


def test_gt_correspondences_move_with_the_movers(seq):
    """--gt-flow's keypoint positions at k+1 equal the exact scene-flow product's flow."""
    from vo_reference.products.scene_flow import sequence_scene_flow
    gt = ground_truth_step(seq, 1, seq.T_world_cam())
    sf = sequence_scene_flow(seq, 1, 2)
    ys, xs = np.nonzero(sf.valid)
    sel = (xs >= 1) & (xs < ds.W - 1) & (ys >= 1) & (ys < ds.H - 1)
    pts = np.stack([xs[sel], ys[sel]], axis=1).astype(float)
    left, right = gt.correspondences(pts)
    ok = np.all(np.isfinite(left), axis=1)   # depth_at drops keypoints on depth edges
    assert ok.sum() > 0.5 * len(pts) and sf.dynamic[ys[sel][ok], xs[sel][ok]].sum() >= 30
    expect = pts[ok] + sf.flow[pts[ok, 1].astype(int), pts[ok, 0].astype(int)]
    assert np.abs(left[ok] - expect).max() <= 1e-4
    # right view: the same point B to the left, same row
    d1 = sf.disparity_tgt(ds.K[0, 0], ds.BASELINE)[pts[ok, 1].astype(int), pts[ok, 0].astype(int)]
    assert np.abs(left[ok, 0] - right[ok, 0] - d1).max() <= 1e-4


def test_mask_needs_ids_and_poses():
    frames, T = stereo_synth.sequence(stereo_synth.smooth_twists(3))
    seq = stereo_synth.ArraySequence(frames, T)
    with pytest.raises(VoError, match="--mask-dynamic-gt needs a render folder with object ids"):
        run_stereo_vo(seq, "accurate", mask_dynamic_gt=True)
    res = run_stereo_vo(seq, "accurate")
    assert res.dynamic_share is None and res.options["mask_dynamic_gt"] is False
