"""A small pure reader (stdlib + numpy) for the OpenEXR files the renderer writes.

Blender's own Python has neither OpenEXR nor OpenImageIO bindings, and
``bpy.data.images.load`` of a multilayer EXR gives Python no access to its passes, so the
add-on's ground-truth preview reads the files itself. Supported: scanline images, single-
or multi-part (Blender 4.x writes one part, 5.0 one part per pass), compression NONE,
ZIPS and ZIP, pixel types UINT, HALF and FLOAT. Anything else raises :class:`ExrError`.

Layout, from the OpenEXR file-format specification: magic, version/flags, header(s) of
``name\\0 type\\0 size value`` attributes, one offset table per part, then chunks. A
scanline chunk holds, for each line of its block, each channel (in header order) as a
row of little-endian samples; ZIP data is zlib-deflated after a byte predictor and an
even/odd byte split.
"""
from __future__ import annotations

import struct
import zlib
from typing import Iterable, Optional

import numpy as np

MAGIC = 20000630
_COMPRESSION = {0: "NONE", 1: "RLE", 2: "ZIPS", 3: "ZIP", 4: "PIZ", 5: "PXR24", 6: "B44", 7: "B44A",
                8: "DWAA", 9: "DWAB", 10: "HTJ2K"}
_LINES_PER_BLOCK = {"NONE": 1, "ZIPS": 1, "ZIP": 16}
_PIXEL_DTYPE = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}
_TILED, _NON_IMAGE, _MULTIPART = 0x200, 0x800, 0x1000


class ExrError(ValueError):
    """The file is not an EXR this reader understands."""


def _cstr(buf: bytes, pos: int) -> tuple[str, int]:
    end = buf.index(b"\0", pos)
    return buf[pos:end].decode("utf-8", errors="replace"), end + 1


def _parse_chlist(value: bytes) -> list[tuple[str, int, int, int]]:
    out, pos = [], 0
    while pos < len(value) and value[pos] != 0:
        name, pos = _cstr(value, pos)
        ptype, _linear, xs, ys = struct.unpack_from("<iB3xii", value, pos)
        pos += 16
        out.append((name, ptype, xs, ys))
    return out


def _read_header(buf: bytes, pos: int) -> tuple[dict, int]:
    header = {}
    while True:
        if buf[pos] == 0:
            return header, pos + 1
        name, pos = _cstr(buf, pos)
        kind, pos = _cstr(buf, pos)
        (size,) = struct.unpack_from("<i", buf, pos)
        pos += 4
        value = buf[pos:pos + size]
        pos += size
        if kind == "chlist":
            header[name] = _parse_chlist(value)
        elif kind == "compression":
            header[name] = _COMPRESSION.get(value[0], str(value[0]))
        elif kind == "box2i":
            header[name] = struct.unpack("<4i", value)
        elif kind == "int":
            header[name] = struct.unpack("<i", value)[0]
        elif kind == "string":
            header[name] = value.decode("utf-8", errors="replace")
        else:
            header[name] = value


def _unzip(data: bytes, raw_size: int) -> bytes:
    t = np.frombuffer(zlib.decompress(data), dtype=np.uint8).astype(np.int64)
    if t.size != raw_size:
        raise ExrError(f"ZIP block decompressed to {t.size} bytes, expected {raw_size}")
    if t.size > 1:  # undo the predictor: t[i] = t[i-1] + d[i] - 128
        t[1:] -= 128
        t = np.cumsum(t)
    t = (t & 0xFF).astype(np.uint8)
    half = (t.size + 1) // 2  # undo the split: even bytes first, odd bytes second
    out = np.empty_like(t)
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return out.tobytes()


def read_channels(path, names: Optional[Iterable[str]] = None) -> dict[str, np.ndarray]:
    """Channels of an EXR file as ``{name: (H, W) float32 array}`` (row 0 = top).

    ``names``: only these channels (all when ``None``); a name missing from the file
    raises :class:`ExrError`. Multi-part files are searched part by part.
    """
    with open(path, "rb") as f:
        buf = f.read()
    if len(buf) < 8 or struct.unpack_from("<i", buf, 0)[0] != MAGIC:
        raise ExrError(f"{path}: not an OpenEXR file")
    flags = struct.unpack_from("<I", buf, 4)[0]
    if flags & (_TILED | _NON_IMAGE):
        raise ExrError(f"{path}: tiled or deep EXR files are not supported")
    multipart = bool(flags & _MULTIPART)
    pos = 8
    headers = []
    while True:
        h, pos = _read_header(buf, pos)
        headers.append(h)
        if not multipart or buf[pos] == 0:
            break
    if multipart:
        pos += 1  # the empty header that ends the list
    wanted = None if names is None else set(names)
    out: dict[str, np.ndarray] = {}
    tables = []
    for h in headers:
        xmin, ymin, xmax, ymax = h["dataWindow"]
        lpb = _LINES_PER_BLOCK.get(h.get("compression"))
        if lpb is None:
            raise ExrError(f"{path}: compression {h.get('compression')} is not supported")
        if h.get("type", "scanlineimage") != "scanlineimage":
            raise ExrError(f"{path}: part type {h.get('type')} is not supported")
        n_chunks = h.get("chunkCount", (ymax - ymin + lpb) // lpb)
        tables.append(struct.unpack_from(f"<{n_chunks}Q", buf, pos))
        pos += 8 * n_chunks
    for part, (h, offsets) in enumerate(zip(headers, tables)):
        channels = h["channels"]
        if any(xs != 1 or ys != 1 for _, _, xs, ys in channels):
            raise ExrError(f"{path}: sub-sampled channels are not supported")
        keep = [i for i, (n, *_r) in enumerate(channels) if wanted is None or n in wanted]
        if not keep:
            continue
        xmin, ymin, xmax, ymax = h["dataWindow"]
        W, H = xmax - xmin + 1, ymax - ymin + 1
        lpb = _LINES_PER_BLOCK[h["compression"]]
        arrays = {channels[i][0]: np.zeros((H, W), dtype=np.float32) for i in keep}
        for off in offsets:
            p = off
            if multipart:
                p += 4  # part number
            y, size = struct.unpack_from("<ii", buf, p)
            data = buf[p + 8:p + 8 + size]
            lines = min(lpb, ymax + 1 - y)
            raw_size = lines * W * sum(_PIXEL_DTYPE[t].itemsize for _, t, _, _ in channels)
            if size < raw_size and h["compression"] != "NONE":
                data = _unzip(data, raw_size)
            elif size != raw_size:
                raise ExrError(f"{path}: chunk at line {y} has {size} bytes, expected {raw_size}")
            q = 0
            for line in range(lines):
                for i, (name, ptype, _, _) in enumerate(channels):
                    dt = _PIXEL_DTYPE[ptype]
                    n = W * dt.itemsize
                    if name in arrays:
                        arrays[name][y - ymin + line] = np.frombuffer(data, dtype=dt, count=W, offset=q)
                    q += n
        out.update(arrays)
    if wanted is not None and not wanted <= set(out):
        raise ExrError(f"{path}: no channel(s) {', '.join(sorted(wanted - set(out)))}")
    return out
