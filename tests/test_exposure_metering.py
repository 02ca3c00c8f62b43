"""The sensor auto-exposure's metering pass takes frame 0 from the automatic exposure's preview.

The exposure preview is the metering preview of frame 0 (same size, samples, seed, objects; no
denoiser, no motion blur; film exposure 1), so the pass does not render it again
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


def test_metering_takes_frame_0_from_the_exposure_preview(tmp_path, monkeypatch):
    from blender_sesgen.blender import exposure, render, rig
    from blender_sesgen.pipeline import RenderJob, RenderOptions
    from blender_sesgen.render.sensor.autoexposure import meter
    from blender_sesgen.scene.presets import EXPOSURE_PREVIEW
    script = tmp_path / "m.ses"
    script.write_text(oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4), baseline=0,
                                    extra_lines=["TIMING rate 20 exposure 0.02 blur off", "SENSOR seed 1",
                                                 "AUTOEXPOSURE", "MOVE id 5 twist 0.04 0 0.02 0 4 0"]))
    renders = []
    real = render.render_view
    monkeypatch.setattr(render, "render_view", lambda *a, **k: renders.append(a[2]) or real(*a, **k))
    job = RenderJob.prepare(script, tmp_path / "out", RenderOptions(samples=1, frames="0:3"))
    job.build()
    s = job.session
    metered = s.metering[:2]
    assert len(s.metering) == job.plan.scene.frames == 3 and all(v > 0 for v in metered)
    assert s.metering[2] is None              # the last frame's: no exposure follows it
    # the build rendered the exposure preview of frame 0, then the pass only frame 1
    assert renders == [rig.blender_frame(k) for k in (0, 1)]
    bscene, camera = s.built.scene, s.built.cameras["left"]
    render.configure(bscene, EXPOSURE_PREVIEW, persistent=False)   # the pass starts a fresh session
    again = exposure.meter_frames(bscene, camera, [rig.blender_frame(k) for k in range(2)], s.exposure)
    assert again == metered                      # a pass of every frame: the same numbers
    # the rule before: frame 0's preview rendered at the frames' film exposure
    with exposure._preview_render(bscene, exposure.METERING_WIDTH_PX, exposure.METERING_SAMPLES, s.exposure) as p:
        real(bscene, camera, rig.blender_frame(0), seed=0, filepath=p)
        before = meter(np.stack(exposure._beauty(p), axis=-1))
    assert metered[0] == pytest.approx(before, rel=1e-5) and metered[0] != pytest.approx(metered[1], rel=1e-6)


@pytest.mark.parametrize("frames, metered", [("0:2", 1), ("0:1", 0)])
def test_a_render_of_the_first_frames_renders_no_metering_preview(tmp_path, monkeypatch, frames, metered):
    """Frame k's exposure follows frames 0..k-1 only: frames 0:2 need frame 0's value, the
    exposure preview's, and frame 0 alone none; neither renders a metering preview, so the
    build reaches frame 0 after the exposure preview (issue 29: the build)."""
    from blender_sesgen.blender import render, rig
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
    assert renders == [rig.blender_frame(0)]                  # the exposure preview only
    m = job.session.metering
    assert len(m) == 3 and all(v > 0 for v in m[:metered]) and all(v is None for v in m[metered:])


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
