"""The error table of the SES language: every bad case names file, line and column.

Each case gives a script, the 1-based line of the error, a *marker* (a piece of that line
whose first character is where the column must point; None = column 1) and a regular
expression the message must match. Columns are computed here from the script text, so the
expectation never comes from the parser itself.
"""
from __future__ import annotations


import pytest

from blender_sesgen.errors import ScriptError, SesgenError
from blender_sesgen.ses import parse_bytes, parse_file, parse_string
from script_errors import parse_error

OBJ = "CUBOID id 1 position 0 0 0 dim 1 1 1\n"   # one valid object, for scripts that need one
CAM = "CAMERA resolution 640 480 focal 389"

CASES = {
    # id: (script, line, marker, message regex)
    "unknown keyword + did-you-mean": (OBJ + "CUBIOD id 2 position 0 0 0 dim 1 1 1\n", 2, None,
                                       r"unknown keyword 'CUBIOD'; did you mean 'CUBOID'\?"),
    "unknown keyword, nothing close": (OBJ + "TELEPORT 1 2 3\n", 2, None, r"unknown keyword 'TELEPORT'"),
    "line starting with a number": (OBJ + "  12 13\n", 2, "12", r"expected a keyword"),
    "unknown tag": (OBJ + "SPHERE id 2 position 0 0 0 dim 1 radius 3\n", 2, "radius",
                    r"SPHERE has no tag 'radius'"),
    "unknown tag + did-you-mean": (OBJ + "SPHERE id 2 postion 0 0 0 dim 1\n", 2, "postion",
                                   r"no tag 'postion'; did you mean 'position'\?"),
    "duplicate tag": (OBJ + "SPHERE id 2 dim 1 position 0 0 0 dim 2\n", 2, "dim 2",
                      r"SPHERE tag 'dim' is given twice \(first at column 13\)"),
    "duplicate tag via synonym": (OBJ + "SPHERE id 2 colour 1 1 1 position 0 0 0 dim 1 color 0 0 0\n", 2,
                                  "color", r"'colour' is given twice"),
    "missing required tag": (OBJ + "CUBOID id 2 position 0 0 0\n", 2, None,
                             r"CUBOID needs the tag 'dim' \(dim sx sy sz\)"),
    "missing id": ("SPHERE position 0 0 0 dim 1\n", 1, None, r"SPHERE needs the tag 'id'"),
    "wrong value count": (OBJ + "CUBOID id 2 position 0 0 0 dim 1 2\n", 2, "dim",
                          r"CUBOID 'dim' needs 3 numbers \(dim sx sy sz\), got 2"),
    "wrong value count, too many": (OBJ + "SPHERE id 2 position 0 0 0 dim 1 2\n", 2, "dim",
                                    r"SPHERE 'dim' needs 1 number \(dim r\), got 2"),
    "position needs 3 or 6": (OBJ + "SPHERE id 2 position 0 0 0 1 dim 1\n", 2, "position",
                              r"'position' needs 3 or 6 numbers \(position x y z \[rx ry rz\]\), got 4"),
    "EGO value count": (OBJ + "EGO 0 0 0.1 0 0\n", 2, None, r"EGO needs 6 numbers .*got 5"),
    "EGO too many values": (OBJ + "EGO 0 0 0.1 0 0 0 7\n", 2, "7", r"EGO needs 6 numbers .*got 7"),
    "non-number": (OBJ + "CUBOID id 2 position 0 zero 0 dim 1 1 1\n", 2, "zero",
                   r"CUBOID 'position' expects a number, got 'zero'"),
    "quoted non-number": (OBJ + 'SPHERE id 2 position 0 0 0 dim "1"\n', 2, '"1"',
                          r"SPHERE 'dim' expects a number, got '\"1\"'"),
    "non-integer id": (OBJ + "SPHERE id 2.5 position 0 0 0 dim 1\n", 2, "2.5", r"'id' must be an integer"),
    "nan": (OBJ + "SPHERE id 2 position 0 nan 0 dim 1\n", 2, "nan", r"'nan' is not allowed, numbers must be finite"),
    "inf": (OBJ + "EGO 0 0 -Inf 0 0 0\n", 2, "-Inf", r"'-Inf' is not allowed"),
    "overflow": (OBJ + "SPHERE id 2 position 0 1e999 0 dim 1\n", 2, "1e999", r"out of range"),
    "duplicate id": (OBJ + "SPHERE id 1 position 0 0 0 dim 1\n", 2, "1 position",
                     r"duplicate id 1: already used by the CUBOID on line 1"),
    "id zero": ("SPHERE id 0 position 0 0 0 dim 1\n", 1, "0 pos", r"'id' must lie in 1\.\.32767"),
    "id too large": ("SPHERE id 32768 position 0 0 0 dim 1\n", 1, "32768", r"'id' must lie in 1\.\.32767"),
    "id negative": ("SPHERE id -4 position 0 0 0 dim 1\n", 1, "-4", r"'id' must lie in 1\.\.32767"),
    "non-coplanar quad": ("QUAD id 1 vertices 0 0 0  1 0 0  1 0.5 1  0 0 1\n", 1, "vertices",
                          r"QUAD vertices are not coplanar"),
    "quad repeated vertex": ("QUAD id 1 vertices 0 0 0  1 0 0  1 0 0  0 0 1\n", 1, "vertices",
                             r"QUAD vertices 2 and 3 are the same point"),
    "quad zero area": ("QUAD id 1 vertices 0 0 0  1 0 0  2 0 0  3 0 0\n", 1, "vertices", r"QUAD has zero area"),
    "quad bow tie": ("QUAD id 1 vertices 0 0 0  1 0 1  1 0 0  0 0 1\n", 1, "vertices", r"self-intersecting"),
    "zero dim": ("CUBOID id 1 position 0 0 0 dim 1 0 1\n", 1, "0 1\n", r"CUBOID 'dim' must be positive, got 0"),
    "negative radius": ("SPHERE id 1 position 0 0 0 dim -0.5\n", 1, "-0.5", r"'dim' must be positive, got -0.5"),
    "negative cylinder height": ("CYLINDER id 1 position 0 0 0 dim 0.5 -2\n", 1, "-2", r"must be positive"),
    "focal zero": (OBJ + "CAMERA resolution 640 480 focal 0\n", 2, "0\n", r"CAMERA 'focal' must be positive"),
    "focal negative": (OBJ + "CAMERA resolution 640 480 focal -389\n", 2, "-389", r"'focal' must be positive"),
    "resolution zero": (OBJ + "CAMERA resolution 0 480 focal 389\n", 2, "0 480",
                        r"'resolution' must be whole numbers in 4\.\.16384"),
    "resolution below Blender's 4 px": (OBJ + "CAMERA resolution 64 2 focal 389\n", 2, "2 focal", r"4\.\.16384"),
    "resolution too large": (OBJ + "CAMERA resolution 640 16385 focal 389\n", 2, "16385", r"4\.\.16384"),
    "near below Blender's clip": (OBJ + "CAMERA resolution 64 48 focal 40 near 1e-7\n", 2, "1e-7",
                                  r"'near' must be at least 1e-06"),
    "resolution fractional": (OBJ + "CAMERA resolution 640.5 480 focal 389\n", 2, "640.5", r"whole numbers"),
    "negative baseline": (OBJ + CAM + " baseline -0.1\n", 2, "-0.1", r"'baseline' must be zero or positive"),
    "near >= far": (OBJ + CAM + " near 10 far 5\n", 2, "5\n", r"'near' \(10\) must be less than 'far' \(5\)"),
    "near >= default far": (OBJ + CAM + " near 2000\n", 2, "2000", r"'near' \(2000\) must be less than 'far'"),
    "two cameras": (OBJ + CAM + "\n" + CAM + "\n", 3, None, r"only one CAMERA statement .*line 2"),
    "EGO mixed with POSE": (OBJ + "EGO 0 0 0.1 0 0 0\nPOSE 0 0 0 0 0 0\n", 3, None,
                            r"POSE cannot be mixed with EGO \(first EGO on line 2\)"),
    "POSE mixed with EGO": (OBJ + "POSE 0 0 0 0 0 0\nPOSE 0 0 1 0 0 0\nEGO 0 0 0.1 0 0 0\n", 4, None,
                            r"EGO cannot be mixed with POSE"),
    "START with POSE": (OBJ + "START position 0 0 0\nPOSE 0 0 0 0 0 0\n", 2, None, r"START cannot be used with POSE"),
    "missing texture file": (OBJ + "SPHERE id 2 texture wall.png position 0 0 0 dim 1\n", 2, "wall.png",
                             r"'wall\.png' is neither a built-in texture name nor an existing image file"),
    "texture name typo": (OBJ + "SPHERE id 2 texture brick position 0 0 0 dim 1\n", 2, "brick",
                          r"did you mean 'bricks'\?"),
    "texture number out of palette": (OBJ + "SPHERE id 2 texture 99 position 0 0 0 dim 1\n", 2, "99",
                                      r"'texture' 99 is not a built-in texture"),
    "missing mesh file": (OBJ + 'MESH id 2 file "models/chair.obj"\n', 2, '"models',
                          r"MESH 'file' file 'models/chair\.obj' not found"),
    "missing trajectory file": (OBJ + "TRAJECTORY file path.txt format tum\n", 2, "path.txt",
                                r"TRAJECTORY 'file' file 'path\.txt' not found"),
    "trajectory bad format": (OBJ + "TRAJECTORY file p.txt format euroc\n", 2, "euroc",
                              r"'format' must be one of tum, kitti"),
    "no objects": (CAM + "\nSTART position 0 0 0\n", 1, None, r"no objects"),
    "empty script": ("// nothing here\n\n", 1, None, r"no objects"),
    "unterminated string": (OBJ + 'SPHERE id 2 texture "wall.png position 0 0 0 dim 1\n', 2, '"wall',
                            r"unterminated string"),
    "colour out of range": (OBJ + "SPHERE id 2 colour 1 1.5 1 position 0 0 0 dim 1\n", 2, "1.5",
                            r"'colour' values must lie in 0\.\.1"),
    "undefined material": (OBJ + "SPHERE id 2 material steel position 0 0 0 dim 1\n", 2, "steel",
                           r"'material' 'steel' is not defined"),
    "light without kind": (OBJ + "LIGHT strength 3\n", 2, None, r"LIGHT needs exactly one of sun, point, spot, area, portal"),
    "sun without direction": (OBJ + "LIGHT sun strength 3\n", 2, None, r"LIGHT sun needs the tag 'direction'"),
    "world colour and sky": (OBJ + "WORLD colour 0 0 0 sky\n", 2, None, r"WORLD needs exactly one of 'colour r g b', 'sky' or 'hdri"),
    "fog end before start": (OBJ + "FOG start 5 end 2\n", 2, "2\n", r"FOG 'end' \(2\) must be greater"),
    "negative noise": (OBJ + "NOISE sigma -1\n", 2, "-1", r"'sigma' must be zero or positive"),
    "render zero samples": (OBJ + "RENDER samples 0\n", 2, "0\n", r"'samples' must lie in 1\.\.1000000"),
    "render denoise value": (OBJ + "RENDER samples 4 denoise maybe\n", 2, "maybe", r"must be one of on, off"),
    "asset without kind": (OBJ + "ASSET id 2 position 0 0 0\n", 2, None, r"ASSET needs exactly one kind \(building, building_shell, car"),
    "asset with two kinds": (OBJ + "ASSET car id 2 tree position 0 0 0\n", 2, "tree", r"ASSET needs exactly one kind"),
    "asset kind misspelt": (OBJ + "ASSET buiding id 2 position 0 0 0\n", 2, "buiding",
                            r"ASSET has no tag 'buiding'; did you mean 'building'\?"),
    # the common slips: what to write instead (grammar.TAG_HINTS), echoing the user's own words
    "asset kind as a tag": (OBJ + "ASSET kind car id 2 position 0 0 -5\n", 2, "kind",
                            r"ASSET has no tag 'kind'; the kind is a word of its own right after the keyword: "
                            r"'ASSET car \.\.\.' \(tags: id, .*; kinds: building, building_shell, car, "),
    "sphere radius": (OBJ + "SPHERE id 2 position 0 0 0 radius 1\n", 2, "radius",
                      r"SPHERE has no tag 'radius'; the size is 'dim r' \("),
    "cylinder radius and height": (OBJ + "CYLINDER id 2 position 0 0 0 radius 1 height 2\n", 2, "radius",
                                   r"CYLINDER has no tag 'radius'; the size is 'dim r h'"),
    "cuboid size": (OBJ + "CUBOID id 2 position 0 0 0 size 1 2 3\n", 2, "size",
                    r"CUBOID has no tag 'size'; the size is 'dim sx sy sz'"),
    "rotation as a tag": (OBJ + "ASSET car id 2 position 0 0 -5 rotation 0 90 0\n", 2, "rotation",
                          r"no tag 'rotation'; the rotation is the last three numbers of 'position x y z \[rx ry rz\]'"),
    "light rotation": (OBJ + "LIGHT sun rotation 0 -1 0\n", 2, "rotation",
                       r"LIGHT has no tag 'rotation'; a light is turned by 'direction dx dy dz'"),
    "light intensity": (OBJ + "LIGHT sun direction 0 -1 0 intensity 3\n", 2, "intensity",
                        r"LIGHT has no tag 'intensity'; write 'strength s'"),
    "light type": (OBJ + "LIGHT type point position 0 2 0\n", 2, "type", r"'LIGHT point \.\.\.'"),
    "camera fx": ("CAMERA resolution 64 48 fx 40\n" + OBJ, 1, "fx", r"CAMERA has no tag 'fx'; write 'focal F' \(pixels\)"),
    "timing fps": (OBJ + "TIMING fps 30\n", 2, "fps", r"TIMING has no tag 'fps'; write 'rate HZ'"),
    "start without its tag": (OBJ + "START 0 1 2 0 10 0\n", 2, "0 1",
                              r"START: expected a tag \(position\), got the value '0'; did you mean "
                              r"'START position 0 1 2 0 10 0'\?"),
    "resolution as WxH": ("CAMERA resolution 640x480 focal 400\n" + OBJ, 1, "640x480",
                          r"'resolution' expects a number, got '640x480'; write two numbers separated by a space: "
                          r"'640 480'$"),
    "commas between numbers": (OBJ + "EGO 0, 0, 0.1, 0, 0, 0\n", 2, "0,", r"separate numbers with spaces, not commas"),
    "a unit on a number": ("CAMERA resolution 64 48 focal 40 baseline 12cm\n" + OBJ, 1, "12cm",
                           r"'baseline' expects a number, got '12cm'; numbers take no unit: write '12'"),
    "a unit on a rotation": (OBJ + "CUBOID id 2 position 0 0 -5 90deg dim 1 1 1\n", 2, "90deg",
                             r"no tag '90deg'; numbers take no unit: write '90'"),
    "move velocity": (OBJ + "MOVE id 1 velocity 0 0 1\n", 2, "velocity",
                      r"MOVE has no tag 'velocity'; a constant motion is 'twist U V W alpha beta gamma'"),
    "asset scale": (OBJ + "ASSET car id 2 position 0 0 -5 scale 2\n", 2, "scale",
                    r"ASSET has no tag 'scale'; write 'size sx sy sz' \(metres\)"),
    "mesh path": (OBJ + "MESH id 2 path chair.obj\n", 2, "path", r"MESH has no tag 'path'; write 'file PATH'"),
    "class vehicle is a car, never the ego vehicle": (OBJ + "SPHERE id 2 position 0 0 0 dim 1 class vehicle\n", 2,
                                                       "vehicle", r"'vehicle' is not a known class; did you mean 'car'\?"),
    "value count says the usage": (OBJ + "CYLINDER id 2 position 0 0 0 dim 1\n", 2, "dim",
                                   r"CYLINDER 'dim' needs 2 numbers \(dim r h\), got 1"),
    "bend on a building": (OBJ + "ASSET building id 2 position 0 0 0 bend 5\n", 2, "bend",
                           r"ASSET building takes no 'bend' \(only road, kerb, gutter, sidewalk, verge do\)"),
    "offset on a car": (OBJ + "ASSET car id 2 position 0 0 0 offset 5\n", 2, "offset", r"ASSET car takes no 'offset'"),
    "bend piece too sharp": (OBJ + "ASSET road id 2 position 0 0 0 bend 0 95 3\n", 2, "95",
                             r"'bend' must lie in -90\.\.90 degrees per piece, got 95"),
    "asset size not positive": (OBJ + "ASSET car id 2 position 0 0 0 size 1.8 0 4\n", 2, "0 4",
                                r"ASSET 'size' must be positive, got 0"),
    "asset seed out of range": (OBJ + "ASSET car id 2 seed -3 position 0 0 0\n", 2, "-3",
                                r"ASSET 'seed' must lie in 0\.\.2147483647"),
    "asset seed not an integer": (OBJ + "ASSET car id 2 seed 1.5 position 0 0 0\n", 2, "1.5",
                                  r"ASSET 'seed' must be an integer"),
    "asset without position": (OBJ + "ASSET car id 2\n", 2, None, r"ASSET needs the tag 'position'"),
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_error_table(case, tmp_path):
    script, line, marker, pattern = CASES[case]
    path, err = parse_error(tmp_path, script, line, marker, pattern)
    assert str(err) == f"{path}:{line}:{err.col}: error: {err.message}"


def test_not_utf8(tmp_path):
    path = tmp_path / "latin1.ses"
    path.write_bytes(OBJ.encode() + "// caf\u00e9 in latin-1\n".encode("latin-1"))
    with pytest.raises(ScriptError) as info:
        parse_file(path)
    # the bad byte is the 'é' (0xe9): line 2, after "// caf" (6 characters)
    assert (info.value.line, info.value.col) == (2, 7)
    assert "not UTF-8" in info.value.message and "0xe9" in info.value.message


def test_all_errors_are_collected_in_source_order():
    script = ("SPHERE id 0 position 0 0 0 dim 1\n"
              "CUBIOD id 3\n"
              "SPHERE id 4 position 0 0 0 dim -1\n")
    with pytest.raises(ScriptError) as info:
        parse_string(script, source="s.ses")
    where = [(e.line, e.col) for e in info.value.errors]
    assert where == [(1, 11), (2, 1), (3, 32)]
    assert info.value is info.value.errors[0]


def test_missing_script_file_is_a_project_error(tmp_path):
    with pytest.raises(SesgenError, match="cannot read the script"):
        parse_file(tmp_path / "absent.ses")


def test_bad_trajectory_file_content(tmp_path):
    (tmp_path / "p.txt").write_text("0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n")
    with pytest.raises(ScriptError, match=r"TRAJECTORY file 'p\.txt' line 2: a TUM pose has 8 numbers, got 7"):
        parse_string(OBJ + "TRAJECTORY file p.txt format tum\n", base_dir=str(tmp_path))


def test_errors_yield_no_scene_even_with_valid_lines():
    with pytest.raises(ScriptError):
        parse_bytes((OBJ * 1 + "SPHERE id 2 position 0 0 0 dim 0\n").encode())


def test_every_hint_names_a_tag_of_the_language_and_never_shadows_one():
    from blender_sesgen.ses.grammar import STATEMENTS, TAG_HINTS
    tags = {t for s in STATEMENTS.values() for t in s.tags} | {"KIND"}
    for word, rules in TAG_HINTS.items():
        assert all(target in tags for target, _ in rules), word
        for s in STATEMENTS.values():   # a word that is a tag of a statement is read as that tag there
            assert word not in s.tags or not any(t in s.tags for t, _ in rules), (word, s.keyword)


def test_class_words_name_real_classes():
    from blender_sesgen.contract import semantics
    from blender_sesgen.ses.parser import CLASS_WORDS, NOT_OBJECT_CLASSES
    assert all(semantics.lookup(name) is not None for name in (*CLASS_WORDS.values(), *NOT_OBJECT_CLASSES))
    assert all(semantics.lookup(word) is None for word in CLASS_WORDS)   # else it would never be asked
