"""Library materials and user image sets as Cycles node setups (the bpy side of
``blender_sesgen.scene.materials``).

Coordinates: the object's own coordinates (``Texture Coordinate > Object``) times the
object's scale (custom property ``sesgen_scale``) are metres on the object; the per-object
offset (``sesgen_offset``, from ``materials.object_variation``) moves the pattern so
that no two objects repeat each other, and ``sesgen_rand`` gives each object its colour,
roughness and wear shifts. The builder sets these three properties on every object
(:func:`object_properties`); one material serves every object using it.

Every recipe returns a :class:`Surface`; :func:`build_shader` adds what all share: the
per-object colour variation, the generic dirt layer scaled by ``wear``, the relief through a
Bump node (shading only: geometry, depth and ids never change) and the Principled BSDF. The
coordinates, the variation and the dirt are node groups made once per scene (``GROUPS``): a
write to a node tree through bpy updates the whole tree, so small trees build faster; Cycles
expands the groups (the pixels of the graph written inline).
"""
from __future__ import annotations

from typing import Callable

import bpy

from ...scene import materials
from ...scene.model import ImageMaps, Material
from .. import compat
from ..datablocks import TAG, load_image, tag
from . import built, interior, metal_glass, nature
from . import lod as lod_module
from .graph import Ctx, G, Surface, box_uv

RECIPES: dict[str, Callable[[Ctx], Surface]] = {**built.RECIPES, **interior.RECIPES, **metal_glass.RECIPES,
                                                 **nature.RECIPES}
assert set(RECIPES) == set(materials.LIBRARY), set(RECIPES) ^ set(materials.LIBRARY)

OFFSET_PROP, RAND_PROP, SCALE_PROP = "sesgen_offset", "sesgen_rand", "sesgen_scale"


def object_properties(obj, seed: int, object_id: int) -> None:
    """Set the per-object variation properties the library shaders read."""
    var = materials.object_variation(seed, object_id)
    obj[OFFSET_PROP] = list(var.offset_m)
    obj[RAND_PROP] = list(var.rand)
    s = obj.matrix_world.to_scale()
    obj[SCALE_PROP] = [abs(float(s[0])), abs(float(s[1])), abs(float(s[2]))]


def _attribute(g: G, name: str):
    return g.node("ShaderNodeAttribute", attribute_type="OBJECT", attribute_name=name).outputs["Vector"]


def _coordinates(g: G, texture_scale, with_offset: bool = True):
    """(metric pattern coordinates, object-space normal, (r0, r1, r2)); ``texture_scale`` a
    number or a socket."""
    tc = g.node("ShaderNodeTexCoord")
    scale = _attribute(g, SCALE_PROP)
    # an object without the property reads (0, 0, 0): fall back to 1 (unscaled)
    safe = g.vmath("MAXIMUM", scale, (1e-6, 1e-6, 1e-6))
    missing = g.math("LESS_THAN", g.vmath("LENGTH", scale), 1e-9)
    scale = g.vmath("ADD", safe, g.vscale((1.0, 1.0, 1.0), missing))
    p = g.vmath("MULTIPLY", tc.outputs["Object"], scale)
    if with_offset:
        p = g.vmath("ADD", p, _attribute(g, OFFSET_PROP))
    p = g.vscale(p, texture_scale)
    rand = g.sep(_attribute(g, RAND_PROP))
    return p, tc.outputs["Normal"], rand


COORDINATES_GROUP = "sesgen_library_coordinates"
VARIATION_GROUP = "sesgen_library_variation"
GRIME_GROUP = "sesgen_library_grime"
GROUPS = (COORDINATES_GROUP, VARIATION_GROUP, GRIME_GROUP)


def _group(name: str, inputs, outputs, build):
    """The library's node group ``name`` (``inputs``/``outputs``: (name, socket type) pairs;
    ``build(g, {input: socket})`` returns the output sockets), built once per scene. The parts
    every library graph shares live in groups: bpy's cost of a write to a tree grows with the
    tree's size, and Cycles expands a group when it synchronises the material (the same nodes
    as written inline: the same pixels, tests/test_material_graph.py)."""
    for group in bpy.data.node_groups:     # (a BLEND file's group may hold the name)
        if group.get(TAG) and group.get(name):
            return group
    group = tag(bpy.data.node_groups.new(name, "ShaderNodeTree"))
    group[name] = 1
    for socket, kind in inputs:
        group.interface.new_socket(socket, in_out="INPUT", socket_type=kind)
    for socket, kind in outputs:
        group.interface.new_socket(socket, in_out="OUTPUT", socket_type=kind)
    g = G(group)
    into = g.node("NodeGroupInput")
    made = build(g, {socket: into.outputs[socket] for socket, _ in inputs})
    out = g.node("NodeGroupOutput")
    for (socket, _), value in zip(outputs, made):
        g.set(out.inputs[socket], value)
    g.layout()
    return group


def _coordinates_group():
    """``_coordinates`` and its box mapping (input: the texture scale): ~45 of a library
    graph's ~90 nodes."""
    def build(g, i):
        p, n, rand = _coordinates(g, i["scale"])
        uv, _, _ = box_uv(g, p, n)
        return (p, n, *rand, uv)
    return _group(COORDINATES_GROUP, [("scale", "NodeSocketFloat")],
                  [("p", "NodeSocketVector"), ("n", "NodeSocketVector"), ("r0", "NodeSocketFloat"),
                   ("r1", "NodeSocketFloat"), ("r2", "NodeSocketFloat"), ("uv", "NodeSocketVector")], build)


def _variation(g: G, colour, rand, amount: float, shared: bool = False):
    """The object's own shift of hue, saturation and value (scaled by ``variation``)."""
    if amount <= 0:
        return colour
    scales = (0.5 * amount, 0.06 * amount, 0.4 * amount)
    if shared:
        node = g.node("ShaderNodeGroup", node_tree=_group(
            VARIATION_GROUP, [("colour", "NodeSocketColor"), ("r0", "NodeSocketFloat"), ("r1", "NodeSocketFloat"),
                              ("r2", "NodeSocketFloat"), ("value", "NodeSocketFloat"), ("hue", "NodeSocketFloat"),
                              ("saturation", "NodeSocketFloat")], [("colour", "NodeSocketColor")],
            lambda g, i: (_shift(g, i["colour"], (i["r0"], i["r1"], i["r2"]), (i["value"], i["hue"], i["saturation"])),)))
        for name, value in zip(("colour", "r0", "r1", "r2", "value", "hue", "saturation"), (colour, *rand, *scales)):
            g.set(node.inputs[name], value)
        return node.outputs["colour"]
    return _shift(g, colour, rand, scales)


def _shift(g: G, colour, rand, scales):
    r0, r1, r2 = rand
    value = g.madd(g.sub(r0, 0.5), scales[0], 1.0)           # +-25 % at variation 1
    hue = g.madd(g.sub(r1, 0.5), scales[1], 0.5)             # +-0.03 of the hue circle
    sat = g.madd(g.sub(r2, 0.5), scales[2], 1.0)             # +-20 %
    return g.hsv(colour, hue, sat, value)


def _grime(g: G, ctx: Ctx, colour, roughness, amount: float, shared: bool = False):
    """Generic dirt: large soft patches with fine breakup, darker and browner, rougher."""
    if amount <= 0:
        return colour, roughness
    if shared:
        node = g.node("ShaderNodeGroup", node_tree=_group(
            GRIME_GROUP, [("p", "NodeSocketVector"), ("colour", "NodeSocketColor"), ("roughness", "NodeSocketFloat"),
                          ("amount", "NodeSocketFloat")], [("colour", "NodeSocketColor"), ("roughness", "NodeSocketFloat")],
            lambda g, i: _dirt(g, i["p"], i["colour"], i["roughness"], i["amount"])))
        for name, value in zip(("p", "colour", "roughness", "amount"), (ctx.p, colour, roughness, min(amount, 1.0))):
            g.set(node.inputs[name], value)
        return node.outputs["colour"], node.outputs["roughness"]
    return _dirt(g, ctx.p, colour, roughness, min(amount, 1.0))


def _dirt(g: G, p, colour, roughness, amount):
    big = g.remap(g.noise(p, 0.7, detail=3.0), 0.45, 0.72, smooth=True)
    fine = g.remap(g.noise(p, 12.0, detail=3.0), 0.35, 0.65)
    mask = g.mul(g.mul(big, g.lerp(0.6, 1.0, fine)), amount)
    dirty = g.cmul(colour, (0.62, 0.58, 0.52))
    return g.cmix(colour, dirty, mask), g.lerp(roughness, 0.95, g.mul(mask, 0.6))


COLOUR_NODE = "sesgen_colour"


def recipe(nt, m: Material, colour, shared_parts: bool = True):
    """The library material ``m``'s coordinates and recipe in node tree ``nt``: (the builder,
    its :class:`Ctx`, the recipe's :class:`Surface`). ``build_shader`` adds the rest; ``lod``
    measures the Surface's means on a patch."""
    g = G(nt)
    lib = m.library
    entry = materials.entry(lib.name)
    if shared_parts:
        coords = g.node("ShaderNodeGroup", {"scale": float(lib.scale)}, node_tree=_coordinates_group())
        p, n, uv = coords.outputs["p"], coords.outputs["n"], coords.outputs["uv"]
        rand = (coords.outputs["r0"], coords.outputs["r1"], coords.outputs["r2"])
    else:
        p, n, rand = _coordinates(g, lib.scale)
        uv, _, _ = box_uv(g, p, n)
    rgb = g.node("ShaderNodeRGB")
    rgb.name = COLOUR_NODE
    set_colour(nt, colour)
    ctx = Ctx(g=g, p=p, uv=uv, n=n, rand=rand, colour=rgb.outputs[0], roughness=float(m.roughness),
              metallic=float(m.metallic), wear=float(lib.wear), entry=entry)
    return g, ctx, RECIPES[entry.name](ctx)


def _finish_surface(g: G, ctx: Ctx, lib, colour, roughness, grime: float, shared_parts: bool):
    """The recipe's colour and roughness with what every library material adds: the object's
    colour variation, the dirt, the object's roughness shift."""
    col = _variation(g, colour, ctx.rand, lib.variation, shared_parts)
    col, rough = _grime(g, ctx, col, roughness, lib.wear * grime, shared_parts)
    if lib.variation > 0:     # the object's own small roughness shift
        rough = g.math("MULTIPLY_ADD", g.sub(ctx.rand[1], 0.5), 0.1 * lib.variation, rough, clamp=True)
    return col, rough


def build_shader(nt, m: Material, colour, *, fog_mix=None, shared_parts: bool = True, lod: bool = False):
    """The library material ``m`` (its ``library`` params) in node tree ``nt``; returns the
    output shader socket. ``colour``: the main albedo (material colour times object colour),
    held by the one RGB node named ``COLOUR_NODE`` (``set_colour`` changes it in a copy).
    ``shared_parts``: the coordinates, the per-object variation and the dirt through the
    scene's node groups (False: written into the tree, as the groups expand:
    tests/test_material_graph.py renders both). ``lod``: where the material allows it, the
    graph's level of detail (``lod.py``): a cheap branch beside the full one, off (its switch
    distance infinite) until ``lod.apply`` has measured it."""
    lib = m.library
    g, ctx, s = recipe(nt, m, colour, shared_parts)
    entry = ctx.entry
    col, rough = _finish_surface(g, ctx, lib, s.colour, s.roughness, s.grime, shared_parts)
    bsdf = g.node("ShaderNodeBsdfPrincipled")
    g.set(bsdf.inputs["Base Color"], col)
    g.set(bsdf.inputs["Roughness"], rough)
    g.set(bsdf.inputs["Metallic"], s.metallic)
    for name, value in s.extra.items():
        g.set(compat.principled_input(bsdf, name), value)
    if s.height is not None and lib.bump > 0:
        bump = g.node("ShaderNodeBump", {"Strength": 1.0, "Distance": float(lib.bump), "Height": s.height})
        g.set(bsdf.inputs["Normal"], bump.outputs["Normal"])
        if "Coat Weight" in s.extra:
            coat = g.node("ShaderNodeBump", {"Strength": 1.0, "Distance": 0.1 * float(lib.bump),
                                             "Height": s.height})
            g.set(bsdf.inputs["Coat Normal"], coat.outputs["Normal"])
    out = bsdf.outputs["BSDF"]
    if lod and lod_module.eligible(entry, s):
        out = lod_module.switch(g, ctx, out, bsdf, s,
                                lambda c, r: _finish_surface(g, ctx, lib, c, r, s.grime, shared_parts))
    if entry.transmittance > 0 and getattr(m, "glow", False):
        out = _glow(g, out, col, entry)
    elif entry.transmittance > 0:
        out = _translucent(g, out, col, entry)
    g.layout()
    return out


def measure_lod(sources: list, threads: int = 0) -> list:
    """``lod.measure`` of (Material, colour) pairs with this package's recipes."""
    return lod_module.measure(sources, threads, recipe, (SCALE_PROP, OFFSET_PROP, RAND_PROP))


def apply_lod(made: list, focal_px: float, threads: int = 0) -> dict:
    """``lod.apply``: the level of detail of every LOD material among ``made`` ((material,
    Material, colour) triples) measured and set for ``focal_px``; {material name: lod.Means}."""
    return lod_module.apply(made, focal_px, lambda sources: measure_lod(sources, threads))


GLOW_NODE = "sesgen_glow"                # the Emission node of a glowing pane (``MATERIAL ... glow``)
GLOW_MAP_NODE = "sesgen_glow_map"        # the daylight over the pane over its strength (blender/glazing.py)


def _passed(g: G, colour, entry):
    """What the pane passes at each point: materials.transmitted_colour in nodes."""
    k = materials.transmission_gain(entry)
    return g.vmath("MINIMUM", g.cmul(colour, k), g.vmath("SUBTRACT", (1.0, 1.0, 1.0), colour))


def _glow(g: G, shader, colour, entry):
    """Diffusing glazing that emits the daylight it passes instead of passing it (no
    Translucent BSDF: the light must not arrive twice): an Emission of the pane's passed
    colour at each point times the image of ``GLOW_MAP_NODE`` (by the UVs: a QUAD's map of the
    irradiance on its outer face) at the strength of ``GLOW_NODE``, both set by
    blender/glazing.py from the world (strength 0 until then)."""
    uv = g.node("ShaderNodeTexCoord").outputs["UV"]
    daylight = g.node("ShaderNodeTexImage", {"Vector": uv}, interpolation="Linear", extension="EXTEND")
    daylight.name = GLOW_MAP_NODE
    emit = g.node("ShaderNodeEmission", {"Color": g.cmul(_passed(g, colour, entry), daylight.outputs["Color"]),
                                         "Strength": 0.0})
    emit.name = GLOW_NODE
    add = g.node("ShaderNodeAddShader")
    g.set(add.inputs[0], shader)
    g.set(add.inputs[1], emit.outputs["Emission"])
    return add.outputs["Shader"]


def _translucent(g: G, shader, colour, entry):
    """Diffusing glazing: the Principled BSDF (no diffuse transmission of its own) plus a
    Translucent BSDF passing light evenly into the other side: materials.transmitted_colour
    of the pane's own colour at each point (variation and dirt included)."""
    tr = g.node("ShaderNodeBsdfTranslucent", {"Color": _passed(g, colour, entry)})
    add = g.node("ShaderNodeAddShader")
    g.set(add.inputs[0], shader)
    g.set(add.inputs[1], tr.outputs["BSDF"])
    return add.outputs["Shader"]


def set_colour(nt, colour) -> None:
    """The main albedo of a library material's node tree (a copy of one built by
    ``build_shader`` takes another colour this way, without building its graph again)."""
    nt.nodes[COLOUR_NODE].outputs[0].default_value = (*(float(c) for c in colour), 1.0)


def build_image_maps(nt, maps: ImageMaps, colour, roughness: float, tag_image):
    """A user's image set (albedo / normal / roughness files), box-mapped on the object's
    metric coordinates, one repeat every ``maps.size_m``; returns the Principled BSDF node.
    The normal map (OpenGL convention: green = +v) is turned into object space with the
    box mapping's own tangents, then into world space."""
    g = G(nt)
    p, n, _ = _coordinates(g, 1.0 / maps.size_m, with_offset=False)
    uv, tu, tv = box_uv(g, p, n)
    bsdf = g.node("ShaderNodeBsdfPrincipled")

    def image(path: str, colour_data: bool):
        img = tag_image(load_image(path))
        if not colour_data:
            img.colorspace_settings.is_data = True
        return g.node("ShaderNodeTexImage", {"Vector": uv}, image=img, interpolation="Linear",
                      extension="REPEAT").outputs["Color"]

    if maps.albedo:
        g.set(bsdf.inputs["Base Color"], g.cmul(image(maps.albedo, True), tuple(colour)))
    else:
        g.set(bsdf.inputs["Base Color"], tuple(colour))
    g.set(bsdf.inputs["Roughness"], g.sep(image(maps.roughness, False))[0] if maps.roughness else roughness)
    if maps.normal:
        c = g.sep(image(maps.normal, False))
        strength = float(maps.bump)
        du, dv = g.madd(c[0], 2.0 * strength, -strength), g.madd(c[1], 2.0 * strength, -strength)
        dn = g.madd(c[2], 2.0, -1.0)
        nn = g.vmath("NORMALIZE", n)

        def tangent(t):  # Gram-Schmidt against the normal
            return g.vmath("NORMALIZE", g.vmath("SUBTRACT", t, g.vscale(nn, g.vmath("DOT_PRODUCT", t, nn))))
        v = g.vmath("ADD", g.vmath("ADD", g.vscale(tangent(tu), du), g.vscale(tangent(tv), dv)), g.vscale(nn, dn))
        world = g.node("ShaderNodeVectorTransform", {"Vector": g.vmath("NORMALIZE", v)},
                       vector_type="NORMAL", convert_from="OBJECT", convert_to="WORLD")
        g.set(bsdf.inputs["Normal"], world.outputs[0])
    g.layout()
    return bsdf
