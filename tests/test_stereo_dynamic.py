"""Stereo VO on a rendered sequence with a large moving object, with and without the
ground-truth motion mask (``--mask-dynamic-gt``).

The first 4 frames of ``scenes/paper_room.ses`` with a textured board (1.6 m x 1.2 m, a
quarter of the image) sliding sideways 2 m in front of the camera, 0.12 m per frame
(~12 px of flow of its own), rendered at half resolution (320x240) with 2 samples, denoised (4 samples
gave the same margins; 6 frames too: worst relative step error from images 0.034 either way, bound
0.6; without the denoiser the VO from images fails).

What must hold:
- the board covers a large share of the image, and the run reports it;
- with ground-truth depth and correspondences (no robust estimation then) the board's
  true correspondences corrupt both solvers, and the mask removes exactly them: the
  accurate solver is exact again (1e-3 of each step) and the paper's back to its
  linearisation error;
- from the images alone the accurate VO keeps rejecting moving points: (almost) none of
  the points it keeps lie on the board, and its error with and without the mask is alike;
- ``run`` reports the dynamic share and the error with and without the mask.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from markers import needs
from stereo_synth import rel_errors as _rel_errors

pytestmark = [pytest.mark.render, needs("bpy")]
pytest.importorskip("OpenEXR")

FRAMES = 4
BOARD = ("CUBOID id 99 texture camouflage colour 1 0.9 0.8 position -0.7 1.3 1.5 dim 1.6 1.2 0.2\n"
         "MOVE id 99 twist 0.12 0 0 0 0 0\n")


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    from render_support import render_paper_room
    return render_paper_room(tmp_path_factory.mktemp("stereo_dynamic"), FRAMES, 0.5, BOARD, samples=2, here=True)


@pytest.fixture(scope="module")
def seq(render):
    from vo_reference.io.sequence import open_sequence
    return open_sequence(render)


def test_the_board_is_a_large_moving_object(seq):
    from vo_reference.groundtruth.scene_flow import motion_mask
    assert seq.moving_ids == (99,)
    shares = [motion_mask(seq, k, k + 1).mean() for k in range(FRAMES - 1)]
    assert min(shares) >= 0.15, shares


def test_gt_depth_and_flow_solvers_are_corrupted_by_the_board_and_cured_by_the_mask(seq):
    from vo_reference.stereo.pipeline import run_stereo_vo
    span = range(FRAMES)
    acc = run_stereo_vo(seq, "accurate", frames=span, gt_depth=True, gt_flow=True)
    acc_m = run_stereo_vo(seq, "accurate", frames=span, gt_depth=True, gt_flow=True, mask_dynamic_gt=True)
    assert _rel_errors(acc).max() >= 0.05          # non-robust: the board's points pull it away
    assert _rel_errors(acc_m).max() <= 1e-3        # exact again without them
    assert acc_m.dynamic_points.max() == 0 and acc.dynamic_points.min() > 0.05
    pap = run_stereo_vo(seq, "paper", frames=span, gt_depth=True, gt_flow=True)
    pap_m = run_stereo_vo(seq, "paper", frames=span, gt_depth=True, gt_flow=True, mask_dynamic_gt=True)
    assert _rel_errors(pap_m).max() <= 0.1         # back to the first-order model's error
    assert _rel_errors(pap).mean() > 2 * _rel_errors(pap_m).mean()
    np.testing.assert_allclose(acc.dynamic_share, acc_m.dynamic_share)


def test_accurate_vo_keeps_rejecting_moving_points(seq):
    from vo_reference.stereo.pipeline import run_stereo_vo
    span = range(FRAMES)
    res = run_stereo_vo(seq, "accurate", frames=span)
    res_m = run_stereo_vo(seq, "accurate", frames=span, mask_dynamic_gt=True)
    assert not res.failed and not res_m.failed
    # RANSAC + inlier re-selection: at most a stray point on the board's edge survives
    assert res.dynamic_points.max() <= 0.03, res.dynamic_points
    assert res_m.dynamic_points.max() == 0
    # ... so the mask changes little: both track the motion like the static room does
    assert _rel_errors(res).max() <= 0.6 and _rel_errors(res_m).max() <= 0.6
    assert abs(_rel_errors(res).mean() - _rel_errors(res_m).mean()) <= 0.1


def test_run_reports_the_dynamic_share_and_both_errors(render, tmp_path):
    from vo_reference.commands.main import main
    rep = tmp_path / "report"
    assert main(["run", str(render), "--frames", f"0:{FRAMES}", "--report", str(rep), "--no-plots", "--quiet",
                 "--methods", "accurate"]) == 0
    data = json.loads((rep / "report.json").read_text())
    assert data["dynamic_image_share"]["mean"] >= 0.15
    cmp_ = data["methods"]["accurate"]["motion_mask_comparison"]
    assert set(cmp_) == {"with", "without"}
    for e in cmp_.values():
        assert np.isfinite(e["ape_trans_rmse"]) and np.isfinite(e["rpe_trans_rmse"])
    assert cmp_["with"]["dynamic"]["points_on_movers_max"] == 0
    summary = (rep / "summary.md").read_text()
    assert "## Moving objects" in summary and "| accurate | without |" in summary and "| accurate | with |" in summary
    # --mask-dynamic-gt makes the masked run the main one (its est.txt)
    rep2 = tmp_path / "report2"
    assert main(["run", str(render), "--frames", f"0:{FRAMES}", "--report", str(rep2), "--no-plots", "--quiet",
                 "--methods", "accurate", "--mask-dynamic-gt"]) == 0
    d2 = json.loads((rep2 / "report.json").read_text())
    assert d2["mask_dynamic_gt"] and d2["methods"]["accurate"]["dynamic"]["points_on_movers_max"] == 0
    assert d2["methods"]["accurate"]["ape_trans_rmse"] == pytest.approx(cmp_["with"]["ape_trans_rmse"])
