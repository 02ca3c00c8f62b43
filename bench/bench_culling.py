"""Streaming a large world: the peak memory and seconds per frame of ``render --cull`` chunks of
a drive through a 1 km route's city against the same chunks in the world of its first 100 m
(the goal: within 10 %), and without culling for contrast.

    PYTHONPATH=. python bench/bench_culling.py [--route-m 1000] [--short-m 100] [--chunk 20]
        [--chunks 3] [--scale 0.5] [--quality gt] [--far 150] [--no-full] [--overhead [--repeat 5]]

The city generator (blender_sesgen/generators/builtin/city_grid.py, seed 0, no loop closures) writes the long
route's script: its city grows with the route (5 x 5 blocks, ~2700 objects for 1 km). The
short one is the same drive cut after its first ``--short-m`` metres, in the world that drive
needs: the objects whose bounds come within far + 50 m of its camera path (and its moving cars
cut to its frames) -- the script a 100 m route would have. The same ``--chunks`` chunks of
``--chunk`` frames of that first stretch are rendered from both scripts, each by its own
``python -m blender_sesgen render --frames A:B --cull`` process with one Cycles thread, as a
farm's chunks are; its peak resident set (``ru_maxrss``, measured by a wrapper process) and its
wall time (parsing, culling, building, rendering and writing: everything a chunk costs) per
frame are printed, then the ratios long / short. Without ``--no-full`` each script's first
chunk is rendered once more with the whole world built.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
WRAPPER = ("import resource, subprocess, sys, json, time; t = time.perf_counter(); "
           "p = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
           "print(json.dumps({'rc': p.returncode, 'wall_s': time.perf_counter() - t, "
           "'maxrss_kib': resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, "
           "'cpu_s': resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime "
           "+ resource.getrusage(resource.RUSAGE_CHILDREN).ru_stime, "
           "'out': p.stdout[:4000], 'err': p.stderr[-2000:]}))")
_ID = re.compile(r"\bid (\d+)\b")
_FRAME = re.compile(r"^MOVE id \d+ frame (\d+)\b")


def short_world(text: str, short_m: float, margin_m: float) -> tuple[str, int]:
    """The script of the drive's first ``short_m`` metres in the world it needs (see the
    module docstring) and its frame count."""
    from blender_sesgen.render.culling import object_box
    from blender_sesgen.ses import parse_string
    scene = parse_string(text, source="long.ses")
    P = scene.timeline.left()[:, :3, 3]
    dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    n = int(np.searchsorted(dist, short_m)) + 1
    cam = P[:n]
    reach = scene.rig.far + margin_m
    keep = set()
    for o in scene.objects:
        b = object_box(o)
        m = scene.motion_of(o.id)
        if b is None or o.name == "ground":
            keep.add(o.id)
            continue
        c = b.corners()
        pts = c if m is None else np.concatenate([T[:3, 3][None] + (c - b.T_world[:3, 3]) for T in m.poses()[:n]])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        gap = np.maximum(np.maximum(lo - cam, cam - hi), 0.0)
        if np.linalg.norm(gap, axis=1).min() <= reach:
            keep.add(o.id)
    out, poses = [], 0
    for line in text.splitlines():
        if line.startswith("POSE "):
            poses += 1
            if poses > n:
                continue
        elif line.startswith("MOVE "):
            f = _FRAME.match(line)
            if int(_ID.search(line).group(1)) not in keep or (f and int(f.group(1)) >= n):
                continue
        elif line.split(" ", 1)[0] in ("CUBOID", "QUAD", "ASSET", "SPHERE", "CYLINDER", "MESH"):
            if int(_ID.search(line).group(1)) not in keep:
                continue
        out.append(line)
    return "\n".join(out) + "\n", n


def render_chunk(script: Path, out: Path, a: int, b: int, args, cull: bool) -> dict:
    cmd = [sys.executable, "-m", "blender_sesgen", "render", str(script), "--out", str(out), "--frames", f"{a}:{b}",
           "--quality", args.quality, "--resolution-scale", str(args.scale), "--threads", "1", "--progress", "plain"]
    if cull:
        cmd.append("--cull")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p))
    res = json.loads(subprocess.run([sys.executable, "-c", WRAPPER, *cmd], capture_output=True, text=True,
                                    env=env, check=True).stdout)
    if res["rc"] != 0:
        raise SystemExit(f"render failed ({res['rc']}): {res['err']}")
    built = next((ln.split("culling: ")[1].split(" objects")[0] for ln in res["out"].splitlines()
                  if ln.startswith("culling: ")), "all")
    return {"frames": b - a, "wall_s": res["wall_s"], "s_per_frame": res["wall_s"] / (b - a),
            "cpu_per_frame": res["cpu_s"] / (b - a), "peak_rss_mib": res["maxrss_kib"] / 1024, "built": built}


def rgb_difference(a) -> int:
    """PSNR of the display images of a culled render against the whole world's, same frames."""
    from blender_sesgen.generators.builtin.city_grid import generate as gen
    from vo_reference.evaluate.image_quality import psnr
    from vo_reference.io.render import RenderSequence
    f0, f1 = (int(x) for x in a.rgb_frames.split(":"))
    print(f"# culled vs whole world, RGB: city_grid seed 0, {a.route_m:g} m route, frames {f0}:{f1}, quality "
          f"{a.quality}, scale {a.scale}, far {a.far:g} m; load {' '.join(Path('/proc/loadavg').read_text().split()[:3])}",
          flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "long.ses"
        script.write_text(gen(0, route_m=a.route_m, closures=0, far=a.far))
        out = {}
        for cull in (True, False):
            out[cull] = Path(tmp) / ("culled" if cull else "full")
            r = render_chunk(script, out[cull], f0, f1, a, cull=cull)
            print(f"{'culled' if cull else 'whole world'}: built {r['built']}, {r['s_per_frame']:.1f} s/frame, "
                  f"{r['cpu_per_frame']:.1f} CPU s/frame, peak RSS {r['peak_rss_mib']:.0f} MiB", flush=True)
        A, B = RenderSequence(out[True]), RenderSequence(out[False])
        ea, eb = (S.manifest.get("render", {}).get("exposure") for S in (A, B))
        print(f"exposure: culled {ea:.4f}, whole world {eb:.4f}")
        for k in range(f0, f1):
            for v in A.views:
                ga, gb = A.depth(k, v), B.depth(k, v)
                same_gt = np.array_equal(ga, gb) and np.array_equal(A.ids(k, v), B.ids(k, v))
                print(f"frame {k} {v}: display image PSNR {psnr(A.image_rgb(k, v), B.image_rgb(k, v), 255.0):.2f} dB, "
                      f"depth and ids {'identical' if same_gt else 'DIFFERENT'}")
    return 0


CHANNELS = {"rgb": ["ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B", "ViewLayer.Combined.A"],
            "depth": "ViewLayer.Depth.Z", "object_index": "ViewLayer.Object Index.X"}


def route_overhead(a, scripts: dict, start: int) -> int:
    """``--overhead``: the CPU seconds of what every chunk does for the whole route rather than
    for its frames (no Blender): parsing and checking the script, culling (every object
    against the chunk's views), the manifest (every frame's poses and the movers' at every
    frame) built, written (twice a chunk: when it begins and when it ends) and read back
    (what a resumed or later farm chunk does), the pose files; for the short and the long
    script, each step ``--repeat`` times (min and max: the load's noise)."""
    import time

    from blender_sesgen.contract.manifest import Manifest
    from blender_sesgen.render.culling import visible_objects
    from blender_sesgen.render.folder import OutputFolder
    from blender_sesgen.render.plan import RenderOptions, RenderPlan
    opts = RenderOptions(frames=f"{start}:{start + a.chunk}", quality=a.quality, resolution_scale=a.scale, cull=True)
    steps = {}
    with tempfile.TemporaryDirectory() as tmp:
        for world, script in scripts.items():
            out = Path(tmp) / world
            out.mkdir()
            plan = RenderPlan.from_file(script, opts)
            m = plan.manifest(channels=CHANNELS, render_extra={}, blender_version="bench")
            todo = {"parse and check the script": lambda: RenderPlan.from_file(script, opts),
                    "cull (every object)": lambda: visible_objects(plan, plan.frames),
                    "build the manifest": lambda: plan.manifest(channels=CHANNELS, render_extra={},
                                                                blender_version="bench"),
                    "write the manifest (x2)": lambda: (m.write(out), m.write(out)),
                    "read the manifest": lambda: Manifest.read(out, sealed=False),
                    "pose files": lambda: OutputFolder._pose_files(plan, m)}
            for name, step in todo.items():
                times = []
                for _ in range(a.repeat):
                    t0 = time.process_time()
                    step()
                    times.append(time.process_time() - t0)
                steps.setdefault(name, {})[world] = (min(times), max(times))
    print(f"\n| per chunk, CPU s (min-max of {a.repeat}) | first {a.short_m:g} m | {a.route_m:g} m route | more |")
    print("|---|---|---|---|")
    total = {"short": 0.0, "long": 0.0}
    for name, r in steps.items():
        for w in total:
            total[w] += r[w][0]
        print(f"| {name} | {r['short'][0]:.3f}-{r['short'][1]:.3f} | {r['long'][0]:.3f}-{r['long'][1]:.3f} | "
              f"+{r['long'][0] - r['short'][0]:.3f} |")
    print(f"| all (the minima) | {total['short']:.3f} | {total['long']:.3f} | +{total['long'] - total['short']:.3f} |")
    print(f"# load after: {' '.join(Path('/proc/loadavg').read_text().split()[:3])}")
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--route-m", type=float, default=1000.0)
    p.add_argument("--short-m", type=float, default=100.0)
    p.add_argument("--chunk", type=int, default=20)
    p.add_argument("--chunks", type=int, default=3)
    p.add_argument("--scale", type=float, default=0.5)
    p.add_argument("--quality", default="gt")
    p.add_argument("--far", type=float, default=150.0, help="the camera's far plane (m), where the haze ends")
    p.add_argument("--no-full", action="store_true", help="skip the renders with the whole world built")
    p.add_argument("--rgb-frames", metavar="A:B", help="instead: render these frames of the long route at --quality "
                   "(e.g. draft) culled and with the whole world, and print the PSNR of their images")
    p.add_argument("--overhead", action="store_true", help="instead: time (CPU s, --repeat times) the steps "
                   "every chunk does for the whole route, without Blender")
    p.add_argument("--repeat", type=int, default=5)
    a = p.parse_args(argv)
    if a.rgb_frames:
        return rgb_difference(a)
    from blender_sesgen.generators.builtin.city_grid import generate as gen
    long_text = gen(0, route_m=a.route_m, closures=0, far=a.far)
    short_text, n_short = short_world(long_text, a.short_m, 50.0)
    n_obj = [sum(1 for ln in t.splitlines() if ln.split(" ", 1)[0] in ("CUBOID", "QUAD", "ASSET")) for t in
             (short_text, long_text)]
    starts = [int(round((n_short - a.chunk) * (i + 0.5) / a.chunks)) for i in range(a.chunks)]
    print(f"# culling bench: city_grid seed 0; the first {a.short_m:g} m ({n_short} frames, {n_obj[0]} objects) "
          f"alone and in the {a.route_m:g} m route's city ({n_obj[1]} objects); chunks {starts} of {a.chunk} "
          f"frames; quality {a.quality}, scale {a.scale}, far {a.far:g} m; 1 Cycles thread per render")
    print(f"# load before: {' '.join(Path('/proc/loadavg').read_text().split()[:3])}", flush=True)
    if a.overhead:
        with tempfile.TemporaryDirectory() as tmp:
            scripts = {"short": Path(tmp) / "short.ses", "long": Path(tmp) / "long.ses"}
            scripts["short"].write_text(short_text)
            scripts["long"].write_text(long_text)
            return route_overhead(a, scripts, starts[0])
    rows = {"short": [], "long": []}
    full = {}
    with tempfile.TemporaryDirectory() as tmp:
        scripts = {"short": Path(tmp) / "short.ses", "long": Path(tmp) / "long.ses"}
        scripts["short"].write_text(short_text)
        scripts["long"].write_text(long_text)
        for s in starts:                      # interleaved: the machine's load hits both alike
            for world in ("short", "long"):
                r = render_chunk(scripts[world], Path(tmp) / f"{world}_{s}", s, s + a.chunk, a, cull=True)
                rows[world].append(r)
                print(f"{world:5s} world, chunk {s}:{s + a.chunk}, culled: built {r['built']}, "
                      f"{r['s_per_frame']:.2f} s/frame, {r['cpu_per_frame']:.2f} CPU s/frame, "
                      f"peak RSS {r['peak_rss_mib']:.0f} MiB", flush=True)
        if not a.no_full:
            for world in ("short", "long"):
                r = render_chunk(scripts[world], Path(tmp) / f"{world}_full", starts[0], starts[0] + a.chunk, a,
                                 cull=False)
                full[world] = r
                print(f"{world:5s} world, chunk {starts[0]}:{starts[0] + a.chunk}, whole world built: "
                      f"{r['s_per_frame']:.2f} s/frame, {r['cpu_per_frame']:.2f} CPU s/frame, "
                      f"peak RSS {r['peak_rss_mib']:.0f} MiB", flush=True)
    print(f"# load after: {' '.join(Path('/proc/loadavg').read_text().split()[:3])}")
    sp = {w: sum(r["s_per_frame"] for r in rows[w]) / len(rows[w]) for w in rows}
    cpu = {w: sum(r["cpu_per_frame"] for r in rows[w]) / len(rows[w]) for w in rows}
    rss = {w: max(r["peak_rss_mib"] for r in rows[w]) for w in rows}
    print("\n| world | objects | culled: s/frame | culled: CPU s/frame | culled: peak RSS MiB |"
          + (" whole world: s/frame | CPU s/frame | peak RSS MiB |" if full else ""))
    print("|---|---|---|---|---|" + ("---|---|---|" if full else ""))
    for w, label, n in (("short", f"first {a.short_m:g} m", n_obj[0]), ("long", f"{a.route_m:g} m route", n_obj[1])):
        f = full.get(w)
        extra = f" {f['s_per_frame']:.2f} | {f['cpu_per_frame']:.2f} | {f['peak_rss_mib']:.0f} |" if f else ""
        print(f"| {label} | {n} | {sp[w]:.2f} | {cpu[w]:.2f} | {rss[w]:.0f} |{extra}")
    print(f"\nculled, {a.route_m:g} m city / {a.short_m:g} m: s/frame x{sp['long'] / sp['short']:.3f}, CPU s/frame "
          f"x{cpu['long'] / cpu['short']:.3f}, peak RSS x{rss['long'] / rss['short']:.3f} (goal: within 10 %)")
    if full:
        print(f"whole world built, {a.route_m:g} m / {a.short_m:g} m: s/frame "
              f"x{full['long']['s_per_frame'] / full['short']['s_per_frame']:.2f}, CPU s/frame "
              f"x{full['long']['cpu_per_frame'] / full['short']['cpu_per_frame']:.2f}, peak RSS "
              f"x{full['long']['peak_rss_mib'] / full['short']['peak_rss_mib']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
