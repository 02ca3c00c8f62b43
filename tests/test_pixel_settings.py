"""One key of the pixel-affecting settings, used alike by the folder lock, by resume and in the
manifest (pure: plans and folders, no render).

The lock once compared samples, denoise, seed, scale, passes and size only: ``--quality gt``
(1 sample, no denoise, flat shading, no bounces) and ``--quality draft --samples 1
--no-denoise`` (1 sample, no denoise, 8 bounces, full shading) looked the same, so two
writers of disjoint frame ranges with those settings could share one folder (before the
first frame completes nothing else tells them apart).
"""
from __future__ import annotations

import json

import pytest

from blender_sesgen.errors import SesgenError
from blender_sesgen.render.folder import OutputFolder
from blender_sesgen.render.plan import RenderOptions, RenderPlan

SCRIPT = """\
CAMERA resolution 64 48 focal 50 baseline 0.1
START position 0 1 3
QUAD id 1 texture 4 vertices -3 0 -3  3 0 -3  3 0 4  -3 0 4
""" + "EGO 0 0 0.1 0 0 0\n" * 5
TIMED = SCRIPT + "TIMING rate 10 exposure 0.02\n"


def _plan(tmp_path, script=SCRIPT, **options) -> RenderPlan:
    p = tmp_path / "s.ses"
    p.write_text(script)
    return RenderPlan.from_file(p, RenderOptions(**options))


def test_gt_and_a_one_sample_draft_are_different_settings_for_the_lock(tmp_path):
    gt = _plan(tmp_path, quality="gt", frames="0:3")
    draft = _plan(tmp_path, quality="draft", samples=1, denoise=False, frames="3:6")
    assert (gt.settings.samples, gt.settings.denoise) == (draft.settings.samples, draft.settings.denoise)
    out = tmp_path / "out"
    first = OutputFolder(out)
    first.acquire(gt)                        # a live writer (this process) renders frames 0..2
    try:
        with pytest.raises(SesgenError, match="another scene or other settings"):
            OutputFolder(out).acquire(draft)   # disjoint frames 3..5, other pixels: refused
        same = _plan(tmp_path, quality="gt", frames="3:6")
        assert OutputFolder.settings_key(same.settings) == OutputFolder.settings_key(gt.settings)
    finally:
        first.release()


def test_the_lock_resume_and_the_manifest_read_one_key(tmp_path):
    """The key a lock stores is the one read back from the manifest the plan writes, and resume
    accepts exactly the manifests with that key."""
    from blender_sesgen.contract.pixel_settings import PixelSettings
    for options in ({}, {"quality": "gt"}, {"quality": "draft", "samples": 1, "denoise": False},
                    {"seed": 7}, {"resolution_scale": 0.5}, {"normal_pass": True}):
        plan = _plan(tmp_path, **options)
        channels = {"rgb": ["R", "G", "B", "A"], "depth": "Z", "object_index": "X", "normal": ["X", "Y", "Z"]}
        written = json.loads(json.dumps(plan.manifest(channels=channels, render_extra={},
                                                      blender_version=None).to_json()))
        key = PixelSettings.from_manifest(written)
        assert key == plan.settings.pixel and key.key() == OutputFolder.settings_key(plan.settings)
        assert OutputFolder.same_settings(written, plan.settings)
    gt, draft = _plan(tmp_path, quality="gt"), _plan(tmp_path, quality="draft", samples=1, denoise=False)
    assert gt.settings.pixel != draft.settings.pixel


def test_timing_is_part_of_the_key(tmp_path):
    """Exposure and rate change the pixels (motion blur) and the poses: the one key holds them."""
    a = _plan(tmp_path, TIMED)
    b = _plan(tmp_path, TIMED, exposure_s=0.01)
    assert a.settings.pixel != b.settings.pixel
    assert OutputFolder.settings_key(a.settings) != OutputFolder.settings_key(b.settings)


def _written_folder(tmp_path, plan: RenderPlan, edit=None):
    """A folder holding ``plan``'s manifest (frame 0 recorded complete), as an earlier render
    left it; ``edit(manifest)`` changes it first (what another version of the package wrote)."""
    channels = {"rgb": ["R", "G", "B", "A"], "depth": "Z", "object_index": "X"}
    written = json.loads(json.dumps(plan.manifest(channels=channels, render_extra={},
                                                  blender_version=None).to_json()))
    written["frames_complete"][0] = True
    if edit is not None:
        edit(written)
    out = tmp_path / "out"
    out.mkdir(exist_ok=True)
    (out / "manifest.json").write_text(json.dumps(written))
    return out


PROFILED = SCRIPT + "SENSOR profile kitti\nAUTOEXPOSURE\n"


@pytest.mark.parametrize("edit, said", [
    (lambda m: m["sensor"].update(full_well_e=m["sensor"]["full_well_e"] * 1.25), "sensor.full_well_e"),
    (lambda m: m["sensor"]["autoexposure"].update(metering="an older metering rule"), "sensor.autoexposure"),
    (lambda m: m["lens"].update(vignetting=0.5), "lens.vignetting"),
])
def test_resume_refuses_frames_made_by_another_camera_model(tmp_path, edit, said):
    """The script and the settings alone do not fix a render's pixels: ``SENSOR profile kitti``
    takes its numbers, and AUTOEXPOSURE its metering rule, from this package's code. Frames
    made with other values (an older version of the package) are not resumed into a folder
    whose new frames would be made differently; the error names the first difference."""
    plan = _plan(tmp_path, PROFILED, frames="0:3")
    same = _written_folder(tmp_path, plan)
    assert OutputFolder(same).resumable(plan) is not None      # the same camera: resumed
    OutputFolder(same).check(plan, force=False)
    (same / "manifest.json").unlink()
    other = _written_folder(tmp_path, plan, edit)
    assert OutputFolder(other).resumable(plan) is None
    with pytest.raises(SesgenError, match=f"another camera model \\({said}"):
        OutputFolder(other).check(plan, force=False)
    OutputFolder(other).check(plan, force=True)                # --force re-renders
