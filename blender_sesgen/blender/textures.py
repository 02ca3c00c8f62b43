"""The built-in procedural textures (numbers and names in ``blender_sesgen.scene.textures``) and
image textures, as Cycles shader node setups.

Every builtin is evaluated on the object's own coordinates (``Object`` output of Texture
Coordinate: object-local, in scene units), so patterns stick to the surface and never swim
as the camera moves, and a pattern has the same physical size on every object. ``scale``
(TextureRef.scale) multiplies the frequency. Each setup mixes detail at several scales
(roughly 2 cm to 50 cm at scale 1) with strong luminance contrast: at 640x480, f = 389 px
and 3 m, one pixel is ~8 mm, so the finest detail spans ~3 px (finer detail would alias).

``texture_colour(nt, ref)`` returns an output socket with the texture's colour (0..1).
"""
from __future__ import annotations

from typing import Callable


from ..scene.textures import BUILTIN_TEXTURES
from .datablocks import load_image
from .library.graph import G, box_uv


def _noise_fac(g: G, p, scale, detail):
    """The textures' fBm noise (roughness 0.6, lacunarity 2), its factor."""
    return g.noise(p, scale, detail=detail, roughness=0.6)


GREY = lambda v: (v, v, v)  # noqa: E731
OFFSET = (0.1371, 0.2913, 0.1733)  # scene units, added to object coordinates


def _noise(g: G, p, normal):
    a = g.ramp(_noise_fac(g, p, 3.0, 4.0), [(0.40, GREY(0.05)), (0.60, GREY(0.95))])
    b = g.ramp(_noise_fac(g, p, 25.0, 3.0), [(0.35, GREY(0.35)), (0.65, GREY(1.0))])
    return g.cmix(a, b, 1.0, "MULTIPLY")


def _voronoi(g: G, p, normal):
    cells = g.voronoi(p, 6.0)
    edges = g.voronoi(p, 6.0, feature="DISTANCE_TO_EDGE")
    border = g.ramp(edges.outputs["Distance"], [(0.02, GREY(0.03)), (0.06, GREY(1.0))])
    tone = g.ramp(cells.outputs["Color"], [(0.0, (0.15, 0.2, 0.3)), (1.0, (0.95, 0.9, 0.8))])
    return g.cmix(tone, border, 1.0, "MULTIPLY")


def _brick_pattern(g: G, p, normal, overlay: tuple, *, rows_offset: float, every: int, colours, mortar,
                   scale: float, mortar_size: float, row_height: float):
    """Blender's brick texture on the planar mapping (``colours``: two RGB, ``mortar`` RGB,
    every ``every``-th row offset by ``rows_offset``; bricks 0.5 wide, no bias) multiplied
    by a grey noise overlay (scale, detail, ramp stops)."""
    uv, _, _ = box_uv(g, p, normal)  # the first two axes in the surface (bricks use x and y)
    b = g.node("ShaderNodeTexBrick", {"Vector": uv, "Color1": colours[0], "Color2": colours[1],
                                      "Mortar": mortar, "Scale": scale, "Mortar Size": mortar_size, "Bias": 0.0,
                                      "Brick Width": 0.5, "Row Height": row_height},
               offset=rows_offset, offset_frequency=every, squash=1.0, squash_frequency=every)
    o_scale, o_detail, stops = overlay
    return g.cmix(b.outputs["Color"], g.ramp(_noise_fac(g, p, o_scale, o_detail), stops), 1.0, "MULTIPLY")


def _bricks(g: G, p, normal):
    return _brick_pattern(g, p, normal, (30.0, 2.0, [(0.3, GREY(0.55)), (0.7, GREY(1.0))]), rows_offset=0.5,
                          every=2, colours=((0.55, 0.18, 0.10), (0.85, 0.45, 0.30)), mortar=(0.9, 0.9, 0.85),
                          scale=2.0, mortar_size=0.03, row_height=0.25)


def _checker(g: G, p, normal):
    c = g.node("ShaderNodeTexChecker", {"Vector": p, "Color1": GREY(0.95), "Color2": GREY(0.05), "Scale": 4.0})
    mod = g.ramp(_noise_fac(g, p, 12.0, 4.0), [(0.3, GREY(0.4)), (0.7, GREY(1.0))])
    return g.cmix(c.outputs["Color"], mod, 1.0, "MULTIPLY")


def _marble(g: G, p, normal):
    w = g.node("ShaderNodeTexWave", {"Vector": p, "Scale": 1.5, "Distortion": 12.0, "Detail": 6.0,
                                     "Detail Scale": 2.0},
               wave_type="BANDS", bands_direction="DIAGONAL", wave_profile="SIN")
    veins = g.ramp(w.outputs["Fac"], [(0.0, (0.25, 0.25, 0.3)), (0.15, (0.93, 0.92, 0.9)), (1.0, (0.75, 0.74, 0.72))])
    fine = g.ramp(_noise_fac(g, p, 40.0, 2.0), [(0.3, GREY(0.7)), (0.7, GREY(1.0))])
    return g.cmix(veins, fine, 1.0, "MULTIPLY")


def _wood(g: G, p, normal):
    w = g.node("ShaderNodeTexWave", {"Vector": p, "Scale": 3.0, "Distortion": 4.0, "Detail": 3.0},
               wave_type="RINGS", rings_direction="Y", wave_profile="SAW")
    rings = g.ramp(w.outputs["Fac"], [(0.0, (0.75, 0.5, 0.28)), (0.8, (0.45, 0.25, 0.1)), (1.0, (0.2, 0.1, 0.04))])
    grain = g.ramp(_noise_fac(g, g.vscale(p, (60.0, 2.0, 60.0)), 1.0, 3.0), [(0.35, GREY(0.5)), (0.65, GREY(1.0))])
    return g.cmix(rings, grain, 1.0, "MULTIPLY")


def _granite(g: G, p, normal):
    base = g.ramp(_noise_fac(g, p, 4.0, 3.0), [(0.4, (0.45, 0.4, 0.4)), (0.6, (0.75, 0.7, 0.68))])
    speck_dark = g.ramp(_noise_fac(g, p, 45.0, 1.0), [(0.58, GREY(1.0)), (0.62, GREY(0.08))])
    speck_light = g.ramp(_noise_fac(g, p, 30.0, 1.0), [(0.60, GREY(0.0)), (0.64, GREY(0.6))])
    return g.cmix(g.cmix(base, speck_dark, 1.0, "MULTIPLY"), speck_light, 1.0, "ADD")


def _tiles(g: G, p, normal):
    return _brick_pattern(g, p, normal, (15.0, 4.0, [(0.3, GREY(0.6)), (0.7, GREY(1.0))]), rows_offset=0.0,
                          every=1, colours=((0.2, 0.35, 0.55), (0.9, 0.88, 0.8)), mortar=(0.08, 0.08, 0.08),
                          scale=3.0, mortar_size=0.04, row_height=0.5)


def _blotches(g: G, p, normal):
    coarse = g.ramp(_noise_fac(g, p, 1.5, 2.0), [(0.45, (0.1, 0.25, 0.1)), (0.55, (0.9, 0.85, 0.5))])
    fine = g.ramp(_noise_fac(g, p, 20.0, 4.0), [(0.35, GREY(0.3)), (0.65, GREY(1.0))])
    return g.cmix(coarse, fine, 1.0, "MULTIPLY")


def _gravel(g: G, p, normal):
    stones = g.voronoi(p, 20.0)
    edges = g.voronoi(p, 20.0, feature="DISTANCE_TO_EDGE")
    tone = g.ramp(stones.outputs["Color"], [(0.0, GREY(0.25)), (1.0, (0.9, 0.85, 0.75))])
    border = g.ramp(edges.outputs["Distance"], [(0.03, GREY(0.05)), (0.12, GREY(1.0))])
    grain = g.ramp(_noise_fac(g, p, 60.0, 1.0), [(0.3, GREY(0.75)), (0.7, GREY(1.0))])
    return g.cmix(g.cmix(tone, border, 1.0, "MULTIPLY"), grain, 1.0, "MULTIPLY")


def _concrete(g: G, p, normal):
    base = g.ramp(_noise_fac(g, p, 6.0, 6.0), [(0.35, GREY(0.45)), (0.65, GREY(0.8))])
    pit = g.ramp(g.voronoi(p, 25.0).outputs["Distance"], [(0.08, GREY(0.1)), (0.14, GREY(1.0))])
    return g.cmix(base, pit, 1.0, "MULTIPLY")


def _camouflage(g: G, p, normal):
    f = g.add(g.mul(_noise_fac(g, p, 2.0, 3.0), 0.7), g.mul(_noise_fac(g, p, 9.0, 2.0), 0.3))
    return g.ramp(f, [(0.0, (0.2, 0.18, 0.1)), (0.45, (0.35, 0.4, 0.2)), (0.52, (0.7, 0.65, 0.45)),
                      (0.58, (0.08, 0.08, 0.06))], interpolation="CONSTANT")


BUILDERS: dict[str, Callable] = {
    "noise": _noise, "voronoi": _voronoi, "bricks": _bricks, "checker": _checker,
    "marble": _marble, "wood": _wood, "granite": _granite, "tiles": _tiles,
    "blotches": _blotches, "gravel": _gravel, "concrete": _concrete, "camouflage": _camouflage,
}
assert set(BUILDERS) == {name for name, _ in BUILTIN_TEXTURES.values()}


def texture_colour(nt, ref, spherical: bool = False):
    """Build the node setup of TextureRef ``ref`` in node tree ``nt``; return its colour socket.

    Image textures use the UVs, or (``spherical``: spheres, which are point clouds without
    UVs) a spherical projection of the object-local direction.
    """
    g = G(nt)
    colour = _texture_colour(g, ref, spherical)
    g.layout()
    return colour


def _texture_colour(g: G, ref, spherical: bool):
    coords = g.node("ShaderNodeTexCoord")
    if ref.kind == "image":
        img = load_image(ref.path)
        tex = g.node("ShaderNodeTexImage", interpolation="Cubic", extension="REPEAT")
        tex.image = img
        if spherical:
            tex.projection = "SPHERE"
            g.set(tex.inputs["Vector"], coords.outputs["Object"])
            return tex.outputs["Color"]
        g.set(tex.inputs["Vector"], g.vscale(coords.outputs["UV"], float(ref.scale)))
        return tex.outputs["Color"]
    # a fixed offset keeps surfaces on coordinate planes (a floor at y = 0) off the
    # patterns' cell boundaries, where a texture would flicker between two values
    p = g.vscale(g.vmath("ADD", coords.outputs["Object"], OFFSET), float(ref.scale))
    return BUILDERS[ref.name](g, p, coords.outputs["Normal"])
