"""What a cheaper automatic-exposure preview would change: the film exposure (and the metered
luminance of frame 0) each preview size and sample count gives, beside today's preview, and
what it costs, on the library scenes.

    PYTHONPATH=. .venv/bin/python bench/bench_exposure_preview.py [--scenes office hall city_kitti forest]
        [--previews 96x8 64x8 48x8 96x4 64x4] [--scale 1]

Each scene is built once (``RenderJob.build``: its exposure measured the usual way), then every
preview renders frame 0's left view in a fresh Cycles session (``blender/exposure.py:
measure_exposure`` with another width and sample count), in order, twice; the table gives the
exposure and its ratio to today's (the first preview, ``PREVIEW_WIDTH`` x ``PREVIEW_SAMPLES``),
the preview's mean linear luminance (at film exposure 1, unclipped) and its
ratio, and the process's CPU seconds per preview (the median of the two; set-up included). For
a scene with AUTOEXPOSURE, frame 0's metered value (taken from the exposure preview) beside the
same preview rendered again at the frames' film exposure (how it was metered before).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="+", default=["office", "hall", "city_kitti", "forest"])
    p.add_argument("--previews", nargs="+", default=["96x8", "64x8", "48x8", "96x4", "64x4"],
                   help="WIDTHxSAMPLES; the first is the reference")
    p.add_argument("--scale", type=float, default=1.0, help="resolution scale of the scene")
    a = p.parse_args(argv)
    import numpy as np
    from blender_sesgen.blender import exposure, render, rig
    from blender_sesgen.render.sensor.autoexposure import meter
    from blender_sesgen.pipeline import RenderJob, RenderOptions
    from blender_sesgen.scene.presets import EXPOSURE_PREVIEW
    previews = [tuple(int(v) for v in s.split("x")) for s in a.previews]
    print(f"# exposure previews of frame 0 (left view), scale {a.scale}; {os.cpu_count()} CPUs, "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    print(f"{'scene':12s}{'preview':>10s}{'exposure':>10s}{'ratio':>8s}{'mean lum':>10s}{'ratio':>8s}{'cpu s':>8s}")
    for name in a.scenes:
        job = RenderJob.prepare(REPO / "scenes" / f"{name}.ses", Path(tempfile.mkdtemp(prefix="sesgen-preview-")),
                                RenderOptions(frames="0:2", samples=1, resolution_scale=a.scale))
        job.build()
        s = job.session
        bscene, camera = s.built.scene, s.built.cameras["left"]
        render.configure(bscene, EXPOSURE_PREVIEW, **{**s._configure, "persistent": False})
        ref = None
        for width, samples in previews:
            got, cpu = [], []
            for _ in range(2):
                c = time.process_time()   # this process's user + sys CPU s
                got.append(exposure.measure_exposure(bscene, camera, rig.blender_frame(0), None, width, samples))
                cpu.append(time.process_time() - c)
            value, lum = got[0][0], meter(got[0][1])   # the preview's mean linear luminance
            ref = ref or (value, lum)
            print(f"{name:12s}{f'{width}x{samples}':>10s}{value:10.4f}{value / ref[0]:8.3f}{lum:10.4f}"
                  f"{lum / ref[1]:8.3f}{statistics.median(cpu):8.2f}", flush=True)
        print(f"# {name}: the build's exposure {s.exposure:.4f} (load {os.getloadavg()[0]:.1f})", flush=True)
        if s.metering:   # AUTOEXPOSURE: frame 0's metered value, from the exposure preview and as it was
            with exposure._preview_render(bscene, exposure.METERING_WIDTH_PX, exposure.METERING_SAMPLES,
                                          s.exposure, exposure.METERING_DENOISE) as path:
                render.render_view(bscene, camera, rig.blender_frame(0), seed=0, filepath=path)
                before = s.plan.sensor.meter(np.stack(exposure._beauty(path), axis=-1), [])
            print(f"# {name}: metered frame 0 {s.metering[0]:.9g} (the exposure preview's x exposure), "
                  f"{before:.9g} rendered again at the frames' film exposure (before): ratio {s.metering[0] / before:.9f}",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
