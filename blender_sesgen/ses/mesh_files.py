"""The files a MESH model refers to, found and checked at parse time (pure: stdlib only).

A model file can make the importer open other files: a glTF's ``buffers[].uri`` and
``images[].uri``, an OBJ's ``mtllib`` and the texture maps of those MTL files. A model
downloaded from elsewhere could thus read any file of this machine into a render
(``"uri": "../../../../etc/passwd"``, ``mtllib /home/me/.ssh/id_rsa``). So every reference
must resolve (symlinks followed) to a regular file inside the model's own folder (its
subfolders included); a reference that leaves it or an absolute path is an error unless the
MESH statement carries ``allow_external``. A referenced file that does not exist (or is a
FIFO or a device), or an image that does not decode (``image_check``), is an error either
way: the importer would fail, fall back to a file named relative to the working folder,
or render a placeholder. ``data:`` URIs are
embedded data and always fine.

:func:`reference_problems` returns the problems (messages) of one model file; PLY and STL
refer to nothing. References are resolved as Blender's importers resolve them (glTF:
percent-decoded URI joined to the file's folder; OBJ: ``mtllib`` takes the rest of the line;
MTL maps: the path after the options, joined to the MTL's folder).
"""
from __future__ import annotations

import json
import os
import re
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Optional
from urllib.parse import unquote

from ..contract.errors import ContractError
from ..contract.inputs import MiB, check_regular, is_inside, is_number, read_bytes
from ..image_check import ImageFileError, check_image

MAX_MODEL_TEXT = 256 * MiB    # an OBJ, MTL or glTF JSON larger than this is refused
# MTL statements whose image Blender's OBJ importer loads (keywords are case-sensitive there)
_MTL_MAPS = {"map_Kd", "map_Ks", "map_Ns", "map_d", "refl", "map_refl", "map_Ke", "bump", "map_Bump", "map_bump",
             "map_Pr", "map_Pm", "map_Ps"}
# map options before the file name and how many values each takes (-o, -s: up to 3 numbers, -bm 1)
_MTL_OPTIONS = {"-o": 3, "-s": 3, "-bm": 1, "-type": 1, "-blendu": 1, "-blendv": 1, "-boost": 1, "-cc": 1,
                "-clamp": 1, "-imfchan": 1, "-mm": 2, "-t": 3, "-texres": 1}


@dataclass(frozen=True)
class Reference:
    text: str                 # as written in the file
    owner: Path               # the file that holds the reference
    line: Optional[int]       # its line there (text formats)
    what: str                 # "buffer", "image", "material library", "texture map"


def reference_problems(model: Path, allow_external: bool = False) -> list[str]:
    """Messages for every reference of ``model`` that is missing, unreadable or (without
    ``allow_external``) outside the model's folder; an empty list when all is well."""
    model = Path(model)
    ext = model.suffix.lower()
    try:
        if ext in (".gltf", ".glb"):
            refs = _gltf_references(model, gltf_document(model))
        elif ext == ".obj":
            return _obj_problems(model, allow_external)
        else:
            return []
    except ContractError as e:
        return [e.detail]
    return [p for p in (_problem(r, model.parent, allow_external) for r in refs) if p]


# --- glTF --------------------------------------------------------------------------------

def _glb_json(path: Path) -> bytes:
    """The JSON chunk of a binary glTF (only it is read)."""
    size = check_regular(path, "glTF binary")
    with open(path, "rb") as f:
        head = f.read(20)
        if len(head) < 20 or head[:4] != b"glTF":
            raise ContractError("not a binary glTF (no 'glTF' header)")
        _, version, length, chunk_len, chunk_type = struct.unpack("<4sIIII", head)
        if version != 2 or chunk_type != 0x4E4F534A or chunk_len > min(size - 20, MAX_MODEL_TEXT) or length > size:
            raise ContractError("binary glTF header is corrupt or truncated (version 2, JSON chunk first)")
        data = f.read(chunk_len)
    if len(data) != chunk_len:
        raise ContractError("binary glTF is truncated inside its JSON chunk")
    return data


def gltf_document(model: Path) -> dict:
    """The JSON document of a .gltf, or of a .glb's JSON chunk (ContractError if none)."""
    data = _glb_json(model) if model.suffix.lower() == ".glb" else read_bytes(model, MAX_MODEL_TEXT, "glTF file")
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise ContractError(f"not valid glTF JSON ({e})") from None
    if not isinstance(doc, dict):
        raise ContractError("not valid glTF JSON (no top-level object)")
    return doc


def _gltf_references(model: Path, doc: dict) -> list[Reference]:
    refs = []
    for key, what in (("buffers", "buffer"), ("images", "image")):
        items = doc.get(key) or []
        if not isinstance(items, list):
            raise ContractError(f"glTF '{key}' is not a list")
        for item in items:
            uri = item.get("uri") if isinstance(item, dict) else None
            if uri is None:
                continue  # bufferView images and the GLB's own buffer
            if not isinstance(uri, str):
                raise ContractError(f"glTF {what} uri is not a string")
            refs.append(Reference(uri, model, None, what))
    return refs


# --- OBJ and MTL (as Blender's OBJ importer reads them) -----------------------------------

def _lines(path: Path, what: str) -> list[str]:
    text = read_bytes(path, MAX_MODEL_TEXT, what).decode("utf-8", errors="replace")
    return re.split(r"\r\n|\r|\n", text)


def _unquote(text: str) -> str:
    return text[1:-1] if len(text) > 2 and text[0] == text[-1] == '"' else text


def _obj_problems(model: Path, allow_external: bool) -> list[str]:
    """``mtllib REST`` names one library (the whole rest of the line, quotes removed),
    relative to the OBJ's folder; each library's texture maps are checked in turn."""
    problems: list[str] = []
    for lineno, raw in enumerate(_lines(model, "OBJ file"), 1):
        words = raw.split()
        if len(words) < 2 or words[0] != "mtllib":
            continue
        ref = Reference(_unquote(raw.strip()[len("mtllib"):].strip()), model, lineno, "material library")
        problem = _problem(ref, model.parent, allow_external)
        if problem:
            problems.append(problem)
        else:
            problems += _mtl_problems(_target(ref), model.parent, allow_external)
    return problems


def _mtl_problems(mtl: Path, folder: Path, allow_external: bool) -> list[str]:
    """Texture maps: ``KEYWORD [options] PATH``, PATH (quotes removed) relative to the MTL's folder."""
    try:
        lines = _lines(mtl, "material library")
    except ContractError as e:
        return [f"{mtl.name}: {e.detail}"]
    problems = []
    for lineno, raw in enumerate(lines, 1):
        words = raw.split()
        if not words or words[0] not in _MTL_MAPS:
            continue
        i = 1
        while i < len(words) and words[i] in _MTL_OPTIONS:
            n, i = _MTL_OPTIONS[words[i]], i + 1
            if words[i - 1] in ("-o", "-s", "-bm"):  # up to n numbers
                while n and i < len(words) and is_number(words[i]):
                    i, n = i + 1, n - 1
            else:  # exactly n words
                i += n
        rest = " ".join(words[i:]).replace('"', "")
        if rest:
            p = _problem(Reference(rest, mtl, lineno, "texture map"), folder, allow_external)
            if p:
                problems.append(p)
    return problems


# --- the rule -----------------------------------------------------------------------------

def _target(ref: Reference) -> Path:
    """Where the importer looks: glTF URIs are percent-decoded (``data:`` aside); an absolute
    path stays absolute."""
    text = unquote(ref.text) if ref.what in ("buffer", "image") else ref.text
    return Path(os.path.normpath(ref.owner.parent / text))


def _problem(ref: Reference, folder: Path, allow_external: bool) -> Optional[str]:
    shown = ref.text if len(ref.text) <= 80 else ref.text[:77] + "..."
    where = f"{ref.owner.name}" + (f":{ref.line}" if ref.line else "")
    if ref.what in ("buffer", "image") and ref.text.startswith("data:"):
        return None  # embedded
    if "\0" in ref.text:
        return f"{where}: {ref.what} '{shown}' is not a valid file name"
    path = _target(ref)
    if not allow_external and (Path(ref.text).is_absolute() or not is_inside(path, folder)):
        return (f"{where}: {ref.what} '{shown}' lies outside the model's folder {folder}; "
                "add 'allow_external' to the MESH statement if you trust this model")
    try:
        check_regular(path, f"{ref.what} file")
    except ContractError as e:
        return f"{where}: {ref.what} '{shown}': {e.detail}"
    if ref.what in ("image", "texture map"):
        try:
            check_image(path)
        except ImageFileError as e:
            return f"{where}: {ref.what} '{shown}' is not a usable image: {e}"
    return None
