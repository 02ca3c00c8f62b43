"""Where a ground-truth (``gt``) stereo frame's time goes: CPU seconds per stereo frame in
one persistent session at several resolutions (a fixed per-render cost would show at the
smallest), and with the EXRs written without compression (the ZIP encoding's share).

    .venv/bin/python bench/bench_gt_cost.py [--scene scenes/paper_room.ses] [--scales 0.1 0.5 1.0]
        [--frames 6]

Each row: frames 1..N rendered after frame 0 (which builds the Cycles scene) through
``BlenderSession.render_frame``, the job's own render path; CPU seconds are the process's
(robust on a shared machine). The codec rows alternate ZIP and uncompressed renders of the
same frames at scale 1 and keep each one's fastest round.
"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def session(scene: str, scale: float):
    from blender_sesgen.blender.session import BlenderSession
    from blender_sesgen.plan import RenderOptions, RenderPlan
    plan = RenderPlan.from_file(scene, RenderOptions(quality="gt", resolution_scale=scale))
    return plan, BlenderSession(plan)


def frames(s, plan, tmp: Path, ks) -> tuple[float, float]:
    c0, t0 = cpu_s(), time.perf_counter()
    for k in ks:
        s.render_frame(plan.frames[k % len(plan.frames)], {v: tmp / f"{v}.exr" for v in plan.views})
    return (cpu_s() - c0) / len(ks), (time.perf_counter() - t0) / len(ks)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=str(REPO / "scenes" / "paper_room.ses"))
    p.add_argument("--scales", type=float, nargs="+", default=[0.1, 0.5, 1.0])
    p.add_argument("--frames", type=int, default=6)
    a = p.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="sesgen-gtcost-"))
    print(f"# gt cost: {Path(a.scene).name}, {a.frames} stereo frames per row, load {os.getloadavg()[0]:.1f}", flush=True)
    print(f"{'size':>10s} {'pixels':>8s} {'cpu s':>7s} {'wall s':>7s} {'cpu us/px':>9s}", flush=True)
    last = None
    for scale in a.scales:
        plan, s = session(a.scene, scale)
        frames(s, plan, tmp, [0])
        cpu, wall = frames(s, plan, tmp, range(1, a.frames + 1))
        px = plan.settings.width * plan.settings.height * len(plan.views)
        print(f"{plan.settings.width:>5d}x{plan.settings.height:<4d} {px:8d} {cpu:7.3f} {wall:7.3f} {cpu / px * 1e6:9.2f}",
              flush=True)
        last = (plan, s)
    plan, s = last
    image = s.built.scene.render.image_settings
    best = {}
    for _ in range(3):
        for codec in ("ZIP", "NONE"):
            image.exr_codec = codec
            cpu, _w = frames(s, plan, tmp, range(1, a.frames + 1))
            best[codec] = min(best.get(codec, cpu), cpu)
            best[codec + "_bytes"] = (tmp / "left.exr").stat().st_size
    image.exr_codec = "ZIP"
    for codec in ("ZIP", "NONE"):
        print(f"# EXR {codec:4s}: {best[codec]:.3f} CPU s per stereo frame, {best[codec + '_bytes'] / 2**20:.1f} MiB per view")
    print(f"# ZIP encoding: {best['ZIP'] - best['NONE']:.3f} CPU s per stereo frame "
          f"({(best['ZIP'] - best['NONE']) / best['ZIP']:.0%}); load {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
