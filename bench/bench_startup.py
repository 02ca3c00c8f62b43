"""The render process's fixed start-up: what a ``sesgen render`` of a tiny scene costs before and
around its one frame (every test render, farm chunk and study variant pays it).

    PYTHONPATH=. .venv/bin/python bench/bench_startup.py [--scene scenes/paper_room.ses]
        [--scale 0.1] [--samples 1] [--quality final] [--repeat 3] [--base REV] [--profile N]
        [--asset-cache off|warm] [--no-bytecode]

Rows, each a fresh process, run ``--repeat`` times interleaved (median and fastest CPU s):
- ``python``: the interpreter alone (``python -c pass``);
- ``import bpy``: Blender's module and its factory start-up (the floor of any render process);
- ``render``: ``python -m blender_sesgen render SCENE --frames 0:1 --samples N
  --resolution-scale S --quality Q --quiet`` into a fresh folder (the paper room at 64x48:
  nearly all of it is start-up: plan, scene build, exposure preview, Cycles set-up, one
  frame of 64x48 pixels, sealing, manifest); ``render @REV``: the same with revision REV's
  code (a temporary git worktree), in the same run.

The children's asset cache (``SESGEN_ASSET_CACHE``) is off: each builds everything, as a
machine's first render; ``--asset-cache warm``: a fresh cache shared by the children, filled by
the warm-up renders, as every later render of a machine finds it (the sky's baked table).

Python's bytecode is cached (``__pycache__``, as an installed package has it; a warm-up render of
each side writes it first); ``--no-bytecode`` keeps ``PYTHONDONTWRITEBYTECODE`` if set, and
every process then compiles each module it imports (~0.25 CPU s here).

CPU seconds are the process tree's user + system time (``os.wait4``: the process and the
children it reaped), robust on a shared machine; wall seconds beside them. ``--profile N``
prints the N functions with the most cumulative CPU time of one render of the working tree
(cProfile, CPU clock) after the table.
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


BYTECODE = {"keep": True}   # False: the children compile every module from source (PYTHONDONTWRITEBYTECODE)
ASSET_CACHE = {"value": "off"}   # SESGEN_ASSET_CACHE of the children (--asset-cache warm: a folder)


def run(cmd: list[str], code_root: Path) -> tuple[float, float]:
    """(CPU s, wall s) of ``cmd`` run with ``code_root``'s package; exits on failure."""
    env = dict(os.environ, PYTHONPATH=str(code_root), SESGEN_ASSET_CACHE=ASSET_CACHE["value"])
    if BYTECODE["keep"]:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=code_root, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, ru = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"failed ({proc.returncode}) in {code_root}: {' '.join(cmd)}\n{err[-3000:]}")
    return ru.ru_utime + ru.ru_stime, wall


def render_cmd(a, out: Path, prefix=()) -> list[str]:
    return [sys.executable, *prefix, "-m", "blender_sesgen", "render", str(a.scene), "--out", str(out),
            "--frames", "0:1", "--samples", str(a.samples), "--resolution-scale", str(a.scale),
            "--quality", a.quality, "--quiet"]


def profile(a, tmp: Path, top: int) -> None:
    """One render of the working tree under cProfile (CPU clock); the ``top`` functions by
    cumulative time."""
    stats = tmp / "render.prof"
    code = ("import cProfile, sys, time\n"
            "from blender_sesgen.commands.main import main\n"
            "p = cProfile.Profile(time.process_time)\n"
            "p.runcall(main, sys.argv[1:])\n"
            f"p.dump_stats({str(stats)!r})\n")
    cmd = render_cmd(a, tmp / "prof-out")
    run([sys.executable, "-c", code, *cmd[3:]], REPO)
    import pstats
    print(f"\n# cProfile of one render (CPU clock), top {top} by cumulative time")
    pstats.Stats(str(stats)).sort_stats("cumulative").print_stats(top)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", type=Path, default=Path("scenes/paper_room.ses"))
    p.add_argument("--scale", type=float, default=0.1, help="resolution scale (0.1: the paper room at 64x48)")
    p.add_argument("--samples", type=int, default=1)
    p.add_argument("--quality", default="final")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--base", help="also render with this git revision's code (same run)")
    p.add_argument("--profile", type=int, default=0, metavar="N", help="print a cProfile's top N functions")
    p.add_argument("--no-bytecode", action="store_true", help="keep PYTHONDONTWRITEBYTECODE (compile every import)")
    p.add_argument("--asset-cache", choices=("off", "warm"), default="off",
                   help="warm: the children share a fresh asset cache, filled by the warm-up renders")
    a = p.parse_args(argv)
    BYTECODE["keep"] = not a.no_bytecode
    print(f"# startup: {a.scene} at scale {a.scale}, {a.samples} sample(s), frame 0, quality {a.quality}; "
          f"{os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}", flush=True)
    tmp = Path(tempfile.mkdtemp(prefix="sesgen-startup-"))
    if a.asset_cache == "warm":
        ASSET_CACHE["value"] = str(tmp / "asset-cache")
    print(f"# asset cache: {a.asset_cache}", flush=True)
    base = None
    if a.base:
        base = tmp / "base-src"
        subprocess.run(["git", "worktree", "add", "--detach", str(base), a.base], cwd=REPO, check=True,
                       capture_output=True)
    rows: dict[str, list] = {}
    try:
        for root in ([base] if base is not None else []) + [REPO]:   # warm-up: the bytecode caches
            run(render_cmd(a, tmp / "warm"), root)
            shutil.rmtree(tmp / "warm", ignore_errors=True)
        n = 0
        for _ in range(a.repeat):
            todo = [("python", [sys.executable, "-c", "pass"], REPO),
                    ("import bpy", [sys.executable, "-c", "import bpy"], REPO)]
            if base is not None:
                todo.append((f"render @{a.base}", None, base))
            todo.append(("render", None, REPO))
            for label, cmd, root in todo:
                n += 1
                out = tmp / f"out{n}"
                rows.setdefault(label, []).append(run(cmd or render_cmd(a, out), root))
                shutil.rmtree(out, ignore_errors=True)
                if cmd is None:
                    print(f"  {label}: {rows[label][-1][0]:.2f} CPU s (load {os.getloadavg()[0]:.1f})", flush=True)
        print(f"\n{'row':24s}{'cpu s':>9s}{'min':>8s}{'wall s':>9s}")
        med = {}
        for label, runs in rows.items():
            med[label] = statistics.median(c for c, _ in runs)
            print(f"{label:24s}{med[label]:9.2f}{min(c for c, _ in runs):8.2f}"
                  f"{statistics.median(w for _, w in runs):9.2f}")
        floor = med["import bpy"]
        print(f"# render above import bpy: {med['render'] - floor:.2f} CPU s", end="")
        if base is not None:
            old = med[f"render @{a.base}"]
            print(f" (@{a.base}: {old - floor:.2f}); render x{med['render'] / old:.3f}, "
                  f"above import bpy x{(med['render'] - floor) / (old - floor):.3f} against {a.base} (same run)")
        else:
            print()
        if a.profile:
            profile(a, tmp, a.profile)
    finally:
        if base is not None:
            subprocess.run(["git", "worktree", "remove", "--force", str(base)], cwd=REPO, capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"# load {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
