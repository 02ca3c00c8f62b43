"""A real render's folder proves what it holds: ``verify`` finds a hand-edited manifest, an
edited ``scene.ses``, a deleted display PNG, damaged sensor images, lens tables and IMU
streams; ``render --resume`` repairs each at once (the first resume, without ``verify``), and
the repaired folder equals an undamaged render byte for byte."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from markers import needs
from render_support import cli_in_process, rendered

pytestmark = [pytest.mark.render, needs("bpy", "OpenEXR")]

# not denoised (RENDER denoise off): verify and resume do not depend on it, and the denoiser costs
# as much as the rest of these tiny frames
PLAIN = """\
CAMERA resolution 64 48 focal 44 baseline 0.1
RENDER denoise off
START position 0 1 3
QUAD id 1 texture 3 vertices -3 0 -3  3 0 -3  3 3 -3  -3 3 -3
SPHERE id 3 texture 9 position 0.5 0.6 0 dim 0.4
""" + "EGO 0 0 -0.05 0 0.5 0\n" * 3
SENSORS = """\
CAMERA resolution 64 48 focal 50 baseline 0.1
RENDER denoise off
POSE 0 1 3 0 0 0
POSE 0.05 1.02 2.9 1 3 0.5
POSE 0.12 1.01 2.82 2 5 1
QUAD id 1 texture 3 vertices -3 0 -2  3 0 -2  3 3 -2  -3 3 -2
TIMING rate 20 exposure 0.008 readout 0.02
LENS brown -0.2 0.05 0.001 0
SENSOR bits 12 readnoise 3 jpeg 90 seed 2
IMU rate 200 seed 1
"""


def files_of(out: Path) -> dict[str, bytes]:
    """Every file of a render folder but its own state (locks, logs) and the manifest."""
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*"))
            if p.is_file() and ".sesgen" not in p.parts and p.name != "manifest.json"}


@pytest.fixture(scope="module", params=["plain", "sensors"])
def reference(request, tmp_path_factory):
    tmp = tmp_path_factory.mktemp(request.param)
    s = tmp / "s.ses"
    s.write_text(PLAIN if request.param == "plain" else SENSORS)
    out = tmp / "ref"
    rendered(s, out, "--samples", "1", here=True)   # the resumes below: children
    assert cli_in_process("blender_sesgen", "verify", out).returncode == 0
    return request.param, s, out


def damaged(reference, tmp_path, damage) -> tuple[Path, Path]:
    kind, s, ref = reference
    out = tmp_path / "out"
    shutil.copytree(ref, out)
    damage(out, json.loads((out / "manifest.json").read_text()))
    return s, out


def repaired_by_resume(s: Path, out: Path, ref: Path) -> None:
    rendered(s, out, "--samples", "1", "--resume")
    assert files_of(out) == files_of(ref)
    v = cli_in_process("blender_sesgen", "verify", out)
    assert v.returncode == 0, v.stdout + v.stderr


def test_a_deleted_image_fails_verify_and_the_first_resume_renders_it_again(reference, tmp_path):
    kind, _, ref = reference

    def delete(out, m):
        listed = m["display"]["files"]["left"] if kind == "plain" else m["sensor"]["files"]["rgb"]["left"]
        (out / listed[2]).unlink()
    s, out = damaged(reference, tmp_path, delete)
    v = cli_in_process("blender_sesgen", "verify", out, "--dry-run")
    assert v.returncode == 1 and "frame 2:" in v.stdout and "missing" in v.stdout, v.stdout
    e = cli_in_process("vo_reference", "export", out, tmp_path / "E", "--to", "kitti-folder", "--progress", "off")
    assert e.returncode == 2 and "(2)" in e.stderr, e.stderr          # never substituted
    repaired_by_resume(s, out, ref)                                     # no verify in between


@pytest.mark.parametrize("what", ["K", "scene.ses", "static"])
def test_the_folders_own_files_are_checked_and_written_again_by_resume(reference, tmp_path, what):
    kind, _, ref = reference

    def damage(out, m):
        if what == "K":
            m["K"][0][0] += 1.0
            (out / "manifest.json").write_text(json.dumps(m, indent=1))
        elif what == "scene.ses":
            with open(out / "scene.ses", "a") as f:
                f.write("// edited\n")
        else:
            rel = m["trajectories"]["kitti"]["left"] if kind == "plain" else m["imu"]["files"]["noisy"]
            with open(out / rel, "a") as f:
                f.write("0\n")
    s, out = damaged(reference, tmp_path, damage)
    v = cli_in_process("blender_sesgen", "verify", out)
    assert v.returncode == 1, v.stdout
    assert {"K": "manifest.json", "scene.ses": "scene.ses", "static": "SHA-256"}[what] in v.stdout, v.stdout
    repaired_by_resume(s, out, ref)


def test_verify_checks_the_lens_table_and_sensor_images_of_a_sensor_render(reference, tmp_path):
    kind, _, ref = reference
    if kind != "sensors":
        pytest.skip("the plain render has no lens table or sensor images")

    def damage(out, m):
        lut = out / m["lens"]["files"]["undistort_lut"]
        lut.write_bytes(lut.read_bytes()[:-8])
        raw = out / m["sensor"]["files"]["raw"]["right"][1]
        data = bytearray(raw.read_bytes())
        data[-20] ^= 0xFF
        raw.write_bytes(bytes(data))
    s, out = damaged(reference, tmp_path, damage)
    v = cli_in_process("blender_sesgen", "verify", out)
    assert v.returncode == 1 and "undistort_lut.bin" in v.stdout and "frame 1:" in v.stdout, v.stdout
    repaired_by_resume(s, out, ref)
