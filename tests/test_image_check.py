"""Image files are decoded (not just found) when a script is checked: every format the parser
accepts, written by independent writers (OpenCV, OpenEXR, and the PNG/TGA specifications
by hand), must pass with its true size; truncated, corrupt or fake files must fail with a
reason -- through ``check`` as ``file:line:col`` with exit 2 -- and a decompression bomb
must stop at its first excess byte.
"""
from __future__ import annotations

import os
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import fuzz_targets as ft
from markers import examples
from blender_sesgen.image_check import ImageFileError, check_image, check_image_bytes

REPO = Path(__file__).resolve().parents[1]
W, H = 53, 37


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


def png_from_spec(rows: list[bytes], w: int, h: int, colour: int, depth: int, interlace: int = 0,
                  plte: bytes | None = None) -> bytes:
    """A PNG assembled from the specification: ``rows`` are the filtered scanlines (filter
    byte first), already in interlaced pass order when ``interlace``."""
    out = b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, interlace))
    if plte is not None:
        out += _chunk(b"PLTE", plte)
    data = zlib.compress(b"".join(rows))
    return out + _chunk(b"IDAT", data[: len(data) // 2]) + _chunk(b"IDAT", data[len(data) // 2:]) + _chunk(b"IEND", b"")


def _adam7_rows(w: int, h: int, bytes_per_px: int) -> list[bytes]:
    rows = []
    for x0, y0, dx, dy in ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2),
                           (0, 1, 1, 2)):
        pw, ph = (w - x0 + dx - 1) // dx, (h - y0 + dy - 1) // dy
        if pw > 0 and ph > 0:
            rows += [b"\x01" + b"\x07" * (pw * bytes_per_px)] * ph  # filter 1 (Sub) on every row
    return rows


def tga(w: int, h: int) -> bytes:
    return struct.pack("<BBBHHBHHHHBB", 0, 0, 2, 0, 0, 0, 0, 0, w, h, 24, 0) + b"\x80" * (w * h * 3)


def samples() -> dict[str, bytes]:
    import cv2
    img = (np.random.default_rng(0).random((H, W, 3)) * 255).astype(np.uint8)
    out = {}
    for name, ext, data, params in (("png", ".png", img, []), ("png16", ".png", img[..., 0].astype(np.uint16) * 200, []),
                                    ("jpeg", ".jpg", img, []), ("jpeg-progressive", ".jpg", img,
                                                                [cv2.IMWRITE_JPEG_PROGRESSIVE, 1]),
                                    ("bmp", ".bmp", img, []), ("tiff", ".tiff", img, []), ("webp", ".webp", img, []),
                                    ("webp-lossless", ".webp", img, [cv2.IMWRITE_WEBP_QUALITY, 101]),
                                    ("hdr", ".hdr", img.astype(np.float32) / 255, [])):
        ok, buf = cv2.imencode(ext, data, params)
        assert ok, name
        out[name] = buf.tobytes()
    out["png-interlaced"] = png_from_spec(_adam7_rows(W, H, 3), W, H, colour=2, depth=8, interlace=1)
    out["png-palette"] = png_from_spec([b"\x00" + bytes(W)] * H, W, H, colour=3, depth=8, plte=b"\x10\x20\x30")
    out["tga"] = tga(W, H)
    return out


@pytest.fixture(scope="module")
def images(tmp_path_factory) -> dict[str, bytes]:
    out = samples()
    from vo_reference.io.exr import write_exr_parts
    path = tmp_path_factory.mktemp("exr") / "x.exr"
    write_exr_parts(path, {"a.RGB": {"R": np.ones((H, W), np.float32)}, "b.Z": {"Z": np.zeros((H, W), np.float32)}})
    out["exr"] = path.read_bytes()
    return out


def test_every_format_decodes_with_its_size(images):
    for name, data in images.items():
        fmt, w, h = check_image_bytes(data, tga=name == "tga")
        assert (w, h) == (W, H) and name.startswith(fmt), (name, fmt)


def test_truncation_anywhere_is_an_error(images):
    """60 cuts per format: each is refused, unless it removed only bytes no image data lies
    in (a TIFF's padding byte) -- then OpenCV, the independent decoder, reads it whole too."""
    import cv2
    for name, data in images.items():
        cuts = sorted(set(np.linspace(1, len(data) - 1, 60).astype(int)))
        for cut in cuts:
            try:
                check_image_bytes(data[:cut], tga=name == "tga")
            except ImageFileError:
                continue
            img = cv2.imdecode(np.frombuffer(data[:cut], np.uint8), cv2.IMREAD_UNCHANGED)
            assert img is not None and img.shape[:2] == (H, W), f"{name} cut at {cut} of {len(data)} passed"


def test_fake_and_corrupt_pngs(images):
    good = images["png"]
    with pytest.raises(ImageFileError, match="no PNG, JPEG"):
        check_image_bytes(b"x")
    with pytest.raises(ImageFileError, match="empty"):
        check_image_bytes(b"")
    bad_filter = png_from_spec([b"\x09" + b"\0" * (W * 3)] * H, W, H, colour=2, depth=8)
    with pytest.raises(ImageFileError, match="filter type 9"):
        check_image_bytes(bad_filter)
    short = png_from_spec([b"\x00" + b"\0" * (W * 3)] * (H - 1), W, H, colour=2, depth=8)
    with pytest.raises(ImageFileError, match="expected"):
        check_image_bytes(short)
    with pytest.raises(ImageFileError, match="without a palette"):
        check_image_bytes(png_from_spec([b"\x00" + bytes(W)] * H, W, H, colour=3, depth=8))
    flipped = bytearray(good)
    flipped[len(good) // 2] ^= 0x40
    with pytest.raises(ImageFileError, match="bad CRC"):
        check_image_bytes(bytes(flipped))


def test_png_decompression_bomb_stops_early():
    """512 MB of zeros in a small PNG: claimed as 2 x 2 px, the check stops at the first byte
    beyond the 10 the image holds; a side beyond Blender's 65536 px is refused before any
    inflating; claimed in full (16000 x 16000 16-bit), it is inflated in 1 MiB steps and
    never held (the child's address space is capped at 256 MiB, half the image)."""
    w = h = 16000
    comp = zlib.compressobj(1)
    row = b"\0" * (1 + 2 * w)
    data = b"".join(comp.compress(row) for _ in range(h)) + comp.flush()
    bomb = b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 2, 16, 0, 0, 0, 0)) \
        + _chunk(b"IDAT", data) + _chunk(b"IEND", b"")
    with pytest.raises(ImageFileError, match="inflates beyond the 10 bytes"):
        check_image_bytes(bomb)
    huge = b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", struct.pack(">IIBBBBB", 100000, 100000, 8, 0, 0, 0, 0))
    with pytest.raises(ImageFileError, match="not a usable image size"):
        check_image_bytes(huge)
    full = bomb.replace(_chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 2, 16, 0, 0, 0, 0)),
                        _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0)))
    code = ("import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (256 << 20, 256 << 20)); "
            "from blender_sesgen.image_check import check_image_bytes; "
            "print(check_image_bytes(sys.stdin.buffer.read()))")
    p = subprocess.run([sys.executable, "-c", code], input=full, capture_output=True, timeout=300,
                       env={**os.environ, "PYTHONPATH": str(REPO)})
    assert p.returncode == 0 and b"('png', 16000, 16000)" in p.stdout, p.stderr[-500:]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_files_that_are_not_regular(tmp_path):
    os.mkfifo(tmp_path / "f.png")
    with pytest.raises(ImageFileError, match="FIFO"):
        check_image(tmp_path / "f.png")


@pytest.mark.parametrize("content, reason", [(b"x", "no PNG, JPEG"), ("truncated-png", "truncated")])
def test_check_command_reports_a_bad_texture_at_its_token(tmp_path, images, content, reason):
    data = images["png"][: len(images["png"]) // 2] if content == "truncated-png" else content
    (tmp_path / "fake.png").write_bytes(data)
    script = tmp_path / "s.ses"
    script.write_text("// a texture that is not an image\nQUAD id 1 vertices 0 0 0 1 0 0 1 1 0 0 1 0 texture fake.png\n")
    p = subprocess.run([sys.executable, "-m", "blender_sesgen", "check", str(script)], capture_output=True,
                       text=True, env={**os.environ, "PYTHONPATH": str(REPO)}, timeout=120)
    col = script.read_text().splitlines()[1].index("fake.png") + 1
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert p.stderr.startswith(f"{script}:2:{col}: error: QUAD 'texture' file 'fake.png' is not a usable image")
    assert reason in p.stderr


unit = st.floats(0.0, 1.0, allow_nan=False)
mutation = st.one_of(st.tuples(st.just("flip"), unit, st.integers(1, 255)), st.tuples(st.just("truncate"), unit),
                     st.tuples(st.just("insert"), unit, st.binary(min_size=1, max_size=8)),
                     st.tuples(st.sampled_from(["delete", "duplicate"]), unit, st.integers(1, 32)),
                     st.just(("fixcrc", 0.0)))


@settings(max_examples=examples(400), deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(sorted(samples())), ops=st.lists(mutation, min_size=1, max_size=4))
def test_fuzz_image_check(images, name, ops):
    """Whatever the bytes: a size, or ImageFileError -- nothing else escapes."""
    try:
        fmt, w, h = check_image_bytes(ft.mutate(images[name], ops), tga=name == "tga")
    except ImageFileError as e:
        assert "\n" not in str(e)
    else:
        assert 0 < w <= 65536 and 0 < h <= 65536
