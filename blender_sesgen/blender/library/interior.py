"""Recipes for interiors and objects: wood_planks, ceramic_tiles, fabric, plastic, rubber."""
from __future__ import annotations

from .graph import Ctx, Surface


def wood_planks(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    width = ctx.entry.scale_m                                  # 14 cm planks, 1.6 m long, 2 mm gaps
    rand, gap = g.bricks(ctx.uv, 1.6, width, 0.002, offset=0.37, frequency=1, smooth=0.3)
    u, v, w = g.sep(ctx.uv)
    # grain: streaks along the plank (u), a different figure per plank
    grain_p = g.comb(g.mul(u, 1.5), g.madd(v, 45.0, g.mul(rand, 37.0)), g.mul(w, 45.0))
    grain = g.remap(g.noise(grain_p, 1.0, detail=5.0, roughness=0.6, distortion=0.4), 0.3, 0.7, 0.82, 1.15)
    figure = g.node("ShaderNodeTexWave", {"Vector": g.comb(g.mul(u, 0.25), g.add(v, g.mul(rand, 9.0)), w),
                                          "Scale": 9.0, "Distortion": 5.0, "Detail": 3.0},
                    wave_type="BANDS", bands_direction="Y", wave_profile="SIN").outputs["Factor"]
    figure = g.remap(figure, 0.0, 1.0, 0.9, 1.06)
    value = g.remap(rand, 0.0, 1.0, 0.8, 1.2)
    plank = g.hsv(g.cmul(C, g.mul(g.mul(value, grain), figure)), g.madd(g.white(rand), 0.03, 0.485),
                  g.madd(rand, 0.15, 0.85), 1.0)
    col = g.cmix(plank, (0.02, 0.015, 0.01), gap)
    rough = g.lerp(g.remap(g.noise(ctx.p, 1 / 0.4, detail=2.0), 0.3, 0.7, ctx.roughness - 0.08,
                           ctx.roughness + 0.08), 0.9, gap)
    height = g.add(g.mul(gap, -0.002), g.add(g.mul(rand, 0.0004), g.mul(grain, 0.0002)))
    return Surface(col, rough, height)


def ceramic_tiles(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    size = ctx.entry.scale_m                                   # 30 cm tiles, 3 mm grout
    rand, grout = g.bricks(ctx.uv, size, size, 0.003, offset=0.0, frequency=1, smooth=0.3)
    u, v, _ = g.sep(ctx.uv)
    fu = g.math("FRACT", g.math("DIVIDE", u, size))
    fv = g.math("FRACT", g.math("DIVIDE", v, size))
    r2 = g.white(g.add(rand, 0.71))
    tile = g.hsv(g.cmul(C, g.remap(rand, 0.0, 1.0, 0.94, 1.05)), g.madd(r2, 0.02, 0.49), 1.0, 1.0)
    glaze = g.remap(g.noise(ctx.p, 1 / 0.2, detail=3.0), 0.3, 0.7, 0.97, 1.03)
    dirty_grout = g.cmul((0.36, 0.35, 0.33), g.lerp(1.0, 0.55, ctx.wear))
    col = g.cmix(g.cmul(tile, glaze), dirty_grout, grout)
    rough = g.lerp(g.remap(g.noise(ctx.p, 1 / 0.15, detail=2.0), 0.3, 0.7, ctx.roughness * 0.7,
                           ctx.roughness * 1.4), 0.9, grout)
    # every tile sits at its own slight tilt: its reflections break at the grout lines
    tilt = g.add(g.mul(g.sub(rand, 0.5), fu), g.mul(g.sub(r2, 0.5), fv))
    height = g.add(g.mul(tilt, 0.0008), g.mul(grout, -0.0015))
    return Surface(col, rough, height)


def fabric(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    u, v, _ = g.sep(ctx.uv)
    pitch = ctx.entry.scale_m                                  # 4 mm weave

    def threads(a):
        return g.math("SINE", g.mul(a, 6.2832 / pitch))
    weave = g.mul(threads(u), threads(v))
    folds = g.remap(g.noise(ctx.p, 1 / 0.25, detail=3.0), 0.3, 0.7, 0.88, 1.1)
    slub = g.remap(g.noise(g.comb(g.mul(u, 30.0), g.mul(v, 3.0), 0.0), 1.0, detail=2.0), 0.3, 0.7, 0.98, 1.02)
    col = g.cmul(C, g.mul(g.mul(folds, slub), g.madd(weave, 0.015, 1.0)))
    height = g.mul(weave, 0.0003)
    return Surface(col, ctx.roughness, height,
                   extra={"Sheen Weight": 0.6, "Sheen Roughness": 0.45, "Sheen Tint": (1.0, 1.0, 1.0)})


def plastic(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    tone = g.remap(g.noise(ctx.p, 1 / 0.4, detail=2.0), 0.3, 0.7, 0.97, 1.03)
    smudge = g.mul(g.remap(g.noise(ctx.p, 1 / 0.06, detail=4.0), 0.5, 0.7, smooth=True), ctx.wear)
    rough = g.lerp(g.remap(g.noise(ctx.p, 1 / 0.1, detail=2.0), 0.3, 0.7, ctx.roughness - 0.05,
                           ctx.roughness + 0.05), 0.6, smudge)
    height = g.mul(g.noise(ctx.p, 1 / 0.0015, detail=1.0), 0.00005)
    return Surface(g.cmul(C, tone), rough, height, grime=0.5)


def rubber(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    dust = g.mul(g.remap(g.noise(ctx.p, 1 / 0.08, detail=4.0), 0.45, 0.7, smooth=True), ctx.wear)
    col = g.cmix(g.cmul(C, g.remap(g.noise(ctx.p, 1 / 0.05, detail=2.0), 0.3, 0.7, 0.9, 1.1)),
                 (0.16, 0.15, 0.14), g.mul(dust, 0.6))
    height = g.mul(g.noise(ctx.p, 1 / 0.002, detail=2.0), 0.0002)
    return Surface(col, g.lerp(ctx.roughness, 0.95, dust), height, grime=0.0)


RECIPES = {"wood_planks": wood_planks, "ceramic_tiles": ceramic_tiles, "fabric": fabric, "plastic": plastic,
           "rubber": rubber}
