"""Is this file an image Blender can use? A pure check (stdlib; numpy for EXR samples) at parse time.

Blender loads images lazily and renders a broken one as flat magenta without an error, so
the parser checks every image a script names (textures, PBR maps, HDRIs, the images a MESH
model refers to) before anything is rendered. The format is found from the file's content,
not its name; the formats are those the parser accepts by suffix (``IMAGE_SUFFIXES`` in
``ses/materials.py``), all of which Blender 4.2-5.0 reads:

- PNG is decoded completely: every chunk's CRC, IHDR's fields, PLTE where needed, the zlib
  stream inflated in bounded steps (never more than the image needs: a decompression
  bomb stops at its first excess byte) to exactly its expected length, and every row's
  filter byte;
- Radiance HDR is decoded completely (every scanline's run-length encoding), its largest
  exponent within ``MAX_PIXEL_VALUE`` (RGBE holds no NaN, but exponent 255 is 1.7e38);
- OpenEXR is walked completely (headers, the chunk offset tables, every chunk's header
  within the file and the data window), so a truncated file fails; where the pure reader
  decodes it (``exr``: NONE, RLE, ZIPS, ZIP) every float sample is finite and within
  ``MAX_PIXEL_VALUE`` (an HDRI of NaN or 3e38 renders black frames; Blender says nothing);
- JPEG is walked segment by segment, through every scan's entropy-coded data, to its
  end-of-image marker (a frame header and quantisation tables required);
- TIFF: every IFD and every tag's values, and every strip or tile (offset + byte count)
  within the file;
- BMP: the header and, uncompressed, the pixel array within the file; WebP: the RIFF
  chunk list within the file and a VP8/VP8L/VP8X image chunk; TGA: the header and,
  uncompressed, the pixel data within the file.

``check_image(path)`` returns (format, width, height) or raises :class:`ImageFileError`
with a short reason. Files must be regular files of at most ``MAX_IMAGE_BYTES``.
"""
from __future__ import annotations

import math
import struct
import zlib

from .contract.errors import ContractError
from .contract.exr_format import read_header as read_exr_header
from .contract.inputs import MiB, read_bytes

MAX_IMAGE_BYTES = 1024 * MiB
MAX_SIDE = 65536  # Blender's largest image side
MAX_PIXEL_VALUE = 1e7  # a float image's samples (HDRIs, float textures): finite and within this


class ImageFileError(ValueError):
    """The file is not an image this project can use (the message says why)."""


def check_image(path) -> tuple[str, int, int]:
    try:
        data = read_bytes(path, MAX_IMAGE_BYTES, "image file")
    except ContractError as e:
        raise ImageFileError(e.detail) from None
    return check_image_bytes(data, str(path).lower().endswith(".tga"))


def check_image_bytes(data: bytes, tga: bool = False) -> tuple[str, int, int]:
    """:func:`check_image` on the file's bytes (``tga``: the name ends in .tga, the one
    format without a signature)."""
    if not data:
        raise ImageFileError("the file is empty")
    for magic, fn in _BY_MAGIC:
        if data.startswith(magic):
            return _guarded(fn, data)
    if tga:
        return _guarded(_check_tga, data)
    raise ImageFileError("not an image (no PNG, JPEG, OpenEXR, Radiance HDR, BMP, TIFF, WebP or TGA signature)")


def _guarded(fn, data: bytes) -> tuple[str, int, int]:
    name = fn.__name__[7:].upper()
    try:
        fmt, w, h = fn(data)
    except ImageFileError:
        raise
    except (struct.error, IndexError, ValueError, zlib.error, OverflowError) as e:
        raise ImageFileError(f"corrupt or truncated {name} ({e})") from None
    except MemoryError:
        raise ImageFileError(f"{name} too large to check") from None
    _need(0 < w <= MAX_SIDE and 0 < h <= MAX_SIDE, f"{name} size {w}x{h} is not a usable image size")
    return fmt, w, h


def _need(cond: bool, why: str) -> None:
    if not cond:
        raise ImageFileError(why)


# --- PNG --------------------------------------------------------------------------------

_PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
_PNG_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}
_ADAM7 = ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2))


def _check_png(data: bytes):
    pos, ihdr, end, plte = 8, None, False, False
    rows = None
    while pos < len(data):
        _need(pos + 12 <= len(data), "PNG truncated inside a chunk header")
        (length,) = struct.unpack_from(">I", data, pos)
        ctype = data[pos + 4:pos + 8]
        _need(length < 2**31 and pos + 12 + length <= len(data), f"PNG truncated in chunk {ctype!r}")
        body = data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack_from(">I", data, pos + 8 + length)
        _need(zlib.crc32(ctype + body) & 0xFFFFFFFF == crc, f"PNG chunk {ctype.decode('latin-1')!r} has a bad CRC")
        _need(ihdr is not None or ctype == b"IHDR", "PNG does not start with IHDR")
        if ctype == b"IHDR":
            _need(ihdr is None and length == 13, "PNG IHDR is invalid or repeated")
            ihdr = struct.unpack(">IIBBBBB", body)
            w, h, depth, colour, comp, filt, interlace = ihdr
            _need(0 < w <= MAX_SIDE and 0 < h <= MAX_SIDE, f"PNG size {w}x{h} is not a usable image size")
            _need(colour in _PNG_DEPTHS and depth in _PNG_DEPTHS[colour] and comp == 0 and filt == 0
                  and interlace in (0, 1), "PNG header is invalid")
            rows = _PngRows(w, h, _PNG_CHANNELS[colour] * depth, interlace)
        elif ctype == b"PLTE":
            plte = True
        elif ctype == b"IDAT":
            rows.feed(body)
        elif ctype == b"IEND":
            end = True
            break
        pos += 12 + length
    _need(ihdr is not None, "PNG without IHDR")
    _need(end, "PNG truncated (no IEND chunk)")
    _need(ihdr[3] != 3 or plte, "PNG palette image without a palette (PLTE)")
    rows.finish()
    return "png", ihdr[0], ihdr[1]


class _PngRows:
    """Inflates IDAT data in bounded steps without keeping it: counts the bytes against the
    image's size (a decompression bomb stops at its first excess byte, memory stays at one
    step) and checks each row's filter byte (0..4) as it streams by."""

    STEP = 1 << 20

    def __init__(self, w: int, h: int, bits: int, interlace: int):
        self.segments = []  # (row size, row count) per pass
        for x0, y0, dx, dy in (_ADAM7 if interlace else ((0, 0, 1, 1),)):
            pw, ph = (w - x0 + dx - 1) // dx, (h - y0 + dy - 1) // dy
            if pw > 0 and ph > 0:
                self.segments.append((1 + math.ceil(pw * bits / 8), ph))
        self.expected = sum(size * count for size, count in self.segments)
        self.size = (w, h)
        self.inflater = zlib.decompressobj()
        self.seen = 0            # bytes inflated so far
        self.seg, self.row_left = 0, 0  # current segment; bytes left in the current row

    def feed(self, compressed: bytes) -> None:
        chunk = self.inflater.decompress(compressed, self.STEP)
        while True:
            self._rows(chunk)
            if not self.inflater.unconsumed_tail:
                return
            chunk = self.inflater.decompress(self.inflater.unconsumed_tail, self.STEP)

    def _rows(self, chunk: bytes) -> None:
        self.seen += len(chunk)
        _need(self.seen <= self.expected, f"PNG image data inflates beyond the {self.expected} bytes "
                                          f"a {self.size[0]}x{self.size[1]} image holds")
        at = self.row_left
        while at < len(chunk):  # ``at``: the next filter byte within this chunk
            size, count = self.segments[self.seg]
            n = min(count, (len(chunk) - at + size - 1) // size)
            filters = chunk[at:at + n * size:size]
            _need(max(filters) <= 4, f"PNG row with unknown filter type {max(filters)}")
            self.segments[self.seg] = (size, count - n)
            at += n * size
            if count == n:
                self.seg += 1
        self.row_left = at - len(chunk)

    def finish(self) -> None:
        _need(self.seen == self.expected and self.inflater.eof,
              f"PNG image data has {self.seen} bytes{'' if self.inflater.eof else ' (zlib stream unfinished)'}, "
              f"{self.expected} expected")


# --- JPEG -------------------------------------------------------------------------------

def _check_jpeg(data: bytes):
    """Segments (length-prefixed) and, after each SOS, the entropy-coded data (where 0xFF is
    followed by 0x00 or a restart marker) up to the next marker, until EOI."""
    pos, size, tables, scans = 2, None, False, 0
    n = len(data)
    while True:
        _need(pos + 2 <= n, "JPEG truncated (no end-of-image marker)")
        _need(data[pos] == 0xFF, f"JPEG marker expected at byte {pos}")
        marker = data[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        if marker == 0xD9:  # EOI
            break
        if 0xD0 <= marker <= 0xD7 or marker == 0x01:
            pos += 2
            continue
        _need(marker != 0xD8 and marker != 0x00, f"JPEG marker 0x{marker:02X} out of place")
        _need(pos + 4 <= n, "JPEG truncated inside a segment header")
        (length,) = struct.unpack_from(">H", data, pos + 2)
        _need(length >= 2 and pos + 2 + length <= n, "JPEG segment runs past the end of the file")
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            precision, h, w, comps = struct.unpack_from(">BHHB", data, pos + 4)
            _need(size is None and precision in (8, 12, 16) and 1 <= comps <= 4 and length == 8 + 3 * comps,
                  "JPEG frame header is invalid or repeated")
            size = (w, h)
        elif marker == 0xDB:
            tables = True
        pos += 2 + length
        if marker == 0xDA:  # start of scan: entropy-coded data up to the next real marker
            _need(size is not None and tables, "JPEG scan before its frame header or quantisation tables")
            scans += 1
            while True:
                pos = data.find(b"\xff", pos)
                _need(pos >= 0 and pos + 1 < n, "JPEG truncated inside scan data (no end-of-image marker)")
                nxt = data[pos + 1]
                if nxt == 0x00 or 0xD0 <= nxt <= 0xD7:
                    pos += 2
                elif nxt == 0xFF:
                    pos += 1
                else:
                    break
    _need(size is not None and scans > 0, "JPEG without a frame header or image data")
    _need(size[0] > 0 and size[1] > 0, "JPEG size is zero (DNL-defined heights are not supported)")
    return "jpeg", size[0], size[1]


# --- OpenEXR ----------------------------------------------------------------------------

_EXR_LINES = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}


def _exr_header(data: bytes, pos: int) -> tuple[dict, int]:
    """{name: (type, value bytes)} of the header at ``pos`` (contract.exr_format's parser)."""
    header, pos = read_exr_header(data, pos)
    return {name: (typ, value) for name, typ, value in header[None]}, pos


def _exr_channels(chlist: bytes, x0: int, y0: int, w: int, h: int) -> None:
    """Every channel: a name, a pixel type (UINT, HALF, FLOAT) and a sampling that divides
    the data window, as OpenEXR requires (a flipped bit there makes it refuse the file)."""
    pos = 0
    while chlist[pos] != 0:
        end = chlist.index(b"\0", pos)
        _need(end > pos, "EXR channel without a name")
        ptype, xs, ys = struct.unpack_from("<i4xii", chlist, end + 1)
        _need(ptype in (0, 1, 2), f"EXR channel has an unknown pixel type {ptype}")
        _need(xs >= 1 and ys >= 1 and x0 % xs == 0 and y0 % ys == 0 and w % xs == 0 and h % ys == 0,
              f"EXR channel sampling {xs}x{ys} does not divide the data window")
        pos = end + 17


def _check_exr(data: bytes):
    (version,) = struct.unpack_from("<I", data, 4)
    tiled, multipart, deep = bool(version & 0x200), bool(version & 0x1000), bool(version & 0x800)
    _need(version & 0xFF == 2, f"unknown OpenEXR version {version & 0xFF}")
    _need(not version & ~0x1EFF, f"OpenEXR version flags {version >> 8:#x} hold unknown bits")   # OpenEXR refuses them
    pos, headers = 8, []
    while True:
        header, pos = _exr_header(data, pos)
        headers.append(header)
        _need(len(headers) <= 1024, "EXR with too many parts")
        if not multipart or data[pos] == 0:
            pos += 1 if multipart else 0
            break
    width = height = None
    for header in headers:
        for key in ("channels", "compression", "dataWindow"):
            _need(key in header, f"EXR header has no '{key}'")
        _need(len(header["channels"][1]) > 1, "EXR without channels")
        x0, y0, x1, y1 = struct.unpack("<iiii", header["dataWindow"][1])
        _need(0 <= x1 - x0 < MAX_SIDE and 0 <= y1 - y0 < MAX_SIDE, "EXR data window is empty or too large")
        _exr_channels(header["channels"][1], x0, y0, x1 - x0 + 1, y1 - y0 + 1)
        comp = header["compression"][1][0]
        _need(comp in _EXR_LINES, f"EXR compression {comp} is unknown")
        ptype = header.get("type", ("", b"scanlineimage\0"))[1].rstrip(b"\0")
        if "chunkCount" in header:
            (count,) = struct.unpack("<i", header["chunkCount"][1])
            _need(0 < count <= (y1 - y0 + 1) * (x1 - x0 + 1), "EXR chunk count out of range")
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
        _need(pos + 8 * count <= len(data), "EXR chunk offset table truncated")
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
    _exr_values(data)
    return "exr", width, height


def _exr_values(data: bytes) -> None:
    """Every float sample finite and within MAX_PIXEL_VALUE, where the pure reader decodes the
    file (``exr.value_problem``); other compressions and tiled files are checked by the
    renderer when it loads the image (``blender.textures.load_image``)."""
    from .exr import ExrError, value_problem
    try:
        problem = value_problem(data, MAX_PIXEL_VALUE)
    except ExrError as e:
        if "not supported" in str(e):
            return
        raise ImageFileError(" ".join(str(e).split(": ", 1)[-1].split())) from None
    _need(not problem, problem)


# --- Radiance HDR -----------------------------------------------------------------------

def _check_hdr(data: bytes):
    end = data.find(b"\n\n")
    _need(end > 0, "Radiance HDR header does not end")
    fmt = [ln for ln in data[:end].split(b"\n") if ln.startswith(b"FORMAT=")]
    _need(not fmt or fmt[0].strip() in (b"FORMAT=32-bit_rle_rgbe", b"FORMAT=32-bit_rle_xyze"),
          "Radiance HDR has an unknown FORMAT")
    nl = data.index(b"\n", end + 2)
    parts = data[end + 2:nl].split()
    _need(len(parts) == 4 and parts[0] in (b"-Y", b"+Y", b"-X", b"+X") and parts[2] in (b"+X", b"-X", b"+Y", b"-Y"),
          "Radiance HDR resolution line is invalid")
    a, b = int(parts[1]), int(parts[3])
    w, h = (b, a) if parts[0].endswith(b"Y") else (a, b)
    _need(0 < w <= MAX_SIDE and 0 < h <= MAX_SIDE, "Radiance HDR size is not a usable image size")
    pos, scanlines = nl + 1, (h if parts[0].endswith(b"Y") else w)
    length = w if parts[0].endswith(b"Y") else h
    top = 0   # the largest exponent byte: values lie below 2 ** (top - 128)
    for _ in range(scanlines):
        _need(pos + 4 <= len(data), "Radiance HDR truncated")
        if 8 <= length < 32768 and data[pos] == 2 and data[pos + 1] == 2 and not data[pos + 2] & 0x80:
            _need((data[pos + 2] << 8 | data[pos + 3]) == length, "Radiance HDR scanline has the wrong length")
            pos += 4
            for channel in range(4):
                n = 0
                while n < length:
                    _need(pos < len(data), "Radiance HDR truncated inside a scanline")
                    count = data[pos]
                    if count > 128:
                        count -= 128
                        top = max(top, data[pos + 1]) if channel == 3 else top
                        pos += 2
                    else:
                        _need(count > 0, "Radiance HDR run of length 0")
                        top = max(top, max(data[pos + 1:pos + 1 + count], default=0)) if channel == 3 else top
                        pos += 1 + count
                    n += count
                _need(n == length and pos <= len(data), "Radiance HDR scanline is corrupt or truncated")
        else:  # flat (or old-style RLE) pixels, 4 bytes each
            top = max(top, max(data[pos + 3:pos + 4 * length:4], default=0))
            pos += 4 * length
            _need(pos <= len(data), "Radiance HDR truncated")
    _need(top == 0 or 2.0 ** (top - 128) <= MAX_PIXEL_VALUE,
          f"Radiance HDR holds values up to {2.0 ** (top - 128):.3g}: values must lie within {MAX_PIXEL_VALUE:g}")
    return "hdr", w, h


# --- BMP, TIFF, WebP, TGA: structure within the file ------------------------------------

def _check_bmp(data: bytes):
    offset, header_size, w, h = struct.unpack_from("<IIii", data, 10)
    _need(header_size >= 12 and w > 0 and h != 0 and 14 + header_size <= offset < len(data),
          "BMP header is invalid or the file is truncated")
    if header_size >= 40:
        bpp, compression = struct.unpack_from("<HI", data, 28)
        _need(bpp in (1, 2, 4, 8, 16, 24, 32), f"BMP with {bpp} bits per pixel")
        if compression in (0, 3):  # uncompressed (or bit fields): rows padded to 4 bytes
            _need(offset + ((w * bpp + 31) // 32) * 4 * abs(h) <= len(data), "BMP pixel data truncated")
    return "bmp", w, abs(h)


_TIFF_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 6: 1, 7: 1, 8: 2, 9: 4, 10: 8, 11: 4, 12: 8, 16: 8}


def _tiff_values(data: bytes, e: str, entry: int, typ: int, count: int) -> list[int]:
    size = _TIFF_SIZES.get(typ, 1) * count
    _need(count < 2**24, "TIFF tag with too many values")
    at = entry + 8 if size <= 4 else struct.unpack_from(e + "I", data, entry + 8)[0]
    _need(at + size <= len(data), "TIFF tag values outside the file")
    fmt = {3: "H", 4: "I", 16: "Q"}.get(typ)
    return list(struct.unpack_from(e + fmt * count, data, at)) if fmt else []


def _check_tiff(data: bytes):
    e = "<" if data[:2] == b"II" else ">"
    (ifd,) = struct.unpack_from(e + "I", data, 4)
    w = h = 0
    seen = set()
    while ifd:
        _need(8 <= ifd < len(data) and ifd not in seen and len(seen) < 1024, "TIFF directory offset invalid")
        seen.add(ifd)
        (n,) = struct.unpack_from(e + "H", data, ifd)
        _need(ifd + 2 + 12 * n + 4 <= len(data), "TIFF directory truncated")
        tags = {}
        for i in range(n):
            entry = ifd + 2 + 12 * i
            tag, typ, count = struct.unpack_from(e + "HHI", data, entry)
            values = _tiff_values(data, e, entry, typ, count)  # every tag's values lie within the file
            if tag in (256, 257, 273, 279, 324, 325):
                tags[tag] = values
        if not seen - {ifd}:  # the first image sets the size
            w, h = (tags.get(256) or [0])[0], (tags.get(257) or [0])[0]
        for offsets_tag, counts_tag in ((273, 279), (324, 325)):
            offsets, counts = tags.get(offsets_tag, []), tags.get(counts_tag, [])
            _need(len(offsets) == len(counts), "TIFF strip/tile offsets and byte counts differ in number")
            for off, cnt in zip(offsets, counts):
                _need(off + cnt <= len(data), "TIFF image data runs past the end of the file (truncated)")
        _need(tags.get(273) or tags.get(324), "TIFF directory without image data (no strips or tiles)")
        (ifd,) = struct.unpack_from(e + "I", data, ifd + 2 + 12 * n)
    _need(w > 0 and h > 0, "TIFF without a positive image size")
    return "tiff", w, h


def _check_webp(data: bytes):
    (riff,) = struct.unpack_from("<I", data, 4)
    _need(data[8:12] == b"WEBP" and 12 <= riff + 8 <= len(data), "WebP truncated or not WebP")
    pos, w, h, image = 12, 0, 0, False
    while pos + 8 <= riff + 8:
        kind = data[pos:pos + 4]
        (size,) = struct.unpack_from("<I", data, pos + 4)
        _need(pos + 8 + size <= riff + 8, f"WebP chunk {kind!r} runs past the end of the file")
        body = pos + 8
        if kind == b"VP8X" and pos == 12:
            w = 1 + int.from_bytes(data[body + 4:body + 7], "little")
            h = 1 + int.from_bytes(data[body + 7:body + 10], "little")
        elif kind == b"VP8L":
            _need(data[body] == 0x2F, "WebP lossless signature missing")
            bits = int.from_bytes(data[body + 1:body + 5], "little")
            w, h = w or 1 + (bits & 0x3FFF), h or 1 + ((bits >> 14) & 0x3FFF)
            image = True
        elif kind == b"VP8 ":
            _need(data[body + 3:body + 6] == b"\x9d\x01\x2a", "WebP lossy start code missing")
            vw, vh = (x & 0x3FFF for x in struct.unpack_from("<HH", data, body + 6))
            w, h = w or vw, h or vh
            image = True
        elif kind == b"ANMF":
            image = True
        pos = body + size + (size & 1)
    _need(image, "WebP without an image chunk (VP8, VP8L)")
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
    else:
        _need(len(data) > header, "TGA truncated")
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
