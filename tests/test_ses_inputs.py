"""What the front end reads besides the script's text: only regular files of bounded size
(a FIFO or a device is refused, never opened), and, inside MESH models, only files in the
model's own folder unless the statement says ``allow_external``.

Each case runs the real command line (``python -m blender_sesgen check``) where the promise
is about the command (exit 2, one line, no traceback, no hang); the reference rules are
checked through ``parse_file`` against files planted by the test.
"""
from __future__ import annotations

import json
import os
import re
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from blender_sesgen.errors import ScriptError, SesgenError
from blender_sesgen.ses import parse_file
from image_files import png_bytes

REPO = Path(__file__).resolve().parents[1]
QUAD = "QUAD id 1 vertices 0 0 0 1 0 0 1 1 0 0 1 0\n"
TETRA = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"


def check_cli(path, timeout=60) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "blender_sesgen", "check", str(path)], capture_output=True,
                          text=True, timeout=timeout, env=env)


def one_line_error(p: subprocess.CompletedProcess) -> str:
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    return lines[0]


# --- the script itself --------------------------------------------------------------------

@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_check_refuses_a_fifo_without_blocking(tmp_path):
    fifo = tmp_path / "scene.ses"
    os.mkfifo(fifo)
    line = one_line_error(check_cli(fifo, timeout=30))  # a blocking open would hit the timeout
    assert str(fifo) in line and "FIFO" in line


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null", "/dev/urandom"])
def test_check_refuses_devices(device):
    if not os.path.exists(device):
        pytest.skip(f"{device} does not exist here")
    line = one_line_error(check_cli(device, timeout=30))
    assert device in line and "character device" in line


def test_check_refuses_a_folder(tmp_path):
    assert "folder" in one_line_error(check_cli(tmp_path))


def test_script_size_is_capped(tmp_path, monkeypatch):
    import blender_sesgen.ses as ses
    big = tmp_path / "big.ses"
    big.write_text(QUAD + "// padding\n" * 200)
    monkeypatch.setattr(ses, "MAX_SCRIPT_BYTES", 1000)
    with pytest.raises(SesgenError, match=r"big\.ses: the script is .* more than the 1000 bytes allowed"):
        parse_file(big)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_trajectory_and_texture_fifos_are_errors_at_their_token(tmp_path):
    os.mkfifo(tmp_path / "path.tum")
    os.mkfifo(tmp_path / "wall.png")
    script = tmp_path / "s.ses"
    script.write_text(QUAD.replace("\n", " texture wall.png\n") + "TRAJECTORY file path.tum format tum\n")
    p = check_cli(script, timeout=30)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    errors = p.stderr.strip().splitlines()
    assert errors[0].startswith(f"{script}:1:{QUAD.index('0 0 0 1') + len('0 0 0 1 0 0 1 1 0 0 1 0 texture ') + 1}:")
    assert "FIFO" in errors[0] and errors[1].startswith(f"{script}:2:17:") and "FIFO" in errors[1]


# --- references inside MESH models ---------------------------------------------------------

def _gltf(uris_buffers=(), uris_images=()) -> str:
    return json.dumps({"asset": {"version": "2.0"},
                       "buffers": [{"uri": u, "byteLength": 4} for u in uris_buffers],
                       "images": [{"uri": u} for u in uris_images]})


def _glb(doc: dict) -> bytes:
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    return b"glTF" + struct.pack("<II", 2, 12 + 8 + len(js)) + struct.pack("<II", len(js), 0x4E4F534A) + js


@pytest.fixture
def layout(tmp_path):
    """scene/ holds the script; scene/models/ the model; secret.txt lies beside scene/."""
    (tmp_path / "secret.txt").write_text("not for renders\n")
    models = tmp_path / "scene" / "models"
    (models / "tex").mkdir(parents=True)
    (models / "data.bin").write_bytes(b"\0" * 4)
    (models / "tex" / "wood.png").write_bytes(png_bytes())
    return tmp_path


def _parse(layout, model_name: str, extra: str = ""):
    script = layout / "scene" / "s.ses"
    script.write_text(f"MESH id 1 file models/{model_name}{extra}\n")
    return parse_file(script)


def _error(layout, model_name, extra="") -> ScriptError:
    with pytest.raises(ScriptError) as e:
        _parse(layout, model_name, extra)
    assert (e.value.line, e.value.col) == (1, len("MESH id 1 file ") + 1)
    return e.value


ESCAPES = ["../../secret.txt", "%2E%2E/%2E%2E/secret.txt", "tex/../../../secret.txt", "/etc/passwd",
           "../../../../../../../../etc/passwd"]


@pytest.mark.parametrize("uri", ESCAPES)
def test_gltf_buffer_uri_may_not_leave_the_model_folder(layout, uri):
    (layout / "scene" / "models" / "m.gltf").write_text(_gltf([uri]))
    e = _error(layout, "m.gltf")
    assert "outside the model's folder" in e.message and "allow_external" in e.message


def test_gltf_image_uri_and_glb_json_are_checked_too(layout):
    models = layout / "scene" / "models"
    (models / "m.gltf").write_text(_gltf(["data.bin"], ["../../secret.txt"]))
    assert "image '../../secret.txt'" in _error(layout, "m.gltf").message
    (models / "m.glb").write_bytes(_glb({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 4}],
                                         "images": [{"uri": "/etc/passwd"}]}))
    assert "image '/etc/passwd'" in _error(layout, "m.glb").message


def test_gltf_inside_references_data_uris_and_allow_external_pass(layout):
    models = layout / "scene" / "models"
    (models / "ok.gltf").write_text(_gltf(["data.bin", "data:application/octet-stream;base64,AAAAAA=="],
                                          ["tex/wood.png", "tex%2Fwood.png"]))
    assert _parse(layout, "ok.gltf").objects[0].name == "mesh_1"
    (models / "out.gltf").write_text(_gltf(["../../secret.txt"]))
    scene = _parse(layout, "out.gltf", " allow_external")
    assert scene.objects[0].path.endswith("out.gltf")


def test_symlink_pointing_out_of_the_folder_is_an_escape(layout):
    models = layout / "scene" / "models"
    os.symlink(layout / "secret.txt", models / "link.bin")
    (models / "m.gltf").write_text(_gltf(["link.bin"]))
    assert "outside the model's folder" in _error(layout, "m.gltf").message


def test_missing_or_special_references_are_errors_even_when_allowed(layout):
    models = layout / "scene" / "models"
    (models / "m.gltf").write_text(_gltf(["nothing.bin"]))
    assert "cannot read the buffer file (no such file)" in _error(layout, "m.gltf", " allow_external").message
    (models / "n.gltf").write_text(_gltf(["/dev/zero"]))
    assert "character device" in _error(layout, "n.gltf", " allow_external").message
    (models / "bad.gltf").write_text("{not json")
    assert "not valid glTF JSON" in _error(layout, "bad.gltf").message
    (models / "bad.glb").write_bytes(b"glTF\x02\0\0\0")
    assert "binary glTF" in _error(layout, "bad.glb").message


def test_obj_mtllib_absolute_or_escaping_is_refused(layout):
    models = layout / "scene" / "models"
    for line in ("mtllib /etc/passwd", "mtllib ../../secret.txt", 'mtllib "../../secret.txt"'):
        (models / "m.obj").write_text(f"{line}\n" + TETRA)
        e = _error(layout, "m.obj")
        assert re.search(r"m\.obj:1: material library .* lies outside the model's folder", e.message), e.message


def test_mtl_texture_maps_are_checked_after_their_options(layout):
    models = layout / "scene" / "models"
    (models / "m.obj").write_text("# model\nmtllib my lib.mtl\n" + TETRA)
    mtl = models / "my lib.mtl"
    mtl.write_text("newmtl a\nKd 1 1 1\nmap_Kd -o 0.5 0.5 -bm 2 tex/wood.png\nmap_Bump -bm 0.3 tex/wood.png\n")
    assert _parse(layout, "m.obj").objects  # inside: fine
    mtl.write_text("newmtl a\nmap_Kd -s 1 1 1 -clamp on ../../secret.txt\n")
    e = _error(layout, "m.obj")
    assert "my lib.mtl:2: texture map '../../secret.txt' lies outside" in e.message
    (layout / "outside.png").write_bytes(png_bytes())
    mtl.write_text(f"newmtl a\nmap_Kd {layout / 'outside.png'}\n")
    assert "lies outside" in _error(layout, "m.obj").message
    assert _parse(layout, "m.obj", " allow_external").objects
    mtl.write_text(f"newmtl a\nmap_Kd {layout / 'secret.txt'}\n")  # allowed, but not an image
    assert "is not a usable image" in _error(layout, "m.obj", " allow_external").message
    mtl.write_text("newmtl a\nmap_Kd tex/missing.png\n")
    assert "cannot read the texture map file (no such file)" in _error(layout, "m.obj", " allow_external").message


def test_models_without_references_and_the_repo_assets_still_parse(layout):
    models = layout / "scene" / "models"
    (models / "plain.obj").write_text(TETRA)
    assert _parse(layout, "plain.obj").objects
    from blender_sesgen.ses import parse_file as pf
    assert pf(REPO / "scenes" / "extensions.ses").objects


def test_check_reports_lexical_errors_at_file_line_col(tmp_path):
    """A form feed and U+2028 in comments keep the line numbers; a no-break space and an
    Arabic-Indic digit are errors at their column; the command prints one line each."""
    script = tmp_path / "s.ses"
    script.write_text("// header \f with a form feed\n// and \u2028 a line separator\n"
                      f"{QUAD.strip()}\nSPHERE id 2\u00a0position 0 1 -3 dim 1\nEGO 0 0 \u0661 0 0 0\n",
                      encoding="utf-8")
    p = check_cli(script)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.splitlines() == [
        f"{script}:4:12: error: U+00A0 NO-BREAK SPACE is not allowed here: only spaces and tabs separate tokens",
        f"{script}:5:9: error: non-ASCII digit U+0661 ARABIC-INDIC DIGIT ONE: write numbers with the digits 0-9"]
