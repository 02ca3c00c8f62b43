"""A small pure reader (numpy + zlib) for the EXR files this package writes.

Enough OpenEXR for our own output: scanline images, single- or multi-part (Blender 5.0
writes one part per pass, 4.x one part holding every pass), compression NONE / RLE /
ZIPS / ZIP, pixel types UINT / HALF / FLOAT. It exists so that the contact sheet and the
add-on's preview work inside Blender's own Python, which has no OpenEXR module. Other
readers (vo_reference, the tests) use the OpenEXR package.

    channels = read_exr("exr/left/000000.exr")   # {"ViewLayer.Depth.Z": (H, W) float32, ...}
    write_exr("out.exr", channels)               # single part, float32, ZIP (lossless)

:func:`write_exr` is what the sensor path uses to put a motion-blurred beauty pass and the
sharp ground-truth passes of a separate render into one file.
"""
from __future__ import annotations

import re
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..contract.errors import ContractError
from ..contract.exr_format import MAGIC, ExrError, read_header as _read_header
from ..contract.inputs import read_bytes

_PIXEL_DTYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}
_LINES_PER_BLOCK = {0: 1, 1: 1, 2: 1, 3: 16}  # NONE, RLE, ZIPS, ZIP


def _unzip(data: bytes, expected: int) -> bytes:
    if len(data) >= expected:  # stored uncompressed
        return data
    inflater = zlib.decompressobj()  # bounded: a block never inflates beyond what it holds
    raw = np.frombuffer(inflater.decompress(data, expected), dtype=np.uint8)
    if not inflater.eof:  # more data than the block holds, or a stream cut short
        raise zlib.error("the block's zlib stream does not end where the block does")
    return _unpredict(raw)


def _unpredict(raw: np.ndarray) -> bytes:
    """Undo the byte predictor and interleaving of ZIP and RLE blocks (sums modulo 256: bytes
    that wrap)."""
    x = raw.copy()
    x[1:] -= np.uint8(128)
    t = np.cumsum(x, dtype=np.uint8)
    out = np.empty_like(t)
    half = (len(t) + 1) // 2
    out[0::2] = t[:half]
    out[1::2] = t[half:]
    return out.tobytes()


@dataclass(frozen=True)
class ExrLayout:
    """What an EXR's headers and chunk tables promise: every part's channels and size, and
    where each chunk lies in the file."""
    multipart: bool
    parts: tuple          # ((header, W, H, y0, lines_per_block, offsets), ...)
    headers_end: int      # where the chunk offset tables start

    @property
    def channels(self) -> list[str]:
        return [name for h, *_ in self.parts for name, *_ in h["channels"]]


def read_layout(buf: bytes, path="<exr>") -> ExrLayout:
    """Parse the headers and chunk offset tables (no pixel data); ExrError if malformed."""
    try:
        if len(buf) < 8 or struct.unpack_from("<i", buf, 0)[0] != MAGIC:
            raise ExrError(f"{path}: not an OpenEXR file")
        (version,) = struct.unpack_from("<i", buf, 4)
        if version & 0xFF != 2 or version & ~0x1EFF:
            raise ExrError(f"{path}: not an OpenEXR 2 file (version field {version:#x})")
        if version & 0x200 or version & 0x800:
            raise ExrError(f"{path}: tiled or deep EXR not supported")
        multipart = bool(version & 0x1000)
        pos = 8
        headers = []
        if multipart:
            while buf[pos] != 0:
                h, pos = _read_header(buf, pos)
                headers.append(h)
            pos += 1
        else:
            h, pos = _read_header(buf, pos)
            headers.append(h)
        headers_end = pos
        parts = []
        for h in headers:
            comp = h.get("compression", 0)
            if comp not in _LINES_PER_BLOCK:
                raise ExrError(f"{path}: compression {comp} not supported (NONE, RLE, ZIPS, ZIP only)")
            if not isinstance(h.get("channels"), list) or not isinstance(h.get("dataWindow"), tuple):
                raise ExrError(f"{path}: corrupt EXR header (no channel list or data window)")
            if any(pt not in _PIXEL_DTYPES for _, pt, _, _ in h["channels"]):
                raise ExrError(f"{path}: corrupt EXR header (unknown pixel type)")
            x0, y0, x1, y1 = h["dataWindow"]
            W, H = x1 - x0 + 1, y1 - y0 + 1
            if not (0 < W <= 65536 and 0 < H <= 65536):
                raise ExrError(f"{path}: corrupt EXR header (data window {W}x{H})")
            lpb = _LINES_PER_BLOCK[comp]
            n_chunks = h.get("chunkCount", -(-H // lpb))
            if not (isinstance(n_chunks, int) and 0 < n_chunks <= H and pos + 8 * n_chunks <= len(buf)):
                raise ExrError(f"{path}: truncated or corrupt chunk table")
            offsets = struct.unpack_from(f"<{n_chunks}Q", buf, pos)
            pos += 8 * n_chunks
            parts.append((h, W, H, y0, lpb, offsets))
    except ExrError as e:
        raise ExrError(str(e) if str(e).startswith(str(path)) else f"{path}: {e}") from None
    except (struct.error, IndexError, KeyError, ValueError, TypeError) as e:
        if isinstance(e, (struct.error, IndexError)) or (isinstance(e, ValueError) and "not found" in str(e)):
            # parsing ran past the last byte (a name without its terminator, an attribute or
            # offset table cut off): the file ends inside its headers
            raise ExrError(f"{path}: truncated (the file ends inside its header)") from None
        raise ExrError(f"{path}: corrupt EXR header ({type(e).__name__})") from None
    return ExrLayout(multipart, tuple(parts), headers_end)


def check_complete(buf: bytes, path="<exr>", required: tuple = (), layout: ExrLayout | None = None) -> ExrLayout:
    """The layout of an EXR whose every chunk lies whole inside the file and which holds the
    ``required`` channels: a truncated or short-written file fails (ExrError), without
    decoding pixels. ``layout``: the file's, if already read."""
    layout = layout or read_layout(buf, path)
    for h, W, H, y0, lpb, offsets in layout.parts:
        for off in offsets:
            p = off + (4 if layout.multipart else 0)
            if off < 8 or p + 8 > len(buf):
                raise ExrError(f"{path}: truncated (a chunk lies beyond the end of the file)")
            _y, size = struct.unpack_from("<ii", buf, p)
            if size < 0 or p + 8 + size > len(buf):
                raise ExrError(f"{path}: truncated (a chunk lies beyond the end of the file)")
    missing = [c for c in required if c not in layout.channels]
    if missing:
        raise ExrError(f"{path}: missing channel(s) {', '.join(missing)}")
    return layout


def read_exr(path, names=None) -> dict[str, np.ndarray]:
    """All channels of all parts: {channel name: (H, W) array} (row 0 = top); with ``names``,
    only those channels (the parts holding none of them are not decoded)."""
    try:  # a regular file only: a FIFO must not block the contact sheet or the add-on's preview
        buf = read_bytes(path, 16 << 30, "EXR file")
    except ContractError as e:
        raise ExrError(str(e)) from None
    return decode(buf, path, names)


def decode(buf: bytes, path="<exr>", names=None) -> dict[str, np.ndarray]:
    """:func:`read_exr` of the bytes of a file."""
    layout = check_complete(buf, path)
    wanted = None if names is None else set(names)
    parts = None if wanted is None else \
        {i for i, p in enumerate(layout.parts) if any(c[0] in wanted for c in p[0]["channels"])}
    out: dict[str, np.ndarray] = {}
    arrays: dict[int, dict[str, np.ndarray]] = {}
    for part, h, W, H, r, rows in _blocks(buf, path, layout, parts):
        if part not in arrays:
            arrays[part] = {name: np.empty((H, W), dtype=_PIXEL_DTYPES[pt]) for name, pt, _, _ in h["channels"]
                            if wanted is None or name in wanted}
        for name, a in arrays[part].items():
            a[r:r + rows[name].shape[0]] = rows[name]
    for part in arrays.values():
        for name, a in part.items():
            out[name] = a.astype(a.dtype.newbyteorder("="))
    return out


def value_problem(buf: bytes, limit: float, path="<exr>") -> str:
    """'' when every HALF and FLOAT sample of the EXR is finite and within +-``limit``; else
    what is not (decoded block by block, nothing kept). ExrError for files this reader does
    not decode (compressions other than NONE, RLE, ZIPS, ZIP; tiled files)."""
    layout = check_complete(buf, path)
    for _part, h, _W, _H, r, rows in _blocks(buf, path, layout):
        for name, pt, _, _ in h["channels"]:
            if pt == 0:
                continue
            v = rows[name]
            bad = ~np.isfinite(v) | (np.abs(v.astype(np.float64)) > limit)
            if bad.any():
                y, x = np.argwhere(bad)[0]
                return (f"channel {name!r} holds {float(v[y, x]):.4g} at pixel ({x}, {r + y}): values must be "
                        f"finite and within +-{limit:g}")
    return ""


def _blocks(buf: bytes, path, layout: ExrLayout, parts=None):
    """Each decoded block: (part index, header, W, H, first row, rows) with ``rows`` a
    structured array (n_lines,) whose fields are the channels ((W,) each); only the parts
    whose indices are in ``parts`` when given."""
    for part, (h, W, H, y0, lpb, offs) in enumerate(layout.parts):
        if parts is not None and part not in parts:
            continue
        chans = h["channels"]
        if any(xs != 1 or ys != 1 for _, _, xs, ys in chans):
            raise ExrError(f"{path}: subsampled channels not supported")
        line = np.dtype([(name, _PIXEL_DTYPES[pt], (W,)) for name, pt, _, _ in chans])
        comp = h.get("compression", 0)
        for off in offs:
            p = off + (4 if layout.multipart else 0)
            y, size = struct.unpack_from("<ii", buf, p)
            data = buf[p + 8:p + 8 + size]
            n_lines = min(lpb, y0 + H - y)
            if not 0 <= y - y0 < H or n_lines < 1:
                raise ExrError(f"{path}: corrupt pixel data (a block outside the data window)")
            try:
                block = {0: lambda d, n: d, 1: _unrle}.get(comp, _unzip)(data, line.itemsize * n_lines)
            except (zlib.error, ValueError):
                raise ExrError(f"{path}: corrupt pixel data ({'RLE' if comp == 1 else 'zlib'})") from None
            if len(block) < line.itemsize * n_lines:
                raise ExrError(f"{path}: corrupt pixel data (short block)")
            rows = np.frombuffer(block, dtype=line, count=n_lines)
            yield part, h, W, H, y - y0, {name: rows[name] for name in line.names}


def _unrle(data: bytes, expected: int) -> bytes:
    """OpenEXR's RLE: runs (count >= 0: count + 1 copies of the next byte) and literals
    (count < 0: -count bytes), then the same predictor and interleaving as ZIP."""
    if len(data) >= expected:  # stored uncompressed
        return data
    out, i = bytearray(), 0
    while i < len(data) and len(out) < expected:
        n = struct.unpack_from("<b", data, i)[0]
        if n < 0:
            out += data[i + 1:i + 1 - n]
            i += 1 - n
        else:
            out += data[i + 1:i + 2] * (n + 1)
            i += 2
    if len(out) != expected or i != len(data):
        raise ValueError("RLE data does not end where the block does")
    return _unpredict(np.frombuffer(bytes(out), dtype=np.uint8))


# --- stripping volatile header attributes ---------------------------------------------------

# wall-clock and machine fields Blender and Cycles write into every header: without them
# the same render gives byte-identical files
VOLATILE_ATTRIBUTES = re.compile(r"^(Date|RenderTime|Memory|Hostname|.*\.(render_time|synchronization_time|total_time))$")


def strip_volatile_attributes(buf: bytes, layout: ExrLayout | None = None, volatile=VOLATILE_ATTRIBUTES) -> bytes:
    """The same EXR without the header attributes whose names match ``volatile`` (chunk
    offsets moved accordingly; pixel data untouched). ``layout``: the file's, if already read."""
    layout = layout or read_layout(buf)
    old_end = pos = layout.headers_end
    out = bytearray(buf[:8])
    for h, *_ in layout.parts:
        for name, typ, value in h[None]:
            if not volatile.match(name):
                out += name.encode("latin-1") + b"\0" + typ.encode("latin-1") + b"\0" + struct.pack("<i", len(value)) + value
        out += b"\0"
    if layout.multipart:
        out += b"\0"
    delta = len(out) - old_end
    for _h, _W, _H, _y0, _lpb, offsets in layout.parts:
        out += struct.pack(f"<{len(offsets)}Q", *(o + delta for o in offsets))
        pos += 8 * len(offsets)
    out += buf[pos:]
    return bytes(out)


def _header_attr(name: str, typ: str, value: bytes) -> bytes:
    return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(value)) + value


def _zip_block(raw: bytes) -> bytes:
    """OpenEXR's ZIP coding of one block: bytes split even/odd, delta-coded, deflated
    (stored raw when that is not smaller)."""
    a = np.frombuffer(raw, dtype=np.uint8)
    t = np.concatenate([a[0::2], a[1::2]])
    d = t.astype(np.int16)
    d[1:] = (t[1:].astype(np.int16) - t[:-1].astype(np.int16) + 128 + 256) & 0xFF
    packed = zlib.compress(d.astype(np.uint8).tobytes(), 6)
    return packed if len(packed) < len(raw) else raw


def write_exr(path, channels: dict) -> None:
    """Write {name: (H, W) array} as a single-part scanline EXR, float32, ZIP (lossless),
    through a temporary file. Channels are stored in name order, as the format requires."""
    names = sorted(channels)
    arrays = [np.ascontiguousarray(channels[n], dtype="<f4") for n in names]
    H, W = arrays[0].shape
    if any(a.shape != (H, W) for a in arrays):
        raise ExrError("write_exr: every channel needs the same (H, W) shape")
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for n in names) + b"\0"
    box = struct.pack("<4i", 0, 0, W - 1, H - 1)
    header = (_header_attr("channels", "chlist", chlist) + _header_attr("compression", "compression", bytes([3]))
              + _header_attr("dataWindow", "box2i", box) + _header_attr("displayWindow", "box2i", box)
              + _header_attr("lineOrder", "lineOrder", bytes([0]))
              + _header_attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + _header_attr("screenWindowCenter", "v2f", struct.pack("<2f", 0.0, 0.0))
              + _header_attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    lines = _LINES_PER_BLOCK[3]
    stacked = np.stack(arrays, axis=1)            # (H, C, W): per scanline, channel after channel
    chunks = []
    for y in range(0, H, lines):
        data = _zip_block(stacked[y:y + lines].tobytes())
        chunks.append(struct.pack("<ii", y, len(data)) + data)
    start = 8 + len(header) + 8 * len(chunks)
    offsets, pos = [], start
    for c in chunks:
        offsets.append(pos)
        pos += len(c)
    blob = (struct.pack("<ii", MAGIC, 2) + header + struct.pack(f"<{len(offsets)}Q", *offsets) + b"".join(chunks))
    from ..contract import atomic
    atomic.write_bytes(Path(path), blob)
