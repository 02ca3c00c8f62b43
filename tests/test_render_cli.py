"""The render CLI and output contract: exit codes, no output on bad input, resume after a
kill gives identical files, refusing another scene's folder, the render.py shim."""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from render_support import REPO, cli_in_process, load_manifest, read_exr, render_cmd, render_here, run_render
from markers import needs

pytestmark = [pytest.mark.render, needs("bpy")]
pytest.importorskip("OpenEXR")

SMALL = """\
// a small stereo scene for the CLI tests
CAMERA resolution 96 72 focal 70 baseline 0.1
START position 0 1 3
QUAD id 1 texture 4 vertices -3 0 -3  3 0 -3  3 0 4  -3 0 4
QUAD id 2 texture 3 vertices -3 0 -3  -3 3 -3  3 3 -3  3 0 -3
CUBOID id 3 texture 1 position -0.5 0.4 -0.5 0 25 0 dim 0.8 0.8 0.8
SPHERE id 4 texture 2 position 0.6 0.5 0 dim 0.4
"""


def small_script(tmp_path, steps=2, name="small.ses", extra="") -> Path:
    p = tmp_path / name
    p.write_text(SMALL + extra + "EGO 0.02 0 -0.1 0 1 0\n" * steps)
    return p


def same_exrs(a: Path, b: Path, m: dict) -> None:
    for v in m["views"]:
        for rel in m["files"][v]:
            ea, eb = read_exr(a / rel), read_exr(b / rel)
            assert ea.keys() == eb.keys()
            for ch in ea:
                assert np.array_equal(ea[ch], eb[ch]), f"{rel} {ch} differs"


def test_output_contract(tmp_path):
    out = tmp_path / "out"
    script = small_script(tmp_path, extra="NOISE sigma 2.5 seed 7\n")
    r = run_render(script, "--out", out, "--samples", "1")
    assert r.returncode == 0, r.stderr
    # stderr is a pipe: one plain progress line per frame (each is a third of the work), with ETA
    lines = re.findall(r"^render: (\d)/3 \(\d+%\) [\d.:]+(?: s)?(, ETA [\d.:]+(?: s)?)?  frame \d .*$", r.stderr, re.M)
    assert [n for n, _ in lines] == ["1", "2", "3"] and lines[0][1] and "\r" not in r.stderr, r.stderr
    m = load_manifest(out)
    for key in ("format", "resolution", "K", "baseline", "near", "far", "frames", "views", "depth", "objects",
                "poses", "files", "render", "generator", "scene_sha256", "timestamps", "frames_complete"):
        assert key in m, key
    assert m["format"] == "sesgen-render/1"
    assert m["resolution"] == [96, 72] and m["frames"] == 3 and m["views"] == ["left", "right"]
    assert m["depth"]["kind"] == "planar_z" and m["depth"]["background"] == 1e10
    np.testing.assert_allclose(m["K"], [[70, 0, 47.5], [0, 70, 35.5], [0, 0, 1]])
    assert [o["id"] for o in m["objects"]] == [1, 2, 3, 4]
    # the sphere as the script places it (position 0.6 0.5 0, radius 0.4): its rest pose and object-frame box
    assert m["objects"][3] == {"id": 4, "name": m["objects"][3]["name"], "shape": "sphere", "texture": "voronoi",
                               "material": None, "class": "static", "label_id": 4, "moving": False,
                               "T_world_obj_rest": [[1.0, 0.0, 0.0, 0.6], [0.0, 1.0, 0.0, 0.5], [0.0, 0.0, 1.0, 0.0],
                                                    [0.0, 0.0, 0.0, 1.0]],
                               "box": [[-0.4, -0.4, -0.4], [0.4, 0.4, 0.4]]}
    assert m["frames_complete"] == [True] * 3
    assert m["noise"] == {"sigma": 2.5, "seed": 7}
    assert m["render"]["samples"] == 1 and m["render"]["engine"] == "CYCLES"
    assert (out / "scene.ses").read_text() == script.read_text()
    import hashlib
    assert m["scene_sha256"] == hashlib.sha256(script.read_bytes()).hexdigest()
    for v in m["views"]:
        assert m["files"][v] == [f"exr/{v}/{k:06d}.exr" for k in range(3)]
        exr = read_exr(out / m["files"][v][0])
        assert exr[m["depth"]["channel"]].dtype == np.float32
        assert {1.0, 2.0, 3.0, 4.0} <= set(np.unique(exr[m["segmentation"]["channel"]]))
        for ch in m["channels"]["rgb"]:
            assert ch in exr
    tum = np.loadtxt(out / m["trajectories"]["tum"]["left"])
    np.testing.assert_allclose(tum[:, 0], m["timestamps"])
    np.testing.assert_allclose(tum[:, 1:4], np.array(m["poses"]["left"])[:, :3, 3], atol=1e-8)
    assert not list(out.rglob(".*tmp*")), "no temporary files left"


@pytest.mark.parametrize("bad, pattern", [
    ("CUBOID id 9 position 0 0 0 dim 1 1\n", r"bad\.ses:\d+:\d+: error: .*dim"),
    ("SPHERE id 9 texture missing.png position 0 0 0 dim 1\n", r"bad\.ses:\d+:\d+: error: .*missing\.png"),
])
def test_bad_script_exits_2_and_creates_nothing(tmp_path, bad, pattern):
    script = tmp_path / "bad.ses"
    script.write_text(SMALL + bad)
    out = tmp_path / "out"
    r = cli_in_process("blender_sesgen", "render", script, "--out", out)   # bad options' exit 2: children below
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert re.search(pattern, r.stderr), r.stderr
    assert not out.exists()


def test_bad_options_exit_2(tmp_path):
    script = small_script(tmp_path)
    out = tmp_path / "out"
    r = run_render(script, "--out", out, "--frames", "5:9")
    assert r.returncode == 2 and "--frames" in r.stderr
    r = run_render(tmp_path / "nope.ses", "--out", out)
    assert r.returncode == 2 and "nope.ses" in r.stderr
    assert not out.exists()


def test_refuses_a_folder_with_another_scene(tmp_path):
    out = tmp_path / "out"
    a = small_script(tmp_path, steps=0, name="a.ses")
    render_here(a, out, "--samples", "1")
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*")}
    b = small_script(tmp_path, steps=1, name="b.ses")
    r = run_render(b, "--out", out, "--samples", "1")
    assert r.returncode == 2 and "different scene" in r.stderr
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*")} == before, "folder untouched"
    # a foreign non-empty folder is refused too
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    assert cli_in_process("blender_sesgen", "render", a, "--out", foreign).returncode == 2
    # --force replaces it
    r = cli_in_process("blender_sesgen", "render", b, "--out", out, "--samples", "1", "--quiet", "--force")
    assert r.returncode == 0, r.stderr
    m = load_manifest(out)
    assert m["frames"] == 2 and m["frames_complete"] == [True, True]


def test_resume_after_kill_is_identical(tmp_path):
    script = small_script(tmp_path, steps=7)
    ref, out = tmp_path / "ref", tmp_path / "out"
    args = ["--samples", "2"]   # denoised (the default preset): its pixels too
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen(render_cmd(script, "--out", out, *args, "--quiet"), cwd=REPO, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while time.time() - t0 < 600 and proc.poll() is None:   # wall clock: only a hung render reaches it
        # a frame's line in a completion log: it is complete (a stat a poll; reading the manifest
        # 100 times a second cost this process as much CPU as the render)
        if any(f.stat().st_size for f in out.glob(".sesgen/done-*.jsonl")):
            break
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    m = load_manifest(out)
    done = m["frames_complete"]
    assert any(done)
    if all(done):
        pytest.skip("the render finished before it could be killed (machine too fast for this test)")
    for k, d in enumerate(done):  # consistent: every frame marked complete has its files
        if d:
            assert all((out / m["files"][v][k]).is_file() for v in m["views"])
    r = run_render(script, "--out", out, *args, "--resume")
    assert r.returncode == 0, r.stderr
    assert f"{8 - sum(done)} of 8 frames to render" in r.stdout
    render_here(script, ref, *args)   # the resume above: a child
    m = load_manifest(out)
    assert m["frames_complete"] == [True] * 8
    same_exrs(out, ref, m)
    assert not list(out.rglob(".*tmp*"))


def test_frames_range_and_resume_fill_in(tmp_path):
    script = small_script(tmp_path, steps=3)
    out = tmp_path / "out"
    render_here(script, out, "--samples", "1", "--frames", "1:3")
    assert load_manifest(out)["frames_complete"] == [False, True, True, False]
    r = cli_in_process("blender_sesgen", "render", script, "--out", out, "--samples", "1", "--resume")
    assert r.returncode == 0 and "2 of 4 frames to render" in r.stdout
    assert load_manifest(out)["frames_complete"] == [True] * 4


def test_render_py_shim_matches_the_cli(tmp_path):
    script = small_script(tmp_path, steps=0)
    a, b = tmp_path / "a", tmp_path / "b"
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    r = subprocess.run([sys.executable, str(REPO / "render.py"), "--", str(script), "--out", str(a),
                        "--samples", "2", "--quiet"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    render_here(script, b, "--samples", "2")
    ma, mb = load_manifest(a), load_manifest(b)
    assert ma["poses"] == mb["poses"] and ma["render"] == mb["render"]
    same_exrs(a, b, ma)
    # and bad input through the shim is exit 2 as well
    r = subprocess.run([sys.executable, str(REPO / "render.py"), "--", str(tmp_path / "nope.ses"), "--out",
                        str(tmp_path / "c")], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert r.returncode == 2 and not (tmp_path / "c").exists()


def test_cpu_render_prints_no_gpu_backend_probe_lines_and_keeps_other_output(tmp_path):
    """On a machine without CUDA, Cycles writes "CUEW initialization failed" to the process's
    stdout when the denoiser asks whether OptiX is there; a CPU render never shows it, while
    anything else written during a device probe still comes through."""
    probe = ("import bpy; s = bpy.context.scene; s.render.engine = 'CYCLES'; "
             "s.cycles.denoiser = 'OPENIMAGEDENOISE'")
    raw = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    if "initialization failed" not in raw.stdout + raw.stderr:
        pytest.skip("this machine loads every GPU backend Cycles probes: there is nothing to filter")
    script = small_script(tmp_path, steps=0)
    r = run_render(script, "--out", tmp_path / "out", "--quality", "draft", "--samples", "1")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("sesgen render:") and "done: 1 frames" in r.stdout
    assert "initialization failed" not in r.stdout + r.stderr, (r.stdout, r.stderr)
    keep = ("import os, sys; from blender_sesgen.blender.runtime import probing_devices\n"
            "with probing_devices():\n"
            "    os.write(1, b'CUEW initialization failed: Error opening the library\\n')\n"
            "    os.write(2, b'error: a real one\\n'); os.write(1, b'kept\\n')\n")
    r = subprocess.run([sys.executable, "-c", keep], cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)),
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout == "kept\n" and r.stderr == "error: a real one\n"
