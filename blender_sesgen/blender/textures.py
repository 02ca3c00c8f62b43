"""The built-in procedural textures (numbers and names in ``blender_sesgen.textures``) and
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

import bpy

from ..textures import BUILTIN_TEXTURES


class _Nodes:
    """Tiny helper to build node graphs tersely."""

    def __init__(self, nt):
        self.nt = nt
        self._x = -1400

    def new(self, kind: str, **props):
        n = self.nt.nodes.new(kind)
        n.location = (self._x, 0)
        self._x += 40
        for k, v in props.items():
            if k.startswith("in_"):
                n.inputs[k[3:].replace("_", " ")].default_value = v
            else:
                setattr(n, k, v)
        return n

    def link(self, out_socket, in_socket):
        self.nt.links.new(out_socket, in_socket)
        return in_socket.node

    def mapping(self, vec, scale: float):
        m = self.new("ShaderNodeVectorMath", operation="SCALE")
        self.link(vec, m.inputs[0])
        m.inputs["Scale"].default_value = scale
        return m.outputs[0]

    def noise(self, vec, scale, detail=6.0, roughness=0.6, distortion=0.0):
        n = self.new("ShaderNodeTexNoise")
        if hasattr(n, "noise_dimensions"):
            n.noise_dimensions = "3D"
        self.link(vec, n.inputs["Vector"])
        n.inputs["Scale"].default_value = scale
        n.inputs["Detail"].default_value = detail
        n.inputs["Roughness"].default_value = roughness
        n.inputs["Distortion"].default_value = distortion
        return n

    def voronoi(self, vec, scale, feature="F1", randomness=1.0):
        n = self.new("ShaderNodeTexVoronoi", feature=feature)
        self.link(vec, n.inputs["Vector"])
        n.inputs["Scale"].default_value = scale
        n.inputs["Randomness"].default_value = randomness
        return n

    def ramp(self, fac, stops, interpolation="LINEAR"):
        """stops: [(position, (r, g, b)), ...] -> colour socket."""
        r = self.new("ShaderNodeValToRGB")
        self.link(fac, r.inputs["Fac"])
        cr = r.color_ramp
        cr.interpolation = interpolation
        while len(cr.elements) < len(stops):
            cr.elements.new(0.5)
        for el, (pos, col) in zip(cr.elements, stops):
            el.position = pos
            el.color = (*col, 1.0)
        return r.outputs["Color"]

    def mix(self, a, b, fac=0.5, blend="MIX"):
        m = self.new("ShaderNodeMix", data_type="RGBA", blend_type=blend)
        if isinstance(fac, (int, float)):
            m.inputs[0].default_value = fac
        else:
            self.link(fac, m.inputs[0])
        self.link(a, m.inputs[6])
        self.link(b, m.inputs[7])
        return m.outputs[2]

    def planar(self, p):
        """Coordinates whose first two axes lie in the surface: the object-local position
        with its axes permuted so that the axis closest to the normal comes last (for the
        2-D patterns, bricks and tiles, which only use x and y)."""
        nrm = self.new("ShaderNodeVectorMath", operation="ABSOLUTE")
        self.link(self.coords.outputs["Normal"], nrm.inputs[0])
        sep = self.new("ShaderNodeSeparateXYZ")
        self.link(nrm.outputs[0], sep.inputs[0])
        nx, ny, nz = sep.outputs["X"], sep.outputs["Y"], sep.outputs["Z"]
        fy = self.math("GREATER_THAN", self.math("SUBTRACT", ny, self.math("MAXIMUM", nx, nz)), 0.0)
        fx = self.math("MULTIPLY", self.math("GREATER_THAN", self.math("SUBTRACT", nx, self.math("MAXIMUM", ny, nz)), 0.0),
                       self.math("SUBTRACT", 1.0, fy))
        fz = self.math("SUBTRACT", self.math("SUBTRACT", 1.0, fy), fx)
        ps = self.new("ShaderNodeSeparateXYZ")
        self.link(p, ps.inputs[0])
        x, y, z = ps.outputs["X"], ps.outputs["Y"], ps.outputs["Z"]

        def blend(a, b, c):  # fy * a + fx * b + fz * c
            return self.math("ADD", self.math("ADD", self.math("MULTIPLY", fy, a), self.math("MULTIPLY", fx, b)),
                             self.math("MULTIPLY", fz, c))
        out = self.new("ShaderNodeCombineXYZ")
        self.link(blend(x, z, x), out.inputs["X"])   # normal ~y: (x, z) ; ~x: (z, y) ; ~z: (x, y)
        self.link(blend(z, y, y), out.inputs["Y"])
        self.link(blend(y, x, z), out.inputs["Z"])
        return out.outputs[0]

    def math(self, op, a, b=None):
        m = self.new("ShaderNodeMath", operation=op)
        for i, v in enumerate((a, b)):
            if v is None:
                continue
            if isinstance(v, (int, float)):
                m.inputs[i].default_value = v
            else:
                self.link(v, m.inputs[i])
        return m.outputs[0]


GREY = lambda v: (v, v, v)  # noqa: E731
OFFSET = (0.1371, 0.2913, 0.1733)  # scene units, added to object coordinates


def _noise(n: _Nodes, p):
    big = n.noise(p, 3.0, detail=4.0)
    fine = n.noise(p, 25.0, detail=3.0)
    a = n.ramp(big.outputs["Fac"], [(0.40, GREY(0.05)), (0.60, GREY(0.95))])
    b = n.ramp(fine.outputs["Fac"], [(0.35, GREY(0.35)), (0.65, GREY(1.0))])
    return n.mix(a, b, 1.0, "MULTIPLY")


def _voronoi(n: _Nodes, p):
    cells = n.voronoi(p, 6.0)
    edges = n.voronoi(p, 6.0, feature="DISTANCE_TO_EDGE")
    border = n.ramp(edges.outputs["Distance"], [(0.02, GREY(0.03)), (0.06, GREY(1.0))])
    tone = n.ramp(cells.outputs["Color"], [(0.0, (0.15, 0.2, 0.3)), (1.0, (0.95, 0.9, 0.8))])
    return n.mix(tone, border, 1.0, "MULTIPLY")


def _brick_node(n: _Nodes, p, *, rows_offset: float, every: int, colours, mortar, scale: float,
                mortar_size: float, row_height: float):
    """Blender's brick texture on the planar mapping: ``colours`` (two RGB), ``mortar`` RGB,
    every ``every``-th row offset by ``rows_offset``; bricks 0.5 wide, no bias."""
    b = n.new("ShaderNodeTexBrick", offset=rows_offset, offset_frequency=every, squash=1.0, squash_frequency=every)
    n.link(n.planar(p), b.inputs["Vector"])
    for socket, value in (("Color1", (*colours[0], 1)), ("Color2", (*colours[1], 1)), ("Mortar", (*mortar, 1)),
                          ("Scale", scale), ("Mortar Size", mortar_size), ("Bias", 0.0), ("Brick Width", 0.5),
                          ("Row Height", row_height)):
        b.inputs[socket].default_value = value
    return b


def _brick_pattern(n: _Nodes, p, overlay: tuple, **bricks):
    """Bricks (``_brick_node``) multiplied by a grey noise overlay (scale, detail, ramp stops)."""
    b = _brick_node(n, p, **bricks)
    scale, detail, stops = overlay
    return n.mix(b.outputs["Color"], n.ramp(n.noise(p, scale, detail=detail).outputs["Fac"], stops), 1.0, "MULTIPLY")


def _bricks(n: _Nodes, p):
    return _brick_pattern(n, p, (30.0, 2.0, [(0.3, GREY(0.55)), (0.7, GREY(1.0))]), rows_offset=0.5, every=2,
                          colours=((0.55, 0.18, 0.10), (0.85, 0.45, 0.30)), mortar=(0.9, 0.9, 0.85), scale=2.0,
                          mortar_size=0.03, row_height=0.25)


def _checker(n: _Nodes, p):
    c = n.new("ShaderNodeTexChecker")
    n.link(p, c.inputs["Vector"])
    c.inputs["Color1"].default_value = (0.95, 0.95, 0.95, 1)
    c.inputs["Color2"].default_value = (0.05, 0.05, 0.05, 1)
    c.inputs["Scale"].default_value = 4.0
    mod = n.ramp(n.noise(p, 12.0, detail=4.0).outputs["Fac"], [(0.3, GREY(0.4)), (0.7, GREY(1.0))])
    return n.mix(c.outputs["Color"], mod, 1.0, "MULTIPLY")


def _marble(n: _Nodes, p):
    w = n.new("ShaderNodeTexWave", wave_type="BANDS", bands_direction="DIAGONAL", wave_profile="SIN",
              in_Scale=1.5, in_Distortion=12.0, in_Detail=6.0, in_Detail_Scale=2.0)
    n.link(p, w.inputs["Vector"])
    veins = n.ramp(w.outputs["Fac"], [(0.0, (0.25, 0.25, 0.3)), (0.15, (0.93, 0.92, 0.9)), (1.0, (0.75, 0.74, 0.72))])
    fine = n.ramp(n.noise(p, 40.0, detail=2.0).outputs["Fac"], [(0.3, GREY(0.7)), (0.7, GREY(1.0))])
    return n.mix(veins, fine, 1.0, "MULTIPLY")


def _wood(n: _Nodes, p):
    w = n.new("ShaderNodeTexWave", wave_type="RINGS", rings_direction="Y", wave_profile="SAW",
              in_Scale=3.0, in_Distortion=4.0, in_Detail=3.0)
    n.link(p, w.inputs["Vector"])
    rings = n.ramp(w.outputs["Fac"], [(0.0, (0.75, 0.5, 0.28)), (0.8, (0.45, 0.25, 0.1)), (1.0, (0.2, 0.1, 0.04))])
    st = n.new("ShaderNodeVectorMath", operation="MULTIPLY")
    n.link(p, st.inputs[0])
    st.inputs[1].default_value = (60.0, 2.0, 60.0)
    grain = n.ramp(n.noise(st.outputs[0], 1.0, detail=3.0).outputs["Fac"], [(0.35, GREY(0.5)), (0.65, GREY(1.0))])
    return n.mix(rings, grain, 1.0, "MULTIPLY")


def _granite(n: _Nodes, p):
    base = n.ramp(n.noise(p, 4.0, detail=3.0).outputs["Fac"], [(0.4, (0.45, 0.4, 0.4)), (0.6, (0.75, 0.7, 0.68))])
    speck_dark = n.ramp(n.noise(p, 45.0, detail=1.0).outputs["Fac"], [(0.58, GREY(1.0)), (0.62, GREY(0.08))])
    speck_light = n.ramp(n.noise(p, 30.0, detail=1.0).outputs["Fac"], [(0.60, GREY(0.0)), (0.64, GREY(0.6))])
    return n.mix(n.mix(base, speck_dark, 1.0, "MULTIPLY"), speck_light, 1.0, "ADD")


def _tiles(n: _Nodes, p):
    return _brick_pattern(n, p, (15.0, 4.0, [(0.3, GREY(0.6)), (0.7, GREY(1.0))]), rows_offset=0.0, every=1,
                          colours=((0.2, 0.35, 0.55), (0.9, 0.88, 0.8)), mortar=(0.08, 0.08, 0.08), scale=3.0,
                          mortar_size=0.04, row_height=0.5)


def _blotches(n: _Nodes, p):
    coarse = n.ramp(n.noise(p, 1.5, detail=2.0).outputs["Fac"],
                    [(0.45, (0.1, 0.25, 0.1)), (0.55, (0.9, 0.85, 0.5))])
    fine = n.ramp(n.noise(p, 20.0, detail=4.0).outputs["Fac"], [(0.35, GREY(0.3)), (0.65, GREY(1.0))])
    return n.mix(coarse, fine, 1.0, "MULTIPLY")


def _gravel(n: _Nodes, p):
    stones = n.voronoi(p, 20.0)
    edges = n.voronoi(p, 20.0, feature="DISTANCE_TO_EDGE")
    tone = n.ramp(stones.outputs["Color"], [(0.0, GREY(0.25)), (1.0, (0.9, 0.85, 0.75))])
    border = n.ramp(edges.outputs["Distance"], [(0.03, GREY(0.05)), (0.12, GREY(1.0))])
    grain = n.ramp(n.noise(p, 60.0, detail=1.0).outputs["Fac"], [(0.3, GREY(0.75)), (0.7, GREY(1.0))])
    return n.mix(n.mix(tone, border, 1.0, "MULTIPLY"), grain, 1.0, "MULTIPLY")


def _concrete(n: _Nodes, p):
    base = n.ramp(n.noise(p, 6.0, detail=6.0).outputs["Fac"], [(0.35, GREY(0.45)), (0.65, GREY(0.8))])
    pits = n.voronoi(p, 25.0)
    pit = n.ramp(pits.outputs["Distance"], [(0.08, GREY(0.1)), (0.14, GREY(1.0))])
    return n.mix(base, pit, 1.0, "MULTIPLY")


def _camouflage(n: _Nodes, p):
    a = n.noise(p, 2.0, detail=3.0).outputs["Fac"]
    b = n.noise(p, 9.0, detail=2.0).outputs["Fac"]
    f = n.math("ADD", n.math("MULTIPLY", a, 0.7), n.math("MULTIPLY", b, 0.3))
    return n.ramp(f, [(0.0, (0.2, 0.18, 0.1)), (0.45, (0.35, 0.4, 0.2)), (0.52, (0.7, 0.65, 0.45)),
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
    n = _Nodes(nt)
    coords = n.new("ShaderNodeTexCoord")
    if ref.kind == "image":
        img = bpy.data.images.load(ref.path, check_existing=True)
        img["sesgen"] = 1
        tex = n.new("ShaderNodeTexImage", interpolation="Cubic", extension="REPEAT")
        tex.image = img
        if spherical:
            tex.projection = "SPHERE"
            n.link(coords.outputs["Object"], tex.inputs["Vector"])
            return tex.outputs["Color"]
        uv = n.mapping(coords.outputs["UV"], float(ref.scale))
        n.link(uv, tex.inputs["Vector"])
        return tex.outputs["Color"]
    n.coords = coords
    # a fixed offset keeps surfaces on coordinate planes (a floor at y = 0) off the
    # patterns' cell boundaries, where a texture would flicker between two values
    off = n.new("ShaderNodeVectorMath", operation="ADD")
    n.link(coords.outputs["Object"], off.inputs[0])
    off.inputs[1].default_value = OFFSET
    p = n.mapping(off.outputs[0], float(ref.scale))
    return BUILDERS[ref.name](n, p)
