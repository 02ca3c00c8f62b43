"""Nothing lost, nothing silently wrong on the render path (real renders, real processes):
the folder lock, verified writes on a full disk, kill -9 and Ctrl-C at any point, byte-identical
re-renders, `verify`, and the limits Blender would otherwise apply silently."""
from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from render_support import REPO, cli_in_process, rendered, run_render
from markers import needs

pytestmark = [pytest.mark.render, needs("bpy")]

# not denoised: what these tests check (locks, kills, resumes, verify, limits) does not depend on
# it, and the denoiser costs as much as the rest of each of these tiny frames (the denoised
# pixels' reproducibility across kill and resume: test_render_cli.py, resume after kill)
SCRIPT = """\
CAMERA resolution 96 72 focal 60 baseline 0.1
RENDER denoise off
START position 0 1 3
QUAD id 1 texture 3 vertices -3 0 -3  3 0 -3  3 3 -3  -3 3 -3
QUAD id 2 texture 8 vertices -3 0 3  3 0 3  3 0 -3  -3 0 -3
SPHERE id 3 texture 9 position 0.5 0.6 0 dim 0.4
""" + "EGO 0 0 -0.05 0 0.5 0\n" * 11


def script(tmp_path, text=SCRIPT, name="s.ses") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def start_render(script_path, out, *args) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "blender_sesgen", "render", str(script_path), "--out", str(out), "--quiet", *args]
    return subprocess.Popen(cmd, cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def exr_bytes(out: Path) -> dict[str, bytes]:
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.glob("exr/*/*.exr"))}


def frames_logged(out: Path) -> int:
    return sum(len(p.read_text().splitlines()) for p in (out / ".sesgen").glob("done-*.jsonl"))


def wait_for(cond, timeout=600.0):   # wall clock: only a hung render reaches it
    t0 = time.time()
    while not cond():
        if time.time() - t0 > timeout:
            raise TimeoutError
        time.sleep(0.05)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """One uninterrupted render: what every interrupted-and-resumed folder must equal."""
    tmp = tmp_path_factory.mktemp("ref")
    s = script(tmp)
    out = tmp / "out"
    rendered(s, out, "--samples", "2", here=True)   # the same bytes as a child's (the next test)
    return s.read_text(), out


def test_the_same_seed_gives_byte_identical_files(reference, tmp_path):
    text, ref = reference
    out = tmp_path / "again"
    assert run_render(script(tmp_path, text), "--out", out, "--samples", "2", "--quiet").returncode == 0
    assert exr_bytes(out) == exr_bytes(ref)
    m1, m2 = (json.loads((d / "manifest.json").read_text()) for d in (out, ref))
    for m in (m1, m2):   # the script's path (and so the seal, which covers it) names the folder
        m.pop("scene_source"), m.pop("seal")
    per_frame = 2 * (2 if "display" in m1 else 1)   # both views' EXRs (and display PNGs)
    frame_sums = [rel for rel in m1["checksums"] if rel.startswith(("exr/", "rgb/"))]   # besides poses/
    assert m1 == m2 and len(frame_sums) == per_frame * m1["frames"]


def stopped_holding_its_lock(p: subprocess.Popen, out: Path) -> None:
    """``p`` (a render into ``out``) stopped (SIGSTOP) once it holds its lock and not while it
    holds the folder's mutex (the others would wait on it): busy for as long as a test needs,
    however fast the machine renders; SIGCONT lets it go on."""
    import fcntl
    wait_for(lambda: any((out / ".sesgen").glob("lock-*.json")) if (out / ".sesgen").is_dir() else False)
    while True:
        p.send_signal(signal.SIGSTOP)
        with open(out / ".sesgen" / "mutex", "a+") as f:
            try:
                fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                fcntl.flock(f.fileno(), fcntl.LOCK_UN)
                return
            except BlockingIOError:
                p.send_signal(signal.SIGCONT)
        time.sleep(0.01)


def test_a_second_render_into_a_busy_folder_is_refused(reference, tmp_path):
    text, _ = reference
    s = script(tmp_path, text)
    out = tmp_path / "busy"
    first = start_render(s, out, "--samples", "2")
    try:
        stopped_holding_its_lock(first, out)        # busy while the others try
        try:
            second = cli_in_process("blender_sesgen", "render", s, "--out", out, "--samples", "2", "--seed", "8",
                                    "--quiet")
            assert second.returncode == 2, second.stderr
            assert f"being rendered by pid {first.pid}" in second.stderr and "Traceback" not in second.stderr
            resume = cli_in_process("blender_sesgen", "render", s, "--out", out, "--samples", "2", "--resume",
                                    "--quiet")   # same plan, same frames
            assert resume.returncode == 2 and "being rendered" in resume.stderr
        finally:
            first.send_signal(signal.SIGCONT)
    finally:
        assert first.wait(600) == 0, first.stderr.read()
    m = json.loads((out / "manifest.json").read_text())
    assert m["render"]["seed"] == 0 and all(m["frames_complete"])
    assert not list((out / ".sesgen").glob("lock-*")) and not list((out / ".sesgen").glob("done-*"))


def test_disjoint_chunks_of_one_plan_render_concurrently_and_equal_one_render(reference, tmp_path):
    text, ref = reference
    s = script(tmp_path, text)
    out = tmp_path / "chunks"
    procs = [start_render(s, out, "--samples", "2", "--frames", f) for f in ("0:6", "6:")]
    for p in procs:
        assert p.wait(600) == 0, p.stderr.read()
    assert exr_bytes(out) == exr_bytes(ref)
    m, mr = (json.loads((d / "manifest.json").read_text()) for d in (out, ref))
    assert m["frames_complete"] == mr["frames_complete"] and m["checksums"] == mr["checksums"]


def test_a_stale_lock_of_a_dead_process_is_taken_over(reference, tmp_path):
    text, ref = reference
    s = script(tmp_path, text)
    out = tmp_path / "stale"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    (out / ".sesgen").mkdir(parents=True)
    lock = out / ".sesgen" / f"lock-x-{dead.stdout.strip()}.json"
    import socket
    lock.write_text(json.dumps({"host": socket.gethostname(), "pid": int(dead.stdout), "frames": [0, 11],
                                "started": 0, "scene_sha256": "?", "settings": "?"}))
    rendered(s, out, "--samples", "2", here=True)
    assert not lock.exists() and exr_bytes(out) == exr_bytes(ref)


def test_kill_9_at_random_points_then_resume_gives_the_uninterrupted_files(reference, tmp_path):
    text, ref = reference
    s = script(tmp_path, text)
    rng = random.Random(19)
    for trial in range(4):
        out = tmp_path / f"kill{trial}"
        p = start_render(s, out, "--samples", "2")
        # a random point of the render's progress, not of the wall clock (a fast machine would
        # finish before a late kill, a slow one not reach the writes): trial 0 as it starts
        # writing (its lock taken), the others after a random number of frames, a random
        # fraction of a frame later
        logged = rng.randrange(0, 11) if trial else None
        wait_for(lambda: p.poll() is not None or (
            (out / ".sesgen").is_dir() and (any((out / ".sesgen").glob("lock-*.json")) if logged is None
                                            else frames_logged(out) >= logged)), timeout=600)
        time.sleep(rng.uniform(0.0, 0.3) if trial else 0.0)
        p.send_signal(signal.SIGKILL)
        p.wait()
        rendered(s, out, "--samples", "2", "--resume", here=True)
        assert exr_bytes(out) == exr_bytes(ref), f"trial {trial}"
        assert not [f for f in out.rglob(".*tmp-*")], "temporary files left behind"


def test_ctrl_c_stops_cleanly_with_130_and_the_folder_resumes(reference, tmp_path):
    text, ref = reference
    s = script(tmp_path, text)
    out = tmp_path / "sigint"
    p = start_render(s, out, "--samples", "2")
    wait_for(lambda: (out / ".sesgen").is_dir() and frames_logged(out) >= 2)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 130, err
    assert "interrupted" in err and "--resume" in err and "Traceback" not in err
    m = json.loads((out / "manifest.json").read_text())
    assert 2 <= sum(m["frames_complete"]) < m["frames"]           # stopped early, progress kept
    assert not list((out / ".sesgen").glob("lock-*"))
    rendered(s, out, "--samples", "2", "--resume", here=True)
    assert exr_bytes(out) == exr_bytes(ref)


def _mount_tmpfs(path: Path, size: str) -> bool:
    path.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)], capture_output=True)
    return r.returncode == 0


def test_a_full_disk_is_an_error_and_keeps_the_previous_files(reference, tmp_path):
    text, ref = reference
    disk = tmp_path / "disk"
    ref_bytes = sum(f.stat().st_size for f in ref.rglob("*") if f.is_file())
    if not _mount_tmpfs(disk, f"{(2 * ref_bytes + 2**20) // 4096 * 4096}"):   # the render, twice, plus room
        pytest.skip("cannot mount a tmpfs here (needs root / CAP_SYS_ADMIN)")
    try:
        s = script(tmp_path, text)
        out = disk / "out"
        shutil.copytree(ref, out)                                   # a good render in place
        before = exr_bytes(out)
        filler = disk / "filler"
        free = shutil.disk_usage(disk).free
        with open(filler, "wb") as f:                               # leave a few kB
            f.write(b"\0" * max(free - 20_000, 0))
        r = run_render(s, "--out", out, "--samples", "2", "--quiet")   # re-render everything
        assert r.returncode == 1, (r.returncode, r.stderr)
        assert "Traceback" not in r.stderr and ("not written completely" in r.stderr or "No space" in r.stderr)
        assert exr_bytes(out) == before                             # nothing good was replaced
        filler.unlink()
        rendered(s, out, "--samples", "2", "--resume", here=True)
        assert exr_bytes(out) == exr_bytes(ref)
        assert cli_in_process("blender_sesgen", "verify", out, "--quiet").returncode == 0
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def test_verify_names_damaged_frames_and_resume_renders_them_again(reference, tmp_path):
    text, ref = reference
    s = script(tmp_path, text)
    out = tmp_path / "damaged"
    shutil.copytree(ref, out)
    (out / "exr/left/000003.exr").write_bytes((out / "exr/left/000003.exr").read_bytes()[:3000])   # truncated
    with open(out / "exr/right/000007.exr", "ab") as f:                                            # changed
        f.write(b"?")
    (out / "exr/left/000009.exr").unlink()                                                         # missing
    cmd = [sys.executable, "-m", "blender_sesgen", "verify", str(out)]
    r = subprocess.run(cmd, cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)), capture_output=True, text=True)
    assert r.returncode == 1
    assert "frame 3:" in r.stdout and "truncated" in r.stdout
    assert "frame 7:" in r.stdout and "SHA-256" in r.stdout
    assert "frame 9:" in r.stdout and "missing" in r.stdout
    m = json.loads((out / "manifest.json").read_text())
    assert [k for k, d in enumerate(m["frames_complete"]) if not d] == [3, 7, 9]
    assert f"3 of the sequence's {m['frames']} frames not rendered yet" in r.stdout, r.stdout
    rendered(s, out, "--samples", "2", "--resume", here=True)
    assert exr_bytes(out) == exr_bytes(ref)
    r = cli_in_process("blender_sesgen", *cmd[3:])
    assert r.returncode == 0 and f"all {m['frames']} frames of the sequence are rendered" in r.stdout, r.stdout


def test_a_resume_that_began_after_verify_marked_frames_bad_renders_them(reference, tmp_path):
    """``verify`` records a damaged frame as not rendered while a ``--resume`` render of the
    folder is starting (prepared and building its scene: no lock yet). The render begins after
    that and renders the frame: the old code chose its frames from the manifest it read when it
    was prepared, rendered none, said done and left frame 7 damaged and not rendered."""
    import argparse
    from blender_sesgen.commands.render import add_arguments, render_options
    from blender_sesgen.render.job import RenderJob
    text, ref = reference
    s = script(tmp_path, text)
    out = tmp_path / "damaged"
    shutil.copytree(ref, out)
    with open(out / "exr/right/000007.exr", "ab") as f:
        f.write(b"?")
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    a = parser.parse_args([str(s), "--out", str(out), "--samples", "2", "--resume"])
    job = RenderJob.prepare(a.scene, a.out, render_options(a), resume=True)
    job.build()
    assert cli_in_process("blender_sesgen", "verify", out, "--quick", "--quiet").returncode == 1
    assert [r.frame for r in job.run()] == [7]
    assert exr_bytes(out) == exr_bytes(ref) and all(json.loads((out / "manifest.json").read_text())["frames_complete"])


def test_a_chunk_ending_after_another_rewrote_a_frame_records_that_frames_new_checksum(reference, tmp_path):
    """Chunk Y begins in a complete folder, carrying the checksums it found; chunk X then renders
    frame 0 again (a frame whose file was lost; here other bytes, as another device's render
    gives: frame 1's EXR stands for them), ends and records the new SHA-256; Y ends after it.
    The manifest must hold what X wrote for frame 0 (the old code let every checksum Y carried
    win over the newer one on disk: frame 0 then failed verify, its file being right)."""
    import argparse
    import hashlib
    import socket
    from blender_sesgen.commands.render import add_arguments, render_options
    from blender_sesgen.contract.atomic import temp_path
    from blender_sesgen.render.job import RenderJob
    from blender_sesgen.render.locks import _safe
    text, ref = reference
    s = script(tmp_path, text)
    out = tmp_path / "rewritten"
    shutil.copytree(ref, out)

    def chunk(frames, *more):
        parser = argparse.ArgumentParser()
        add_arguments(parser)
        a = parser.parse_args([str(s), "--out", str(out), "--samples", "2", "--frames", frames, *more])
        return RenderJob.prepare(a.scene, a.out, render_options(a), resume="--resume" in more)
    y = chunk("6:12", "--resume")
    y.begin()
    x = chunk("0:1")
    ended = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                               text=True, check=True).stdout)
    x.folder.locks.writer = f"{_safe(socket.gethostname())}-{ended}"
    x.begin()
    rel = "exr/left/000000.exr"
    tmp = temp_path(out / rel)
    tmp.write_bytes((out / "exr/left/000001.exr").read_bytes())
    new = hashlib.sha256(tmp.read_bytes()).hexdigest()
    x.folder.commit_sealed(0, {"left": tmp}, {rel: new})
    x.folder.release()
    y.folder.release()
    assert json.loads((out / "manifest.json").read_text())["checksums"][rel] == new
    r = cli_in_process("blender_sesgen", "verify", out, "--quick", "--dry-run")
    assert r.returncode == 0, r.stdout


# --- limits Blender would apply silently -----------------------------------------------------

def test_a_focal_below_blenders_lens_clamp_renders_with_the_scripts_K(tmp_path):
    """focal 20 px on 96 px is a 7.5 mm... lens on 36 mm; focal 1.5 px would need 0.56 mm (< Blender's
    1 mm minimum): the sensor is widened instead. Depth at pixel centres of a fronto-parallel
    wall at z = 2 is then z / cos-free planar 2.0 everywhere it is hit, and the wall's edges land
    where the script's K projects them."""
    from synthetic_render import plane_depth
    W, H, f = 96, 72, 1.5
    s = script(tmp_path, f"CAMERA resolution {W} {H} focal {f}\nSTART position 0 0 0\n"
                         "QUAD id 1 vertices -1 -1 -2  1 -1 -2  1 1 -2  -1 1 -2\n")
    out = tmp_path / "wide"
    rendered(s, out, "--samples", "1", here=True)
    from vo_reference.io.render import RenderSequence
    seq = RenderSequence(out)
    assert seq.K[0, 0] == f
    z = seq.depth(0)
    T = np.diag([1.0, -1.0, -1.0, 1.0])                   # START: looking along -Z, Y up
    z_true = plane_depth(seq.K, T, np.array([0, 0, 1.0]), -2.0, W, H)
    # the quad covers |x|, |y| <= 1 at depth 2: pixel centres with |u - cx| < f * 0.5 see it
    u, v = np.meshgrid(np.arange(W) - seq.K[0, 2], np.arange(H) - seq.K[1, 2])
    inside = (np.abs(u) < f * 0.5 - 0.05) & (np.abs(v) < f * 0.5 - 0.05)
    outside = (np.abs(u) > f * 0.5 + 0.05) | (np.abs(v) > f * 0.5 + 0.05)
    assert inside.any() and outside.any()
    np.testing.assert_allclose(z[inside], z_true[inside], rtol=1e-5)
    assert np.all(np.isinf(z[outside]))


@pytest.mark.parametrize("case", ["near", "scale", "trajectory"])
def test_values_blender_would_change_are_refused_before_anything_is_written(tmp_path, case):
    out = tmp_path / "out"
    args = []
    if case == "near":
        s = script(tmp_path, "CAMERA resolution 64 48 focal 40 near 1e-7\nQUAD id 1 vertices 0 0 -1 1 0 -1 1 1 -1 0 1 -1\n")
        where = "s.ses:1:"
    elif case == "scale":
        s = script(tmp_path, "CAMERA resolution 64 48 focal 40\nQUAD id 1 vertices 0 0 -1 1 0 -1 1 1 -1 0 1 -1\n")
        args, where = ["--resolution-scale", "2000"], "128000x96000"
    else:
        (tmp_path / "t.txt").write_text("0 0 0 0 0 0 0 1\n1 1e308 0 0 0 0 0 1\n")
        s = script(tmp_path, "QUAD id 1 vertices 0 0 -1 1 0 -1 1 1 -1 0 1 -1\nTRAJECTORY file t.txt format tum\n")
        where = "s.ses:2:"
    r = cli_in_process("blender_sesgen", "render", s, "--out", out, *args, "--quiet")
    assert r.returncode == 2 and where in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not out.exists()
