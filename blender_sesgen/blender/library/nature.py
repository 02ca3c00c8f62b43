"""Recipes for nature: grass, leaves, bark, soil, gravel."""
from __future__ import annotations

from .graph import Ctx, Surface


def grass(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    tufts = g.voronoi(p, 1 / 0.035)
    tuft = g.remap(g.sep(tufts.outputs["Color"])[0], 0.0, 1.0, 0.6, 1.45)
    lush = g.remap(g.noise(p, 1 / ctx.entry.scale_m, detail=3.0), 0.3, 0.7, 0.75, 1.22)
    col = g.cmul(C, g.mul(tuft, lush))
    dry = g.remap(g.noise(p, 1 / 2.5, detail=3.0), 0.58 - 0.15 * ctx.wear, 0.7 - 0.15 * ctx.wear, smooth=True)
    col = g.cmix(col, g.cmul((0.17, 0.14, 0.065), tuft), g.mul(dry, 0.8))
    # a mown lawn at 1-10 cm, what a street camera resolves 5-20 m away (KITTI sequence_1's lawn has
    # about twice the render's pixel-scale contrast without it): lit blade tips over the shaded
    # thatch between them (1 cm), straw-coloured dead blades and leaves (2 cm), clover patches
    # (lighter, rounder leaves), bare earth where it is worn
    blade = g.voronoi(p, 1 / 0.01)
    lit = g.remap(blade.outputs["Distance"], 0.0, 0.7, 1.45, 0.45)
    col = g.cmul(col, lit)
    dead_cells = g.voronoi(p, 1 / 0.02)
    dead = g.mul(g.math("GREATER_THAN", g.sep(dead_cells.outputs["Color"])[1], 0.88 - 0.1 * ctx.wear),
                 g.remap(dead_cells.outputs["Distance"], 0.2, 0.45, 1.0, 0.0))
    col = g.cmix(col, g.cmul((0.24, 0.21, 0.12), tuft), dead)
    clover = g.mul(g.remap(g.noise(p, 1 / 0.3, detail=3.0), 0.6, 0.66, smooth=True),
                   g.math("GREATER_THAN", g.sep(tufts.outputs["Color"])[2], 0.35))
    col = g.cmix(col, g.cmul(C, g.mul(tuft, 1.35)), clover)
    bare = g.remap(g.noise(p, 1 / 0.6, detail=4.0, roughness=0.6), 0.7 - 0.1 * ctx.wear, 0.74 - 0.1 * ctx.wear,
                   smooth=True)
    col = g.cmix(col, g.cmul((0.12, 0.09, 0.06), g.lerp(0.8, 1.2, tuft)), bare)
    # weeds of 10-20 cm (plantain and dandelion rosettes): broad, darker leaves lying flat, the
    # lawn's texture at the scale one pixel spans along a grazing view 5-15 m away
    weeds = g.voronoi(p, 1 / 0.15)
    weed = g.mul(g.math("GREATER_THAN", g.sep(weeds.outputs["Color"])[0], 0.8),
                 g.remap(weeds.outputs["Distance"], 0.25, 0.4, 1.0, 0.0))
    col = g.cmix(col, g.cmul(C, g.mul(tuft, 0.6)), weed)
    # blades: strong fine relief, so the sun picks out light and dark tufts
    blades = g.noise(g.vmath("MULTIPLY", p, (1.0, 0.3, 1.0)), 1 / 0.008, detail=2.0)
    height = g.add(g.add(g.mul(blades, 0.004), g.mul(g.remap(tufts.outputs["Distance"], 0.0, 0.6, 1.0, 0.0), 0.006)),
                   g.mul(g.remap(blade.outputs["Distance"], 0.0, 0.7, 1.0, 0.0), 0.003))
    # no sheen lobe (a cloth's): at a street camera's grazing view it made a lawn ~1.5 x brighter
    # (docs/sensors.md, Camera twins); the blades' own light is the library's transmittance
    return Surface(col, ctx.roughness, height)


def leaves(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    size = ctx.entry.scale_m                                  # 8 cm: about one leaf
    big = g.voronoi(p, 1 / size)
    small = g.voronoi(p, 1 / (0.4 * size))
    r_big = g.sep(big.outputs["Color"])[0]
    r_small = g.sep(small.outputs["Color"])[1]
    # older and younger, sun and shade leaves: each leaf (or part of one) its own tone
    value = g.mul(g.remap(r_big, 0.0, 1.0, 0.5, 1.6), g.remap(r_small, 0.0, 1.0, 0.75, 1.25))
    col = g.cmul(C, value)
    yellow = g.math("GREATER_THAN", r_small, 0.97 - 0.2 * ctx.wear)
    col = g.cmix(col, g.cmul((0.13, 0.12, 0.045), value), g.mul(yellow, 0.7))
    # a leaf is a flat lamina (its fold is the mesh's): veins and blades' waviness at millimetres,
    # no cluster's dome or dark gaps (the leaves and the gaps between them are geometry)
    height = g.mul(g.noise(p, 1 / 0.01, detail=2.0), ctx.entry.bump_m)
    return Surface(col, ctx.roughness, height, grime=0.0,
                   extra={"Subsurface Weight": 0.15, "Subsurface Radius": (0.2, 0.4, 0.1),
                          "Subsurface Scale": 0.005})


def bark(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    w = ctx.entry.scale_m                                     # ridges 5 cm apart, along the object's y
    stretched = g.vmath("MULTIPLY", p, (1.0 / w, 0.12 / w, 1.0 / w))
    warp = g.vmath("ADD", stretched, g.vscale(g.noise(stretched, 0.5, detail=3.0, colour=True), 0.6))
    edge = g.voronoi(warp, 1.0, feature="DISTANCE_TO_EDGE").outputs["Distance"]
    ridge = g.remap(edge, 0.0, 0.3, 0.0, 1.0, smooth=True)
    col = g.cmul(C, g.mul(g.lerp(0.45, 1.15, ridge), g.remap(g.noise(p, 1 / 0.02, detail=3.0), 0.3, 0.7, 0.85, 1.15)))
    lichen = g.mul(g.remap(g.noise(p, 1 / 0.12, detail=5.0), 0.6 - 0.15 * ctx.wear, 0.68 - 0.15 * ctx.wear,
                           smooth=True), ridge)
    col = g.cmix(col, (0.26, 0.28, 0.21), g.mul(lichen, 0.85))
    height = g.add(g.mul(ridge, ctx.entry.bump_m), g.mul(g.noise(p, 1 / 0.004, detail=2.0), 0.0008))
    return Surface(col, ctx.roughness, height, grime=0.0)


def soil(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    clods = g.voronoi(p, 1 / 0.03)
    tone = g.remap(g.sep(clods.outputs["Color"])[0], 0.0, 1.0, 0.82, 1.18)
    stones = g.voronoi(p, 1 / 0.012)
    stone = g.mul(g.math("GREATER_THAN", g.sep(stones.outputs["Color"])[2], 0.93),
                  g.remap(stones.outputs["Distance"], 0.2, 0.4, 1.0, 0.0))
    damp = g.remap(g.noise(p, 1 / 1.5, detail=3.0), 0.5 - 0.1 * ctx.wear, 0.65 - 0.1 * ctx.wear, smooth=True)
    fine = g.remap(g.noise(p, 1 / ctx.entry.scale_m, detail=4.0), 0.3, 0.7, 0.9, 1.1)
    col = g.cmul(C, g.mul(g.mul(tone, fine), g.lerp(1.0, 0.62, damp)))
    col = g.cmix(col, g.cmul((0.30, 0.29, 0.27), tone), stone)
    rough = g.lerp(g.lerp(ctx.roughness, 0.65, damp), 0.8, stone)
    height = g.add(g.mul(g.remap(clods.outputs["Distance"], 0.0, 0.6, 1.0, 0.0), 0.004), g.mul(stone, 0.004))
    return Surface(col, rough, height, grime=0.0)


def gravel(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    size = ctx.entry.scale_m                                  # 3 cm stones
    stones = g.voronoi(p, 1 / size)
    r = stones.outputs["Color"]
    tone = g.ramp(g.sep(r)[0], [(0.0, (0.55, 0.55, 0.56)), (0.4, (0.95, 0.92, 0.88)), (0.75, (1.2, 1.1, 0.95)),
                                (1.0, (1.35, 1.3, 1.22))])
    col = g.cmul(g.cmul(tone, C), g.remap(g.noise(p, 1 / 0.005, detail=2.0), 0.3, 0.7, 0.92, 1.08))
    gaps = g.remap(g.voronoi(p, 1 / size, feature="DISTANCE_TO_EDGE").outputs["Distance"], 0.0, 0.12, 1.0, 0.0)
    col = g.cmix(col, g.cmul(C, 0.3), g.mul(gaps, 0.75))
    fines = g.voronoi(p, 1 / (0.4 * size))
    col = g.cmul(col, g.remap(g.sep(fines.outputs["Color"])[1], 0.0, 1.0, 0.92, 1.08))
    dome = g.remap(stones.outputs["Distance"], 0.0, 0.55, 1.0, 0.0, smooth=True)
    height = g.mul(dome, ctx.entry.bump_m)
    return Surface(col, ctx.roughness, height, grime=0.5)


RECIPES = {"grass": grass, "leaves": leaves, "bark": bark, "soil": soil, "gravel": gravel}
