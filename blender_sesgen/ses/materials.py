"""Surface appearance: the ``texture`` / ``texture_scale`` tags -> TextureRef, MATERIAL
statements -> named :class:`blender_sesgen.scene.model.Material` (names unique), and the library
materials objects name directly (``material asphalt`` with no MATERIAL asphalt).

A texture is a built-in (number or name, see blender_sesgen.scene.textures) or an image file
relative to the script; image files (textures and PBR maps) are checked to be images
(``blender_sesgen.files.image_check``: decoded or walked, so a corrupt or truncated file is an
error here, not a magenta surface in the render).
"""
from __future__ import annotations

import os
from typing import Optional

from ..scene import model
from ..scene.materials import LIBRARY, OVERRIDES, entry, is_library_name
from ..files.image_check import ImageFileError, check_image
from ..scene.textures import BUILTIN_TEXTURES, NAME_TO_NUMBER
from .checks import Checks, scalar, vec
from .lexer import Token
from .statements import ParsedStatement, did_you_mean

# what ``glow`` takes: diffusing glazing (a pane that passes light; not foliage)
DIFFUSING = tuple(name for name, e in LIBRARY.items() if e.transmittance > 0 and e.semantic_class == "window")

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tga", ".tif", ".tiff", ".exr", ".hdr", ".webp")


def texture(stmt: ParsedStatement, check: Checks) -> Optional[model.TextureRef]:
    """The statement's texture (None if it has none, is 0, or is wrong: then with an error)."""
    tv = stmt.tags.get("texture")
    scale_tv = stmt.tags.get("texture_scale")
    check.positive(stmt, "texture_scale")
    scale = float(scale_tv.values[0]) if scale_tv else 1.0
    if tv is None:
        if scale_tv is not None:
            check.err(scale_tv.tag, f"{stmt.keyword} 'texture_scale' needs a 'texture'")
        return None
    tok: Token = tv.tokens[0]
    text = tv.values[0]
    if tok.kind == "number":
        value = float(text)
        if not value.is_integer():
            check.err(tok, f"{stmt.keyword} 'texture' number must be an integer, got {text}")
            return None
        number = int(value)
        if number == 0:
            return None
        if number not in BUILTIN_TEXTURES:
            check.err(tok, f"{stmt.keyword} 'texture' {number} is not a built-in texture "
                           f"(0 = none, 1..{max(BUILTIN_TEXTURES)}: see docs/ses-language.md)")
            return None
        return model.TextureRef(kind="builtin", name=BUILTIN_TEXTURES[number][0], number=number, scale=scale)
    if tok.lower in NAME_TO_NUMBER:  # bare or quoted: a name ("./noise" names a file)
        number = NAME_TO_NUMBER[tok.lower]
        return model.TextureRef(kind="builtin", name=tok.lower, number=number, scale=scale)
    hint = did_you_mean(text, NAME_TO_NUMBER)
    path = check.existing_file(stmt, "texture", f"{stmt.keyword} 'texture' '{text}' is neither a built-in "
                               f"texture name nor an existing image file (looked for "
                               f"{os.path.join(check.base_dir, text)}){hint}")
    if path is None:
        return None
    if not image_file_ok(stmt, "texture", path, check):
        return None
    return model.TextureRef(kind="image", name=path.stem, path=str(path), source=text, scale=scale)


def image_file_ok(stmt: ParsedStatement, tag: str, path, check: Checks, suffixes=IMAGE_SUFFIXES) -> bool:
    """The file of ``tag`` has an image suffix and decodes as an image (else an error)."""
    tok = stmt.tags[tag].tokens[0]
    if path.suffix.lower() not in suffixes:
        check.err(tok, f"{stmt.keyword} '{tag}' file '{tok.text}' is not an image ({', '.join(suffixes)})")
        return False
    try:
        check_image(path)
    except ImageFileError as e:
        check.err(tok, f"{stmt.keyword} '{tag}' file '{tok.text}' is not a usable image: {e}")
        return False
    return True


def _image(stmt: ParsedStatement, tag: str, check: Checks) -> Optional[str]:
    if tag not in stmt.tags:
        return None
    path = check.existing_file(stmt, tag)
    if path is None or not image_file_ok(stmt, tag, path, check):
        return None
    return str(path)


def _library(stmt: ParsedStatement, check: Checks) -> Optional[model.LibraryParams]:
    """``library L`` and its tags (None if absent or wrong: then with an error)."""
    tv = stmt.tags["library"]
    name = str(tv.values[0])
    if not is_library_name(name):
        check.err(tv.tokens[0], f"MATERIAL 'library' '{name}' is not a library material"
                                f"{did_you_mean(name, LIBRARY)} "
                                f"(library: {', '.join(LIBRARY)})")
        return None
    for tag in ("texture", "specular", "emission", "emission_strength", "albedo_map", "normal_map",
                "roughness_map", "map_size"):
        if tag in stmt.tags:
            check.err(stmt.tags[tag].tag, f"MATERIAL '{tag}' cannot be combined with 'library' "
                                          f"(a library material takes {', '.join(OVERRIDES)})")
            return None
    lib = entry(name)
    return model.LibraryParams(
        name=lib.name, scale=float(scalar(stmt, "texture_scale", 1.0)),
        wear=float(scalar(stmt, "wear", lib.wear)), bump=float(scalar(stmt, "bump", 1.0)),
        variation=float(scalar(stmt, "variation", lib.variation)), seed=int(scalar(stmt, "seed", 0)))


def library_material(name: str) -> model.Material:
    """The material an object gets from ``material NAME`` when NAME is a library entry and
    no MATERIAL defines it: the entry with its documented defaults."""
    lib = entry(name)
    return model.Material(name=name, colour=lib.colour, roughness=lib.roughness, metallic=lib.metallic,
                          library=model.LibraryParams(name=lib.name, wear=lib.wear, variation=lib.variation))


def materials(statements: list[ParsedStatement], check: Checks) -> dict[str, model.Material]:
    """The MATERIAL statements' materials by name, in source order (faulty ones left out)."""
    found: dict[str, model.Material] = {}
    first_line: dict[str, int] = {}
    for stmt in statements:
        name = stmt.get("name")
        if name in found or name in first_line:
            check.err(stmt.tags["name"].tokens[0],
                      f"MATERIAL '{name}' is defined twice (first on line {first_line[name]})")
            continue
        first_line[name] = stmt.token.line
        before = len(check.diags.items)
        for tag in ("colour", "emission", "roughness", "metallic", "specular", "wear", "variation"):
            check.unit_range(stmt, tag)
        check.positive(stmt, "emission_strength", allow_zero=True)
        check.positive(stmt, "bump", allow_zero=True)
        check.positive(stmt, "map_size")
        check.seed(stmt)
        library = _library(stmt, check) if "library" in stmt.tags else None
        if "library" not in stmt.tags:
            for tag in ("wear", "bump", "variation", "seed"):
                if tag in stmt.tags and not (tag == "bump" and "normal_map" in stmt.tags):
                    check.err(stmt.tags[tag].tag, f"MATERIAL '{tag}' needs 'library L' "
                                                  "(it changes a library material)")
        maps = None
        if any(t in stmt.tags for t in ("albedo_map", "normal_map", "roughness_map")):
            if "texture" in stmt.tags:
                check.err(stmt.tags["texture"].tag, "MATERIAL 'texture' cannot be combined with image maps "
                                                    "(albedo_map is the colour image)")
            paths = [_image(stmt, t, check) for t in ("albedo_map", "normal_map", "roughness_map")]
            maps = model.ImageMaps(albedo=paths[0], normal=paths[1], roughness=paths[2],
                                   sources=tuple(scalar(stmt, t) for t in ("albedo_map", "normal_map", "roughness_map")),
                                   size_m=float(scalar(stmt, "map_size", 1.0)),
                                   bump=float(scalar(stmt, "bump", 1.0)))
        elif "map_size" in stmt.tags:
            check.err(stmt.tags["map_size"].tag, "MATERIAL 'map_size' needs an image map "
                                                 "(albedo_map, normal_map or roughness_map)")
        tex = None if library is not None else texture(stmt, check)
        if "glow" in stmt.tags and (library is None or library.name not in DIFFUSING):
            check.err(stmt.tags["glow"].tag, "MATERIAL 'glow' needs a diffusing glazing library material "
                                             f"(library {', '.join(DIFFUSING)})")
        if len(check.diags.items) != before:
            continue
        lib = entry(library.name) if library is not None else None
        found[name] = model.Material(
            name=name, colour=vec(stmt, "colour", lib.colour if lib else (0.8, 0.8, 0.8)), texture=tex,
            roughness=float(scalar(stmt, "roughness", lib.roughness if lib else 0.5)),
            metallic=float(scalar(stmt, "metallic", lib.metallic if lib else 0.0)),
            specular=float(scalar(stmt, "specular", 0.5)),
            emission=vec(stmt, "emission", (0.0, 0.0, 0.0)),
            emission_strength=float(scalar(stmt, "emission_strength", 0.0)),
            library=library, maps=maps, glow="glow" in stmt.tags)
    return found
