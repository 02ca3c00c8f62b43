"""Where the library scenes' render time goes: the scene build (script to first sample), path
tracing, denoising, writing, paths per second, memory, and what each expensive feature
costs, measured by switching it off in the same run.

    PYTHONPATH=. .venv/bin/python bench/profile_scenes.py [--scenes city_kitti hall office forest paper_room]
        [--quality final] [--samples N] [--scale 0.5] [--frames 2] [--features all|none|NAME ...]
        [--base REV] [--json FILE] [--asset-cache off|warm] [--cprofile FILE] [--bytecode compiled|source]
        [--repeat N]

Each row is one fresh render process (the real job: ``RenderJob.build`` and ``run``, EXRs
written and sealed) rendering frames 0..N-1 of the scene at ``--scale`` times its own size.
CPU seconds are the process's user + system time (robust on a shared machine; wall seconds
beside them); ratios come from rows of the same run.

Build, up to frame 0's first sample (what every render process pays before its first frame;
a farm chunk or a study variant pays it again): ``import`` (bpy), ``parse`` (the script and
the plan), ``assets`` (the procedural assets' numpy generators; the rows switch the disk
cache of asset meshes off, as a machine's first render finds it: bench/bench_asset_cache.py
measures what it saves the others; ``--asset-cache warm``: on, filled by a warm-up row (one per
edited script: the exposure preview is kept per script), as the later renders find it), ``meshes`` (their Blender
meshes), ``materials`` (node graphs), ``scene`` (the rest of the builder: objects, lights,
world, cameras), ``exposure`` (the automatic exposure's preview render, Cycles set-up
included when it pays it), ``metering`` (the sensor auto-exposure's metering pass: a preview of
each frame before the render's last), and the Cycles set-up of the render sessions before frame 0's
first sample, split by Cycles' own status: ``sync`` (Blender objects to Cycles), ``shaders``,
``bvh`` (meshes, BVH), ``images`` (textures, the sky), ``lights`` (the world's importance
map, the light tree), ``kernels``; ``total`` = script start to frame 0's first sample.
``--samples`` below the exposure preview's 8 changes the build, not only the frames: the frames
cannot then share the preview's Cycles session (a persistent session does not render fewer samples
as a fresh one), so a scene without the sensor path pays a second sync and BVH that its own sample
count (8 or more: every library script's) does not (the forest: x0.34-0.38 of a351dd9's cold at 4
samples, x0.31-0.32 at 8; bench/RESULTS.md, session 19); ``--samples 8`` builds as the scenes do.

Per stereo frame (the frames after frame 0, which pays the Cycles set-up; frame 0 when it is
the only one): ``c:setup`` (Cycles' set-up inside the frame's renders before their first
sample: the moved cameras and objects synchronised, their BVHs updated; by Cycles' status, as
the build's stages), ``trace`` (Cycles' sampling, the denoiser included: Cycles denoises inside
its last sample), ``write`` (Blender writing the EXRs after Cycles finished), ``other``
(frame set-up, the sensor images, the display PNGs, the sealing hand-off: the rest of the frame), ``frame``
(all of it); ``meter``: one preview of the sensor auto-exposure's metering pass (after its first;
the build renders one for every frame of the sequence but its last: a frame of a long sequence
costs ``seq`` = ``frame`` + ``meter``, which the ratio against ``--base`` also gives); ``Mpath/s``: camera paths (pixels x samples, both views) per CPU second of
``trace``; ``peak MiB``: the process's peak resident set; ``Cycles MiB``: Cycles' own peak.

Features (``--features``; each measured by switching it off, reported as the CPU it costs
per stereo frame and in the build):
- in the same process, frame N-1 rendered again with the feature off, right after the same
  frame with it on: ``denoiser`` (OpenImageDenoise), ``glass`` (the glass_window library
  material replaced by a plain dark diffuse), ``relief`` (every Bump node removed: the
  library materials' relief; the renderer uses no displacement, relief is bump only);
- in a process of its own, the script edited: ``trees`` (the trees, conifers, bushes,
  hedges, grass tufts, ferns and plants with their leaves), ``lights`` (the script's
  point, spot and area lamps; the sky's sun stays), ``bevels`` (CUBOID ``bevel``), ``fog``
  (FOG), ``sensor`` (the camera model: SENSOR, TIMING, LENS and AUTOEXPOSURE, i.e. the
  sensor path's shutter and lens renders and the sensor images). A feature the scene does
  not have is listed as absent.

``--cprofile FILE`` writes a cProfile of each scene's build (``job.build``: the scene, the
exposure preview, the metering pass; CPU clock, so Cycles' threads count inside the render
calls) in the working tree's baseline row to ``FILE`` with the scene's name before its suffix.

``--base REV`` renders the baseline row of every scene again with revision REV's code
(checked out into a temporary git worktree), in the same run: today's figures beside the
working tree's. ``--repeat N``: every baseline row N times, the base's and this tree's in turns
(the load drifts between rows: a base row moved +-25 % between runs); the table shows the
median row of each (by CPU to first sample) and the ratio of each pair.

``--bytecode compiled`` (the default): both trees' ``blender_sesgen`` compiled to ``.pyc``
(``compileall``) before the rows, as a pip install leaves the package and as Python leaves it
after its first import wherever ``PYTHONDONTWRITEBYTECODE`` is unset; ``source``: their
``__pycache__`` folders removed, every row compiling our modules (~0.12 CPU s) as a machine
with that variable set does (this one; the rows before session 10). bench_startup.py caches
bytecode by default too.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

T0 = time.perf_counter()
REPO = Path(__file__).resolve().parents[1]
SCENES = ("city_kitti", "hall", "office", "forest", "paper_room")
IN_PROCESS = ("denoiser", "glass", "relief")
EDITED = ("trees", "lights", "bevels", "fog", "sensor")
SENSOR_STATEMENTS = ("SENSOR", "TIMING", "LENS", "AUTOEXPOSURE")
VEGETATION = ("tree", "conifer", "bush", "hedge", "grass_tuft", "fern", "plant")
BUILD_STAGES = ("import", "parse", "assets", "meshes", "materials", "scene", "exposure", "metering")
CYCLES_STAGES = ("sync", "shaders", "bvh", "images", "lights", "kernels", "other")
# Cycles' status text -> the set-up stage it belongs to (first match; the rest: other)
STATUS_STAGES = (("Synchronizing", "sync"), ("Updating Shaders", "shaders"), ("Updating Meshes", "bvh"),
                 ("Building BVH", "bvh"), ("Copying BVH", "bvh"), ("Computing attributes", "bvh"),
                 ("Copying Attributes", "bvh"), ("Computing normals", "bvh"), ("Copying Mesh", "bvh"),
                 ("Applying Static", "bvh"), ("Updating Geometry BVH", "bvh"), ("Updating Scene BVH", "bvh"),
                 ("Loading render kernels", "kernels"), ("Loading denoising kernels", "kernels"),
                 ("Updating Images", "images"), ("Loading", "images"),   # images: the physical sky's table too
                 ("Updating Lights", "lights"), ("Importance map", "lights"), ("Computing tree", "lights"))
MEM_RE = re.compile(r"Mem:\s*([\d.]+)([KMG])")


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


# --- the script edits (features switched off in a process of their own) ----------------------

def edit_script(text: str, feature: str) -> tuple[str, int]:
    """The script without ``feature``; (text, how many statements or tags it removed)."""
    lines, n = [], 0
    for line in text.splitlines(keepends=True):
        words = line.split()
        key = words[0].upper() if words else ""
        if feature == "trees" and key == "ASSET" and len(words) > 1 and words[1] in VEGETATION:
            n += 1
            continue
        if feature == "lights" and key == "LIGHT" and len(words) > 1 and words[1] in ("point", "spot", "area"):
            n += 1
            continue
        if feature == "fog" and key == "FOG":
            n += 1
            continue
        if feature == "sensor" and key in SENSOR_STATEMENTS:
            n += 1
            continue
        if feature == "bevels" and key == "CUBOID" and " bevel " in f" {line} ":
            line, k = re.subn(r"\s+bevel\s+\S+", "", line)
            n += k
        lines.append(line)
    return "".join(lines), n


# --- the child: one render process -------------------------------------------------------------

class Stages:
    """CPU seconds of the build's stages: wraps the builder's functions where they exist (a
    revision without one reports nothing for it); ``spans[stage]``: the Cycles status log's
    extent during each call (``log``)."""

    def __init__(self, log):
        self.cpu = dict.fromkeys(BUILD_STAGES, 0.0)
        self.spans: dict[str, list] = {}
        self.log = log

    def wrap(self, owner, name: str, stage: str) -> None:
        f = getattr(owner, name, None)
        if f is None:
            return
        stages = self

        def wrapped(*a, **k):
            c, m = cpu_s(), stages.log.mark()
            try:
                return f(*a, **k)
            finally:
                stages.cpu[stage] += cpu_s() - c
                stages.spans.setdefault(stage, []).append((m, stages.log.mark()))
        setattr(owner, name, wrapped)


class CyclesLog:
    """Cycles' status lines with the process's CPU and wall clock at each (render_stats)."""

    def __init__(self):
        self.events: list[tuple[str, float, float]] = []
        self.mem_mib = 0.0

    def __call__(self, text, *args):
        text = str(text)
        m = MEM_RE.search(text)
        if m:
            self.mem_mib = max(self.mem_mib, float(m.group(1)) * {"K": 1 / 1024, "M": 1.0, "G": 1024.0}[m.group(2)])
        fields = [f.strip() for f in text.split("|")]
        fields = [f for f in fields if f and not f.startswith(("Remaining:", "Mem:", "Fra:", "Peak:"))]
        status = fields[0] if fields else ""
        if not self.events or self.events[-1][0] != status:
            self.events.append((status, cpu_s(), time.perf_counter()))

    def mark(self) -> int:
        return len(self.events)

    def first(self, prefix: str, start: int = 0):
        return next((e for e in self.events[start:] if e[0].startswith(prefix)), None)

    def setup(self, start: int, stop: int) -> dict:
        """CPU seconds of each Cycles set-up stage over events[start:stop] (each status lasts
        until the next one)."""
        out = dict.fromkeys(CYCLES_STAGES, 0.0)
        ev = self.events[start:stop]
        for (status, c, _), (_, c_next, _) in zip(ev, ev[1:]):
            if status.startswith(("Sample", "Finished", "Time:")):
                continue
            stage = next((s for prefix, s in STATUS_STAGES if status.startswith(prefix)), "other")
            out[stage] += c_next - c
        return out

    def renders(self, start: int, stop: int) -> list[dict]:
        """Per render over events[start:stop]: sampling (first 'Sample' to 'Finished'; Cycles
        denoises inside its last sample) and writing ('Finished' to the 'Time:' line, which
        Blender prints once the files are saved), CPU seconds."""
        out, cur = [], {}
        for status, c, _ in self.events[start:stop]:
            if status.startswith("Sample") and "sample" not in cur:
                cur["sample"] = c
            elif status.startswith("Finished"):
                cur["finished"] = c
            elif status.startswith("Time:") and "finished" in cur:
                out.append({"trace": cur["finished"] - cur.get("sample", cur["finished"]),
                            "write": c - cur["finished"]})
                cur = {}
        return out


def child(a) -> int:
    import bpy  # noqa: F401
    c_import = cpu_s()
    import importlib
    import blender_sesgen
    # a revision before the subpackages (tools/relayout.py) has its modules at the old paths
    old = (Path(blender_sesgen.__file__).parent / "job.py").is_file()
    assets = importlib.import_module("blender_sesgen.assets" if old else "blender_sesgen.scene.assets")
    # (the old layout predates the disk cache of asset meshes; the check goes by file, since an
    # editable install may resolve a module the revision lacks to another source tree)
    has_cache = (Path(blender_sesgen.__file__).parent / "scene" / "assets" / "cache.py").is_file()
    asset_cache = importlib.import_module("blender_sesgen.scene.assets.cache") if has_cache else None
    from blender_sesgen.blender import assets as bassets, builder, exposure, materials
    RenderJob = importlib.import_module("blender_sesgen.job" if old else "blender_sesgen.render.job").RenderJob
    plan_mod = importlib.import_module("blender_sesgen.plan" if old else "blender_sesgen.render.plan")
    RenderOptions, RenderPlan = plan_mod.RenderOptions, plan_mod.RenderPlan
    log = CyclesLog()
    bpy.app.handlers.render_stats.append(log)
    stages = Stages(log)
    stages.cpu["import"] = c_import
    # the asset meshes (read from the disk cache where the code has one: switched off here)
    stages.wrap(*((asset_cache, "generate") if asset_cache else (assets, "generate")), "assets")
    stages.wrap(bassets, "mesh_from_triangles", "meshes")
    stages.wrap(materials.MaterialFactory, "_make", "materials")
    stages.wrap(builder, "build_scene", "scene")
    stages.wrap(exposure, "measure_exposure", "exposure")
    stages.wrap(exposure, "meter_frames", "metering")
    # the metering pass's previews one by one: a sequence pays one per frame it renders
    render_mod = importlib.import_module("blender_sesgen.blender.render")
    meter_renders: list[float] = []
    metering = getattr(exposure, "meter_frames", None)
    if metering is not None:
        def metered(*x, **y):
            plain = render_mod.render_view

            def timed(*x2, **y2):
                c0 = cpu_s()
                try:
                    return plain(*x2, **y2)
                finally:
                    meter_renders.append(cpu_s() - c0)
            render_mod.render_view = timed
            try:
                return metering(*x, **y)
            finally:
                render_mod.render_view = plain
        exposure.meter_frames = metered

    c = cpu_s()
    edit = (lambda text: edit_script(text, a.feature)[0]) if a.feature in EDITED else None
    options = RenderOptions(quality=a.quality, samples=a.samples, resolution_scale=a.scale, frames=f"0:{a.frames}")
    plan = RenderPlan.from_file(a.scene, options, edit=edit) if edit else RenderPlan.from_file(a.scene, options)
    stages.cpu["parse"] = cpu_s() - c
    tmp = Path(tempfile.mkdtemp(prefix="sesgen-profile-"))
    job = RenderJob.of(plan, tmp / "out")
    prof = None
    if a.cprofile:   # our Python's share of the build (CPU clock: Cycles' threads count in the C calls)
        import cProfile
        prof = cProfile.Profile(time.process_time)
        prof.enable()
    job.build()
    if prof is not None:
        prof.disable()
        prof.dump_stats(a.cprofile)
    # the builder's own work without the stages inside it
    stages.cpu["scene"] -= stages.cpu["assets"] + stages.cpu["meshes"] + stages.cpu["materials"]
    frames = []

    def progress(i, n, r, elapsed):
        frames.append({"cpu": cpu_s(), "wall": time.perf_counter(), "mark": log.mark()})
    start = {"cpu": cpu_s(), "wall": time.perf_counter(), "mark": log.mark()}
    job.run(progress)
    # frame 0's first sample: the first 'Sample' status after the job started rendering
    first = log.first("Sample", start["mark"])
    setup = log.setup(0, log.events.index(first))
    # the previews' (and the builder's: the sky's bake) own Cycles set-up is in the set-up stages, not twice
    for stage in ("scene", "exposure", "metering"):
        for m0, m1 in stages.spans.get(stage, []):
            stages.cpu[stage] -= sum(log.setup(m0, m1).values())
    s = plan.settings
    views = len(plan.views)
    rows = []
    for k in range(len(frames)):
        prev = frames[k - 1] if k else start
        renders = log.renders(prev["mark"], frames[k]["mark"])
        in_frame = log.setup(prev["mark"], frames[k]["mark"])   # (``setup``: the build's, kept for the table)
        rows.append({"frame": frames[k]["cpu"] - prev["cpu"], "wall": frames[k]["wall"] - prev["wall"],
                     "trace": sum(r["trace"] for r in renders), "write": sum(r["write"] for r in renders),
                     "setup": sum(in_frame.values()), "setup_bvh": in_frame["bvh"], "setup_sync": in_frame["sync"]})
    steady = rows[1:] or rows
    per = {key: sum(r[key] for r in steady) / len(steady)
           for key in ("frame", "wall", "trace", "write", "setup", "setup_bvh", "setup_sync")}
    per["other"] = per["frame"] - per["trace"] - per["write"] - per["setup"]
    # a metering preview after the pass's first (which synchronises the scene and builds its BVH:
    # the build's); a render with AUTOEXPOSURE pays one per frame of its sequence
    per["meter"] = sum(meter_renders[1:]) / len(meter_renders[1:]) if meter_renders[1:] else 0.0
    paths = s.width * s.height * views * s.preset.samples
    out = {"scene": Path(a.scene).stem, "feature": a.feature, "size": [s.width, s.height],
           "samples": s.preset.samples, "denoise": s.preset.denoise, "build": stages.cpu, "cycles_setup": setup,
           "to_first_sample": {"cpu": first[1], "wall": first[2] - T0}, "per_frame": per,
           "mpaths_per_s": paths / max(per["trace"], 1e-9) / 1e6, "cycles_mib": log.mem_mib,
           "removed": edit_script(plan.scene_text, a.feature)[1] if a.feature in EDITED else None}
    if a.in_process:
        out["in_process"] = in_process_features(job, plan, log, a.in_process, tmp)
    out["peak_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    shutil.rmtree(tmp, ignore_errors=True)
    print("PROFILE " + json.dumps(out), flush=True)
    return 0


def in_process_features(job, plan, log, names, tmp: Path) -> dict:
    """Frame N-1 again with each feature on, then off (the pair back to back): CPU seconds of
    the two stereo frames and what the feature costs (on - off); None where the scene lacks it."""
    import bpy
    session = job.session
    scene = session.built.scene
    k = plan.frames[-1]
    paths = {v: tmp / f"{v}.exr" for v in plan.views}

    def render() -> float:
        c = cpu_s()
        session.render_frame(k, paths)
        return cpu_s() - c

    out = {}
    for name in names:
        undo = switch_off(bpy, scene, name)
        if undo is None:
            out[name] = None
            continue
        undo()
        on = render()
        undo2 = switch_off(bpy, scene, name)
        off = render()
        undo2()
        out[name] = {"on": on, "off": off, "cost": on - off}
    return out


def switch_off(bpy, scene, name):
    """Switch ``name`` off in the built scene; returns the function that switches it back on
    (None when the scene does not have it)."""
    if name == "denoiser":
        c = scene.cycles
        if not c.use_denoising:
            return None
        c.use_denoising = False
        return lambda: setattr(c, "use_denoising", True)
    trees = [m.node_tree for m in bpy.data.materials if m.node_tree is not None]
    if name == "relief":
        removed = []
        for nt in trees:
            for link in list(nt.links):
                if link.from_node.bl_idname == "ShaderNodeBump":
                    removed.append((nt, link.from_socket, link.to_socket))
                    nt.links.remove(link)
        if not removed:
            return None
        return lambda: [nt.links.new(a, b) for nt, a, b in removed]
    if name == "glass":
        swapped = []
        for m in bpy.data.materials:
            if "glass_window" not in m.name or m.node_tree is None:
                continue
            nt = m.node_tree
            out = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
            link = next((ln for ln in nt.links if ln.to_socket == out.inputs["Surface"]), None)
            if link is None:
                continue
            plain = nt.nodes.new("ShaderNodeBsdfDiffuse")
            plain.inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)
            swapped.append((nt, link.from_socket, out.inputs["Surface"], plain))
            nt.links.new(plain.outputs[0], out.inputs["Surface"])
        if not swapped:
            return None

        def undo():
            for nt, src, dst, plain in swapped:
                nt.links.new(src, dst)
                nt.nodes.remove(plain)
        return undo
    raise ValueError(name)


# --- the parent ----------------------------------------------------------------------------------

def run_child(a, scene: Path, feature: str, code_root: Path, in_process=()) -> dict:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--scene", str(scene), "--feature", feature,
           "--quality", a.quality, "--scale", str(a.scale), "--frames", str(a.frames),
           *(["--samples", str(a.samples)] if a.samples else []),
           *(["--in-process", *in_process] if in_process else []),
           *(["--cprofile", str(Path(a.cprofile).resolve().with_suffix(f".{scene.stem}.prof"))]
             if a.cprofile and code_root == REPO and feature == "baseline" else [])]
    # every row builds its assets the way a machine's first render process does (--asset-cache
    # warm: as every later one, from a cache the warm-up rows filled)
    env = dict(os.environ, PYTHONPATH=str(code_root), SESGEN_ASSET_CACHE=a.cache_folder or "off")
    proc = subprocess.run(cmd, cwd=code_root, env=env, capture_output=True, text=True)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("PROFILE ")), None)
    if proc.returncode != 0 or line is None:
        raise SystemExit(f"{scene.name} ({feature}) failed in {code_root}:\n{proc.stderr[-3000:]}")
    return json.loads(line[len("PROFILE "):])


def median_row(rows: list[dict]) -> dict:
    """The row whose CPU to first sample is the median (the lower one of an even count): one
    real process's row, its stages adding up, not a mix of several."""
    ranked = sorted(rows, key=lambda r: r["to_first_sample"]["cpu"])
    return ranked[(len(ranked) - 1) // 2]


def bytecode(package: Path, compiled: bool) -> None:
    """``package``'s modules compiled to .pyc beside them (``__pycache__``), or those removed."""
    if compiled:
        subprocess.run([sys.executable, "-m", "compileall", "-q", str(package)], check=True, capture_output=True)
    else:
        for folder in package.rglob("__pycache__"):
            shutil.rmtree(folder, ignore_errors=True)


def print_build(rows: list[tuple[str, dict]]) -> None:
    print("\n# build (CPU s): script start to frame 0's first sample")
    head = "".join(f"{s:>10s}" for s in BUILD_STAGES + tuple("c:" + s for s in CYCLES_STAGES) + ("rest",))
    print(f"{'scene':24s}{head}{'total':>9s}{'wall':>8s}")
    for label, r in rows:
        cells = [r["build"][s] for s in BUILD_STAGES] + [r["cycles_setup"][s] for s in CYCLES_STAGES]
        cells.append(r["to_first_sample"]["cpu"] - sum(cells))   # the job's own work, Python's start
        print(f"{label:24s}" + "".join(f"{v:10.2f}" for v in cells)
              + f"{r['to_first_sample']['cpu']:9.2f}{r['to_first_sample']['wall']:8.1f}")


def print_frames(rows: list[tuple[str, dict]]) -> None:
    print("\n# per stereo frame (CPU s; frames after the first)")
    print(f"{'scene':24s}{'size':>11s}{'samples':>8s}{'c:setup':>9s}{'trace':>9s}{'write':>8s}{'other':>8s}"
          f"{'frame':>9s}{'meter':>8s}{'seq':>8s}{'wall':>8s}{'Mpath/s':>9s}{'peak MiB':>9s}{'Cycles MiB':>11s}")
    for label, r in rows:
        p = r["per_frame"]
        size = "x".join(map(str, r["size"]))
        setup = p.get("setup", 0.0)   # (rows of a --json file written before the column)
        print(f"{label:24s}{size:>11s}{r['samples']:8d}{setup:9.2f}{p['trace']:9.2f}{p['write']:8.2f}"
              f"{p['other']:8.2f}{p['frame']:9.2f}{p.get('meter', 0.0):8.2f}{p['frame'] + p.get('meter', 0.0):8.2f}"
              f"{p['wall']:8.1f}{r['mpaths_per_s']:9.3f}{r['peak_mib']:9.0f}"
              f"{r['cycles_mib']:11.0f}")
    if any(r["per_frame"].get("meter", 0.0) > 0 for _, r in rows):
        print("# meter: a metering preview of the sensor auto-exposure's pass (after its first), which the build "
              "renders for every frame but the sequence's last; seq = frame + meter: a frame of a sequence")
    if any(r["per_frame"].get("setup", 0.0) > 0.05 for _, r in rows):
        print("# c:setup: Cycles' own set-up inside the frame's renders before their first sample (the moved "
              "cameras and objects synchronised, BVHs updated), " + ", ".join(
                  f"{label}: sync {r['per_frame']['setup_sync']:.2f} bvh {r['per_frame']['setup_bvh']:.2f}"
                  for label, r in rows if r["per_frame"].get("setup", 0.0) > 0.05))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="+", default=list(SCENES))
    p.add_argument("--quality", default="final")
    p.add_argument("--samples", type=int, help="override the preset's samples (ratios: fewer samples suffice; "
                   "below 8 the build pays a second Cycles session where the scene has no sensor path)")
    p.add_argument("--scale", type=float, default=0.5, help="resolution scale (1.0 = the script's size)")
    p.add_argument("--frames", type=int, default=2)
    p.add_argument("--features", nargs="+", default=["all"], help="all, none, or names: " +
                   ", ".join(IN_PROCESS + EDITED))
    p.add_argument("--base", help="also render the baseline rows with this git revision's code")
    p.add_argument("--json", help="write every row as JSON")
    p.add_argument("--asset-cache", choices=("off", "warm"), default="off",
                   help="warm: the rows share a fresh asset cache (meshes, the sky's table, the glowing "
                        "panes' maps, the exposure preview), filled by a warm-up row (one per edited script)")
    p.add_argument("--cprofile", help="FILE: cProfile (CPU clock) of each scene's build in this tree's baseline "
                   "row, written to FILE with the scene's name before its suffix (FILE.office.prof)")
    p.add_argument("--bytecode", choices=("compiled", "source"), default="compiled",
                   help="compiled: both trees' modules compiled to .pyc first (an installed package); source: none")
    p.add_argument("--repeat", type=int, default=1,
                   help="N: each baseline row N times (the base's and this tree's in turns); the rows shown are the "
                        "median ones by CPU to first sample, each pair's build ratio listed")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--scene", help=argparse.SUPPRESS)
    p.add_argument("--feature", default="baseline", help=argparse.SUPPRESS)
    p.add_argument("--in-process", nargs="*", default=[], help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    a.cache_folder = None
    if a.child:
        return child(a)
    features = list(IN_PROCESS + EDITED) if a.features == ["all"] else [] if a.features == ["none"] else a.features
    unknown = set(features) - set(IN_PROCESS + EDITED)
    if unknown:
        raise SystemExit(f"unknown feature(s): {', '.join(sorted(unknown))}")
    print(f"# profile: {', '.join(a.scenes)}; quality {a.quality}{f' at {a.samples} samples' if a.samples else ''}, "
          f"scale {a.scale}, {a.frames} frames; {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}", flush=True)
    # A kill (SIGTERM) unwinds like Ctrl-C, so the `finally` below removes the base's worktree: a
    # killed run must not leave it registered in the user's repository. One during `git worktree
    # add` waits for it to end: killed, git leaves the worktree locked "initializing" while its own
    # child (the checkout) writes on into the folder being removed.
    terms = []

    def on_term(*_):
        if terms is not None:
            terms.append(1)
        else:
            sys.exit(128 + signal.SIGTERM)
    signal.signal(signal.SIGTERM, on_term)
    worktree = None
    results, pairs = [], {}
    if a.asset_cache == "warm":
        a.cache_folder = tempfile.mkdtemp(prefix="sesgen-profile-cache-")
    print(f"# asset cache: {a.asset_cache}; bytecode: {a.bytecode}", flush=True)
    try:
        if a.base:
            worktree = Path(tempfile.mkdtemp(prefix="sesgen-profile-base-")) / "src"
            subprocess.run(["git", "worktree", "add", "--detach", str(worktree), a.base], cwd=REPO, check=True,
                           capture_output=True)
        kill_came, terms = bool(terms), None
        if kill_came:
            sys.exit(128 + signal.SIGTERM)
        for root in (r for r in (worktree, REPO) if r is not None):
            bytecode(root / "blender_sesgen", a.bytecode == "compiled")
        for name in a.scenes:
            scene = Path(name if name.endswith(".ses") else f"scenes/{name}.ses")
            label = scene.stem
            roots = [r for r in (worktree, REPO) if r is not None]
            for root in roots if a.cache_folder else []:
                run_child(a, scene, "baseline", root)    # the warm-up row: fills the cache
            inproc = [f for f in features if f in IN_PROCESS]
            olds, news = [], []
            for rep in range(a.repeat):   # the two trees' rows in turns: both see the same load drift
                if worktree is not None:
                    r = run_child(a, scene, "baseline", worktree)
                    olds.append(r)
                    print(f"{label} @{a.base}: to first sample {r['to_first_sample']['cpu']:.1f} CPU s, "
                          f"{r['per_frame']['frame']:.1f} CPU s per stereo frame", flush=True)
                r = run_child(a, scene, "baseline", REPO, inproc if rep == 0 else ())
                news.append(r)
                print(f"{label}: to first sample {r['to_first_sample']['cpu']:.1f} CPU s, "
                      f"{r['per_frame']['frame']:.1f} CPU s per stereo frame (load {os.getloadavg()[0]:.1f})",
                      flush=True)
            if olds:
                results.append((f"{label} @{a.base}", median_row(olds)))
            base = median_row(news)
            if "in_process" in news[0]:
                base["in_process"] = news[0]["in_process"]
            if olds and a.repeat > 1:
                pairs[label] = [n["to_first_sample"]["cpu"] / o["to_first_sample"]["cpu"] for o, n in zip(olds, news)]
            results.append((label, base))
            for f in features:
                if f in EDITED:
                    text = (REPO / scene).read_text()
                    if edit_script(text, f)[1] == 0:
                        base.setdefault("features", {})[f] = None
                        continue
                    if a.cache_folder:   # its warm-up row: the edited script's own exposure preview
                        run_child(a, scene, f, REPO)
                    r = run_child(a, scene, f, REPO)
                    results.append((f"{label} -{f}", r))
                    base.setdefault("features", {})[f] = {
                        "frame": base["per_frame"]["frame"] - r["per_frame"]["frame"],
                        "build": base["to_first_sample"]["cpu"] - r["to_first_sample"]["cpu"],
                        "removed": r["removed"]}
                    print(f"{label} -{f}: {r['per_frame']['frame']:.1f} CPU s per stereo frame", flush=True)
    finally:
        if worktree is not None:
            for git in (["unlock"], ["remove", "--force", "--force"]):
                subprocess.run(["git", "worktree", *git, str(worktree)], cwd=REPO, capture_output=True)
            shutil.rmtree(worktree.parent, ignore_errors=True)
            subprocess.run(["git", "worktree", "prune"], cwd=REPO, capture_output=True)
        if a.cache_folder:
            shutil.rmtree(a.cache_folder, ignore_errors=True)
    print_build(results)
    print_frames(results)
    if features:
        print("\n# what each feature costs (CPU s it adds; per stereo frame, and to the build)")
        print(f"{'scene':14s}" + "".join(f"{f:>18s}" for f in features))
        for label, r in results:
            if r["feature"] != "baseline" or "@" in label:
                continue
            cells = []
            for f in features:
                v = (r.get("in_process") or {}).get(f) if f in IN_PROCESS else (r.get("features") or {}).get(f)
                if v is None:
                    cells.append("absent")
                elif f in IN_PROCESS:
                    cells.append(f"{v['cost']:+.2f} ({v['cost'] / v['on']:.0%})")
                else:
                    cells.append(f"{v['frame']:+.2f} / {v['build']:+.1f}b")
            print(f"{label:14s}" + "".join(f"{c:>18s}" for c in cells))
        print("# in-process features: frame N-1 with the feature on, then off (share of that frame);"
              " edited ones: per stereo frame / build (b), against the baseline row")
    def seq(r):   # a frame of a sequence: the frame and its metering preview
        return r["per_frame"]["frame"] + r["per_frame"].get("meter", 0.0)
    if worktree is not None:
        print(f"\n# against {a.base} (same run): CPU to first sample and per stereo frame")
        for name in a.scenes:
            label = Path(name).stem
            old = next(r for lb, r in results if lb == f"{label} @{a.base}")
            new = next(r for lb, r in results if lb == label)
            print(f"{label:14s} build x{new['to_first_sample']['cpu'] / old['to_first_sample']['cpu']:.3f}  "
                  f"frame x{new['per_frame']['frame'] / old['per_frame']['frame']:.3f}  "
                  f"seq x{seq(new) / seq(old):.3f} ({seq(old) / seq(new):.2f}x the base's frames/s)"
                  + (f"  (build, each pair: {' '.join(f'x{x:.3f}' for x in pairs[label])})" if label in pairs else ""))
    print(f"# load {os.getloadavg()[0]:.1f} at the end; {time.perf_counter() - T0:.0f} s in all")
    if a.json:
        Path(a.json).write_text(json.dumps([{"label": lb, **r} for lb, r in results], indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
