"""The render's EXR files as the contract sees them: the channel that holds each product, and
the one parser of an OpenEXR header (stdlib only: the pure reader ``blender_sesgen.files.exr`` and
the image check both walk headers with it).

Channels are ``<view layer>.<pass>.<component>``. Blender 5.0 names the index pass
``Object Index`` and writes one part per pass; Blender 4.x names it ``IndexOB`` and writes
one part holding every pass. Readers accept both (the manifest's ``channels`` names the
exact ones).
"""
from __future__ import annotations

import struct

VIEW_LAYER = "ViewLayer"
PASS_COMBINED = ("Combined",)
PASS_NOISY = ("Noisy Image",)                 # the beauty before the denoiser, beside a denoised Combined
PASS_DEPTH = ("Depth",)
PASS_INDEX = ("Object Index", "IndexOB")      # Blender 5.0, then 4.x
LAYOUT_PARTS = "multilayer, one part per pass"
LAYOUT_SINGLE = "multilayer, one part holding every pass"

MAGIC = 20000630   # the first four bytes of every OpenEXR file (little-endian int)


def channel_names(index_pass: str = PASS_INDEX[0], layout: str = LAYOUT_PARTS,
                  view_layer: str = VIEW_LAYER) -> dict:
    """The EXR channel names of each product (the manifest's ``channels``) and the layout."""
    return {
        "rgb": [f"{view_layer}.{PASS_COMBINED[0]}.{c}" for c in "RGBA"],
        "depth": f"{view_layer}.{PASS_DEPTH[0]}.Z",
        "object_index": f"{view_layer}.{index_pass}.X",
        "normal": [f"{view_layer}.Normal.{c}" for c in "XYZ"],
        "position": [f"{view_layer}.Position.{c}" for c in "XYZ"],
        "layout": layout,
    }


class ExrError(ValueError):
    """Not an EXR this package's readers understand."""


def _cstr(buf: bytes, pos: int) -> tuple[str, int]:
    end = buf.index(b"\0", pos)
    try:   # OpenEXR's readers (its Python binding too) take names as UTF-8
        return buf[pos:end].decode("utf-8"), end + 1
    except UnicodeDecodeError:
        raise ExrError(f"a name in the header is not UTF-8 ({bytes(buf[pos:end])[:40]!r})") from None


def read_header(buf: bytes, pos: int) -> tuple[dict, int]:
    """One header starting at ``pos``: (attributes decoded by type, position after the
    header's null byte); the raw attributes, (name, type, value bytes), are kept under the
    key ``None``. ExrError for an attribute larger than the rest of the file; IndexError,
    ValueError or struct.error where the file ends inside the header."""
    header = {None: []}
    while buf[pos] != 0:
        name, pos = _cstr(buf, pos)
        typ, pos = _cstr(buf, pos)
        (size,) = struct.unpack_from("<i", buf, pos)
        pos += 4
        if not 0 <= size <= len(buf) - pos:  # a negative size would loop back: never
            raise ExrError(f"attribute {name!r} has size {size}, beyond the file")
        value = buf[pos:pos + size]
        pos += size
        header[None].append((name, typ, value))
        if typ == "chlist":
            chans, p = [], 0
            while value[p] != 0:
                cname, p = _cstr(value, p)
                ptype, _linear, xs, ys = struct.unpack_from("<iB3xii", value, p)
                p += 16
                chans.append((cname, ptype, xs, ys))
            header[name] = chans
        elif typ == "compression":
            header[name] = value[0]
        elif typ == "box2i":
            header[name] = struct.unpack("<4i", value)
        elif typ == "int":
            header[name] = struct.unpack("<i", value)[0]
        elif typ == "string":
            header[name] = value.decode("utf-8", "replace")
        else:
            header[name] = value
    return header, pos + 1
