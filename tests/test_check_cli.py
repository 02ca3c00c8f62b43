"""``python -m blender_sesgen check``: summary on success, one line per error and exit 2 on failure."""
from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

from render_support import cli_in_process

pytestmark = pytest.mark.slow   # subprocesses and end-to-end runs (left out of make test-fast)

REPO = Path(__file__).resolve().parents[1]
SCENES = sorted((REPO / "scenes").glob("*.ses"))


def check(path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "blender_sesgen", "check", str(path)], cwd=REPO,
                          capture_output=True, text=True, timeout=120)


def test_minimal_summary():
    r = check(REPO / "scenes" / "minimal.ses")
    assert r.returncode == 0, r.stderr
    out = r.stdout
    # scenes/minimal.ses: 2 quads, 1 cuboid, 1 sphere, 1 cylinder; 2 EGO lines; 64x48, focal 40, B 0.1
    assert "objects   5: 1 cuboid, 1 cylinder, 2 quad, 1 sphere" in out
    assert "3 frames" in out and "motion    ego" in out
    assert "64x48 px, focal 40 px, principal (31.5, 23.5), stereo baseline 0.1" in out
    fov_h = math.degrees(2 * math.atan(32 / 40))
    fov_v = math.degrees(2 * math.atan(24 / 40))
    assert f"fov       {fov_h:.2f} x {fov_v:.2f} deg" in out
    # path: 0.1 forward, then 0.1 forward + 0.05 right: length 0.1 + sqrt(0.1^2 + 0.05^2)
    length = 0.1 + math.hypot(0.1, 0.05)
    assert f"path length {length:.4g}" in out
    assert "start     position 0 1 3  rotation 0 0 0 deg" in out
    assert "default lighting" in out


@pytest.mark.parametrize("statements, lights, world", [
    # the rules of docs/ses-language.md (LIGHT, WORLD): neither -> the default lighting, a
    # clear-sky day; a WORLD alone lights the scene; LIGHTs without a WORLD get a uniform one
    ("", "default lighting: a clear-sky day (the sky and its sun), plus a ceiling light when START is inside a "
         "closed space", "none: the default lighting's sky, strength 1, sun at elevation 50 azimuth 210 deg"),
    ("WORLD sky elevation 30 azimuth 10\n", "none: the WORLD lights the scene + the sky's sun",
     "sky, strength 1, sun at elevation 30 azimuth 10 deg"),
    ("LIGHT sun direction 0 -1 0\nWORLD sky\n", "sun + the sky's sun", "sky, strength 1, sun at elevation 45 azimuth 0 deg"),
    ("WORLD colour 0.2 0.2 0.2\n", "none: the WORLD lights the scene", "colour 0.2 0.2 0.2, strength 1"),
    ("LIGHT point position 0 2 0\nLIGHT point position 1 2 0\nLIGHT sun direction 0 -1 0\n", "2 point, sun",
     "none: a uniform colour 0.55 0.6 0.7, strength 0.35 (the LIGHTs light the scene)"),
    ("LIGHT area position 0 2 0 direction 0 -1 0\nWORLD hdri studio\n", "area",
     "hdri studio, strength 1, rotation 0 deg"),
])
def test_check_labels_the_lighting_the_renderer_uses(statements, lights, world):
    from blender_sesgen.scene.summary import summary
    from blender_sesgen.ses import parse_string
    text = "CAMERA resolution 64 48 focal 40\nCUBOID id 1 position 0 0 -5 dim 1 1 1\n" + statements
    lines = {line[:10].strip(): line[10:] for line in summary(parse_string(text, source="s.ses")).splitlines()}
    assert (lines["lights"], lines["world"]) == (lights, world)


@pytest.mark.parametrize("scene", SCENES, ids=[p.name for p in SCENES])
def test_every_scene_is_accepted(scene):
    r = cli_in_process("blender_sesgen", "check", scene)   # the command in this process (children: the others)
    assert r.returncode == 0 and r.stderr == "", r.stderr


def test_bad_script_exit_2_with_located_errors(tmp_path):
    bad = tmp_path / "bad.ses"
    bad.write_text("CUBIOD id 1 position 0 0 0 dim 1 1 1\nSPHERE id 2 position 0 0 0 dim 0\n")
    r = check(bad)
    assert r.returncode == 2 and r.stdout == ""
    lines = r.stderr.splitlines()
    assert lines[0] == f"{bad}:1:1: error: " + lines[0].split(": error: ")[1]
    assert "did you mean 'CUBOID'?" in lines[0]
    assert re.fullmatch(rf"{re.escape(str(bad))}:2:32: error: SPHERE 'dim' must be positive, got 0", lines[1])
    assert "Traceback" not in r.stderr


def test_missing_script_and_non_utf8(tmp_path):
    r = check(tmp_path / "nope.ses")
    assert r.returncode == 2 and "cannot read the script" in r.stderr and "Traceback" not in r.stderr
    latin = tmp_path / "latin.ses"
    latin.write_bytes(b"// \xe9\n")
    r = check(latin)
    assert r.returncode == 2 and f"{latin}:1:4: error:" in r.stderr and "Traceback" not in r.stderr
