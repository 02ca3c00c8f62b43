"""SES sensor statements: parsing, defaults (off), documented example, file:line:col errors."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from blender_sesgen.errors import ScriptError
from blender_sesgen.ses import parse_string

HEAD = "CAMERA resolution 64 48 focal 50 baseline 0.1\nQUAD id 1 vertices -1 0 -1 1 0 -1 1 1 -1 -1 1 -1\n"
DOC = (Path(__file__).resolve().parents[1] / "docs" / "ses-language.md").read_text(encoding="utf-8")


def test_sesgen_scripts_have_every_effect_off():
    s = parse_string(HEAD + "EGO 0 0 0.1 0 1 0\n")
    assert (s.timing, s.lens, s.sensor, s.autoexposure, s.imu) == (None,) * 5
    assert "timing" not in s.to_json()


def test_documented_sensor_example_parses():
    block = next(b for b in re.findall(r"```ses\n(.*?)```", DOC, flags=re.S) if "TIMING" in b)
    s = parse_string("CAMERA resolution 752 480 focal 458 baseline 0.11\nCUBOID id 1 position 0 0 -3 dim 1 1 1\n"
                     + block + "EGO 0 0 0.1 0 1 0\n")
    assert s.timing.rate_hz == 30 and s.timing.readout_s == 0.02 and s.timing.motion_blur
    assert s.lens.model == "brown" and len(s.lens.coeffs) == 5 and s.lens.f_number == 2.8
    assert s.sensor.cfa == "rggb" and s.sensor.bits == 12 and s.sensor.jpeg_quality == 90
    assert s.autoexposure.speed == 4 and s.imu.position == (0.05, 0.0, 0.0) and s.imu.time_offset_s == 0.002


def test_fisheye_and_imu_rotation():
    s = parse_string(HEAD + "LENS fisheye -0.01 0.02 -0.01 0.002\nIMU position 0 0.1 0 0 90 0\n")
    assert s.lens.model == "kannala_brandt" and s.imu.rotation_deg == (0.0, 90.0, 0.0)
    T = s.imu.T_cam_imu()
    assert T[1, 3] == 0.1 and abs(T[0, 2] - 1) < 1e-12


@pytest.mark.parametrize("line,where,message", [
    ("TIMING exposure -0.01", "3:17", "'exposure' must be zero or positive"),
    ("TIMING rate 20 readout 0.06", "3:24", "'readout' (0.06 s) is longer than the frame period"),
    ("TIMING rate 20 exposure 0.2", "3:25", "'exposure' (0.2 s) is longer than the frame period"),
    ("LENS brown -0.9 0 0 0", "3:6", "folds the image"),
    ("LENS fisheye -0.5 0 0 0", "3:6", "folds the image"),
    ("LENS brown 0 0 0 0 fisheye 0 0 0 0", "3:20", "one distortion model"),
    ("SENSOR cfa rgbg", "3:12", "'cfa' must be one of rggb, bggr, grbg, gbrg"),
    ("SENSOR bits 7", "3:13", "'bits' must lie in 8..16"),
    ("SENSOR jpeg 101", "3:13", "quality must lie in 1..100"),
    ("AUTOEXPOSURE speed 1", "3:1", "needs a SENSOR"),
    ("IMU rate -200", "3:10", "'rate' must be positive"),
    ("TIMING rate 20\nTIMING rate 30", "4:1", "only one TIMING"),
])
def test_bad_sensor_input_is_a_file_line_col_error(line, where, message):
    with pytest.raises(ScriptError) as e:
        parse_string(HEAD + line + "\n", source="s.ses")
    text = str(e.value)
    assert text.startswith(f"s.ses:{where}: error:") and message in text, text


def test_bad_sensor_input_writes_nothing(tmp_path):
    import subprocess
    import sys
    script = tmp_path / "bad.ses"
    script.write_text(HEAD + "TIMING rate 20 readout 0.06\n")
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "blender_sesgen", "render", str(script), "--out", str(out)],
                       capture_output=True, text=True, cwd=Path(__file__).resolve().parents[1])
    assert r.returncode == 2 and "bad.ses:3:24: error:" in r.stderr and "Traceback" not in r.stderr
    assert not out.exists()
