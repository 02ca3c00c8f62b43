"""The sensor auto-exposure's metering pass: frame 0 from the automatic exposure's preview, and
what it meters (the clipped signal, as a camera meters its digitised output).

The exposure preview is the metering preview of frame 0 (same size, samples, seed, objects,
denoiser; no motion blur; film exposure 1; its film exposure from the image before the
denoiser), so the pass does not render it again
(blender/exposure.py: ``meter_frames(first=...)``). Oracles: an independent metering pass of
every frame, rendered in a fresh session after the build (the values must be equal, float for
float), and the metering rule as it was (each preview rendered at the frames' film exposure):
equal to float rounding.
"""
from __future__ import annotations

import numpy as np
import pytest

from render_support import oracle_script

pytestmark = pytest.mark.render


def _built(tmp_path, monkeypatch, frames: str):
    """A small moving-cube AUTOEXPOSURE scene built for ``frames`` (1 sample), and the frames
    of every ``render_view`` call the build made (the previews)."""
    from blender_sesgen.blender import render
    from blender_sesgen.pipeline import RenderJob, RenderOptions
    script = tmp_path / "m.ses"
    script.write_text(oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4), baseline=0,
                                    extra_lines=["TIMING rate 20 exposure 0.02 blur off", "SENSOR seed 1",
                                                 "AUTOEXPOSURE", "MOVE id 5 twist 0.04 0 0.02 0 4 0"]))
    renders = []
    real = render.render_view
    monkeypatch.setattr(render, "render_view", lambda *a, **k: renders.append(a[2]) or real(*a, **k))
    job = RenderJob.prepare(script, tmp_path / "out", RenderOptions(samples=1, frames=frames))
    job.build()
    return job, renders, real



def test_metering_takes_frame_0_from_the_exposure_preview(tmp_path, monkeypatch):
    from blender_sesgen.blender import exposure, render, rig
    from blender_sesgen.scene.presets import EXPOSURE_PREVIEW
    job, renders, real = _built(tmp_path, monkeypatch, "0:3")
    s = job.session
    metered = s.metering[:2]
    assert len(s.metering) == job.plan.scene.frames == 3 and all(v > 0 for v in metered)
    assert s.metering[2] is None              # the last frame's: no exposure follows it
    # the build rendered the exposure preview of frame 0, then the pass only frame 1
    assert renders == [rig.blender_frame(k) for k in (0, 1)]
    bscene, camera = s.built.scene, s.built.cameras["left"]
    render.configure(bscene, EXPOSURE_PREVIEW, persistent=False)   # the pass starts a fresh session
    again = exposure.meter_frames(bscene, camera, [rig.blender_frame(k) for k in range(2)], s.exposure,
                                  metering=job.plan.sensor.meter)
    assert again == metered                      # a pass of every frame: the same numbers
    # and the film exposure is the undenoised preview's, as it was (the denoised preview's 90th
    # percentile comes from its Noisy Image: the same samples before the denoiser)
    assert exposure.measure_exposure(bscene, camera, rig.blender_frame(0))[0] == s.exposure
    # the rule before: frame 0's preview rendered at the frames' film exposure
    with exposure._preview_render(bscene, exposure.METERING_WIDTH_PX, exposure.METERING_SAMPLES, s.exposure,
                                  exposure.METERING_DENOISE) as p:
        real(bscene, camera, rig.blender_frame(0), seed=0, filepath=p)
        before = job.plan.sensor.meter(np.stack(exposure._beauty(p), axis=-1), [])
    assert metered[0] == pytest.approx(before, rel=1e-5) and metered[0] != pytest.approx(metered[1], rel=1e-6)


@pytest.mark.parametrize("frames, metered", [("0:2", 1), ("0:1", 1)])
def test_a_render_of_the_first_frames_renders_no_metering_preview(tmp_path, monkeypatch, frames, metered):
    """Frame k's exposure follows frames 0..k-1 and, with the converged start (AUTOEXPOSURE's
    default), frame 0's its own metering: frames 0:2 and frame 0 alone need frame 0's value, the
    exposure preview's; neither renders a metering preview, so the
    build reaches frame 0 after the exposure preview (issue 29: the build) - while the metering
    preview is the exposure preview (same size and samples; denoised as the metering preview)."""
    from blender_sesgen.blender import exposure, rig
    job, renders, _ = _built(tmp_path, monkeypatch, frames)
    assert exposure.PREVIEW_IS_METERING
    assert renders == [rig.blender_frame(0)]                          # the exposure preview alone
    m = job.session.metering
    assert len(m) == 3 and all(v > 0 for v in m[:metered]) and all(v is None for v in m[metered:])


def test_a_burnt_out_window_is_metered_at_full_scale(tmp_path, monkeypatch):
    """A camera meters its digitised output: a pixel burnt out counts at full scale, not at its
    radiance. A still view whose left quarter is a glowing wall of radiance 10 (a window) and
    the rest one of 0.1, fast auto-exposure (speed 400 at 20 Hz: each frame answers the last
    almost fully): the metering pass settles where the clipped preview's mean brings the output
    to the target T, E = (T - a) S t_nom / mean(L [L < S t_nom / E]) with a the share of the
    preview's pixels at or above full scale (S t_nom / E; S = 1 here) - the closed form from the
    preview's own pixels, independent of the code's metering; the unclipped mean (the rule
    before) would expose 10 x shorter."""
    from blender_sesgen.pipeline import RenderJob, RenderOptions
    n, target, t_nom = 24, 0.5, 0.004
    lines = ["CAMERA resolution 32 24 focal 20 baseline 0", "LOOK exposure 0", "WORLD colour 0 0 0",
             "RENDER samples 1",
             "MATERIAL name window colour 0 0 0 emission 1 1 1 emission_strength 10 roughness 1 specular 0",
             "MATERIAL name wall colour 0 0 0 emission 1 1 1 emission_strength 0.1 roughness 1 specular 0",
             "QUAD id 1 material window vertices -30 -20 -5  -2 -20 -5  -2 20 -5  -30 20 -5",
             "QUAD id 2 material wall vertices -2 -20 -5  30 -20 -5  30 20 -5  -2 20 -5",
             f"TIMING rate 20 exposure {t_nom} blur off", "SENSOR seed 1",
             f"AUTOEXPOSURE target {target} speed 400"] + ["POSE 0 0 0 0 0 0"] * n
    script = tmp_path / "window.ses"
    script.write_text("\n".join(lines) + "\n")
    job = RenderJob.prepare(script, tmp_path / "out", RenderOptions(frames=f"0:{n}"))
    sensor, previews = job.plan.sensor, []
    real = sensor.meter
    monkeypatch.setattr(sensor, "meter", lambda image, before: previews.append(np.array(image)) or real(image, before))
    job.build()
    metered = job.session.metering
    metered = metered[:n - 1]                                   # no exposure follows the last frame's
    assert len(previews) == n - 1 and all(v is not None for v in metered)
    w = np.array([0.2126, 0.7152, 0.0722])
    L = previews[-1].astype(np.float64)                         # (h, w, 3): a colour sensor clips each channel
    clipped = L > 1.0                                           # the window; then as E decides
    for _ in range(20):
        a = (clipped.mean(axis=(0, 1)) * w).sum()
        E = (target - a) * t_nom / (np.where(clipped, 0.0, L).mean(axis=(0, 1)) * w).sum()
        if np.array_equal(L >= t_nom / E, clipped):
            break
        clipped = L >= t_nom / E
    assert 0.2 < a < 0.35 and L[~clipped].max() < t_nom / E     # a quarter burns out; the rest does not
    exposure_s, gain = sensor.exposures(metered)[-1]
    # the previews of a still view differ by the denoiser's round-off only: the schedule settles there
    assert exposure_s * gain == pytest.approx(E, rel=1e-3)
    E_last = np.prod(sensor.exposures(metered[:-1])[-1])       # frame n-1's: the meter's clip level
    assert metered[-1] == pytest.approx((np.minimum(L, t_nom / E_last).mean(axis=(0, 1)) * w).sum(), rel=1e-6)
    assert target * t_nom / (L.mean(axis=(0, 1)) * w).sum() < E / 10     # what the unclipped mean would give


def test_sigterm_stops_a_render_during_its_metering_pass(tmp_path):
    """SIGTERM while the build meters a long sequence stops the render there (exit 130, the
    folder as it was), not after the pass: the pass asks the render's stop request between
    frames as the frames do between views."""
    import os
    import signal
    import subprocess
    import time
    from render_support import REPO, render_cmd
    script = tmp_path / "long.ses"
    script.write_text(oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4), baseline=0,
                                    extra_lines=["TIMING rate 20 exposure 0.02 blur off", "SENSOR seed 1", "AUTOEXPOSURE",
                                                 *["EGO 0 0 0.0005 0 0.01 0"] * 3000]))
    out = tmp_path / "out"
    # the last frame: its exposure follows every frame before it, so the build meters ~3000 frames
    p = subprocess.Popen(render_cmd(script, "--out", out, "--samples", 1, "--frames", "3000:3001", "--progress", "plain"),
                         cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)},
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout.readline().startswith("sesgen render:")    # the build starts now
    time.sleep(6.0)                                              # well into the metering pass
    assert p.poll() is None, p.communicate()
    p.send_signal(signal.SIGTERM)
    t0 = time.monotonic()
    stdout, stderr = p.communicate(timeout=600)
    waited = time.monotonic() - t0
    print(f"stopped {waited:.1f} s after SIGTERM")
    assert p.returncode == 130, stdout + stderr
    assert "interrupted (SIGTERM) before frame 0 was rendered" in stderr and "Traceback" not in stderr, stderr
    assert not (out / "manifest.json").exists() and not list(out.glob("exr/*/*.exr"))


def test_the_metering_pass_evaluates_only_its_renders(tmp_path, monkeypatch):
    """The metering pass and the exposure preview render the fast way (issue 29: ~0.45 CPU s a
    metered frame of the city, ~1 CPU s of its build): the frame set for the render's own
    dependency graph, the view layer not evaluated for it (``frame_set``) - Blender's frame-change
    events of a pass of N frames are N times those of one such render, the preview's those of
    one, none more - and the numbers are those of the previews rendered the plain way
    (``frame_set`` each frame), float for float."""
    import bpy
    from blender_sesgen.blender import exposure, render, rig
    from blender_sesgen.scene.presets import EXPOSURE_PREVIEW
    job, _, real = _built(tmp_path, monkeypatch, "0:2")
    s = job.session
    bscene, camera = s.built.scene, s.built.cameras["left"]
    frames = [rig.blender_frame(k) for k in range(3)]
    events = []
    handler = lambda *a: events.append(1)   # noqa: E731
    bpy.app.handlers.frame_change_post.append(handler)
    try:
        render.configure(bscene, EXPOSURE_PREVIEW, persistent=False)
        with exposure._preview_render(bscene, exposure.METERING_WIDTH_PX, exposure.METERING_SAMPLES, 1.0,
                                      exposure.METERING_DENOISE) as p:
            real(bscene, camera, frames[0], seed=0, filepath=p, fast=True)
        one = len(events)
        del events[:]
        metered = exposure.meter_frames(bscene, camera, frames, s.exposure, metering=job.plan.sensor.meter)
        assert one >= 1 and len(events) == len(frames) * one
        del events[:]
        value, preview = exposure.measure_exposure(bscene, camera, frames[1], denoise=exposure.METERING_DENOISE)
        assert len(events) == one
    finally:
        bpy.app.handlers.frame_change_post.remove(handler)
    # the oracle: each preview rendered the plain way, in a fresh persistent session
    render.configure(bscene, EXPOSURE_PREVIEW, persistent=False)
    bscene.render.use_persistent_data = True
    plain = []
    with exposure._preview_render(bscene, exposure.METERING_WIDTH_PX, exposure.METERING_SAMPLES, 1.0,
                                  exposure.METERING_DENOISE) as p:
        for f in frames:
            real(bscene, camera, f, seed=0, filepath=p)
            plain.append(job.plan.sensor.meter(s.exposure * np.stack(exposure._beauty(p), axis=-1), list(plain)))
        real(bscene, camera, frames[1], seed=0, filepath=p)    # the exposure preview's frame, the plain way
        assert np.array_equal(np.stack(exposure._beauty(p), axis=-1), preview)
    bscene.render.use_persistent_data = False
    assert metered == plain and len(set(metered)) == len(frames) and value > 0


def _settings(owner) -> dict:
    """Every plain property (not a pointer or a collection) of a bpy struct, by name."""
    return {p.identifier: getattr(owner, p.identifier) for p in owner.bl_rna.properties
            if p.type not in ("POINTER", "COLLECTION") and not p.is_readonly}


def test_a_preview_leaves_every_render_and_cycles_setting_as_it_found_it():
    """``_preview_render`` sets the scene up for a small denoised preview (OpenImageDenoise on
    the CPU, albedo and normal guides, accurate prefilter) and restores everything afterwards:
    every property of the scene's render and Cycles settings equals its value before. The old
    code left the denoiser's guides, prefilter and device (the GPU one a GPU render had chosen)
    as the preview set them."""
    import bpy
    from blender_sesgen.blender import exposure
    bscene = bpy.data.scenes.new("sesgen-preview-restore")
    try:
        bscene.render.engine = "CYCLES"
        c = bscene.cycles
        c.use_denoising, c.denoising_input_passes, c.denoising_prefilter = True, "RGB_ALBEDO", "FAST"
        c.samples, c.film_exposure = 24, 1.7
        if hasattr(c, "denoising_use_gpu"):
            c.denoising_use_gpu = True
        before = (_settings(bscene.render), _settings(c))
        with exposure._preview_render(bscene, 32, 2, 1.0, denoise=True) as path:
            assert c.denoising_input_passes == "RGB_ALBEDO_NORMAL" and c.samples == 2 and path.endswith(".exr")
        after = (_settings(bscene.render), _settings(c))
        changed = {k for b, a in zip(before, after) for k in b if b[k] != a[k]}
        assert not changed, changed
    finally:
        bpy.data.scenes.remove(bscene)
