"""Memory over a long render: the resident set of a 1000-frame ``gt`` render must stay flat.

    .venv/bin/python bench/bench_memory.py [--frames 1000] [--scale 0.05] [--quality gt]

Renders the paper room's objects along a 1000-step path (the room's own 40 steps of EGO
motion, played forwards and backwards in turn, so the camera stays in the room) into a
temporary folder through the real render job (``RenderJob.run``) at a tiny size, in a
fresh process, and prints the process's resident set (VmRSS) and peak (VmHWM) after frames
1, 10, 100, ... and the last, and the ratio last / frame 10 (goal: within 5 %).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def long_script(frames: int) -> str:
    """paper_room.ses with its EGO steps repeated forwards then backwards up to ``frames``."""
    text = (REPO / "scenes" / "paper_room.ses").read_text(encoding="utf-8")
    lines = text.splitlines()
    ego = [ln for ln in lines if ln.startswith("EGO ")]
    rest = [ln for ln in lines if not ln.startswith("EGO ")]
    steps, forward = [], True
    while len(steps) < frames - 1:
        for ln in (ego if forward else reversed(ego)):
            if len(steps) == frames - 1:
                break
            v = [float(x) for x in ln.split()[1:]]
            steps.append("EGO " + " ".join(f"{x if forward else -x:.6g}" for x in v))
        forward = not forward
    return "\n".join(rest + steps) + "\n"


def status_kib(field: str) -> int:
    m = re.search(rf"^{field}:\s+(\d+) kB", Path("/proc/self/status").read_text(), re.M)
    return int(m.group(1)) if m else -1


def child(args) -> int:
    from blender_sesgen.job import RenderJob
    from blender_sesgen.plan import RenderOptions
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "long.ses"
        script.write_text(long_script(args.frames))
        job = RenderJob.prepare(script, Path(tmp) / "out", RenderOptions(quality=args.quality,
                                                                         resolution_scale=args.scale))
        job.build()
        marks = {1, 10, args.frames} | {10 ** i for i in range(2, 7) if 10 ** i < args.frames}
        t0 = time.perf_counter()

        def progress(i, n, r, elapsed):
            if i in marks:
                print(json.dumps({"frame": i, "rss_kib": status_kib("VmRSS"), "hwm_kib": status_kib("VmHWM"),
                                  "elapsed_s": time.perf_counter() - t0}), flush=True)
        job.run(progress)
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=1000)
    p.add_argument("--scale", type=float, default=0.05, help="resolution scale (0.05: 32x24)")
    p.add_argument("--quality", default="gt")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.child:
        return child(a)
    cmd = [sys.executable, "-X", "faulthandler", __file__, "--child", "--frames", str(a.frames), "--scale", str(a.scale),
           "--quality", a.quality]
    print(f"# memory bench: paper room objects, {a.frames} frames, quality {a.quality}, scale {a.scale}, "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    proc = subprocess.run(cmd, cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)), capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"render failed ({proc.returncode}): {proc.stderr[-2000:]}")
    rows = [json.loads(ln) for ln in proc.stdout.splitlines() if ln.startswith("{")]
    print(f"{'frame':>7} {'RSS MiB':>9} {'peak MiB':>9} {'elapsed s':>10}")
    for r in rows:
        print(f"{r['frame']:7d} {r['rss_kib'] / 1024:9.1f} {r['hwm_kib'] / 1024:9.1f} {r['elapsed_s']:10.1f}")
    by = {r["frame"]: r for r in rows}
    if 10 in by and a.frames in by:
        for key, label in (("rss_kib", "RSS"), ("hwm_kib", "peak RSS")):
            ratio = by[a.frames][key] / by[10][key]
            print(f"# {label}: frame {a.frames} / frame 10 = {ratio:.3f} ({'within' if abs(ratio - 1) <= 0.05 else 'OUTSIDE'} 5 %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
