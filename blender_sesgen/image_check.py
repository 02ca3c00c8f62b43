"""Is this file an image Blender can use? A pure check (stdlib only) at parse time.

Blender loads images lazily and renders a broken one as flat magenta without an error, so
the parser checks every image a script names (textures, PBR maps, HDRIs) before anything
is rendered. The format is found from the file's content, not its name:

- PNG and Radiance HDR are decoded completely (PNG: every chunk's CRC, the zlib stream
  and its exact length; HDR: every scanline's run-length encoding);
- OpenEXR is walked completely without decompressing (headers, the chunk offset tables,
  every chunk's header within the file and the data window), so a truncated file fails;
- JPEG is walked marker by marker up to the scan and must end with its end-of-image
  marker; BMP, TIFF, WebP and TGA headers are checked for a positive size and a file
  long enough for it.

``check_image(path)`` returns (format, width, height) or raises :class:`ImageFileError`
with a short reason.
"""
from __future__ import annotations

import math
import struct
import zlib


class ImageFileError(ValueError):
    """The file is not an image this project can use (the message says why)."""


def check_image(path) -> tuple[str, int, int]:
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise ImageFileError(f"cannot read it ({e.strerror})") from None
    if not data:
        raise ImageFileError("the file is empty")
    for magic, fn in _BY_MAGIC:
        if data.startswith(magic):
            try:
                return fn(data)
            except (struct.error, IndexError, ValueError, zlib.error) as e:
                if isinstance(e, ImageFileError):
                    raise
                raise ImageFileError(f"corrupt or truncated {fn.__name__[7:].upper()} ({e})") from None
    if str(path).lower().endswith(".tga"):
        try:
            return _check_tga(data)
        except (struct.error, IndexError) as e:
            raise ImageFileError(f"corrupt or truncated TGA ({e})") from None
    raise ImageFileError("not an image (no PNG, JPEG, OpenEXR, Radiance HDR, BMP, TIFF, WebP or TGA signature)")


def _need(cond: bool, why: str) -> None:
    if not cond:
        raise ImageFileError(why)


# --- PNG --------------------------------------------------------------------------------

_PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}


def _check_png(data: bytes):
    pos, idat, ihdr, end = 8, [], None, False
    while pos < len(data):
        _need(pos + 12 <= len(data), "PNG truncated inside a chunk header")
        (length,) = struct.unpack_from(">I", data, pos)
        ctype = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + length]
        _need(len(body) == length and pos + 12 + length <= len(data), f"PNG truncated in chunk {ctype!r}")
        (crc,) = struct.unpack_from(">I", data, pos + 8 + length)
        _need(zlib.crc32(ctype + body) & 0xFFFFFFFF == crc, f"PNG chunk {ctype.decode('latin-1')} has a bad CRC")
        if ctype == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif ctype == b"IDAT":
            idat.append(body)
        elif ctype == b"IEND":
            end = True
            break
        pos += 12 + length
    _need(ihdr is not None, "PNG without IHDR")
    _need(end, "PNG truncated (no IEND chunk)")
    w, h, depth, ctype, _, _, interlace = ihdr
    _need(w > 0 and h > 0 and ctype in _PNG_CHANNELS, "PNG header is invalid")
    _need(bool(idat), "PNG without image data")
    raw = zlib.decompress(b"".join(idat))
    bits = _PNG_CHANNELS[ctype] * depth
    if interlace:
        passes = ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2))
        expected = 0
        for x0, y0, dx, dy in passes:
            pw, ph = (w - x0 + dx - 1) // dx, (h - y0 + dy - 1) // dy
            if pw > 0 and ph > 0:
                expected += ph * (1 + math.ceil(pw * bits / 8))
    else:
        expected = h * (1 + math.ceil(w * bits / 8))
    _need(len(raw) == expected, f"PNG image data has {len(raw)} bytes, {expected} expected")
    return "png", w, h


# --- JPEG -------------------------------------------------------------------------------

def _check_jpeg(data: bytes):
    pos, size = 2, None
    while True:
        _need(pos + 4 <= len(data), "JPEG truncated before its image data")
        _need(data[pos] == 0xFF, "JPEG marker expected")
        marker = data[pos + 1]
        if marker == 0xFF:
            pos += 1
            continue
        if 0xD0 <= marker <= 0xD7 or marker == 0x01:
            pos += 2
            continue
        (length,) = struct.unpack_from(">H", data, pos + 2)
        _need(length >= 2 and pos + 2 + length <= len(data), "JPEG segment runs past the end of the file")
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            h, w = struct.unpack_from(">HH", data, pos + 5)
            size = (w, h)
        if marker == 0xDA:  # start of scan: entropy-coded data follows
            break
        pos += 2 + length
    _need(size is not None and size[0] > 0 and size[1] > 0, "JPEG without a valid frame header")
    _need(data.rfind(b"\xff\xd9") > pos, "JPEG truncated (no end-of-image marker)")
    return "jpeg", size[0], size[1]


# --- OpenEXR ----------------------------------------------------------------------------

_EXR_LINES = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}


def _exr_header(data: bytes, pos: int) -> tuple[dict, int]:
    header = {}
    while data[pos] != 0:
        name_end = data.index(b"\0", pos)
        type_end = data.index(b"\0", name_end + 1)
        (size,) = struct.unpack_from("<i", data, type_end + 1)
        _need(0 <= size <= len(data), "EXR attribute size out of range")
        value = data[type_end + 5:type_end + 5 + size]
        _need(len(value) == size, "EXR header truncated")
        header[data[pos:name_end].decode("latin-1")] = (data[name_end + 1:type_end].decode("latin-1"), value)
        pos = type_end + 5 + size
    return header, pos + 1


def _check_exr(data: bytes):
    (version,) = struct.unpack_from("<I", data, 4)
    tiled, multipart, deep = bool(version & 0x200), bool(version & 0x1000), bool(version & 0x800)
    _need(version & 0xFF == 2, f"unknown OpenEXR version {version & 0xFF}")
    pos, headers = 8, []
    while True:
        header, pos = _exr_header(data, pos)
        headers.append(header)
        if not multipart or data[pos] == 0:
            pos += 1 if multipart else 0
            break
    width = height = None
    for header in headers:
        for key in ("channels", "compression", "dataWindow"):
            _need(key in header, f"EXR header has no '{key}'")
        _need(len(header["channels"][1]) > 1, "EXR without channels")
        x0, y0, x1, y1 = struct.unpack("<iiii", header["dataWindow"][1])
        _need(x1 >= x0 and y1 >= y0, "EXR data window is empty")
        comp = header["compression"][1][0]
        _need(comp in _EXR_LINES, f"EXR compression {comp} is unknown")
        ptype = header.get("type", ("", b"scanlineimage\0"))[1].rstrip(b"\0")
        if "chunkCount" in header:
            (count,) = struct.unpack("<i", header["chunkCount"][1])
        elif tiled or ptype in (b"tiledimage", b"deeptile"):
            count = None  # tile count needs the level layout: walked by offsets only
        else:
            count = math.ceil((y1 - y0 + 1) / _EXR_LINES[comp])
        header["_count"], header["_window"] = count, (x0, y0, x1, y1)
        if width is None:
            width, height = x1 - x0 + 1, y1 - y0 + 1
    for i, header in enumerate(headers):
        count = header["_count"]
        _need(count is not None or not multipart, "EXR tiled part without a chunk count")
        if count is None:
            break  # single-part tiled: trust the structure checked so far
        offsets = struct.unpack_from(f"<{count}Q", data, pos)
        pos += 8 * count
        for off in offsets:
            _need(0 < off < len(data), "EXR chunk offset points outside the file (truncated?)")
            p = off + (4 if multipart else 0)
            if multipart:
                (part,) = struct.unpack_from("<i", data, off)
                _need(part == i, "EXR chunk belongs to another part")
            if tiled or deep or header.get("type", ("", b""))[1].rstrip(b"\0") != b"scanlineimage" and multipart:
                continue
            y, size = struct.unpack_from("<ii", data, p)
            _need(header["_window"][1] <= y <= header["_window"][3], "EXR chunk outside the data window")
            _need(0 <= size and p + 8 + size <= len(data), "EXR chunk runs past the end of the file (truncated)")
    return "exr", width, height


# --- Radiance HDR -----------------------------------------------------------------------

def _check_hdr(data: bytes):
    end = data.find(b"\n\n")
    _need(end > 0, "Radiance HDR header does not end")
    fmt = [ln for ln in data[:end].split(b"\n") if ln.startswith(b"FORMAT=")]
    _need(not fmt or fmt[0].strip() in (b"FORMAT=32-bit_rle_rgbe", b"FORMAT=32-bit_rle_xyze"),
          "Radiance HDR has an unknown FORMAT")
    nl = data.index(b"\n", end + 2)
    parts = data[end + 2:nl].split()
    _need(len(parts) == 4 and parts[0] in (b"-Y", b"+Y", b"-X", b"+X"), "Radiance HDR resolution line is invalid")
    a, b = int(parts[1]), int(parts[3])
    w, h = (b, a) if parts[0].endswith(b"Y") else (a, b)
    _need(w > 0 and h > 0, "Radiance HDR size is not positive")
    pos, scanlines = nl + 1, (h if parts[0].endswith(b"Y") else w)
    length = w if parts[0].endswith(b"Y") else h
    for _ in range(scanlines):
        _need(pos + 4 <= len(data), "Radiance HDR truncated")
        if 8 <= length < 32768 and data[pos] == 2 and data[pos + 1] == 2 and not data[pos + 2] & 0x80:
            _need((data[pos + 2] << 8 | data[pos + 3]) == length, "Radiance HDR scanline has the wrong length")
            pos += 4
            for _channel in range(4):
                n = 0
                while n < length:
                    count = data[pos]
                    if count > 128:
                        count -= 128
                        pos += 2
                    else:
                        _need(count > 0, "Radiance HDR run of length 0")
                        pos += 1 + count
                    n += count
                _need(n == length and pos <= len(data), "Radiance HDR scanline is corrupt or truncated")
        else:  # flat (or old-style RLE) pixels, 4 bytes each
            pos += 4 * length
            _need(pos <= len(data), "Radiance HDR truncated")
    return "hdr", w, h


# --- the rest: headers ------------------------------------------------------------------

def _check_bmp(data: bytes):
    offset, _, w, h = struct.unpack_from("<IIii", data, 10)
    _need(w > 0 and h != 0 and offset < len(data), "BMP header is invalid or the file is truncated")
    return "bmp", w, abs(h)


def _check_tiff(data: bytes):
    e = "<" if data[:2] == b"II" else ">"
    (ifd,) = struct.unpack_from(e + "I", data, 4)
    _need(8 <= ifd < len(data), "TIFF directory offset outside the file")
    (n,) = struct.unpack_from(e + "H", data, ifd)
    tags = {}
    for i in range(n):
        tag, typ, _count, value = struct.unpack_from(e + "HHII", data, ifd + 2 + 12 * i)
        if typ == 3:  # SHORT, left-justified in the value field
            value = struct.unpack_from(e + "H", data, ifd + 2 + 12 * i + 8)[0]
        tags[tag] = value
    w, h = tags.get(256, 0), tags.get(257, 0)
    _need(w > 0 and h > 0, "TIFF without a positive image size")
    return "tiff", w, h


def _check_webp(data: bytes):
    (riff,) = struct.unpack_from("<I", data, 4)
    _need(data[8:12] == b"WEBP" and riff + 8 <= len(data), "WebP truncated or not WebP")
    kind = data[12:16]
    if kind == b"VP8X":
        w = 1 + int.from_bytes(data[24:27], "little")
        h = 1 + int.from_bytes(data[27:30], "little")
    elif kind == b"VP8L":
        bits = int.from_bytes(data[21:25], "little")
        w, h = 1 + (bits & 0x3FFF), 1 + ((bits >> 14) & 0x3FFF)
    elif kind == b"VP8 ":
        w, h = (x & 0x3FFF for x in struct.unpack_from("<HH", data, 26))
    else:
        raise ImageFileError("WebP chunk is unknown")
    _need(w > 0 and h > 0, "WebP without a positive image size")
    return "webp", w, h


def _check_tga(data: bytes):
    idlen, cmap_type, itype = data[0], data[1], data[2]
    cmap_len, cmap_bits = struct.unpack_from("<H", data, 5)[0], data[7]
    w, h, bpp = *struct.unpack_from("<HH", data, 12), data[16]
    _need(itype in (1, 2, 3, 9, 10, 11) and w > 0 and h > 0 and bpp in (8, 15, 16, 24, 32),
          "not an image (TGA header is invalid)")
    header = 18 + idlen + (cmap_len * math.ceil(cmap_bits / 8) if cmap_type else 0)
    if itype in (1, 2, 3):
        _need(len(data) >= header + w * h * math.ceil(bpp / 8), "TGA truncated")
    return "tga", w, h


_BY_MAGIC = (
    (b"\x89PNG\r\n\x1a\n", _check_png),
    (b"\xff\xd8", _check_jpeg),
    (b"\x76\x2f\x31\x01", _check_exr),
    (b"#?RADIANCE", _check_hdr),
    (b"#?RGBE", _check_hdr),
    (b"BM", _check_bmp),
    (b"II*\x00", _check_tiff),
    (b"MM\x00*", _check_tiff),
    (b"RIFF", _check_webp),
)
