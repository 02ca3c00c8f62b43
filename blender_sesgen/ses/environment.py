"""The scene around the objects and how it is rendered: LIGHT, WORLD, FOG, NOISE and
RENDER statements -> their :mod:`blender_sesgen.model` values, with their value checks.

Each function takes one statement (None where the singleton is absent) and returns its
model value, or None after recording an error; absent statements give the defaults.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from .. import model
from .checks import Checks, scalar, vec
from .statements import ParsedStatement

MAX_SEED = 2**31 - 1           # Cycles seeds are 32-bit signed
LIGHT_DEFAULTS = {  # per kind: strength (sun W/m^2, others W) and size (point radius, area edge)
    "sun": (3.0, 0.0), "point": (500.0, 0.1), "area": (500.0, 1.0)}


def light(stmt: ParsedStatement, check: Checks) -> Optional[model.Light]:
    kinds = [k for k in ("sun", "point", "area") if k in stmt.tags]
    if len(kinds) != 1:
        at = stmt.tags[kinds[1]].tag if len(kinds) > 1 else stmt.token
        check.err(at, "LIGHT needs exactly one of sun, point, area")
        return None
    kind = kinds[0]
    needs = {"sun": ("direction",), "point": ("position",), "area": ("position", "direction")}[kind]
    unused = {"sun": ("position", "size"), "point": ("direction",), "area": ()}[kind]
    for tag in needs:
        if tag not in stmt.tags:
            check.err(stmt.token, f"LIGHT {kind} needs the tag '{tag}'")
    for tag in unused:
        if tag in stmt.tags:
            check.err(stmt.tags[tag].tag, f"LIGHT {kind} takes no '{tag}'")
    check.unit_range(stmt, "colour")
    check.positive(stmt, "strength", allow_zero=True)
    check.positive(stmt, "size", allow_zero=(kind != "area"))
    direction = vec(stmt, "direction")
    if direction is not None:
        norm = float(np.linalg.norm(direction))
        if norm == 0.0:
            check.err(stmt.tags["direction"].tag, "LIGHT 'direction' must not be the zero vector")
            return None
        direction = tuple(float(x) / norm for x in direction)
    strength, size = LIGHT_DEFAULTS[kind]
    return model.Light(kind=kind, colour=vec(stmt, "colour", (1.0, 1.0, 1.0)),
                       strength=float(scalar(stmt, "strength", strength)),
                       position=vec(stmt, "position"), direction=direction,
                       size=float(scalar(stmt, "size", size)))


def world(stmt: Optional[ParsedStatement], check: Checks) -> Optional[model.World]:
    if stmt is None:
        return None
    has_colour, has_sky = "colour" in stmt.tags, "sky" in stmt.tags
    if has_colour == has_sky:
        check.err(stmt.token, "WORLD needs either 'colour r g b' or 'sky' (one of them)")
        return None
    if has_colour:
        for tag in ("elevation", "azimuth"):
            if tag in stmt.tags:
                check.err(stmt.tags[tag].tag, f"WORLD '{tag}' is only for 'WORLD sky'")
    check.unit_range(stmt, "colour")
    check.positive(stmt, "strength", allow_zero=True)
    elevation = scalar(stmt, "elevation", model.World.sun_elevation_deg)
    if not -90.0 <= elevation <= 90.0:
        check.err(stmt.tags["elevation"].tokens[0], f"WORLD 'elevation' must lie in -90..90 degrees, got {elevation:g}")
    return model.World(kind="sky" if has_sky else "colour",
                       colour=vec(stmt, "colour", model.World.colour),
                       strength=float(scalar(stmt, "strength", 1.0)),
                       sun_elevation_deg=float(elevation),
                       sun_azimuth_deg=float(scalar(stmt, "azimuth", 0.0)))


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
    tv = stmt.tags.get(name)
    if tv is None:
        return 0
    if not 0 <= tv.values[0] <= MAX_SEED:
        check.err(tv.tokens[0], f"{stmt.keyword} '{name}' must lie in 0..{MAX_SEED}, got {tv.tokens[0].text}")
    return int(tv.values[0])
