"""The library materials' level of detail: far away, the costly parts of a material's graph
(its relief, then its recipe's texture layers) are replaced by their measured pixel means.

Cycles' SVM jumps over the branch of a Mix Shader whose factor is exactly 0 or 1 (the nodes
only that branch uses). :func:`switch` puts three levels under two Mix Shaders switched on the
Camera Data's view distance: the full material near; beyond ``LOD_RELIEF_DISTANCE_NODE`` the
same colour graph on a Principled BSDF without the relief (the Bump evaluates its height graph
three times), the roughness widened by the relief's mean squared slope (Toksvig: GGX alpha^2 +
slope variance); beyond ``LOD_DISTANCE_NODE`` a Principled BSDF of the recipe's mean colour,
roughness and metallic, with the per-object variation and the dirt of the full material (large
patches, not below a pixel). Built with infinite distances (the full graph everywhere);
:func:`apply` measures every LOD material of a scene in one small render and writes the means
and distances (:func:`write`). Measured in bench/RESULTS.md (session 21): at distances that keep
the picture it buys nothing in city_kitti, so it is off by default.

The measurement (:func:`measure`): each material's recipe on square patches ``PATCH_M`` metres
wide, seen from above by an orthographic camera (``PATCH_PX`` pixels a side, ``PATCH_SAMPLES``
samples: each pixel is the mean over its footprint), as Emission: its colour on a horizontal
and on an upright patch (the recipes box-map by the normal), its (roughness, metallic, squared
slope of the relief's normal), the relief's normal. The recipe's footprint is the smallest box
(pixels of the patch averaged) over which the colour's box means deviate from the patch mean by
less than ``TOLERANCE`` of it (relative RMS, worst channel, both orientations), both
orientations' means agreeing within it; the relief's, the smallest box whose mean normal tilts
by less than ``TILT_TOLERANCE`` (RMS; Lambert is linear in the normal). A distance is its
footprint times the focal length in pixels (a pixel's footprint at distance z is z / f); a
pattern that holds contrast at the largest box keeps its level everywhere.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import bpy
import numpy as np

from .. import compat
from .graph import G

LOD_DISTANCE_NODE = "sesgen_lod_distance"     # Value: beyond it (metres from the camera) the cheap branch
LOD_COLOUR_NODE = "sesgen_lod_colour"         # RGB: the recipe's mean colour
LOD_ROUGHNESS_NODE = "sesgen_lod_roughness"   # Value: the mean roughness widened by the relief
LOD_METALLIC_NODE = "sesgen_lod_metallic"     # Value: the mean metallic
LOD_RELIEF_DISTANCE_NODE = "sesgen_lod_relief_distance"   # Value: beyond it the relief as roughness
LOD_SLOPE_NODE = "sesgen_lod_slope2"           # Value: the relief's mean squared slope
FAR_AWAY = 1e30                               # the switch distance before measuring: never

PATCH_M = 4.0          # a patch's side in metres (the recipe's metric coordinates)
PATCH_PX = 128         # its side in pixels (3.1 cm a pixel)
PATCH_SAMPLES = 4
TOLERANCE = 0.02       # relative RMS of the box means left at the switch footprint
TILT_TOLERANCE = 0.02  # RMS of the box-mean normal's tangential part left at the relief's footprint
BOXES = (1, 2, 4, 8, 16, 32)   # box sides tried, pixels of the patch (3 cm ... 1 m)


@dataclass(frozen=True)
class Means:
    """A material's pixel means and where they may stand in for it."""
    colour: tuple[float, float, float]   # linear RGB, the recipe's colour before variation and dirt
    roughness: float                     # mean roughness widened by the relief (Toksvig)
    metallic: float
    footprint_m: float                   # the switch footprint of the recipe's means (inf: never)
    slope2: float                        # the relief's mean squared slope (1 - (n . n_geometric)^2)
    relief_footprint_m: float = math.inf  # the footprint beyond which the relief is roughness

    def distance(self, focal_px: float) -> float:
        return self.footprint_m * focal_px if math.isfinite(self.footprint_m) else FAR_AWAY

    def relief_distance(self, focal_px: float) -> float:
        foot = min(self.relief_footprint_m, self.footprint_m)
        return foot * focal_px if math.isfinite(foot) else FAR_AWAY


def eligible(entry, s) -> bool:
    """Whether the cheap branch can stand for the recipe: opaque (no glazing), every other
    Principled input a constant."""
    return entry.transmittance <= 0 and not any(isinstance(v, bpy.types.NodeSocket) for v in s.extra.values())


def switch(g: G, ctx, full, bsdf, s, finish) -> object:
    """Three levels under two Mix Shaders: ``full`` near; beyond LOD_RELIEF_DISTANCE_NODE the
    same colour graph (its nodes shared) on a Principled BSDF without the relief, its roughness
    widened by the relief's squared slope (Toksvig); beyond LOD_DISTANCE_NODE the recipe's means.
    ``bsdf``: the full Principled BSDF; ``finish(colour, roughness)`` adds the variation and the
    dirt as the full material does."""
    view = g.node("ShaderNodeCameraData").outputs["View Distance"]

    def value(name: str, v: float):
        n = g.node("ShaderNodeValue")
        n.name = name
        n.outputs[0].default_value = v
        return n.outputs[0]

    def principled(colour, roughness, metallic):
        b = g.node("ShaderNodeBsdfPrincipled")
        g.set(b.inputs["Base Color"], colour)
        g.set(b.inputs["Roughness"], roughness)
        g.set(b.inputs["Metallic"], metallic)
        for name, v in s.extra.items():
            g.set(compat.principled_input(b, name), v)
        return b.outputs["BSDF"]

    def link_of(name):
        links = bsdf.inputs[name].links
        return links[0].from_socket if links else bsdf.inputs[name].default_value

    slope2 = value(LOD_SLOPE_NODE, 0.0)
    r = link_of("Roughness")
    widened = g.math("POWER", g.add(g.math("POWER", r, 4.0), slope2), 0.25, clamp=True)
    mid = principled(link_of("Base Color"), widened, link_of("Metallic"))
    col, r = finish(_rgb(g), value(LOD_ROUGHNESS_NODE, float(ctx.roughness)))
    far = principled(col, r, value(LOD_METALLIC_NODE, float(ctx.metallic)))
    # the recipe's switch outside the relief's: the colour graph, which the full and the
    # relief-less levels share, then lies in one branch of the outer mix and is skipped far away
    inner = g.node("ShaderNodeMixShader")
    g.set(inner.inputs[0], g.math("GREATER_THAN", view, value(LOD_RELIEF_DISTANCE_NODE, FAR_AWAY)))
    g.set(inner.inputs[1], full)
    g.set(inner.inputs[2], mid)
    outer = g.node("ShaderNodeMixShader")
    g.set(outer.inputs[0], g.math("GREATER_THAN", view, value(LOD_DISTANCE_NODE, FAR_AWAY)))
    g.set(outer.inputs[1], inner.outputs[0])
    g.set(outer.inputs[2], far)
    return outer.outputs[0]


def _rgb(g: G):
    rgb = g.node("ShaderNodeRGB")
    rgb.name = LOD_COLOUR_NODE
    rgb.outputs[0].default_value = (0.5, 0.5, 0.5, 1.0)
    return rgb.outputs[0]


def has_lod(mat) -> bool:
    nt = mat.node_tree if mat is not None else None
    return nt is not None and LOD_DISTANCE_NODE in nt.nodes


def write(nt, means: Means, focal_px: float) -> None:
    """Set the cheap branches and switch distances of a LOD material's node tree from ``means``."""
    nodes = nt.nodes
    nodes[LOD_COLOUR_NODE].outputs[0].default_value = (*means.colour, 1.0)
    nodes[LOD_ROUGHNESS_NODE].outputs[0].default_value = means.roughness
    nodes[LOD_METALLIC_NODE].outputs[0].default_value = means.metallic
    nodes[LOD_DISTANCE_NODE].outputs[0].default_value = min(means.distance(focal_px), FAR_AWAY)
    nodes[LOD_RELIEF_DISTANCE_NODE].outputs[0].default_value = min(means.relief_distance(focal_px), FAR_AWAY)
    nodes[LOD_SLOPE_NODE].outputs[0].default_value = means.slope2


def footprint(tiles: list[np.ndarray], tolerance: float | None = None) -> float:
    """The smallest box side (metres) over which every tile's box means deviate from its mean by
    a relative RMS below ``tolerance`` (worst channel); inf if none, or if the tiles' means
    differ by more than it. ``tiles``: linear colour (n, n, 3) of patches, ``PATCH_M / PATCH_PX``
    metres a pixel."""
    tolerance = TOLERANCE if tolerance is None else tolerance
    means = [t.reshape(-1, 3).mean(0) for t in tiles]
    scale = np.maximum(np.max(means, 0), 1e-6)
    if any(np.max(np.abs(m - means[0]) / scale) > tolerance for m in means[1:]):
        return math.inf
    for b in BOXES:
        worst = 0.0
        for t, m in zip(tiles, means):
            p = t.shape[0] // b * b
            box = t[:p, :p].reshape(p // b, b, p // b, b, 3).mean((1, 3)).reshape(-1, 3)
            rel = np.sqrt(((box - m) ** 2).mean(0)) / np.maximum(m, 1e-6)
            worst = max(worst, float(rel.max()))
        if worst < tolerance:
            return b * PATCH_M / PATCH_PX
    return math.inf


def relief_footprint(normal_xy: np.ndarray, tolerance: float | None = None) -> float:
    """The smallest box side (metres) over which the relief's box-mean normal tilts by an RMS
    below ``tolerance`` (its tangential part, ``normal_xy`` (P, P, 2) of a patch facing +z): a
    pixel that wide shades as the flat surface (Lambert is linear in the normal); inf if none."""
    tolerance = TILT_TOLERANCE if tolerance is None else tolerance
    for b in BOXES:
        p = normal_xy.shape[0] // b * b
        box = normal_xy[:p, :p].reshape(p // b, b, p // b, b, 2).mean((1, 3))
        if float(np.sqrt((box ** 2).sum(-1).mean())) < tolerance:
            return b * PATCH_M / PATCH_PX
    return math.inf


def toksvig(roughness: float, slope2: float) -> float:
    """The roughness whose GGX alpha^2 (alpha = roughness^2) is the mean's plus the relief's
    squared slope: sub-pixel relief as widened highlights."""
    return float(min(1.0, (roughness ** 4 + slope2) ** 0.25))


def measure(sources: list, threads: int, recipe, props: tuple[str, str, str]) -> list[Means]:
    """The :class:`Means` of library materials ``sources`` ((Material model, colour) pairs: their
    recipes rebuilt on patches by ``recipe(nt, m, colour)``; ``props``: the names of the objects'
    scale, offset and random properties the recipes read), one render (library.measure_lod)."""
    from ..datablocks import tag
    from ..render import Bake
    SCALE_PROP, OFFSET_PROP, RAND_PROP = props
    n = len(sources)
    cols = 4          # colour flat, colour upright, (rough, metal, slope2), the relief's normal (x, y) upright
    bake = Bake("sesgen_lod_measure", cols * PATCH_PX, n * PATCH_PX, samples=PATCH_SAMPLES, threads=threads,
                ortho_scale=max(cols, n) * PATCH_M, camera_location=(cols * PATCH_M / 2, -n * PATCH_M / 2, 10.0))
    c = bake.scene.cycles
    c.pixel_filter_type, c.filter_width, c.seed = "BOX", 1.0, 0
    bake.camera.data.clip_end = 100.0
    scene, made, new = bake.scene, bake.made, bake.new
    L = PATCH_M
    flat = new("meshes", "sesgen_lod_flat")
    flat.from_pydata([(0, 0, 0), (L, 0, 0), (L, L, 0), (0, L, 0)], [], [(0, 1, 2, 3)])
    upright = new("meshes", "sesgen_lod_upright")       # in the object's xz plane, normal -y
    upright.from_pydata([(0, 0, 0), (0, 0, L), (L, 0, L), (L, 0, 0)], [], [(0, 1, 2, 3)])
    for i, (m, colour) in enumerate(sources):
        for j in range(cols):
            mesh = (flat if j == 0 else upright).copy()
            made.append(tag(mesh))
            probe = new("materials", f"sesgen_lod_{i}_{j}")
            nt = compat.node_tree(probe)
            nt.nodes.clear()
            g, ctx, s = recipe(nt, m, colour)
            emit = g.node("ShaderNodeEmission", {"Strength": 1.0})
            g.set(g.node("ShaderNodeOutputMaterial").inputs["Surface"], emit.outputs[0])
            if j < 2:
                g.set(emit.inputs["Color"], s.colour)
            else:
                slope2, nx, ny = 0.0, 0.0, 0.0
                if s.height is not None and m.library.bump > 0:
                    bump = g.node("ShaderNodeBump", {"Strength": 1.0, "Distance": float(m.library.bump),
                                                     "Height": s.height})
                    geo = g.node("ShaderNodeNewGeometry").outputs["True Normal"]
                    d = g.vmath("DOT_PRODUCT", bump.outputs["Normal"], geo)
                    slope2 = g.sub(1.0, g.mul(d, d))
                    nx, ny, _ = g.sep(bump.outputs["Normal"])   # the patch faces world +z
                g.set(emit.inputs["Color"], g.node("ShaderNodeCombineColor",
                                                   {0: s.roughness, 1: s.metallic, 2: slope2} if j == 2 else
                                                   {0: nx, 1: ny, 2: 0.0}).outputs[0])
            g.layout()
            mesh.materials.append(probe)
            obj = new("objects", f"sesgen_lod_{i}_{j}", mesh)
            obj.location = (j * L, -(i + 1) * L, 0.0)
            if j > 0:
                obj.rotation_euler = (-math.pi / 2, 0.0, 0.0)   # local xz faces the camera (up)
                obj.location = (j * L, -(i + 1) * L, 0.0)
            obj[SCALE_PROP] = [1.0, 1.0, 1.0]
            obj[OFFSET_PROP] = [0.0, 0.0, 0.0]
            obj[RAND_PROP] = [0.5, 0.5, 0.5]
            scene.collection.objects.link(obj)
    try:
        img = bake.render_rgb("lod")                     # row 0 at the top
    finally:
        bake.close()
    out = []
    P = PATCH_PX
    for i in range(n):
        tiles = [img[i * P:(i + 1) * P, j * P:(j + 1) * P].astype(np.float64) for j in range(cols)]
        inner = [t[2:-2, 2:-2] for t in tiles]           # the patches' edges may see their neighbours
        colour = tuple(float(v) for v in (inner[0].reshape(-1, 3).mean(0) + inner[1].reshape(-1, 3).mean(0)) / 2)
        rough, metal, slope2 = (float(v) for v in inner[2].reshape(-1, 3).mean(0))
        out.append(Means(colour=colour, roughness=toksvig(rough, max(slope2, 0.0)), metallic=metal,
                         footprint_m=footprint(inner[:2]), slope2=max(slope2, 0.0),
                         relief_footprint_m=relief_footprint(inner[3][..., :2])))
    return out


def apply(made: list, focal_px: float, measure_means) -> dict:
    """Measure (``measure_means(sources)``) the LOD materials among ``made`` ((material, Material
    model, colour) triples) and set their cheap branches and distances; {material name: Means}."""
    todo = [(mat, m, colour) for mat, m, colour in made if has_lod(mat)]
    if not todo:
        return {}
    means = measure_means([(m, colour) for _, m, colour in todo])
    for (mat, _, _), mm in zip(todo, means):
        write(mat.node_tree, mm, focal_px)
    return {mat.name: mm for (mat, _, _), mm in zip(todo, means)}
