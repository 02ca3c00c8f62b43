"""Per-frame bookkeeping cost of a long render: recording a frame complete must cost O(1) in
the sequence length.

    .venv/bin/python bench/bench_completion.py [--frames 100000] [--commits 200] [--render-s 0.09]

Builds the plan of a script with ``--frames`` frames (EGO lines), begins its output folder
(manifest written once) and then records ``--commits`` frames complete the way a render does
(``OutputFolder.commit_frame``: check the EXR, strip its wall-clock fields, rename it, append
one line to the completion log, fsync), with small valid EXRs standing in for Cycles'
output. The baseline, measured in the same run, is what the renderer did before: rewrite
the whole manifest (with fsync) after every frame. Printed: ms per frame for both, and the
overhead relative to a render of ``--render-s`` seconds per frame (the issue's figure:
0.09 s). No Blender needed (the EXRs: ``vo_reference.io.exr.render_exr_parts``).
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]

from blender_sesgen.contract.atomic import temp_path
from blender_sesgen.output import OutputFolder
from blender_sesgen.plan import RenderOptions, RenderPlan
from blender_sesgen.ses import parse_string
from vo_reference.io.exr import render_exr_parts, write_exr_parts

CHANNELS = {"rgb": [f"ViewLayer.Combined.{c}" for c in "RGBA"], "depth": "ViewLayer.Depth.Z",
            "object_index": "ViewLayer.Object Index.X", "layout": "multilayer, one part per pass"}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=100_000)
    p.add_argument("--commits", type=int, default=200)
    p.add_argument("--render-s", type=float, default=0.09, help="seconds per rendered frame to relate to")
    a = p.parse_args(argv)
    t0 = time.perf_counter()
    text = "CAMERA resolution 64 48 focal 40 baseline 0.1\nQUAD id 1 vertices 0 0 -1 1 0 -1 1 1 -1 0 1 -1\n"
    text += "EGO 0 0 -0.01 0 0.01 0\n" * (a.frames - 1)
    plan = RenderPlan.from_scene(parse_string(text), RenderOptions(samples=1), scene_text=text)
    manifest = plan.manifest(channels=CHANNELS, render_extra={"exr_layout": CHANNELS["layout"]}, blender_version="-")
    print(f"plan of {plan.scene.frames} frames in {time.perf_counter() - t0:.1f} s")
    tmp = Path(tempfile.mkdtemp(prefix="sesgen-bench-"))
    try:
        rng = np.random.default_rng(0)
        src = tmp / "src.exr"
        write_exr_parts(src, render_exr_parts(rng.random((48, 64, 3), dtype=np.float32),
                                       np.full((48, 64), 2.0, np.float32), np.ones((48, 64), np.int32)))
        required = tuple(CHANNELS["rgb"]) + (CHANNELS["depth"], CHANNELS["object_index"])
        folder = OutputFolder(tmp / "out")
        t0 = time.perf_counter()
        folder.begin(plan, manifest, resume=False, force=False)
        t_begin = time.perf_counter() - t0
        size_mb = (tmp / "out" / "manifest.json").stat().st_size / 1e6

        def stand_ins(k):
            paths = {}
            for v in plan.views:
                paths[v] = temp_path(folder.exr_path(v, k))
                shutil.copyfile(src, paths[v])
            return paths

        t_new = cpu_new = 0.0
        for k in range(a.commits):
            paths = stand_ins(k)
            t0, c0 = time.perf_counter(), time.process_time()
            folder.commit_frame(k, paths, required)
            t_new += time.perf_counter() - t0
            cpu_new += time.process_time() - c0
        t0 = time.perf_counter()
        folder.release()
        t_release = time.perf_counter() - t0
        n_old = max(3, a.commits // 20)                  # the old way is slow: fewer samples
        t_old = 0.0
        for k in range(n_old):
            t0 = time.perf_counter()
            folder.manifest.frames_complete[k] = True
            folder.manifest.write(folder.root)            # the whole manifest, fsync'd, every frame
            t_old += time.perf_counter() - t0
        new_ms, old_ms = 1e3 * t_new / a.commits, 1e3 * t_old / n_old
        print(f"manifest {size_mb:.1f} MB, written once at begin ({t_begin:.2f} s) and once at the end "
              f"({t_release:.2f} s)")
        print(f"per frame: completion log {new_ms:.2f} ms wall, {1e3 * cpu_new / a.commits:.2f} ms CPU "
              f"(a loaded machine inflates wall time; CPU time is the robust figure) "
              f"({100 * new_ms / 1e3 / a.render_s:.2f} % of a "
              f"{a.render_s:g} s render; includes the EXR check and strip) vs rewriting the manifest "
              f"{old_ms:.0f} ms ({100 * old_ms / 1e3 / a.render_s:.0f} %): {old_ms / new_ms:.0f}x")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
