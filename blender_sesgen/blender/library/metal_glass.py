"""Recipes for metals, paints and glass: metal_painted, metal_brushed, metal_rusty, galvanised,
chrome, vehicle_lamp, car_paint, glass_window, frosted_glass."""
from __future__ import annotations

from .graph import Ctx, Surface

STEEL = (0.55, 0.55, 0.55)


def metal_painted(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    fade = g.remap(g.noise(ctx.p, 1 / 0.6, detail=3.0), 0.3, 0.7, 0.93, 1.06)
    paint = g.cmul(C, fade)
    # chips: small flakes of paint gone, primer or steel showing (more with wear)
    chip_noise = g.noise(ctx.p, 1 / 0.02, detail=6.0, roughness=0.65)
    chips = g.remap(chip_noise, 0.72 - 0.12 * ctx.wear, 0.74 - 0.12 * ctx.wear)
    steel = g.math("GREATER_THAN", g.noise(ctx.p, 1 / 0.01, detail=2.0), 0.55)
    under = g.cmix((0.32, 0.10, 0.06), STEEL, steel)
    col = g.cmix(paint, under, chips)
    metallic = g.mul(chips, steel)
    rough = g.lerp(g.remap(g.noise(ctx.p, 1 / 0.2, detail=2.0), 0.3, 0.7, ctx.roughness - 0.06,
                           ctx.roughness + 0.06), 0.55, chips)
    height = g.sub(g.mul(g.noise(ctx.p, 1 / 0.002, detail=2.0), 0.00008), g.mul(chips, 0.0002))
    return Surface(col, rough, height, metallic=metallic)


def metal_brushed(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    streak_p = g.vmath("MULTIPLY", ctx.p, (2.0, 400.0, 400.0))   # brushed along the object's x
    streaks = g.noise(streak_p, 1.0, detail=3.0)
    col = g.cmul(C, g.remap(streaks, 0.3, 0.7, 0.96, 1.04))
    rough = g.remap(streaks, 0.3, 0.7, ctx.roughness - 0.08, ctx.roughness + 0.08)
    height = g.mul(streaks, 0.00005)
    return Surface(col, rough, height, metallic=ctx.metallic, grime=0.5)


def metal_rusty(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    n = g.noise(ctx.p, 1 / 0.35, detail=8.0, roughness=0.6)
    rust = g.remap(n, 0.56 - 0.3 * ctx.wear, 0.7 - 0.3 * ctx.wear, smooth=True)
    rust_tone = g.ramp(g.noise(ctx.p, 1 / 0.03, detail=4.0),
                       [(0.3, (0.05, 0.025, 0.012)), (0.55, (0.13, 0.055, 0.025)), (0.75, (0.2, 0.085, 0.035))])
    stain = g.remap(n, 0.4 - 0.3 * ctx.wear, 0.6 - 0.3 * ctx.wear, 1.0, 0.7)   # rust-stained halo
    base = g.cmul(C, g.mul(stain, g.remap(g.noise(ctx.p, 1 / 0.3, detail=2.0), 0.3, 0.7, 0.9, 1.08)))
    col = g.cmix(base, rust_tone, rust)
    metallic = g.lerp(ctx.metallic, 0.0, rust)
    rough = g.lerp(ctx.roughness, 0.92, rust)
    height = g.mul(rust, g.mul(g.noise(ctx.p, 1 / 0.004, detail=3.0), 0.001))
    return Surface(col, rough, height, metallic=metallic, grime=0.4)


def galvanised(ctx: Ctx) -> Surface:
    """The patina is a dielectric (zinc carbonate scatters); bare zinc shows as metal only where
    handling and clamps wore it (a few %), so the surface reads by its albedo in the sun."""
    g, C = ctx.g, ctx.colour
    cells = g.voronoi(ctx.p, 1 / ctx.entry.scale_m)                 # spangle: zinc crystals 1-3 cm
    spangle = g.remap(cells.outputs["Color"], 0.0, 1.0, 0.9, 1.1)
    cloud = g.remap(g.noise(ctx.p, 1 / 0.4, detail=3.0), 0.3, 0.7, 0.88, 1.08)   # uneven weathering
    worn = g.remap(g.noise(ctx.p, 1 / 0.05, detail=4.0, roughness=0.6), 0.7, 0.76, smooth=True)
    white = g.mul(g.remap(g.noise(ctx.p, 1 / 0.12, detail=4.0), 0.6 - 0.2 * ctx.wear, 0.7 - 0.2 * ctx.wear,
                          smooth=True), ctx.wear)                        # white rust blooms
    col = g.cmix(g.cmul(C, g.mul(spangle, cloud)), (0.58, 0.58, 0.56), white)
    col = g.cmix(col, (0.62, 0.63, 0.64), worn)
    metallic = g.mul(worn, 0.9)
    rough = g.lerp(g.remap(cloud, 0.88, 1.08, ctx.roughness + 0.1, ctx.roughness - 0.1), 0.35, worn)
    height = g.mul(g.noise(ctx.p, 1 / 0.005, detail=2.0), 0.0002)
    return Surface(col, rough, height, metallic=metallic, grime=0.5)


def chrome(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    smudge = g.mul(g.remap(g.noise(ctx.p, 1 / 0.03, detail=4.0), 0.5, 0.7, smooth=True), ctx.wear)
    rough = g.lerp(ctx.roughness, ctx.roughness + 0.15, smudge)
    height = g.mul(g.noise(ctx.p, 1 / 0.05, detail=2.0), 0.0001)
    return Surface(C, rough, height, metallic=ctx.metallic, grime=0.0)


def vehicle_lamp(ctx: Ctx) -> Surface:
    """A vehicle lamp: the metallised reflector in the lens's colour (the light passes the lens
    twice), rough: the lens's pillow optics spread what it returns over tens of degrees (ECE
    R7 asks a tail lamp to show over +-45 deg and more), so a lamp returns the sky and the
    sun's light in the lens's colour from most directions; the lens's own glossy face on top
    (a clear coat of PMMA, IOR 1.49); the moulded optics a faint relief at 1 cm."""
    g, C = ctx.g, ctx.colour
    height = g.mul(g.noise(ctx.p, 1 / ctx.entry.scale_m * 4, detail=2.0), 0.0001)
    return Surface(C, ctx.roughness, height, metallic=ctx.metallic, grime=0.2,
                   extra={"Coat Weight": 1.0, "Coat Roughness": 0.02, "Coat IOR": 1.49})


def car_paint(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    flakes = g.remap(g.noise(ctx.p, 1 / 0.0008, detail=1.0), 0.3, 0.7, 0.96, 1.04)
    col = g.cmul(C, flakes)
    height = g.mul(g.noise(ctx.p, 1 / 0.004, detail=2.0), 0.00003)   # orange peel of the clear coat
    return Surface(col, ctx.roughness, height, metallic=ctx.metallic, grime=0.6,
                   extra={"Coat Weight": 1.0, "Coat Roughness": 0.03, "Coat IOR": 1.5})


def glass_window(ctx: Ctx) -> Surface:
    """Opaque on purpose: a dark interior under the glass's Fresnel reflection (IOR 1.52),
    so that what the camera sees and its depth are both the glass."""
    g, C = ctx.g, ctx.colour
    r0, r1, _ = ctx.rand
    u, v, _ = g.sep(ctx.uv)
    room = g.remap(g.noise(g.comb(u, v, g.mul(r0, 50.0)), 1 / 0.6, detail=3.0), 0.3, 0.7, 0.5, 1.8)
    lit = g.math("GREATER_THAN", r1, 0.8)             # some rooms lit, or light curtains
    interior = g.cmul(C, g.mul(room, g.lerp(1.0, 3.5, lit)))
    wave = g.mul(g.noise(ctx.p, 1 / 1.5, detail=2.0), 0.0003)   # float glass is not perfectly flat
    return Surface(interior, ctx.roughness, wave, grime=0.3, extra={"IOR": 1.52, "Specular IOR Level": 0.5})


def frosted_glass(ctx: Ctx) -> Surface:
    """Diffusing glazing: a faint cloudiness (+-3 % over 5-30 cm), no relief (its matte face
    is the roughness); what it passes (library ``transmittance``) build_shader adds."""
    g, C = ctx.g, ctx.colour
    cloud = g.remap(g.noise(ctx.p, 1 / 0.15, detail=3.0), 0.3, 0.7, 0.97, 1.03)
    return Surface(g.cmul(C, cloud), ctx.roughness, None, grime=0.3)


RECIPES = {"metal_painted": metal_painted, "metal_brushed": metal_brushed, "metal_rusty": metal_rusty,
           "galvanised": galvanised, "chrome": chrome, "vehicle_lamp": vehicle_lamp, "car_paint": car_paint,
           "glass_window": glass_window, "frosted_glass": frosted_glass}
