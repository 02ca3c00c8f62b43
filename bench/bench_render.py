"""Render speed: seconds per stereo frame at 640x480 for 1, 16 and 64 samples, and the
overhead of the CLI (process wall time / the render time Cycles itself reports), and the
render process's peak memory (resident set size).

    .venv/bin/python bench/bench_render.py [--scene scenes/paper_room.ses] [--frames 2]
                                           [--samples 1 16 64] [--scale 1.0]

Each setting runs the real CLI in a fresh process (``python -m blender_sesgen render``) on
the first ``--frames`` frames; "s/frame" is the mean wall time of a stereo frame (both
views, EXR writing included) as the CLI's progress lines report it; "overhead" compares
the whole process (Python start, import bpy, parsing, building, writing) with the sum of
Cycles' own render times. Goal: overhead < 10 % for real renders. A noisy shared machine
changes absolute numbers; the ratio is the robust figure.
"""
from __future__ import annotations

import argparse
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
LINE = re.compile(r"^frame\s+\d+\s+\[\d+/\d+\]\s+([\d.]+) s, cycles ([\d.]+) s", re.M)


def run(scene: Path, samples: int, frames: int, scale: float, out: Path) -> dict:
    cmd = [sys.executable, "-m", "blender_sesgen", "render", str(scene), "--out", str(out), "--samples", str(samples),
           "--no-denoise", "--frames", f"0:{frames}", "--resolution-scale", str(scale), "--force"]
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as so, tempfile.TemporaryFile("w+") as se:
        proc = subprocess.Popen(cmd, cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)), stdout=so, stderr=se, text=True)
        _, status, usage = os.wait4(proc.pid, 0)  # this child's own peak memory
        proc.returncode = os.waitstatus_to_exitcode(status)
        so.seek(0), se.seek(0)
        stdout, stderr = so.read(), se.read()
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"render failed ({proc.returncode}): {stderr}")
    rows = [(float(a), float(b)) for a, b in LINE.findall(stdout)]
    frame_wall = sum(a for a, _ in rows)
    cycles = sum(b for _, b in rows)
    return {"samples": samples, "s_per_frame": frame_wall / len(rows), "cycles_s": cycles,
            "process_s": wall, "overhead": wall / cycles - 1.0, "frame_overhead": frame_wall / cycles - 1.0,
            "peak_rss_mib": usage.ru_maxrss / 1024.0}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default=str(REPO / "scenes" / "paper_room.ses"))
    p.add_argument("--frames", type=int, default=2)
    p.add_argument("--samples", type=int, nargs="+", default=[1, 16, 64])
    p.add_argument("--scale", type=float, default=1.0, help="resolution scale (1.0 = the script's 640x480)")
    a = p.parse_args()
    print(f"# render benchmark: {Path(a.scene).name}, {a.frames} stereo frames per setting, scale {a.scale}, "
          f"{os.cpu_count()} CPUs, {platform.processor() or platform.machine()}")
    print(f"{'samples':>8} {'s/stereo frame':>15} {'process s':>10} {'cycles s':>9} {'overhead':>9} {'per-frame ovh':>14} {'peak RSS MiB':>13}")
    with tempfile.TemporaryDirectory() as tmp:
        for s in a.samples:
            r = run(Path(a.scene), s, a.frames, a.scale, Path(tmp) / f"s{s}")
            print(f"{s:8d} {r['s_per_frame']:15.2f} {r['process_s']:10.1f} {r['cycles_s']:9.1f} "
                  f"{r['overhead']:9.1%} {r['frame_overhead']:14.1%} {r['peak_rss_mib']:13.0f}", flush=True)
    print("# overhead = process wall time / Cycles render time - 1 (Python start, import bpy, build, EXR writing);")
    print("# per-frame ovh = the same within the frame loop only (what grows with the sequence length).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
