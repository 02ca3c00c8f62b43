"""Where a ground-truth (``gt``) stereo frame's time goes: CPU seconds per stereo frame in
one persistent session at several resolutions (a fixed per-render cost would show at the
smallest), then, at the last resolution, split by stage: Cycles' render alone, + the EXRs
(ZIP at the renderer's deflate level, the product; OpenEXR's default level 4, the files
before; every other lossless codec for comparison), + the display PNGs (what they would
cost: the job writes none for gt), + sealing (``output.seal_frame``: read back, check, strip, hash).

    .venv/bin/python bench/bench_gt_cost.py [--scene scenes/paper_room.ses] [--scales 0.1 0.5 1.0]
        [--frames 6] [--rounds 3] [--codecs ZIP ZIP:4 NONE RLE ZIPS PIZ]

Each row: frames 1..N rendered after frame 0 (which builds the Cycles scene) through the
job's own render path (``BlenderSession.render_frame``); CPU seconds are the process's
(robust on a shared machine). The stage rows alternate round by round over the same frames
and keep each one's cheapest round, so that load changes hit every row alike. The last
line is the ceiling the CPU time allows on this machine's cores if they were idle and kept
busy: cores / CPU s per stereo frame.
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def session(scene: str, scale: float):
    from blender_sesgen.blender.session import BlenderSession
    from blender_sesgen.plan import RenderOptions, RenderPlan
    plan = RenderPlan.from_file(scene, RenderOptions(quality="gt", resolution_scale=scale))
    return plan, BlenderSession(plan)


def frames(s, plan, tmp: Path, ks, display: bool = False) -> tuple[float, float]:
    """The job's render path: EXRs (and the display PNGs) of frames ``ks``."""
    c0, t0 = cpu_s(), time.perf_counter()
    for k in ks:
        s.render_frame(plan.frames[k % len(plan.frames)], {v: tmp / f"{v}.exr" for v in plan.views},
                       display_paths={v: tmp / f"{v}.png" for v in plan.views} if display else None)
    return (cpu_s() - c0) / len(ks), (time.perf_counter() - t0) / len(ks)


def render_only(s, plan, ks) -> tuple[float, float]:
    """Cycles' render of both views (the same multiview render), no file written."""
    import bpy
    from blender_sesgen.blender import render, rig
    from blender_sesgen.contract.manifest import render_seed
    scene = s.built.scene
    c0, t0 = cpu_s(), time.perf_counter()
    for k in ks:
        render.set_multiview(scene, True, tuple(plan.views))
        render._prepare(scene, s.built.cameras["left"], rig.blender_frame(plan.frames[k % len(plan.frames)]),
                        render_seed(plan.settings.seed, 0, 0), fast=True)
        with bpy.context.temp_override(scene=scene):
            bpy.ops.render.render(write_still=False, scene=scene.name)
    return (cpu_s() - c0) / len(ks), (time.perf_counter() - t0) / len(ks)


def seal(plan, tmp: Path, n: int) -> float:
    """CPU s of sealing one stereo frame (the EXRs, and the PNGs where the job writes them),
    from pristine copies each time."""
    from blender_sesgen.output import display_key, seal_frame
    written = {v: tmp / f"{v}.exr" for v in plan.views}
    if plan.writes_display:
        written.update({display_key(v): tmp / f"{v}.png" for v in plan.views})
    keep = tmp / "pristine"
    keep.mkdir(exist_ok=True)
    for p in written.values():
        shutil.copy(p, keep / p.name)
    total = 0.0
    for _ in range(n):
        for p in written.values():
            shutil.copy(keep / p.name, p)
        c0 = time.process_time()
        seal_frame(0, written, ())
        total += time.process_time() - c0
    return total / n


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=str(REPO / "scenes" / "paper_room.ses"))
    p.add_argument("--scales", type=float, nargs="+", default=[0.1, 0.5, 1.0])
    p.add_argument("--frames", type=int, default=6)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--codecs", nargs="+", default=["ZIP", "ZIP:4", "NONE", "RLE", "ZIPS", "PIZ"],
                   help="lossless EXR codecs to compare (ZIP is the product; ZIP:L at deflate level L)")
    a = p.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="sesgen-gtcost-"))
    print(f"# gt cost: {Path(a.scene).name}, {a.frames} stereo frames per row, {os.cpu_count()} CPUs, "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    print(f"{'size':>10s} {'pixels':>8s} {'cpu s':>7s} {'wall s':>7s} {'cpu us/px':>9s}", flush=True)
    last = None
    for scale in a.scales:
        plan, s = session(a.scene, scale)
        frames(s, plan, tmp, [0], display=plan.writes_display)
        cpu, wall = frames(s, plan, tmp, range(1, a.frames + 1), display=plan.writes_display)
        px = plan.settings.width * plan.settings.height * len(plan.views)
        print(f"{plan.settings.width:>5d}x{plan.settings.height:<4d} {px:8d} {cpu:7.3f} {wall:7.3f} {cpu / px * 1e6:9.2f}",
              flush=True)
        last = (plan, s)
    plan, s = last
    from blender_sesgen.blender import render
    product_level = render.EXR_ZIP_LEVEL
    image = s.built.scene.render.image_settings
    ks = range(1, a.frames + 1)
    rows = {"render": None, **{f"exr {c}": None for c in a.codecs}, "exr ZIP + png": None}
    sizes = {}
    for _ in range(max(1, a.rounds)):
        for name in rows:
            if name == "render":
                m = render_only(s, plan, ks)
            else:
                codec = name.split()[1]
                kind, _, level = codec.partition(":")
                image.exr_codec = kind         # save_display puts ZIP back after each PNG
                render.EXR_ZIP_LEVEL = int(level or product_level)
                m = frames(s, plan, tmp, ks, display=name.endswith("png"))
                sizes[codec] = (tmp / "left.exr").stat().st_size
                render.EXR_ZIP_LEVEL = product_level
            rows[name] = m if rows[name] is None or m[0] < rows[name][0] else rows[name]
    image.exr_codec = "ZIP"
    frames(s, plan, tmp, [1], display=True)
    sealing = min(seal(plan, tmp, a.frames) for _ in range(max(1, a.rounds)))
    base = rows["render"][0]
    # the job's frame: the EXRs, the PNGs only where it writes them (not for gt), the sealing
    job = rows["exr ZIP + png" if plan.writes_display else "exr ZIP"][0] + sealing
    print(f"# ZIP is written at deflate level {product_level}")
    print(f"# CPU s per stereo frame by stage at {plan.settings.width}x{plan.settings.height} "
          f"(cheapest of {a.rounds} rounds; load {os.getloadavg()[0]:.1f}):")
    print(f"{'stage':22s} {'cpu s':>7s} {'wall s':>7s} {'+cpu s':>7s} {'share':>6s} {'MiB/view':>9s}")
    print(f"{'Cycles render only':22s} {base:7.3f} {rows['render'][1]:7.3f} {'':>7s} {base / job:6.0%}")
    for c in a.codecs:
        cpu, wall = rows[f"exr {c}"]
        print(f"{'+ EXRs, ' + c:22s} {cpu:7.3f} {wall:7.3f} {cpu - base:7.3f} {(cpu - base) / job:6.0%} "
              f"{sizes[c] / 2**20:9.2f}")
    cpu, wall = rows["exr ZIP + png"]
    zip_cpu = rows["exr ZIP"][0]
    label, share = ("+ display PNGs", f"{(cpu - zip_cpu) / job:6.0%}") if plan.writes_display else \
        ("(+ PNGs, not written)", "")
    print(f"{label:22s} {cpu:7.3f} {wall:7.3f} {cpu - zip_cpu:7.3f} {share:>6s}")
    print(f"{'+ sealing (worker)':22s} {job:7.3f} {'':>7s} {sealing:7.3f} {sealing / job:6.0%}")
    n = os.cpu_count() or 1
    print(f"# ceiling on {n} idle cores kept busy: {n / job:.2f} stereo frames/s (the job's stages), "
          f"{n / base:.2f} for Cycles' render alone; load {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
