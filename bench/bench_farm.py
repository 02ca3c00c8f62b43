"""A farm on one machine against rendering the same scenes one after the other, measured in
one run: wall time of ``render`` for each scene in turn (Cycles' automatic threads: every
CPU) and of one ``farm`` over all of them (a local Ray started and stopped by the farm,
counted in its time; one task per CPU), and whether both wrote the same bytes.

    .venv/bin/python bench/bench_farm.py [--count 2] [--steps 7] [--scale 0.15] [--samples 8]
                                         [--chunk 4] [--threaded] [--repeat N] [--keep DIR]

The scenes are ``generate street --count N --seed 1 -o steps=S`` (S+1 frames each).
``--threaded`` adds a third run: the farm with all CPUs per task (one multi-threaded render
at a time), the alternative to one single-threaded render per CPU. ``--repeat N`` runs the
configurations N times in turn (A B C A B C ...) and keeps each one's fastest time. The
machine should be otherwise idle (the load average is printed before and after); the ratio
is the figure.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def sh(*args, quiet=True) -> float:
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "blender_sesgen", *map(str, args)], cwd=REPO,
                       env=dict(os.environ, PYTHONPATH=str(REPO)), capture_output=quiet, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{args[0]} failed ({r.returncode}): {r.stderr if quiet else ''}")
    return time.perf_counter() - t0


def exr_bytes(out: Path) -> dict:
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.glob("*/exr/*/*.exr"))}


def load() -> str:
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=2, help="scenes (default 2)")
    p.add_argument("--steps", type=int, default=7, help="EGO steps per scene (frames - 1; default 7)")
    p.add_argument("--scale", type=float, default=0.15, help="resolution scale of the 640x480 street (default 0.15)")
    p.add_argument("--samples", type=int, default=8)
    p.add_argument("--chunk", type=int, default=4, help="the farm's frames per task (default 4)")
    p.add_argument("--threaded", action="store_true", help="also: the farm with all CPUs per task")
    p.add_argument("--repeat", type=int, default=1, metavar="N", help="runs of each configuration, in turn; "
                   "the fastest counts (default 1)")
    p.add_argument("--keep", metavar="DIR", help="keep the scripts and renders here")
    a = p.parse_args()
    try:
        import ray  # noqa: F401
    except ImportError:
        print("# bench_farm: skipped, Ray is not installed (pip install 'blender-sesgen[farm]')")
        return 0
    work = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="bench-farm-"))
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    render_opts = ["--samples", a.samples, "--no-denoise", "--resolution-scale", a.scale]
    print(f"# farm benchmark: {a.count} street scenes x {a.steps + 1} stereo frames, scale {a.scale}, {a.samples} "
          f"samples, {cpus} CPUs; load average before: {load()}")
    try:
        sh("generate", "street", "--count", a.count, "--seed", 1, "--out", work / "scripts", "-o", f"steps={a.steps}",
           "-q")
        scripts = sorted((work / "scripts").glob("*.ses"))

        def in_turn(out):
            return sum(sh("render", s, "--out", out / s.stem, *render_opts, "--quiet") for s in scripts)

        configs = [("render, one scene after the other (all threads)", "sequential", in_turn),
                   ("farm, local Ray, 1 CPU per task", "farm",
                    lambda out: sh("farm", work / "scripts", "--out", out, "--chunk", a.chunk, *render_opts, "-q"))]
        if a.threaded:
            configs.append((f"farm, local Ray, {cpus} CPUs per task", "farm_threaded",
                            lambda out: sh("farm", work / "scripts", "--out", out, "--chunk", a.chunk,
                                           "--cpus-per-task", cpus, *render_opts, "-q")))
        best = {}
        for rep in range(a.repeat):
            for name, folder, fn in configs:
                out = work / f"{folder}-{rep}"
                t = fn(out)
                best[name] = min(best.get(name, t), t)
                if rep or folder != "sequential":
                    if exr_bytes(out) != exr_bytes(work / "sequential-0"):
                        print(f"# {name} (run {rep + 1}): EXRs differ from the sequential renders")
                        return 1
                    shutil.rmtree(out)
        seq = best[configs[0][0]]
        rows = [(name, best[name]) for name, _, _ in configs]
        print(f"{'':52s} {'wall s':>8s} {'/ in turn':>10s}")
        for name, t in rows:
            print(f"{name:52s} {t:8.1f} {t / seq:10.2f}")
        print(f"# every farm's EXRs byte-identical to the sequential renders; best of {a.repeat} run(s) each; "
              f"load average after: {load()}")
        return 0
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
