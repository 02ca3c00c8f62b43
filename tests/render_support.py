"""Helpers of the render tests: the oracle scene, EXR reading (OpenEXR), CLI runs."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import raycast

REPO = Path(__file__).resolve().parents[1]


def _planar_quad(centre, rotation_deg, half_w, half_h):
    R = raycast.euler_xyz_deg(*rotation_deg)
    c = np.asarray(centre, dtype=float)
    corners = [(-half_w, -half_h), (half_w, -half_h), (half_w, half_h), (-half_w, half_h)]
    return np.array([c + R @ np.array([a, b, 0.0]) for a, b in corners])


# The oracle scene: floor, back wall, a tilted quad, a rotated and an axis-aligned cuboid,
# a sphere, a rotated camera with an off-centre principal point, a rotating EGO path.
TILTED = _planar_quad((-1.3, 0.9, -2.0), (10.0, 35.0, -8.0), 0.45, 0.6)
ORACLE_PRIMS = [
    raycast.QuadP(1, np.array([[-3, 0, -4], [3, 0, -4], [3, 0, 4], [-3, 0, 4]], dtype=float)),
    raycast.QuadP(2, np.array([[-3, 0, -4], [-3, 3, -4], [3, 3, -4], [3, 0, -4]], dtype=float)),
    raycast.QuadP(3, TILTED),
    raycast.BoxP(4, np.array([0.6, 0.55, -1.2]), (25.0, 40.0, -15.0), np.array([0.7, 0.5, 0.9])),
    raycast.BoxP(5, np.array([-0.45, 0.25, -0.3]), (0.0, 0.0, 0.0), np.array([0.5, 0.5, 0.5])),
    raycast.SphereP(6, np.array([0.9, 1.35, -2.2]), 0.4),
]
ORACLE_START = ((0.2, 1.3, 3.0), (-10.0, 6.0, 3.0))
ORACLE_EGO = [(0.05, -0.02, -0.15, 2.0, -3.0, 1.5), (-0.04, 0.03, -0.2, -1.5, 4.0, -2.0)]


def oracle_script(width=160, height=120, focal=110.0, principal=(81.3, 57.6), baseline=0.15,
                  materials: dict | None = None, extra_lines=()) -> str:
    """The oracle scene; ``materials`` {id: library material} replaces those objects'
    textures (same geometry), ``extra_lines`` are appended (WORLD, LOOK, ...)."""
    v = " ".join(f"{x:.10g}" for x in TILTED.reshape(-1))
    (sx, sy, sz), (rx, ry, rz) = ORACLE_START
    lines = [
        "// oracle scene of tests/test_render_oracle.py",
        f"CAMERA resolution {width} {height} focal {focal} principal {principal[0]} {principal[1]} "
        f"baseline {baseline} near 0.05 far 100",
        f"START position {sx} {sy} {sz} {rx} {ry} {rz}",
        "QUAD id 1 texture 4 vertices -3 0 -4  3 0 -4  3 0 4  -3 0 4",
        "QUAD id 2 texture 3 vertices -3 0 -4  -3 3 -4  3 3 -4  3 0 -4",
        f"QUAD id 3 texture 1 vertices {v}",
        "CUBOID id 4 texture 2 position 0.6 0.55 -1.2 25 40 -15 dim 0.7 0.5 0.9",
        "CUBOID id 5 texture 7 colour 0.8 0.6 0.5 position -0.45 0.25 -0.3 dim 0.5 0.5 0.5",
        "SPHERE id 6 texture 9 position 0.9 1.35 -2.2 dim 0.4",
    ]
    lines += [f"EGO {' '.join(str(x) for x in e)}" for e in ORACLE_EGO]
    for obj_id, name in (materials or {}).items():
        i = next(i for i, ln in enumerate(lines) if f" id {obj_id} " in ln)
        lines[i] = re.sub(r"texture \d+ ", f"material {name} ", lines[i])
    lines += list(extra_lines)
    return "\n".join(lines) + "\n"


def read_exr(path) -> dict[str, np.ndarray]:
    """All channels of a (multi-part) EXR: {name: (H, W) array}."""
    import OpenEXR
    out = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for part in f.parts:
            for name, ch in part.channels.items():
                out[name] = np.array(ch.pixels)
    return out


def depth_and_ids(exr: dict, manifest: dict):
    depth = exr[manifest["depth"]["channel"]].astype(np.float64)
    ids = np.rint(exr[manifest["segmentation"]["channel"]]).astype(np.int64)
    return depth, ids


def load_manifest(out: Path) -> dict:
    """The manifest as a reader sees it: completion logs of a running render merged in."""
    from blender_sesgen.contract.manifest import Manifest
    return Manifest.read(out).to_json()


def render_cmd(*args) -> list[str]:
    return [sys.executable, "-m", "blender_sesgen", "render", *map(str, args)]


def run_loaded(cmd, timeout: float, poll_s: float = 1.0, **popen) -> subprocess.CompletedProcess:
    """``subprocess.run(cmd, capture_output=True, text=True)`` whose ``timeout`` counts seconds of a
    core's fair share, not of the wall clock: each second waited counts 1 / (load per core) while
    the machine runs more processes than it has cores (a render that takes 60 s alone takes ~25
    times that at load 50 on 2 cores), so a loaded machine is not a hung child; a hung child still
    times out, later on a loaded machine (subprocess.TimeoutExpired, the child killed)."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **popen)
    share_s, last = 0.0, time.monotonic()
    while True:
        try:
            out, err = proc.communicate(timeout=poll_s)
            return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
        except subprocess.TimeoutExpired:
            now = time.monotonic()
            share_s += (now - last) / max(1.0, os.getloadavg()[0] / (os.cpu_count() or 1))
            last = now
            if share_s > timeout:
                proc.kill()
                out, err = proc.communicate()
                raise subprocess.TimeoutExpired(proc.args, timeout, out, err) from None


def run_render(*args, timeout=300) -> subprocess.CompletedProcess:
    """``sesgen render ARGS`` in a child process; ``timeout``: see ``run_loaded``."""
    return run_loaded(render_cmd(*args), timeout, cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)))


def rendered(script, out, *args, timeout=300, here=False) -> Path:
    """``sesgen render SCRIPT --out OUT ARGS --quiet`` that must succeed (a failed render fails the
    test with its stderr); returns ``out``. ``here``: in this process (``render_here``)."""
    if here:
        return render_here(script, out, *args)
    r = run_render(script, "--out", out, *args, "--quiet", timeout=timeout)
    assert r.returncode == 0, r.stderr
    return Path(out)


def render_here(script, out, *args) -> Path:
    """``sesgen render SCRIPT --out OUT ARGS`` in this process: the command's own options
    (its parser and ``render_options``) through the Python API (``blender_sesgen.api.render``),
    the same folder without a Python and a Blender started for it (~1 CPU s of a small render).
    For tests whose subject is what a render holds; the command's process (exit codes, output,
    signals, locks, resume after a kill) is tested through children (test_render_cli.py,
    test_render_reliability.py, test_render_integrity.py, ...)."""
    import argparse
    from blender_sesgen.api import render
    from blender_sesgen.commands.render import add_arguments, render_options
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    a = parser.parse_args([str(script), "--out", str(out), *map(str, args)])
    render(a.scene, a.out, render_options(a), resume=a.resume, force=a.force)
    return Path(out)


def render_text(folder, text: str, *args, timeout=300, here=False) -> Path:
    """``text`` written to FOLDER/s.ses and rendered into FOLDER/out (``rendered``); returns the out folder."""
    (Path(folder) / "s.ses").write_text(text)
    return rendered(Path(folder) / "s.ses", Path(folder) / "out", *args, timeout=timeout, here=here)


def render_paper_room(folder, frames: int, scale: float, extra: str = "", samples: int = 4, here=False) -> Path:
    """The first ``frames`` of scenes/paper_room.ses (``extra`` lines added) at ``scale``, rendered
    into FOLDER/out denoised: under the physically based default lighting (no ambient glow)
    2 noisy samples leave the dim room as noise, and a VO finds its corners on lit things only."""
    script = Path(folder) / "paper_room.ses"
    script.write_text((REPO / "scenes" / "paper_room.ses").read_text() + extra)
    return rendered(script, Path(folder) / "out", "--frames", f"0:{frames}", "--samples", str(samples), "--denoise",
                    "--resolution-scale", str(scale), here=here)


def processes_mentioning(marker: str) -> list[str]:
    """Command lines of live processes whose command line or environment names ``marker``."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit() or int(d.name) == os.getpid():
            continue
        try:
            cmd = (d / "cmdline").read_bytes()
            env = (d / "environ").read_bytes()
            state = (d / "stat").read_text().rsplit(")", 1)[-1].split()[0]
        except OSError:
            continue
        if state != "Z" and (marker.encode() in cmd or marker.encode() in env):
            found.append(cmd.replace(b"\0", b" ").decode(errors="replace")[:160])
    return found


def cli_in_process(package: str, *args) -> subprocess.CompletedProcess:
    """``python -m PACKAGE ARGS`` (blender_sesgen or vo_reference) run in this process: its
    ``commands.main.main`` with stdout and stderr captured; what a child would exit with and
    print, without a Python started (and the package imported) for each check."""
    import contextlib
    import importlib
    import io
    main = importlib.import_module(f"{package}.commands.main").main
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in args])
    return subprocess.CompletedProcess([package, *map(str, args)], rc, out.getvalue(), err.getvalue())
