"""Inputs that used to pass, or fail the wrong way, each refused with one clear line and the
right exit code (2: the user's input; 1: a generator that failed), from the real command line.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
SCENE = "CAMERA resolution 64 48 focal 50\nSTART position 0 1 3\nCUBOID id 1 position 0 0 -2 dim 1 1 1\n"


def cli(package: str, *args, cwd=REPO) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", package, *map(str, args)], capture_output=True, text=True,
                          timeout=300, cwd=cwd, env={**os.environ, "PYTHONPATH": str(REPO)})


def one_line(r: subprocess.CompletedProcess, code: int) -> str:
    assert r.returncode == code, (r.returncode, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    return lines[0]


# --- generate ----------------------------------------------------------------------------------

def test_a_generators_sys_exit_is_not_generates_exit_code(tmp_path):
    gen = tmp_path / "quits.py"
    gen.write_text("import sys\n\ndef generate(seed, **options):\n    sys.exit(3)\n")
    line = one_line(cli("blender_sesgen", "generate", gen, "--count", "2", "--out", tmp_path / "g", "-q"), 1)
    assert "sys.exit(3)" in line and not (tmp_path / "g").exists()


@pytest.mark.parametrize("option", ["steps=abc", "steps=2.5", "steps=true", "kitti=1"])
def test_an_option_of_the_wrong_type_is_a_user_error(tmp_path, option):
    line = one_line(cli("blender_sesgen", "generate", "street", "--count", "2", "--out", tmp_path / "g", "-o", option,
                        "-q"), 2)
    assert option.split("=")[0] in line and "expected" in line, line
    assert not (tmp_path / "g").exists()
    assert cli("blender_sesgen", "generate", "street", "--count", "1", "--out", tmp_path / "ok", "-o", "steps=3",
               "-q").returncode == 0


# --- render options and script values ----------------------------------------------------------

@pytest.mark.parametrize("seed", ["-1", "2147483648"])
def test_render_refuses_a_seed_cycles_cannot_take(tmp_path, seed):
    s = tmp_path / "s.ses"
    s.write_text(SCENE)
    line = one_line(cli("blender_sesgen", "render", s, "--out", tmp_path / "out", "--seed", seed), 2)
    assert "--seed" in line and "2147483647" in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("lines, where, words", [
    ("TIMING exposure 0.01\nSENSOR fill 5\n", "5:13", "'fill'"),
    ("TIMING rate 25 exposure 0.01\nSENSOR\nAUTOEXPOSURE min_exposure 0.02 max_exposure 0.01\n", "6:27", "longer than 'max_exposure'"),
    ("TIMING rate 25 exposure 0.01\nSENSOR\nAUTOEXPOSURE max_exposure 0.5\n", "6:27", "frame period"),
    ("TIMING rate 25 exposure 0.01 readout 0.01\nSENSOR\nAUTOEXPOSURE min_exposure 0.035\n", "6:27", "frame period"),
])
def test_sensor_values_outside_their_meaning_are_refused(tmp_path, lines, where, words):
    s = tmp_path / "s.ses"
    s.write_text(SCENE + lines)
    r = cli("blender_sesgen", "check", s)
    assert r.returncode == 2 and f"s.ses:{where}: error:" in r.stderr and words in r.stderr, r.stderr


def test_autoexposure_within_the_frame_period_passes(tmp_path):
    s = tmp_path / "s.ses"
    s.write_text(SCENE + "TIMING rate 25 exposure 0.01 readout 0.01\nSENSOR fill 0.8\n"
                         "AUTOEXPOSURE min_exposure 0.001 max_exposure 0.03\n")
    r = cli("blender_sesgen", "check", s)
    assert r.returncode == 0, r.stderr


# --- a KITTI right camera with the wrong sign ---------------------------------------------------

def test_a_right_camera_on_the_wrong_side_is_named_as_such(tmp_path):
    """calib.txt's P1[0,3] = -fx * B: positive puts the right camera to the left, and stereo VO
    used to say only that it needs 'baseline > 0'."""
    import cv2
    root = tmp_path / "kitti"
    rng = np.random.default_rng(0)
    for d in ("image_0", "image_1"):
        (root / d).mkdir(parents=True)
        for k in range(3):
            cv2.imwrite(str(root / d / f"{k:06d}.png"), (rng.random((48, 64)) * 255).astype(np.uint8))
    P0 = "700 0 32 0 0 700 24 0 0 0 1 0"
    (root / "calib.txt").write_text(f"P0: {P0}\nP1: 700 0 32 378 0 700 24 0 0 0 1 0\n")
    line = one_line(cli("vo_reference", "stereo-vo", root, "--out", tmp_path / "e.txt", "--quiet"), 2)
    assert "to the left of the left one" in line and "0.54" in line, line


# --- a Blender importer's error --------------------------------------------------------------
def test_a_blender_importers_traceback_becomes_its_last_line():
    """Blender's operators raise RuntimeError whose text is a whole Python traceback (how the
    oversized glTF once reached the user): the render prints its last line only."""
    from blender_sesgen.render_cli import one_line as render_error
    text = ("Error: Python: Traceback (most recent call last):\n"
            '  File "/usr/lib/blender/io_import_scene_gltf2.py", line 121, in execute\n'
            "    return self.import_gltf2(context)\n"
            "MemoryError: Unable to allocate 11.2 GiB for an array with shape (1000000000, 3)\n")
    line = render_error(RuntimeError(text))
    assert "\n" not in line and "Traceback" not in line and line.endswith(
        "MemoryError: Unable to allocate 11.2 GiB for an array with shape (1000000000, 3)"), line
    assert render_error(ValueError("no such object")) == "ValueError: no such object"
    assert render_error(RuntimeError("")) == "RuntimeError"
