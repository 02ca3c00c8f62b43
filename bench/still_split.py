"""Split a still camera's frame-to-frame difference in a render: the sensor model against the
path tracer (docs/sensors.md, "Camera profiles": a still render's frame difference, split).

    python bench/still_split.py RENDER [--frames 30,31] [--again RENDER2]

RENDER is a render folder with EXRs (``render`` or ``bench/twin.py``'s ``--out``/SCENE). For
each pair of consecutive frames it prints the mean absolute difference (DN, left view, the
sensor's 8-bit grey) of: the frames developed through today's camera chain as rendered;
one frame's EXR developed with two sensor-noise seeds (the sensor model alone); the frames
developed without noise (the path tracer's per-frame noise and the camera's motion), on flat
pixels (gradient < 1 DN/px) and on edges (> 5 DN/px) apart; and the median KLT
forward-backward error (px) of each. ``--again`` names a folder holding the same frames
rendered with another Cycles seed (``render --seed``): the same pose developed alike, so the
path tracer alone. Every frame is developed at the first frame's exposure and gain (recorded
state): only the image changes.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("render", type=Path)
    ap.add_argument("--frames", default="30,31", help="frames, comma-separated (default 30,31)")
    ap.add_argument("--again", type=Path, help="the same frames rendered with another Cycles seed")
    a = ap.parse_args(argv)
    try:
        frames = [int(x) for x in a.frames.split(",")]
    except ValueError:
        print(f"--frames: integers separated by commas, got {a.frames!r}", file=sys.stderr)
        return 2
    for folder in [a.render] + ([a.again] if a.again else []):
        missing = [k for k in frames if not (folder / "exr" / "left" / f"{k:06d}.exr").is_file()]
        if not (folder / "scene.ses").is_file() or missing:
            print(f"{folder}: not a render folder holding the EXRs of frames {frames}", file=sys.stderr)
            return 2
    from blender_sesgen.render.plan import EffectiveSettings, RenderOptions
    from blender_sesgen.render.sensor import pipeline, raw
    from blender_sesgen.render.sensor.autoexposure import LUMA
    from blender_sesgen.render.sensor.outputs import state_relpath
    from blender_sesgen.render.sensor.render_plan import SensorPlan
    from blender_sesgen.ses.parser import parse_text
    from vo_reference.evaluate.realism import klt_fb_error
    from vo_reference.io.color import rgb8_to_gray8
    from vo_reference.io.sequence import open_sequence

    out = a.render
    scene = parse_text((out / "scene.ses").read_text(), str(out / "scene.ses"), str(out))
    if scene.sensor is None:
        print(f"{out}: the scene has no SENSOR: nothing to split", file=sys.stderr)
        return 2
    scale = json.loads((out / "manifest.json").read_text())["render"]["resolution_scale"]
    plan = SensorPlan.create(scene, EffectiveSettings.of(scene, RenderOptions(resolution_scale=scale)))
    S = plan.sensor
    cam = pipeline.Camera(S, plan.lens_spec, plan.pixel_rays(), plan.K[0, 2], plan.K[1, 2], plan.nominal_exposure_s())
    state_file = out / state_relpath(frames[0])
    state = json.loads(state_file.read_text()) if state_file.is_file() else {}
    exposure_s = float(state.get("exposure_s", plan.nominal_exposure_s()))
    gain = float(state.get("gain", 1.0))

    def developed(linear, k, seed):
        c = dataclasses.replace(cam, sensor=dataclasses.replace(S, seed=seed))
        return rgb8_to_gray8(pipeline.process(linear, c, pipeline.Shot(exposure_s, gain, k, 0)).rgb8)

    def noiseless(linear):
        """The chain's 8-bit grey without noise or quantisation (a colour sensor: the luma of the
        signal, before its mosaic)."""
        img = pipeline.optical_image(linear, cam.lens, S, cam.rays, cam.cx, cam.cy)
        ratio = exposure_s / cam.nominal_exposure_s if cam.nominal_exposure_s > 0 else 1.0
        e = (np.clip(img, 0.0, None) * (S.full_well_e / S.saturation * ratio)) @ LUMA
        full = 2 ** S.bits - 1
        raw_dn = np.clip(S.black_level_dn + e * raw.conversion_gain(S.full_well_e, S.bits, gain), 0.0, full)
        pedestal = S.black_level_dn / full
        x = (raw_dn - S.black_level_dn) / (full - S.black_level_dn)
        return 255.0 * (pedestal + (1.0 - pedestal) * raw.response(x, S.response, S.gamma))

    def parts(x, y):
        grad = np.hypot(*np.gradient(x))
        ok = (x < 254) & (y < 254)
        d = np.abs(x - y)
        return f"{d.mean():.2f} (flat {d[ok & (grad < 1)].mean():.2f}, edges {d[ok & (grad > 5)].mean():.2f})"

    seq = open_sequence(out)
    lin = {k: seq.rgb_linear(k, "left") for k in frames}
    dev = {k: developed(lin[k], k, S.seed) for k in frames}
    clean = {k: noiseless(lin[k]) for k in frames}
    print(f"{out}: {getattr(S, 'profile', None) or 'SENSOR'} at {seq.resolution[0]} px wide, "
          f"exposure {exposure_s * 1e3:.2f} ms, gain {gain:g}")
    for k0, k1 in zip(frames, frames[1:]):
        print(f"frames {k0}-{k1}: developed {np.abs(dev[k0].astype(float) - dev[k1]).mean():.2f} DN "
              f"(KLT {klt_fb_error(dev[k0], dev[k1]):.4f} px); without noise {parts(clean[k0], clean[k1])}")
    for k in frames:
        other = developed(lin[k], k, S.seed + 1)
        line = (f"frame {k}: sensor model alone (two noise seeds) {np.abs(dev[k].astype(float) - other).mean():.2f} DN "
                f"(KLT {klt_fb_error(dev[k], other):.4f} px)")
        if a.again:
            lin2 = open_sequence(a.again).rgb_linear(k, "left")
            dev2 = developed(lin2, k, S.seed + 1)
            line += (f"; path tracer alone (two Cycles seeds) without noise {parts(clean[k], noiseless(lin2))}, "
                     f"developed {np.abs(dev[k].astype(float) - dev2).mean():.2f} "
                     f"(KLT {klt_fb_error(dev[k], dev2):.4f} px)")
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
