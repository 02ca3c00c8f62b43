"""The scene around the objects and how it is rendered: LIGHT, WORLD, FOG, NOISE and
RENDER statements -> their :mod:`blender_sesgen.scene.model` values, with their value checks.

Each function takes one statement (None where the singleton is absent) and returns its
model value, or None after recording an error; absent statements give the defaults.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..scene import model
from ..scene.lighting import AEROSOL_RANGE, BUILTIN_HDRIS, HDRI_SUFFIXES
from .checks import Checks, scalar, vec
from .materials import image_file_ok
from .statements import ParsedStatement, did_you_mean

LIGHT_KINDS = ("sun", "point", "spot", "area", "portal")
LIGHT_DEFAULTS = {  # per kind: strength (sun W/m^2, others W) and size (point/spot radius, area edge)
    "sun": (3.0, 0.0), "point": (500.0, 0.1), "spot": (500.0, 0.05), "area": (500.0, 1.0), "portal": (0.0, 1.0)}
_LIGHT_NEEDS = {"sun": ("direction",), "point": ("position",), "spot": ("position", "direction"),
                "area": ("position", "direction"), "portal": ("position", "direction")}
_LIGHT_TAKES_NO = {"sun": ("position", "size", "angle", "blend"), "point": ("direction", "angle", "blend"),
                   "spot": (), "area": ("angle", "blend"),
                   "portal": ("angle", "blend", "strength", "colour")}


def light(stmt: ParsedStatement, check: Checks) -> Optional[model.Light]:
    kinds = [k for k in LIGHT_KINDS if k in stmt.tags]
    if len(kinds) != 1:
        at = stmt.tags[kinds[1]].tag if len(kinds) > 1 else stmt.token
        check.err(at, f"LIGHT needs exactly one of {', '.join(LIGHT_KINDS)}")
        return None
    kind = kinds[0]
    for tag in _LIGHT_NEEDS[kind]:
        if tag not in stmt.tags:
            check.err(stmt.token, f"LIGHT {kind} needs the tag '{tag}'")
    for tag in _LIGHT_TAKES_NO[kind]:
        if tag in stmt.tags:
            check.err(stmt.tags[tag].tag, f"LIGHT {kind} takes no '{tag}'")
    size_tv = stmt.tags.get("size")
    if size_tv is not None and len(size_tv.values) == 2 and kind not in ("area", "portal"):
        check.err(size_tv.tag, f"LIGHT {kind} 'size' takes one number (two are for area and portal rectangles)")
    check.unit_range(stmt, "colour")
    check.unit_range(stmt, "blend")
    check.positive(stmt, "strength", allow_zero=True)
    check.positive(stmt, "size", allow_zero=kind not in ("area", "portal"))
    angle = float(scalar(stmt, "angle", 45.0))
    if "angle" in stmt.tags and not 0.0 < angle <= 180.0:
        check.err(stmt.tags["angle"].tokens[0], f"LIGHT spot 'angle' (the cone's full angle) must lie in "
                                                f"0..180 degrees, got {angle:g}")
    direction = vec(stmt, "direction")
    if direction is not None:
        norm = float(np.linalg.norm(direction))
        if norm == 0.0:
            check.err(stmt.tags["direction"].tag, "LIGHT 'direction' must not be the zero vector")
            return None
        direction = tuple(float(x) / norm for x in direction)
    strength, size = LIGHT_DEFAULTS[kind]
    sizes = vec(stmt, "size", (size,))
    return model.Light(kind=kind, colour=vec(stmt, "colour", (1.0, 1.0, 1.0)),
                       strength=float(scalar(stmt, "strength", strength)),
                       position=vec(stmt, "position"), direction=direction,
                       size=float(sizes[0]), size_y=float(sizes[1]) if len(sizes) == 2 else None,
                       spot_angle_deg=angle, spot_blend=float(scalar(stmt, "blend", 0.15)))


def world(stmt: Optional[ParsedStatement], check: Checks) -> Optional[model.World]:
    if stmt is None:
        return None
    kinds = [k for k in ("colour", "sky", "hdri") if k in stmt.tags]
    if len(kinds) != 1:
        check.err(stmt.token, "WORLD needs exactly one of 'colour r g b', 'sky' or 'hdri NAME|FILE'")
        return None
    kind = kinds[0]
    only = {"elevation": "sky", "azimuth": "sky", "aerosol": "sky", "rotation": "hdri"}
    for tag, owner in only.items():
        if tag in stmt.tags and kind != owner:
            check.err(stmt.tags[tag].tag, f"WORLD '{tag}' is only for 'WORLD {owner}'")
    check.unit_range(stmt, "colour")
    check.positive(stmt, "strength", allow_zero=True)
    elevation = scalar(stmt, "elevation", model.World.sun_elevation_deg)
    if not -90.0 <= elevation <= 90.0:
        check.err(stmt.tags["elevation"].tokens[0], f"WORLD 'elevation' must lie in -90..90 degrees, got {elevation:g}")
    aerosol = scalar(stmt, "aerosol", model.World.aerosol)
    if not AEROSOL_RANGE[0] <= aerosol <= AEROSOL_RANGE[1]:
        check.err(stmt.tags["aerosol"].tokens[0], f"WORLD 'aerosol' must lie in "
                  f"{AEROSOL_RANGE[0]:g}..{AEROSOL_RANGE[1]:g} (1 = a city's clear day), got {aerosol:g}")
    hdri = _hdri(stmt, check) if kind == "hdri" else (None, None, None)
    return model.World(kind=kind, colour=vec(stmt, "colour", model.World.colour),
                       strength=float(scalar(stmt, "strength", 1.0)),
                       sun_elevation_deg=float(elevation),
                       sun_azimuth_deg=float(scalar(stmt, "azimuth", 0.0)),
                       aerosol=float(aerosol),
                       hdri=hdri[0], hdri_path=hdri[1], hdri_source=hdri[2],
                       rotation_deg=float(scalar(stmt, "rotation", 0.0)))


def _hdri(stmt: ParsedStatement, check: Checks):
    """(built-in name, None, None) or (None, absolute path, as written); errors recorded."""
    tok = stmt.tags["hdri"].tokens[0]
    text = tok.text
    if tok.lower in BUILTIN_HDRIS:
        return tok.lower, None, None
    path = check.existing_file(stmt, "hdri", f"WORLD 'hdri' '{text}' is neither a built-in HDRI "
                               f"({', '.join(BUILTIN_HDRIS)}) nor an existing file (looked for "
                               f"{check.base_dir / text}){did_you_mean(text, BUILTIN_HDRIS)}")
    if path is None or not image_file_ok(stmt, "hdri", path, check, suffixes=HDRI_SUFFIXES):
        return None, None, None
    return None, str(path), text


def fog(stmt: Optional[ParsedStatement], check: Checks) -> Optional[model.Fog]:
    if stmt is None:
        return None
    check.positive(stmt, "start", allow_zero=True)
    check.unit_range(stmt, "colour")
    start, end = float(stmt.get("start")), float(stmt.get("end"))
    if end <= start:
        check.err(stmt.tags["end"].tokens[0], f"FOG 'end' ({end:g}) must be greater than 'start' ({start:g})")
    return model.Fog(start=start, end=end, colour=vec(stmt, "colour", (0.7, 0.7, 0.7)))


def noise(stmt: Optional[ParsedStatement], check: Checks) -> Optional[model.Noise]:
    if stmt is None:
        return None
    check.positive(stmt, "sigma", allow_zero=True)
    return model.Noise(sigma=float(stmt.get("sigma")), seed=_seed(stmt, check))


def look(stmt: Optional[ParsedStatement], check: Checks) -> model.Look:
    if stmt is None:
        return model.Look()
    view = str(stmt.get("view", "agx"))
    look_name = str(stmt.get("look", "base"))
    if look_name != "base" and view != "agx":
        check.err(stmt.tags["look"].tokens[0], f"LOOK 'look' {look_name} is one of AgX's looks: it needs 'view agx'")
    tv = stmt.tags.get("exposure")
    if tv is None:
        return model.Look(view=view, look=look_name)
    tok = tv.tokens[0]
    if tok.kind == "word" and tok.lower == "auto":
        return model.Look(view=view, look=look_name, auto_exposure=True)
    try:
        ev = float(tok.text) if tok.kind == "number" else None
    except ValueError:
        ev = None
    if ev is None or not -20.0 <= ev <= 20.0:
        check.err(tok, f"LOOK 'exposure' must be 'auto' or a number of stops in -20..20, got '{tok.shown()}'")
        return model.Look(view=view, look=look_name)
    return model.Look(view=view, look=look_name, auto_exposure=False, exposure_ev=ev)


def render(stmt: Optional[ParsedStatement], check: Checks) -> model.RenderSettings:
    if stmt is None:
        return model.RenderSettings()
    samples = stmt.tags.get("samples")
    if samples is not None and not 1 <= samples.values[0] <= 1_000_000:
        check.err(samples.tokens[0], f"RENDER 'samples' must lie in 1..1000000, got {samples.tokens[0].text}")
    denoise = stmt.get("denoise")
    return model.RenderSettings(quality=stmt.get("quality"),
                                samples=None if samples is None else int(samples.values[0]),
                                denoise=None if denoise is None else denoise == "on", seed=_seed(stmt, check))


def _seed(stmt: ParsedStatement, check: Checks, name: str = "seed") -> int:
    return check.seed(stmt, name)
