"""The SES parser against hand-written expectations (golden JSON, hand-computed poses)."""
from __future__ import annotations

import builtins
import os
import json
import math
from pathlib import Path

import numpy as np
import pytest

from blender_sesgen import model
from blender_sesgen.errors import ScriptError
from blender_sesgen.ses import parse_file, parse_string
from blender_sesgen.textures import BUILTIN_TEXTURES
from image_files import jpeg_bytes, png_bytes

GOLDEN = Path(__file__).resolve().parent / "golden"
OBJ = "CUBOID id 1 position 0 0 0 dim 1 1 1\n"


def assert_matches(actual, expected, where="$"):
    """Structural equality with a 1e-12 tolerance on floats (cos 90 deg is 6e-17, not 0)."""
    if isinstance(expected, dict):
        assert isinstance(actual, dict) and set(actual) == set(expected), f"{where}: keys {set(actual) ^ set(expected)}"
        for k in expected:
            assert_matches(actual[k], expected[k], f"{where}.{k}")
    elif isinstance(expected, list):
        assert isinstance(actual, list) and len(actual) == len(expected), f"{where}: {actual!r} vs {expected!r}"
        for i, (a, e) in enumerate(zip(actual, expected)):
            assert_matches(a, e, f"{where}[{i}]")
    elif isinstance(expected, float) and not isinstance(expected, bool):
        assert isinstance(actual, (int, float)) and math.isclose(actual, expected, abs_tol=1e-12), \
            f"{where}: {actual!r} != {expected!r}"
    else:
        assert actual == expected and type(actual) is type(expected), f"{where}: {actual!r} != {expected!r}"


@pytest.mark.parametrize("name", ["sesgen_style", "extensions"])
def test_golden(name, monkeypatch):
    monkeypatch.chdir(GOLDEN)
    scene = parse_file(f"{name}.ses")
    expected = json.loads((GOLDEN / f"{name}.json").read_text().replace("@DIR@", str(GOLDEN)))
    actual = json.loads(json.dumps(scene.to_json()))  # also proves it is JSON-serialisable
    assert_matches(actual, expected)


def test_golden_object_types_and_lines():
    scene = parse_file(GOLDEN / "sesgen_style.ses")
    assert [type(o) for o in scene.objects] == [model.Sphere, model.Cuboid, model.Cylinder, model.Quad]
    assert [o.line for o in scene.objects] == [4, 5, 6, 7]
    assert scene.frames == 4 and scene.rig.stereo


# --- lexical rules ---------------------------------------------------------------------

def test_comments_strings_case_and_numbers(tmp_path):
    (tmp_path / "my tex.png").write_bytes(png_bytes())
    text = ("\ufeff// whole-line comment\r\n"
            "\tsPhErE  ID 3\tTEXTURE \"my tex.png\" // trailing comment with \"quotes\"\r\n"
            "   POSITION +1.5e0 -2.5E-1 .5 dIm 5.  \r\n")
    # a statement is one line: the SPHERE above lacks position/dim on its own line
    with pytest.raises(ScriptError, match="SPHERE needs the tag 'position'"):
        parse_string(text, base_dir=str(tmp_path))
    one_line = ('sPhErE ID 3 TEXTURE "my tex.png" POSITION +1.5e0 -2.5E-1 .5 dIm 5. '
                'COLOR 1 1 1 // x "y // z\n')
    s = parse_string(one_line, base_dir=str(tmp_path))
    sphere = s.objects[0]
    assert sphere.position == (1.5, -0.25, 0.5) and sphere.radius == 5.0
    assert sphere.texture.kind == "image" and sphere.texture.path == str(tmp_path / "my tex.png")


def test_string_may_hold_comment_marker(tmp_path):
    (tmp_path / "a" / "b").mkdir(parents=True)
    (tmp_path / "a" / "b" / "t.png").write_bytes(png_bytes())
    s = parse_string(OBJ + 'SPHERE id 2 position 0 0 0 dim 1 texture "a//b/t.png"\n', base_dir=str(tmp_path))
    assert s.objects[1].texture.source == "a//b/t.png"


# --- textures ---------------------------------------------------------------------------

@pytest.mark.parametrize("number", sorted(BUILTIN_TEXTURES))
def test_texture_numbers_and_names(number):
    name = BUILTIN_TEXTURES[number][0]
    by_number = parse_string(f"SPHERE id 1 position 0 0 0 dim 1 texture {number}").objects[0].texture
    by_name = parse_string(f"SPHERE id 1 position 0 0 0 dim 1 texture {name.upper()}").objects[0].texture
    assert by_number == by_name == model.TextureRef(kind="builtin", name=name, number=number)


def test_sesgen_texture_numbers_1_to_10_exist():
    assert set(range(1, 11)) <= set(BUILTIN_TEXTURES)


def test_texture_zero_is_plain_colour():
    assert parse_string("SPHERE id 1 position 0 0 0 dim 1 texture 0").objects[0].texture is None


def test_image_texture_relative_to_script(tmp_path):
    (tmp_path / "tex").mkdir()
    (tmp_path / "tex" / "wall.jpg").write_bytes(jpeg_bytes())
    (tmp_path / "scene.ses").write_text("QUAD id 1 texture tex/wall.jpg vertices 0 0 0 1 0 0 1 1 0 0 1 0\n")
    tex = parse_file(tmp_path / "scene.ses").objects[0].texture
    assert (tex.kind, tex.name, tex.path, tex.source) == ("image", "wall", str(tmp_path / "tex" / "wall.jpg"),
                                                          "tex/wall.jpg")


# --- objects and rig --------------------------------------------------------------------

def test_position_with_and_without_rotation():
    s = parse_string("CUBOID id 1 position 1 2 3 dim 1 1 1\nCUBOID id 2 position 1 2 3 10 20 30 dim 1 1 1")
    assert s.objects[0].rotation_deg == (0.0, 0.0, 0.0)
    assert s.objects[1].rotation_deg == (10.0, 20.0, 30.0)


@pytest.mark.parametrize("vertices", [
    "0 0 0  2 0 0  1.5 0 1  0.5 0 1",         # trapezoid
    "0 0 0  2 0 0  1 0 0.3  0 0 2",           # concave (arrow head)
    "0 0 0  1 0 0  1 0.00005 1  0 0 1",        # off-plane by 5e-5 with size ~1.4: within 1e-4 relative
    "0 0 0  1 0 0  2 0 0  1 0 1",             # three collinear vertices: a triangle, still a surface
])
def test_valid_quads(vertices):
    parse_string(f"QUAD id 1 vertices {vertices}")


def test_default_rig_and_principal_point():
    assert parse_string(OBJ).rig == model.Rig(width=640, height=480, focal_px=389.0, cx=319.5, cy=239.5,
                                              baseline=0.12, near=0.05, far=1000.0)
    rig = parse_string(OBJ + "CAMERA resolution 101 50 focal 80").rig
    assert (rig.cx, rig.cy, rig.baseline) == (50.0, 24.5, 0.0)  # (W-1)/2, (H-1)/2; no baseline = mono
    assert not rig.stereo and rig.views == ("left",)


def test_names_default_and_unique():
    s = parse_string(OBJ + 'SPHERE id 2 name "big ball" position 0 0 0 dim 1')
    assert [o.name for o in s.objects] == ["cuboid_1", "big ball"]
    with pytest.raises(ScriptError, match="duplicate object name 'cuboid_1'"):
        parse_string(OBJ + "SPHERE id 2 name cuboid_1 position 0 0 0 dim 1")


# --- motion -----------------------------------------------------------------------------

def test_frames_count():
    assert parse_string(OBJ).frames == 1
    assert parse_string(OBJ + "EGO 0 0 0.1 0 0 0\n" * 40).frames == 41


def test_pose_keyframes_one_frame_per_line():
    s = parse_string(OBJ + "POSE 1 2 3 0 0 0\nPOSE 4 5 6 0 -90 0\n")
    T = s.timeline.left()
    assert s.motion.kind == "pose" and s.frames == 2
    np.testing.assert_allclose(T[0], [[1, 0, 0, 1], [0, -1, 0, 2], [0, 0, -1, 3], [0, 0, 0, 1]], atol=1e-12)
    # ry = -90: Ry(-90) @ diag(1,-1,-1); the camera looks along world +X
    np.testing.assert_allclose(T[1], [[0, 0, 1, 4], [0, -1, 0, 5], [1, 0, 0, 6], [0, 0, 0, 1]], atol=1e-12)
    assert s.start_position == (1.0, 2.0, 3.0)


def test_trajectory_tum_replayed_relative_to_start(tmp_path):
    h = math.sqrt(0.5)
    (tmp_path / "traj.txt").write_text(
        "# timestamp tx ty tz qx qy qz qw\n"
        "0.0 5 5 5 0 0 0 1\n"
        "0.1 5 5 6 0 0 0 1\n"          # +1 along the file camera's z: forward
        f"0.2 5 5 6 0 0 {h} {h}\n")    # then 90 deg about the camera's z
    s = parse_string(OBJ + "START position 0 1 0\nTRAJECTORY file traj.txt format TUM\n", base_dir=str(tmp_path))
    T = s.timeline.left()
    assert s.motion.kind == "trajectory" and s.motion.trajectory_format == "tum" and s.frames == 3
    np.testing.assert_allclose(T[0], [[1, 0, 0, 0], [0, -1, 0, 1], [0, 0, -1, 0], [0, 0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(T[1], [[1, 0, 0, 0], [0, -1, 0, 1], [0, 0, -1, -1], [0, 0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(T[2], [[0, -1, 0, 0], [-1, 0, 0, 1], [0, 0, -1, -1], [0, 0, 0, 1]], atol=1e-12)


def test_trajectory_kitti(tmp_path):
    (tmp_path / "poses.txt").write_text(
        "1 0 0 0 0 1 0 0 0 0 1 0\n"
        "1 0 0 0.5 0 1 0 0 0 0 1 2\n")   # right 0.5, forward 2 in the first camera's frame
    s = parse_string(OBJ + "TRAJECTORY file poses.txt format kitti\n", base_dir=str(tmp_path))
    np.testing.assert_allclose(s.timeline.left()[1][:3, 3], [0.5, 0.0, -2.0], atol=1e-12)


def test_only_named_files_are_read(tmp_path, monkeypatch):
    (tmp_path / "t.png").write_bytes(png_bytes())
    (tmp_path / "m.obj").write_text("v 0 0 0\n")
    (tmp_path / "p.txt").write_text("0 0 0 0 0 0 0 1\n")
    script = tmp_path / "s.ses"
    script.write_text("SPHERE id 1 position 0 0 0 dim 1 texture t.png\nMESH id 2 file m.obj\n"
                      "TRAJECTORY file p.txt format tum\n")
    opened = []
    real_open, real_os_open = builtins.open, os.open
    monkeypatch.setattr(builtins, "open", lambda f, *a, **k: opened.append(str(f)) or real_open(f, *a, **k))
    monkeypatch.setattr(os, "open", lambda f, *a, **k: opened.append(str(f)) or real_os_open(f, *a, **k))
    parse_file(script)
    # the script, the image (decoded: a corrupt image is a parse error), the model (for the
    # files it refers to, ses/mesh_files.py, and its vertices, ses/mesh_content.py) and the
    # trajectory
    assert sorted(set(opened)) == sorted([str(script), str(tmp_path / "t.png"), str(tmp_path / "m.obj"),
                                          str(tmp_path / "p.txt")])


def test_python_in_a_script_is_never_run(tmp_path):
    sentinel = tmp_path / "pwned"
    code = f"__import__('pathlib').Path({str(sentinel)!r}).touch()"
    with pytest.raises(ScriptError):
        parse_string(OBJ + code + "\n" + f"SPHERE id 2 name {code} position 0 0 0 dim 1\n", base_dir=str(tmp_path))
    assert not sentinel.exists()
