"""Render speed: seconds per stereo frame of each quality preset against today's default,
the pipeline's own overhead per frame over Cycles' render time, and peak memory.

    .venv/bin/python bench/bench_render.py [--scene scenes/paper_room.ses] [--frames 6]
        [--scale 1.0] [--configs gt draft final today] [--repeat 1]

Each configuration renders the first ``--frames`` frames of the scene through the real
render job (``RenderJob.run``: EXRs written, renamed, frames marked complete) in a fresh
process. Configurations: a preset name (``gt``, ``draft``, ``final``, ``reference``),
``NAME-plain`` (that preset rendered the plain way: a fresh Cycles session per view, as
before the fast path), and ``today``: the renderer's settings before the presets (16
samples, no denoiser, 6/3/3 bounces, indirect clamp 10, light tree) rendered the plain way.
``CONFIG+zipL`` writes the EXRs at deflate level L (``gt+zip4``: OpenEXR's default level, as
before the renderer chose its own). ``CONFIG@N`` renders that preset with N samples
(``--samples N``: ``final@12``). ``CONFIG/gpu`` renders on the GPU (``--device gpu``: Cycles'
OptiX or CUDA device; ``final/gpu``, without ``/gpu`` the CPU). ``CONFIG*P`` runs P render processes side by side, each
with cores/P Cycles threads and its own N frames (``gt*2``: two single-threaded renders on two
cores, as ``farm`` runs chunks; the columns are then their throughput together, CPU per
frame over both, peak MiB summed).

Any scene renders (``--scene``, the paper room by default), at its own size times ``--scale``.

Columns (frames 2..N: the first frame pays for building the Cycles scene):
- s/frame: wall seconds per stereo frame in the loop, and frames per second;
- cpu s: CPU seconds the rendering process used per stereo frame (user + system; robust on a
  shared machine); seal s: the sealing worker process's CPU seconds per stereo frame (its
  whole life, start-up included, over all frames), which compete for the same cores;
- cycles s: Cycles' own render time per stereo frame (its ``Time:``, EXR writing included);
- png s: writing the display-referred PNGs (Blender's colour management and PNG writer);
- overhead: loop wall time / Cycles' time - 1, the pipeline's per-frame cost over Cycles'
  (goal <= 2 %); w/o png: the same without the PNGs' time; ours: only what the pipeline's
  Python does outside Blender's render operator and the PNGs (frame and camera set-up, the
  sealing hand-off, renames, the completion log), over Cycles' time (the rest of "w/o png" is
  Blender's render operator outside Cycles' own timer);
- build s: parsing the script and building the Blender scene (``RenderJob.build``: the
  builder, textures, the exposure measurement); first s: the first frame (it synchronises
  the Cycles scene: BVH, shaders, images);
- peak MiB: the process's peak resident set.
Ratios against ``today`` (when in the run) come from the same run. On a shared machine,
read the ratios and the CPU seconds; ``--repeat`` runs each configuration again and keeps
the fastest.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# the settings the renderer used before the quality presets (main before issue #13)
TODAY = dict(quality="custom", samples=16)


def child(a) -> int:
    from dataclasses import replace
    from blender_sesgen.job import RenderJob
    from blender_sesgen.plan import RenderOptions, RenderPlan
    from blender_sesgen.presets import Preset

    gpu = "/gpu" in a.config
    name, _, zip_level = a.config.split("*")[0].replace("/gpu", "").partition("+zip")
    name, _, samples = name.partition("@")
    if zip_level:   # the EXRs at another deflate level (OpenEXR's default: 4)
        from blender_sesgen.blender import render
        render.EXR_ZIP_LEVEL = int(zip_level)
    plain = name == "today" or name.endswith("-plain")
    quality = None if name == "today" else name.removesuffix("-plain")
    first = a.part * a.frames
    options = RenderOptions(quality=quality, samples=int(samples) if samples else None,
                            resolution_scale=a.scale, frames=f"{first}:{first + a.frames}",
                            fast_pipeline=not plain, threads=a.threads, device="gpu" if gpu else "cpu")
    plan = RenderPlan.from_file(a.scene, options)
    if name == "today":
        plan = replace(plan, settings=replace(plan.settings, preset=Preset(**TODAY)))
    with tempfile.TemporaryDirectory() as tmp:
        job = RenderJob.of(plan, Path(tmp) / "out")
        t_build = time.perf_counter()
        job.build()
        build_s = time.perf_counter() - t_build
        rows = []

        def progress(i, n, r, elapsed):
            ru = resource.getrusage(resource.RUSAGE_SELF)
            rows.append({"t": time.perf_counter(), "cpu": ru.ru_utime + ru.ru_stime, "cycles": r.cycles_s,
                         "wall": r.wall_s, "display": sum(v.get("display_s", 0.0) for v in r.views.values()),
                         "op": sum(v.get("wall_s", 0.0) for v in r.views.values())})
        job.run(progress)
        ru = resource.getrusage(resource.RUSAGE_SELF)
        ch = resource.getrusage(resource.RUSAGE_CHILDREN)   # the sealing worker, waited for by run()
        end = {"t": time.perf_counter(), "cpu": ru.ru_utime + ru.ru_stime, "children_cpu": ch.ru_utime + ch.ru_stime}
    print(json.dumps({"rows": rows, "end": end, "start_s": rows[0]["t"] - START, "build_s": build_s}), flush=True)
    return 0


START = time.perf_counter()


def run(a, config: str) -> dict:
    """One configuration; ``NAME*P``: P render processes at once, each with cores/P Cycles
    threads, process i rendering frames [i*N, (i+1)*N) (N = --frames): the steady-state
    throughput is the frames all of them finish while all of them are past their first frame."""
    procs = int(config.split("*")[1]) if "*" in config else 1
    threads = max(1, (os.cpu_count() or 1) // procs) if procs > 1 else 0
    t0 = time.perf_counter()
    files, children = [], []
    for i in range(procs):
        so, se = tempfile.TemporaryFile("w+"), tempfile.TemporaryFile("w+")
        cmd = [sys.executable, __file__, "--child", config, "--scene", str(a.scene), "--frames", str(a.frames),
               "--scale", str(a.scale), "--part", str(i), "--threads", str(threads)]
        children.append(subprocess.Popen(cmd, cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)), stdout=so,
                                         stderr=se, text=True))
        files.append((so, se))
    results = []
    for proc, (so, se) in zip(children, files):
        _, status, usage = os.wait4(proc.pid, 0)  # this child's own peak memory
        proc.returncode = os.waitstatus_to_exitcode(status)
        so.seek(0), se.seek(0)
        out, err = so.read(), se.read()
        so.close(), se.close()
        if proc.returncode != 0:
            raise SystemExit(f"{config}: render failed ({proc.returncode}): {err[-3000:]}")
        results.append(_summary(config, json.loads(out.strip().splitlines()[-1]), usage, t0))
    if procs == 1:
        return results[0]
    return _combined(config, results)


def _combined(config: str, results: list[dict]) -> dict:
    """P processes' figures as one: throughput over the window in which all were rendering."""
    start = max(r["rows"][0]["t"] for r in results)
    stop = min(r["rows"][-1]["t"] for r in results)
    done = sum(sum(start < row["t"] <= stop for row in r["rows"]) for r in results)
    n = sum(len(r["rows"]) - 1 for r in results)
    out = {k: sum(r[k] for r in results) / len(results) for k in ("cycles_frame", "png_frame", "overhead",
                                                                 "overhead_no_png", "overhead_ours", "start_s",
                                                                 "build_s", "first_s")}
    out.update(config=config, s_frame=(stop - start) / max(done, 1),
               cpu_frame=sum(r["cpu_frame"] * (len(r["rows"]) - 1) for r in results) / n,
               seal_cpu_frame=sum(r["seal_cpu_frame"] for r in results) / len(results),
               peak_mib=sum(r["peak_mib"] for r in results), process_s=max(r["process_s"] for r in results))
    return out


def _summary(config: str, data: dict, usage, t0: float) -> dict:
    rows, end = data["rows"], data["end"]
    loop = rows[1:] if len(rows) > 1 else rows
    n = len(loop)
    # frames 2..N: from the end of frame 1 to the end of frame N (each frame's render, its
    # predecessor's commit); the job's close (the last commit, the manifest) is not per frame
    wall = rows[-1]["t"] - rows[0]["t"] if len(rows) > 1 else rows[0]["wall"]
    cpu = rows[-1]["cpu"] - rows[0]["cpu"] if len(rows) > 1 else float("nan")
    cycles = sum(r["cycles"] for r in loop)
    display = sum(r["display"] for r in loop)
    op = sum(r["op"] for r in loop)   # Blender's render operator calls (Cycles' Time + the operator's own)
    return {"config": config, "s_frame": wall / n, "cpu_frame": cpu / n, "cycles_frame": cycles / n,
            "seal_cpu_frame": end["children_cpu"] / len(rows), "png_frame": display / n,
            "overhead": wall / cycles - 1.0, "overhead_no_png": (wall - display) / cycles - 1.0,
            "overhead_ours": (wall - display - op) / cycles, "start_s": data["start_s"], "build_s": data["build_s"],
            "first_s": rows[0]["wall"],
            "process_s": time.perf_counter() - t0, "peak_mib": usage.ru_maxrss / 1024.0, "rows": rows}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=str(REPO / "scenes" / "paper_room.ses"))
    p.add_argument("--frames", type=int, default=6)
    p.add_argument("--scale", type=float, default=1.0, help="resolution scale (1.0 = the script's size)")
    p.add_argument("--configs", nargs="+", default=["gt", "draft", "final", "today"])
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--child", metavar="CONFIG", help=argparse.SUPPRESS)
    p.add_argument("--part", type=int, default=0, help=argparse.SUPPRESS)
    p.add_argument("--threads", type=int, default=0, help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.child:
        a.config = a.child
        return child(a)
    print(f"# render benchmark: {Path(a.scene).name}, {a.frames} stereo frames per configuration, scale {a.scale}, "
          f"{os.cpu_count()} CPUs, {platform.processor() or platform.machine()}, load {os.getloadavg()[0]:.1f}",
          flush=True)
    print(f"{'config':14s} {'s/frame':>8s} {'fps':>6s} {'cpu s':>7s} {'seal s':>7s} {'cycles s':>9s} {'png s':>7s} "
          f"{'overhead':>9s} {'w/o png':>8s} {'ours':>6s} {'build s':>8s} {'first s':>8s} {'peak MiB':>9s}", flush=True)
    results = {}
    for c in a.configs:
        best = None
        for _ in range(max(1, a.repeat)):
            r = run(a, c)
            best = r if best is None or r["s_frame"] < best["s_frame"] else best
        results[c] = best
        r = best
        print(f"{c:14s} {r['s_frame']:8.3f} {1 / r['s_frame']:6.2f} {r['cpu_frame']:7.3f} {r['seal_cpu_frame']:7.3f} "
              f"{r['cycles_frame']:9.3f} {r['png_frame']:7.3f} {r['overhead']:9.1%} {r['overhead_no_png']:8.1%} "
              f"{r['overhead_ours']:6.1%} "
              f"{r['build_s']:8.1f} {r['first_s']:8.1f} {r['peak_mib']:9.0f}", flush=True)
    if "today" in results:
        t = results["today"]
        for c, r in results.items():
            if c != "today":
                print(f"# {c}: time per stereo frame x{r['s_frame'] / t['s_frame']:.3f} of today's "
                      f"(cpu x{r['cpu_frame'] / t['cpu_frame']:.3f})")
    for c, r in results.items():
        cpu = results.get(c.replace("/gpu", ""))
        if "/gpu" in c and cpu is not None:
            print(f"# {c}: wall seconds per stereo frame x{r['s_frame'] / cpu['s_frame']:.3f} of the CPU's "
                  f"({cpu['s_frame'] / r['s_frame']:.1f}x faster), build x{r['build_s'] / cpu['build_s']:.3f}")
    print(f"# load {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
