"""``check`` bounds what a script costs before anything is allocated or written: the IMU
stream (frames x rate x duration), the timestamps, mesh vertex counts and buffer sizes,
the values of HDRIs and float textures (finite, in range), vertex coordinates of model files
(finite), and ``generate``'s count. Each is a one-line ``file:line:col`` error naming the
limit (docs/ses-language.md, *Limits*), from the command line's main (in this process; the
render command's refusals from a child process).
"""
from __future__ import annotations

import base64
import json
import struct
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from markers import needs
from render_support import cli_in_process, run_render

CAMERA = "CAMERA resolution 64 48 focal 50\nSTART position 0 1 3\n"
QUAD = "QUAD id 1 vertices -1 0 -1 1 0 -1 1 1 -1 -1 1 -1\n"


def cli(*args) -> subprocess.CompletedProcess:
    """``sesgen ARGS`` (check, generate) through the command line's main, in this process."""
    return cli_in_process("blender_sesgen", *args)


def refused(script: Path, *words: str, line: int | None = None) -> str:
    r = cli("check", script)
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    if line is not None:
        assert lines[0].startswith(f"{script}:{line}:"), lines[0]
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


def write(tmp_path: Path, text: str, name: str = "s.ses") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


# --- time: the IMU stream and the timestamps ------------------------------------------------

def test_a_slow_frame_rate_with_an_imu_is_bounded_by_the_imu_sample_count(tmp_path):
    """TIMING rate 1e-9 over two frames is 1e9 s of IMU data at 200 Hz (2e11 samples, the
    1.46 TiB the renderer tried to allocate)."""
    s = write(tmp_path, CAMERA + QUAD + "EGO 0 0 -0.1 0 0 0\nTIMING rate 1e-9\nIMU rate 200\n")
    refused(s, "IMU", "2000000 samples", line=6)
    ok = write(tmp_path, CAMERA + QUAD + "EGO 0 0 -0.1 0 0 0\nTIMING rate 20\nIMU rate 200\n", "ok.ses")
    assert cli("check", ok).returncode == 0


def test_timestamps_beyond_the_manifests_limit_are_refused(tmp_path):
    s = write(tmp_path, CAMERA + QUAD + "EGO 0 0 -0.1 0 0 0\nTIMING rate 1e-13\n")
    refused(s, "TIMING", "1e+12 s", line=5)


@needs("bpy")
def test_the_render_commands_rate_override_is_bounded_too(tmp_path):
    s = write(tmp_path, CAMERA + QUAD + "EGO 0 0 -0.1 0 0 0\nIMU rate 200\n")
    out = tmp_path / "out"
    r = run_render(s, "--out", out, "--rate", "1e-9")
    assert r.returncode == 2 and "IMU" in r.stderr and "2000000 samples" in r.stderr, r.stderr
    assert not out.exists()


# --- generate ---------------------------------------------------------------------------------

def test_generate_refuses_a_count_beyond_its_limit_at_once(tmp_path):
    t0 = time.time()
    r = cli("generate", "street", "--count", "10000001", "--out", tmp_path / "g")
    assert r.returncode == 2 and "--count" in r.stderr and "1000000" in r.stderr, r.stderr
    assert time.time() - t0 < 30 and not (tmp_path / "g").exists()


def test_sequence_seeds_refuse_more_sequences_than_there_are_seeds():
    from blender_sesgen.files.dataset import SEQUENCE_SEEDS, sequence_seeds
    with pytest.raises(ValueError, match="at most"):
        sequence_seeds(0, SEQUENCE_SEEDS + 1)


# --- model files --------------------------------------------------------------------------------

def gltf(tmp_path: Path, positions: np.ndarray, claimed: int | None = None, name: str = "m.gltf") -> Path:
    data = np.asarray(positions, dtype="<f4").tobytes()
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
           "buffers": [{"byteLength": len(data),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(data)}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": claimed or len(positions),
                          "type": "VEC3"}]}
    p = tmp_path / name
    p.write_text(json.dumps(doc))
    return p


TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=float)


def mesh_script(tmp_path: Path, model: Path) -> Path:
    return write(tmp_path, CAMERA + f"MESH id 1 file {model.name} position 0 0 -2\n")


def test_a_gltf_claiming_a_billion_vertices_is_refused_before_it_is_loaded(tmp_path):
    s = mesh_script(tmp_path, gltf(tmp_path, TRIANGLE, claimed=10**9))
    refused(s, "accessor 0", line=3)


def test_a_gltf_over_the_vertex_limit_is_refused(tmp_path):
    from blender_sesgen.ses.mesh_content import MAX_MESH_VERTICES
    s = mesh_script(tmp_path, gltf(tmp_path, TRIANGLE, claimed=MAX_MESH_VERTICES + 1))
    refused(s, str(MAX_MESH_VERTICES), line=3)


@pytest.mark.parametrize("bad", [np.nan, np.inf, 3e38])
def test_gltf_positions_must_be_finite_and_in_range(tmp_path, bad):
    pos = TRIANGLE.copy()
    pos[1, 2] = bad
    s = mesh_script(tmp_path, gltf(tmp_path, pos))
    refused(s, "POSITION", line=3)
    assert cli("check", mesh_script(tmp_path, gltf(tmp_path, TRIANGLE, name="ok.gltf"))).returncode == 0


@pytest.mark.parametrize("fmt", ["obj", "stl-ascii", "stl-binary", "ply-ascii", "ply-binary"])
def test_model_files_with_nan_vertices_are_refused(tmp_path, fmt):
    def model(bad: float) -> Path:
        v = TRIANGLE.copy()
        v[2, 0] = bad
        if fmt == "obj":
            text = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in v) + "f 1 2 3\n"
            return write(tmp_path, text, f"m{bad}.obj")
        if fmt == "stl-ascii":
            text = "solid t\nfacet normal 0 0 1\nouter loop\n" + "".join(f"vertex {x!r} {y!r} {z!r}\n" for x, y, z in v) \
                + "endloop\nendfacet\nendsolid t\n"
            return write(tmp_path, text, f"m{bad}.stl")
        if fmt == "stl-binary":
            p = tmp_path / f"m{bad}.stl"
            p.write_bytes(b"\0" * 80 + struct.pack("<I", 1) + struct.pack("<12f", 0, 0, 1, *v.ravel()) + b"\0\0")
            return p
        p = tmp_path / f"m{bad}.ply"
        head = ("ply\nformat {}\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 1\nproperty list uchar int vertex_indices\nend_header\n")
        if fmt == "ply-ascii":
            p.write_text(head.format("ascii 1.0") + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in v) + "3 0 1 2\n")
        else:
            p.write_bytes(head.format("binary_little_endian 1.0").encode() + v.astype("<f4").tobytes()
                          + struct.pack("<B3i", 3, 0, 1, 2))
        return p
    assert cli("check", mesh_script(tmp_path, model(0.5))).returncode == 0
    refused(mesh_script(tmp_path, model(float("nan"))), "vertex", line=3)


def test_a_binary_stl_whose_triangle_count_does_not_match_its_size_is_refused(tmp_path):
    p = tmp_path / "m.stl"
    p.write_bytes(b"\0" * 80 + struct.pack("<I", 10**9) + struct.pack("<12f", 0, 0, 1, *TRIANGLE.ravel()) + b"\0\0")
    refused(mesh_script(tmp_path, p), "triangles", line=3)


# --- HDRIs and float textures ----------------------------------------------------------------

def exr(path: Path, value: float, compression=None) -> Path:
    import OpenEXR
    rgb = np.full((8, 16, 3), 0.5, np.float32)
    rgb[3, 5] = value
    header = {"compression": compression or OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": rgb}) as f:
        f.write(str(path))
    return path


@pytest.mark.parametrize("value", [np.nan, np.inf, 3e38])
@pytest.mark.parametrize("use", ["hdri", "texture"])
def test_float_images_must_hold_finite_values_in_range(tmp_path, value, use):
    pytest.importorskip("OpenEXR")
    img = exr(tmp_path / "bad.exr", value)
    stmt = "WORLD hdri bad.exr\n" if use == "hdri" else QUAD.rstrip("\n") + " texture bad.exr\n"
    refused(write(tmp_path, CAMERA + QUAD.replace("id 1", "id 2") + stmt), img.name, "1e+07", line=4)
    exr(tmp_path / "ok.exr", 12000.0)          # a bright sun is fine
    assert cli("check", write(tmp_path, CAMERA + QUAD.replace("id 1", "id 2") + stmt.replace("bad", "ok"),
                              "ok.ses")).returncode == 0


def test_an_hdr_file_with_a_huge_exponent_is_refused(tmp_path):
    """Radiance RGBE holds no NaN, but exponent 255 is 1.7e38."""
    p = tmp_path / "sky.hdr"
    pixels = bytearray(b"\x80\x80\x80\x81" * (16 * 8))
    pixels[4 * 20 + 3] = 255
    p.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n" + bytes(pixels))
    refused(write(tmp_path, CAMERA + QUAD + "WORLD hdri sky.hdr\n"), "sky.hdr", "1e+07", line=4)
    pixels[4 * 20 + 3] = 0x81
    p.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n" + bytes(pixels))
    assert cli("check", tmp_path / "s.ses").returncode == 0


@pytest.mark.render
@needs("bpy", "OpenEXR")
@pytest.mark.parametrize("use", ["hdri", "texture"])
def test_the_renderer_checks_float_images_check_cannot_decode(tmp_path, use):
    """A PIZ-compressed EXR is beyond the pure reader (``check`` passes it); the renderer
    checks every float image as Blender decoded it, before it writes anything."""
    import OpenEXR
    exr(tmp_path / "bad.exr", np.nan, OpenEXR.PIZ_COMPRESSION)
    stmt = "WORLD hdri bad.exr\n" if use == "hdri" else QUAD.rstrip("\n") + " texture bad.exr\n"
    s = write(tmp_path, CAMERA + QUAD.replace("id 1", "id 2") + stmt)
    assert cli("check", s).returncode == 0
    out = tmp_path / "out"
    r = run_render(s, "--out", out, "--samples", "1")
    assert r.returncode == 2 and "bad.exr" in r.stderr and "finite" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists(), r.stderr


def test_a_ply_header_that_ends_the_file_is_refused(tmp_path):
    """``end_header`` with no line end after it (found by the campaign: a ValueError
    traceback from the header scan) is one line, exit 2."""
    model = tmp_path / "m.ply"
    model.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nend_header")
    refused(mesh_script(tmp_path, model), "PLY", line=3)


@needs("OpenEXR")
def test_an_exr_whose_names_are_not_utf8_is_refused(tmp_path):
    """A channel name that is not UTF-8 (found by the campaign: ``check`` passed it, and
    OpenEXR's own Python reader cannot open it) is refused at the script's line."""
    good = exr(tmp_path / "sky.exr", 1.0)
    buf = bytearray(good.read_bytes())
    at = buf.index(b"\0G\0") + 1            # the channel name "G" in the channel list
    buf[at] = 0xC6                          # a lone UTF-8 lead byte
    good.write_bytes(bytes(buf))
    refused(write(tmp_path, CAMERA + QUAD + "WORLD hdri sky.exr\n"), "sky.exr", "UTF-8", line=4)
