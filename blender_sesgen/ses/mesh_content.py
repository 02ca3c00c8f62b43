"""What a MESH model file costs, and whether its vertices are numbers (pure: numpy + stdlib).

Blender's importers believe a file: a glTF accessor that claims a billion vertices makes
the importer allocate gigabytes before it finds out, and a vertex at NaN renders, with exit
0, as a surface that is not there. So before a model reaches an importer, :func:`content_problems`
checks what it claims against what it holds and the limits:

- **glTF** (.gltf, .glb): every accessor lies inside its buffer view, every view inside its
  buffer, every buffer inside the data it has (the GLB's BIN chunk, the file, the ``data:``
  URI); an accessor without data (all zeros) or the POSITIONs of the file together hold at
  most :data:`MAX_MESH_VERTICES`; float POSITIONs are finite and within ``MAX_ABS``;
- **OBJ**: at most :data:`MAX_MESH_VERTICES` ``v`` lines, each with three finite numbers
  within ``MAX_ABS`` (the error names the line);
- **STL**: binary with exactly the size its triangle count gives (84 + 50 bytes a
  triangle), or ASCII; 3 vertices a triangle within the limit; coordinates finite;
- **PLY**: the vertex count of the header within the limit and within the file (binary:
  its records; ASCII: its lines); the x, y, z of every vertex finite.

A file's references to other files are ``mesh_files``'s concern.
"""
from __future__ import annotations

import base64
import json
import re
import struct
from pathlib import Path
from urllib.parse import unquote

import numpy as np

from ..contract.errors import ContractError
from ..contract.inputs import check_regular, read_bytes
from .mesh_files import MAX_MODEL_TEXT, gltf_document
from .statements import MAX_ABS

MAX_MESH_VERTICES = 20_000_000   # per model file: a 3-D scan of a street; more is split into several files
_GLTF_COMPONENTS = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_GLTF_TYPES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def content_problems(model: Path) -> list[str]:
    """Messages for what ``model`` claims beyond its data or the limits, or for vertices that
    are not finite numbers within range; an empty list when all is well."""
    model = Path(model)
    ext = model.suffix.lower()
    try:
        if ext in (".gltf", ".glb"):
            return _gltf_problems(model)
        if ext == ".obj":
            return _obj_problems(model)
        if ext == ".stl":
            return _stl_problems(model)
        if ext == ".ply":
            return _ply_problems(model)
    except ContractError as e:
        return [e.detail]
    return []


def _bad_vertices(xyz: np.ndarray) -> np.ndarray:
    """Indices of the rows of (n, 3) ``xyz`` that are not finite or beyond ``MAX_ABS``."""
    with np.errstate(invalid="ignore"):
        return np.flatnonzero(~np.all(np.isfinite(xyz) & (np.abs(xyz) <= MAX_ABS), axis=1))


def _too_many(n: int, what: str) -> str:
    return f"{what} claims {n} vertices, more than the limit of {MAX_MESH_VERTICES} per model file"


# --- glTF ------------------------------------------------------------------------------------

def _gltf_problems(model: Path) -> list[str]:
    doc = gltf_document(model)
    bin_chunk = _glb_bin(model) if model.suffix.lower() == ".glb" else None
    buffers, views, accessors = (_list(doc, k) for k in ("buffers", "bufferViews", "accessors"))
    for i, b in enumerate(buffers):      # each buffer within its data (read only where POSITIONs are)
        _buffer_data(model, b, i, bin_chunk, read=False)
    for i, v in enumerate(views):
        b = _index(v, "buffer", buffers, f"bufferView {i}")
        end = _int(v, "byteOffset", 0, f"bufferView {i}") + _int(v, "byteLength", None, f"bufferView {i}")
        if end > _int(buffers[b], "byteLength", None, f"buffer {b}"):
            raise ContractError(f"glTF bufferView {i} ends at byte {end}, beyond its buffer {b}")
    positions = set()
    for m in _list(doc, "meshes"):
        prims = m.get("primitives")
        for prim in prims if isinstance(prims, list) else ():
            attrs = prim.get("attributes") if isinstance(prim, dict) else None
            if isinstance(attrs, dict) and isinstance(attrs.get("POSITION"), int):
                positions.add(attrs["POSITION"])
    total = 0
    for i, a in enumerate(accessors):
        what = f"glTF accessor {i}"
        count = _int(a, "count", None, what)
        ct, typ = a.get("componentType"), a.get("type")
        size = (_GLTF_COMPONENTS.get(ct, 0) if isinstance(ct, int) else 0) * \
            (_GLTF_TYPES.get(typ, 0) if isinstance(typ, str) else 0)
        if not size:
            raise ContractError(f"{what} has an unknown componentType or type")
        if i in positions:
            total += count
            if count > MAX_MESH_VERTICES or total > MAX_MESH_VERTICES:
                return [_too_many(max(count, total), f"{what} (POSITION)")]
        if "bufferView" not in a:       # all zeros, allocated by the importer
            if count > MAX_MESH_VERTICES:
                return [_too_many(count, what)]
            continue
        vi = _index(a, "bufferView", views, what)
        view = views[vi]
        stride = _int(view, "byteStride", 0, f"bufferView {vi}") or size
        need = _int(a, "byteOffset", 0, what) + stride * (count - 1) + size
        if count < 1 or need > _int(view, "byteLength", None, f"bufferView {vi}"):
            return [f"{what} claims {count} elements of {size} bytes, which do not fit its bufferView {vi} "
                    f"({view.get('byteLength')} bytes)"]
        if i in positions and a.get("componentType") == 5126 and a.get("type") == "VEC3":
            b = _index(view, "buffer", buffers, f"bufferView {vi}")
            raw = _buffer_data(model, buffers[b], b, bin_chunk)
            start = _int(view, "byteOffset", 0, "") + _int(a, "byteOffset", 0, "")
            xyz = np.ndarray((count, 3), dtype="<f4", buffer=raw, offset=start, strides=(stride, 4))
            bad = _bad_vertices(xyz)
            if bad.size:
                return [f"{what} (POSITION): vertex {bad[0]} is {xyz[bad[0]].tolist()}, not finite numbers "
                        f"within {MAX_ABS:g}"]
    return []


def _list(doc: dict, key: str) -> list:
    items = doc.get(key) or []
    if not isinstance(items, list) or not all(isinstance(x, dict) for x in items):
        raise ContractError(f"glTF '{key}' is not a list of objects")
    return items


def _int(obj: dict, key: str, default, what: str) -> int:
    v = obj.get(key, default)
    if not isinstance(v, int) or isinstance(v, bool) or v < 0:
        raise ContractError(f"{what}: '{key}' must be a whole number >= 0, got {json.dumps(v)[:40]}")
    return v


def _index(obj: dict, key: str, items: list, what: str) -> int:
    i = _int(obj, key, None, what)
    if i >= len(items):
        raise ContractError(f"{what}: '{key}' {i} does not exist")
    return i


def _buffer_data(model: Path, buf: dict, i: int, bin_chunk, read: bool = True) -> bytes:
    """The bytes buffer ``i`` has, checked against its byteLength (``read=False``: only the
    check, an external file is not read)."""
    uri = buf.get("uri")
    if uri is None:
        have = bin_chunk if i == 0 and bin_chunk is not None else b""
    elif isinstance(uri, str) and uri.startswith("data:"):
        try:
            have = base64.b64decode(uri.split(",", 1)[1], validate=False) if ";base64," in uri[:200] \
                else unquote(uri.split(",", 1)[1]).encode("latin-1")
        except (ValueError, IndexError, UnicodeEncodeError):
            raise ContractError(f"glTF buffer {i}: its data URI does not decode") from None
    else:
        path = model.parent / unquote(str(uri))
        length = _int(buf, "byteLength", None, f"glTF buffer {i}")
        size = check_regular(path, f"glTF buffer {i}")
        if length > size:
            raise ContractError(f"glTF buffer {i} claims {length} bytes, its file {uri} has {size}")
        return read_bytes(path, size, f"glTF buffer {i}") if read else b""
    length = _int(buf, "byteLength", None, f"glTF buffer {i}")
    if length > len(have):
        raise ContractError(f"glTF buffer {i} claims {length} bytes and has {len(have)}")
    return have


def _glb_bin(model: Path):
    """The BIN chunk of a binary glTF (None without one)."""
    size = check_regular(model, "glTF binary")
    with open(model, "rb") as f:
        f.seek(12)
        json_len = struct.unpack("<I", f.read(4))[0]
        f.seek(20 + json_len)
        head = f.read(8)
        if len(head) < 8:
            return None
        length, kind = struct.unpack("<II", head)
        if kind != 0x004E4942:
            return None
        if 28 + json_len + length > size:
            raise ContractError(f"binary glTF: its BIN chunk claims {length} bytes beyond the end of the file")
        return f.read(length)


# --- OBJ, STL, PLY ----------------------------------------------------------------------------

def _text_vertices(lines: list[str], keyword: str, what: str) -> list[str]:
    """Problems of the vertex lines (``keyword x y z ...``) of a text model: their number
    and their first three numbers."""
    rows, where = [], []
    for n, line in enumerate(lines, 1):
        words = line.split()
        if words and words[0] == keyword:
            rows.append(words[1:4])
            where.append(n)
            if len(rows) > MAX_MESH_VERTICES:
                return [_too_many(len(rows), what)]
    for k, row in enumerate(rows):
        if len(row) != 3:
            return [f"{what} line {where[k]}: a vertex needs three numbers"]
    try:
        xyz = np.array(rows, dtype=float).reshape(-1, 3)
    except ValueError:
        for k, row in enumerate(rows):
            try:
                [float(x) for x in row]
            except ValueError:
                return [f"{what} line {where[k]}: the vertex {' '.join(row)} is not three numbers"]
        raise
    bad = _bad_vertices(xyz)
    if bad.size:
        return [f"{what} line {where[bad[0]]}: the vertex {' '.join(rows[bad[0]])} is not finite numbers within "
                f"{MAX_ABS:g}"]
    return []


def _text_lines(model: Path, what: str) -> list[str]:
    return re.split(r"\r\n|\r|\n", read_bytes(model, MAX_MODEL_TEXT, what).decode("utf-8", errors="replace"))


def _obj_problems(model: Path) -> list[str]:
    return _text_vertices(_text_lines(model, "OBJ file"), "v", "OBJ")


def _stl_problems(model: Path) -> list[str]:
    size = check_regular(model, "STL file")
    with open(model, "rb") as f:
        head = f.read(84)
    if len(head) == 84:
        (n,) = struct.unpack_from("<I", head, 80)
        if size == 84 + 50 * n:
            if 3 * n > MAX_MESH_VERTICES:
                return [_too_many(3 * n, f"binary STL ({n} triangles)")]
            tri = np.fromfile(model, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                              count=n, offset=84)
            bad = _bad_vertices(tri["v"].reshape(-1, 3).astype(float))
            if bad.size:
                return [f"binary STL: triangle {bad[0] // 3} has a vertex that is not finite numbers within "
                        f"{MAX_ABS:g}"]
            return []
    if not head.lstrip().startswith(b"solid"):
        n = struct.unpack_from("<I", head, 80)[0] if len(head) == 84 else 0
        return [f"STL: neither ASCII (no 'solid') nor binary (its {n} triangles would take {84 + 50 * n} bytes, "
                f"the file has {size})"]
    return _text_vertices(_text_lines(model, "STL file"), "vertex", "ASCII STL")


_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}


def _ply_problems(model: Path) -> list[str]:
    size = check_regular(model, "PLY file")
    with open(model, "rb") as f:
        head = f.read(min(size, 1 << 20))
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0 or head.find(b"\n", end) < 0:
        return ["PLY: no 'ply' signature or no 'end_header' line in its first MiB"]
    body = head.index(b"\n", end) + 1
    fmt, elements = None, []                       # [(name, count, [(type, name) or ("list", ...)])]
    for line in head[:end].decode("latin-1").splitlines():
        w = line.split()
        if w[:1] == ["format"] and len(w) >= 2:
            fmt = w[1]
        elif w[:1] == ["element"] and len(w) == 3 and w[2].isdigit():
            elements.append((w[1], int(w[2]), []))
        elif w[:1] == ["property"] and elements and len(w) >= 3:
            elements[-1][2].append(("list",) if w[1] == "list" else (_PLY_TYPES.get(w[1]), w[2]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        return [f"PLY: unknown format {fmt!r}"]
    vertex = next((e for e in elements if e[0] == "vertex"), None)
    if vertex is None:
        return []
    n = vertex[1]
    if n > MAX_MESH_VERTICES:
        return [_too_many(n, "PLY header")]
    before = elements[:elements.index(vertex)]
    props = vertex[2]
    names = [p[1] for p in props if p[0] != "list"]
    if fmt == "ascii":
        lines = [ln for ln in _text_lines(model, "PLY file")[len(head[:body].decode("latin-1").splitlines()):]
                 if ln.strip()]
        skip = sum(e[1] for e in before)
        if len(lines) < skip + n:
            return [f"PLY header claims {n} vertices, the file holds {max(len(lines) - skip, 0)}"]
        if not all(c in names for c in "xyz") or any(p[0] == "list" for p in props):
            return []
        cols = [names.index(c) for c in "xyz"]
        rows = [ln.split() for ln in lines[skip:skip + n]]
        prefixed = [f"vertex {' '.join(r[c] for c in cols)}" if len(r) > max(cols) else "vertex ?" for r in rows]
        return _text_vertices(prefixed, "vertex", "PLY vertex")
    if any(p[0] == "list" or p[0] is None for e in before + [vertex] for p in e[2]):
        return []                                  # list properties first: record sizes vary
    order = "<" if fmt == "binary_little_endian" else ">"
    rec = lambda e: np.dtype([(f"p{i}_{p[1]}", order + p[0]) for i, p in enumerate(e[2])])  # noqa: E731
    offset = body + sum(rec(e).itemsize * e[1] for e in before)
    dt = rec(vertex)
    if offset + dt.itemsize * n > size:
        return [f"PLY header claims {n} vertices of {dt.itemsize} bytes, beyond the end of the file"]
    if not all(c in names for c in "xyz"):
        return []
    v = np.fromfile(model, dtype=dt, count=n, offset=offset)
    xyz = np.stack([v[f"p{names.index(c)}_{c}"].astype(float) for c in "xyz"], axis=1)
    bad = _bad_vertices(xyz)
    if bad.size:
        return [f"PLY vertex {bad[0]} is {xyz[bad[0]].tolist()}, not finite numbers within {MAX_ABS:g}"]
    return []
