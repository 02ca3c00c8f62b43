"""Streaming a large world: peak memory and seconds per frame of ``render --cull`` chunks of a
1 km city drive against a 100 m one (the goal: within 10 %), and without culling for contrast.

    PYTHONPATH=. python bench/bench_culling.py [--routes 100 1000] [--chunk 20] [--chunks 3]
        [--scale 0.5] [--quality gt] [--far 150] [--full]

For each route length the city generator (scenes/generators/city_grid.py, seed 0, no loop
closures, its default traffic; the city grows with the route) writes a script; ``--chunks``
chunks of ``--chunk`` frames spread evenly over the drive are rendered, each by its own
``python -m blender_sesgen render --frames A:B --cull`` process (one Cycles thread), as a
farm's chunks are. Each process's peak resident set (its own ``ru_maxrss``, measured by a
wrapper process) and wall time (parse, culling, build, render, write: everything a chunk
costs) are printed per chunk, then per route the objects built, the mean seconds per frame,
the largest peak RSS, and the ratios of the long route to the short one. ``--full`` also
renders each route's first chunk without culling (the whole world built).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
WRAPPER = ("import resource, subprocess, sys, json, time; t = time.perf_counter(); "
           "p = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
           "print(json.dumps({'rc': p.returncode, 'wall_s': time.perf_counter() - t, "
           "'maxrss_kib': resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, "
           "'out': p.stdout[-4000:], 'err': p.stderr[-2000:]}))")


def render_chunk(script: Path, out: Path, a: int, b: int, args, cull: bool) -> dict:
    cmd = [sys.executable, "-m", "blender_sesgen", "render", str(script), "--out", str(out), "--frames", f"{a}:{b}",
           "--quality", args.quality, "--resolution-scale", str(args.scale), "--threads", "1", "--progress", "off"]
    if cull:
        cmd.append("--cull")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    res = json.loads(subprocess.run([sys.executable, "-c", WRAPPER, *cmd], capture_output=True, text=True,
                                    env=env, check=True).stdout)
    if res["rc"] != 0:
        raise SystemExit(f"render failed ({res['rc']}): {res['err']}")
    built = next((ln.split("culling: ")[1].split(" objects")[0] for ln in res["out"].splitlines()
                  if ln.startswith("culling: ")), "all")
    return {"frames": b - a, "wall_s": res["wall_s"], "s_per_frame": res["wall_s"] / (b - a),
            "peak_rss_mib": res["maxrss_kib"] / 1024, "built": built}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--routes", type=float, nargs="+", default=[100.0, 1000.0], metavar="M")
    p.add_argument("--chunk", type=int, default=20)
    p.add_argument("--chunks", type=int, default=3)
    p.add_argument("--scale", type=float, default=0.5)
    p.add_argument("--quality", default="gt")
    p.add_argument("--far", type=float, default=150.0, help="the camera's far plane (m), where the haze ends")
    p.add_argument("--full", action="store_true", help="also each route's first chunk without culling")
    a = p.parse_args(argv)
    from blender_sesgen.generators import load_file
    gen = load_file(REPO / "scenes" / "generators" / "city_grid.py").function
    print(f"# culling bench: city_grid seed 0, routes {a.routes} m, {a.chunks} chunks of {a.chunk} frames, "
          f"quality {a.quality}, scale {a.scale}, far {a.far:g} m, 1 Cycles thread per render")
    print(f"# load before: {Path('/proc/loadavg').read_text().split()[:3]}")
    summary = {}
    with tempfile.TemporaryDirectory() as tmp:
        for route in a.routes:
            script = Path(tmp) / f"city_{int(route)}.ses"
            script.write_text(gen(0, route_m=route, closures=0, far=a.far))
            n = script.read_text().count("\nPOSE ")
            starts = [int(round((n - a.chunk) * (i + 0.5) / a.chunks)) for i in range(a.chunks)]
            rows = []
            for s in starts:
                t0 = time.perf_counter()
                r = render_chunk(script, Path(tmp) / f"out_{int(route)}_{s}", s, s + a.chunk, a, cull=True)
                rows.append(r)
                print(f"route {route:6.0f} m ({n} frames) chunk {s}:{s + a.chunk} culled: built {r['built']}, "
                      f"{r['s_per_frame']:.2f} s/frame, peak RSS {r['peak_rss_mib']:.0f} MiB "
                      f"({time.perf_counter() - t0:.0f} s)", flush=True)
            entry = {"frames": n, "s_per_frame": sum(r["s_per_frame"] for r in rows) / len(rows),
                     "peak_rss_mib": max(r["peak_rss_mib"] for r in rows), "chunks": rows}
            if a.full:
                r = render_chunk(script, Path(tmp) / f"full_{int(route)}", starts[0], starts[0] + a.chunk, a,
                                 cull=False)
                entry["full"] = r
                print(f"route {route:6.0f} m chunk {starts[0]}:{starts[0] + a.chunk} FULL world: "
                      f"{r['s_per_frame']:.2f} s/frame, peak RSS {r['peak_rss_mib']:.0f} MiB", flush=True)
            summary[route] = entry
    print(f"# load after: {Path('/proc/loadavg').read_text().split()[:3]}")
    short, long_ = summary[min(summary)], summary[max(summary)]
    print(f"\n| route | frames | culled: mean s/frame | culled: peak RSS MiB |" + (" full: s/frame | full: peak RSS MiB |"
                                                                                 if a.full else ""))
    print("|---|---|---|---|" + ("---|---|" if a.full else ""))
    for route, e in summary.items():
        full = f" {e['full']['s_per_frame']:.2f} | {e['full']['peak_rss_mib']:.0f} |" if a.full else ""
        print(f"| {route:.0f} m | {e['frames']} | {e['s_per_frame']:.2f} | {e['peak_rss_mib']:.0f} |{full}")
    print(f"\nculled, {max(summary):.0f} m / {min(summary):.0f} m: s/frame x{long_['s_per_frame'] / short['s_per_frame']:.2f}, "
          f"peak RSS x{long_['peak_rss_mib'] / short['peak_rss_mib']:.2f} (goal: within 10 %)")
    if a.full:
        print(f"full world, {max(summary):.0f} m / {min(summary):.0f} m: s/frame "
              f"x{long_['full']['s_per_frame'] / short['full']['s_per_frame']:.2f}, peak RSS "
              f"x{long_['full']['peak_rss_mib'] / short['full']['peak_rss_mib']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
