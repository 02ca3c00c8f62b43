"""Recipes of the built environment: asphalt, lane_marking, concrete, paving, setts, granite,
brick, blockwork, plaster, roof_tiles. Lengths in metres (the coordinates are metric); ``ctx.entry.scale_m`` is the
documented size of each one's main element."""
from __future__ import annotations

from .graph import Ctx, Surface


def _aggregate(ctx: Ctx, stone_m: float = 0.011):
    """Asphalt's exposed stones (AC 11: up to 11 mm) in dark binder, with the sand between
    them: (tone factor around 1, dome height 0..1). Worn surface course shows light-grey
    stones against near-black binder: the salt-and-pepper texture a camera resolves near
    the car."""
    g = ctx.g
    cells = g.voronoi(ctx.p, 1.0 / stone_m)
    stone = g.remap(g.sep(cells.outputs["Color"])[0], 0.0, 1.0, 0.45, 1.75)
    sand = g.remap(g.sep(g.voronoi(ctx.p, 1.0 / 0.003).outputs["Color"])[1], 0.0, 1.0, 0.85, 1.15)
    tone = g.mul(stone, sand)
    dome = g.remap(cells.outputs["Distance"], 0.0, 0.5, 1.0, 0.0)
    return tone, dome


def asphalt(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    tone, dome = _aggregate(ctx)
    # segregation and ravelling: clusters of stones and binder-rich spots at 2-10 cm (octaves of 10 cm), the
    # texture still resolved tens of metres ahead (a pixel there covers centimetres)
    grit = g.remap(g.noise(p, 1 / 0.1, detail=6.0, roughness=0.7), 0.3, 0.7, 0.5, 1.5)
    mottle = g.remap(g.noise(p, 1 / 0.35, detail=3.0), 0.3, 0.7, 0.84, 1.16)
    large = g.remap(g.noise(p, 1 / 4.0, detail=2.0), 0.3, 0.7, 0.85, 1.15)
    # the worn surface's light and dark spots at 1-3 cm: single stones polished bright or
    # binder-filled, the scale one KITTI pixel covers 5-20 m ahead (the stones alone, 11 mm,
    # average out within a pixel there). Grit and spots together give sunlit asphalt KITTI's
    # pixel-scale contrast (docs/sensors.md, Camera twins: the relative high-pass deviation of
    # its sunlit road at half size, 0.06-0.07)
    spots = g.voronoi(p, 1 / 0.022)
    spot = g.remap(g.sep(spots.outputs["Color"])[2], 0.0, 1.0, 0.45, 1.6)
    f = g.mul(g.mul(g.mul(g.mul(tone, grit), mottle), large), spot)
    col = g.cmul(C, f)
    # oil drips and tyre stains: dark blotches, more of them with wear
    stain = g.remap(g.noise(p, 1 / 0.6, detail=4.0, roughness=0.6), 0.66 - 0.08 * ctx.wear, 0.74 - 0.08 * ctx.wear,
                    smooth=True)
    col = g.cmix(col, g.cmul(col, 0.6), stain)
    # repair patches: square-ish cells, some of them newer (darker, finer) asphalt
    cells = g.voronoi(p, 1 / 3.0, metric="CHEBYCHEV")
    patch = g.math("GREATER_THAN", g.sep(cells.outputs["Color"])[1], 0.86)
    col = g.cmix(col, g.cmul(C, g.mul(g.lerp(0.95, 1.05, tone), 0.62)), patch)
    # sealed cracks: a thin network, only where a low-frequency mask (and wear) allows
    warp = g.vmath("ADD", p, g.vscale(g.noise(p, 1 / 0.6, detail=3.0, colour=True), 0.35))
    edge = g.voronoi(warp, 1 / 1.6, feature="DISTANCE_TO_EDGE").outputs["Distance"]
    line = g.remap(edge, 0.0, 0.004 / 1.6, 1.0, 0.0)     # ~4 mm wide (distances are in cells of 1.6 m)
    where = g.remap(g.noise(p, 1 / 5.0, detail=2.0), 0.62 - 0.2 * ctx.wear, 0.7 - 0.2 * ctx.wear, smooth=True)
    crack = g.mul(g.mul(line, where), g.sub(1.0, patch))
    col = g.cmix(col, (0.025, 0.025, 0.025), crack)
    rough = g.lerp(g.lerp(ctx.roughness, ctx.roughness - 0.08, patch), 0.55, crack)
    height = g.sub(g.add(g.mul(dome, 0.0015), g.mul(spots.outputs["Distance"], -0.002)), g.mul(crack, 0.003))
    return Surface(col, rough, height)


def lane_marking(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    tone, dome = _aggregate(ctx)
    # paint worn off in patches: coverage falls with wear
    worn = g.noise(p, 1 / 0.12, detail=6.0, roughness=0.6)
    cover = g.remap(worn, 0.18 + 0.3 * ctx.wear, 0.3 + 0.3 * ctx.wear, 0.35, 1.0, smooth=True)  # thinned, not gone
    dirt = g.remap(g.noise(p, 1 / 0.8, detail=3.0), 0.3, 0.7, 0.82, 1.05)
    paint = g.cmul(C, g.mul(dirt, g.lerp(0.92, 1.04, tone)))
    road = g.cmul((0.085, 0.085, 0.082), tone)
    col = g.cmix(road, paint, cover)
    rough = g.lerp(0.88, ctx.roughness, cover)
    height = g.add(g.mul(dome, 0.0012), g.mul(cover, 0.0008))
    return Surface(col, rough, height)


def concrete(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    stains = g.remap(g.noise(p, 1 / 1.2, detail=4.0, roughness=0.55), 0.3, 0.7, 0.8, 1.2)
    mid = g.remap(g.noise(p, 1 / 0.12, detail=4.0, roughness=0.6), 0.3, 0.7, 0.86, 1.14)
    # the sand and fine aggregate of the surface: a speckle at millimetres to centimetres
    speckle = g.remap(g.noise(p, 1 / 0.02, detail=4.0, roughness=0.7), 0.25, 0.75, 0.7, 1.3)
    pores = g.voronoi(p, 1 / 0.006)
    pit = g.mul(g.math("GREATER_THAN", g.sep(pores.outputs["Color"])[2], 0.93),
                g.remap(pores.outputs["Distance"], 0.15, 0.35, 1.0, 0.0))
    col = g.cmul(C, g.mul(g.mul(g.mul(stains, mid), speckle), g.lerp(1.0, 0.55, pit)))
    # with wear: scuffs and dirt (tyre marks, footprints, spills) at decimetres
    scuff = g.mul(g.remap(g.noise(g.vmath("MULTIPLY", p, (1.0, 1.0, 0.25)), 1 / 0.15, detail=5.0, roughness=0.6),
                          0.58, 0.72, smooth=True), ctx.wear)
    col = g.cmix(col, g.cmul(col, 0.55), scuff)
    rough = g.remap(g.noise(p, 1 / 0.3, detail=2.0), 0.3, 0.7, ctx.roughness - 0.06, ctx.roughness + 0.06)
    fine = g.noise(p, 1 / 0.01, detail=2.0)
    height = g.sub(g.mul(fine, 0.0004), g.mul(pit, 0.0015))
    return Surface(col, rough, height)


def paving(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    length = ctx.entry.scale_m                     # 20 x 10 cm pavers, 4 mm sand joints
    rand, joint = g.bricks(ctx.uv, length + 0.004, 0.5 * length + 0.004, 0.004, smooth=0.3)
    value = g.remap(rand, 0.0, 1.0, 0.88, 1.12)    # each paver its own cast and weathering (one batch: KITTI s1 0.049)
    speckle = g.remap(g.noise(p, 1 / 0.015, detail=3.0, roughness=0.7), 0.25, 0.75, 0.85, 1.15)
    stains = g.remap(g.noise(p, 1 / 0.8, detail=3.0), 0.3, 0.7, 0.85, 1.12)
    col = g.cmul(C, g.mul(g.mul(value, speckle), stains))
    # swept-in sand (light: KITTI sequence_1's sidewalk shows its joints faintly), darker with dirt and moss
    sand = g.cmul((0.28, 0.26, 0.23), g.lerp(1.0, 0.55, ctx.wear))
    col = g.cmix(col, sand, joint)
    chips = g.remap(g.noise(p, 1 / 0.02, detail=3.0), 0.64, 0.72, 0.0, 1.0)
    rough = g.lerp(ctx.roughness, 0.95, joint)
    height = g.sub(g.sub(g.mul(g.noise(p, 1 / 0.008, detail=2.0), 0.0004), g.mul(joint, 0.003)),
                   g.mul(chips, 0.001))
    return Surface(col, rough, height)


def setts(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    size = ctx.entry.scale_m                       # 20 cm square blocks in straight rows, 6 mm sand joints
    rand, joint = g.bricks(ctx.uv, size + 0.006, size + 0.006, 0.006, offset=0.0, smooth=0.25)
    value = g.remap(rand, 0.0, 1.0, 0.8, 1.2)      # each block its own cast and weathering
    # the blocks' exposed aggregate and the tyre-polished face: millimetre grains, centimetre mottle
    grain = g.remap(g.sep(g.voronoi(p, 1 / 0.005).outputs["Color"])[0], 0.0, 1.0, 0.8, 1.2)
    mottle = g.remap(g.noise(p, 1 / 0.04, detail=3.0, roughness=0.6), 0.3, 0.7, 0.85, 1.15)
    col = g.cmul(C, g.mul(g.mul(value, grain), mottle))
    # a parking bay's oil drips and tyre stains: dark blotches at decimetres, more with wear
    stain = g.remap(g.noise(p, 1 / 0.5, detail=4.0, roughness=0.6), 0.64 - 0.08 * ctx.wear, 0.72 - 0.08 * ctx.wear,
                    smooth=True)
    col = g.cmix(col, g.cmul(col, 0.6), stain)
    # light sand swept into the joints (what makes KITTI sequence_1's dark bay a grid of light lines),
    # greyed by dirt and moss with wear
    sand = g.cmul((0.30, 0.28, 0.24), g.lerp(1.0, 0.6, ctx.wear))
    col = g.cmix(col, sand, joint)
    # litter: a few light specks (leaves, paper, gravel) of 1-3 cm
    bits = g.voronoi(p, 1 / 0.05)
    speck = g.mul(g.math("GREATER_THAN", g.sep(bits.outputs["Color"])[2], 0.985),
                  g.remap(bits.outputs["Distance"], 0.15, 0.3, 1.0, 0.0))
    col = g.cmix(col, (0.45, 0.42, 0.36), speck)
    rough = g.lerp(ctx.roughness, 0.95, joint)
    height = g.sub(g.mul(g.noise(p, 1 / 0.01, detail=2.0), 0.0005), g.mul(joint, 0.004))
    return Surface(col, rough, height)


def granite(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    # grey granite's grains (2-6 mm): black biotite, grey quartz, white feldspar; a sawn or
    # flamed kerb shows them as a salt-and-pepper texture
    grains = g.sep(g.voronoi(p, 1 / ctx.entry.scale_m).outputs["Color"])[0]
    tone = g.ramp(grains, [(0.0, (0.35, 0.35, 0.36)), (0.14, (0.35, 0.35, 0.36)), (0.15, (0.85, 0.85, 0.86)),
                           (0.68, (1.0, 1.0, 1.0)), (0.7, (1.3, 1.28, 1.25)), (1.0, (1.4, 1.37, 1.33))])
    stains = g.remap(g.noise(p, 1 / 0.4, detail=3.0), 0.3, 0.7, 0.85, 1.12)
    col = g.cmul(g.cmul(C, tone), stains)
    # black tyre scuffs streaked along the kerb (the object's z), more with wear
    scuff = g.mul(g.remap(g.noise(g.vmath("MULTIPLY", p, (1.0, 1.0, 0.1)), 1 / 0.05, detail=4.0), 0.62, 0.72,
                          smooth=True), ctx.wear)
    col = g.cmix(col, g.cmul(col, 0.4), scuff)
    height = g.add(g.mul(grains, 0.0003), g.mul(g.noise(p, 1 / 0.02, detail=3.0), 0.0006))
    return Surface(col, ctx.roughness, height)


def brick(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    length = ctx.entry.scale_m                     # 24 cm bricks, 1 cm mortar, 7.1 cm courses
    rand, mortar = g.bricks(ctx.uv, length + 0.01, 0.081, 0.01, smooth=0.15)
    r2 = g.white(g.add(rand, 0.37))
    value = g.remap(rand, 0.0, 1.0, 0.72, 1.22)
    burnt = g.math("GREATER_THAN", r2, 0.92)       # a few dark over-fired bricks
    value = g.lerp(value, 0.55, burnt)
    face = g.remap(g.noise(ctx.p, 1 / 0.03, detail=3.0), 0.3, 0.7, 0.84, 1.12)   # fired clay's blotches
    tint = g.hsv(g.cmul(C, g.mul(value, face)), g.madd(r2, 0.02, 0.49), g.madd(rand, 0.15, 0.85), 1.0)
    mortar_col = g.cmul((0.42, 0.40, 0.37), g.remap(g.noise(ctx.p, 1 / 0.05, detail=2.0), 0.3, 0.7, 0.85, 1.1))
    col = g.cmix(tint, mortar_col, mortar)
    rough = g.lerp(ctx.roughness, 0.95, mortar)
    chips = g.remap(g.noise(ctx.p, 1 / 0.015, detail=4.0), 0.62, 0.72, 0.0, 1.0)
    height = g.add(g.mul(mortar, -0.004), g.sub(g.mul(g.noise(ctx.p, 1 / 0.01, detail=3.0), 0.0006),
                                                  g.mul(chips, 0.0015)))
    return Surface(col, rough, height)


def blockwork(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    length = ctx.entry.scale_m                     # 50 cm blocks in 25 cm courses
    # the joint as the sun sees it: 2 mm of mortar between 3-4 mm bevels, a dark line ~1 cm wide
    rand, joint = g.bricks(ctx.uv, length, 0.5 * length, 0.01, smooth=0.3)
    r2 = g.white(g.add(rand, 0.61))
    value = g.remap(rand, 0.0, 1.0, 0.84, 1.14)    # per-block tone: batches, dust, sun-dried or not
    value = g.lerp(value, 0.72, g.math("GREATER_THAN", r2, 0.9))   # a few blocks still damp
    face = g.remap(g.noise(p, 1 / 0.04, detail=3.0), 0.3, 0.7, 0.9, 1.08)   # the pressed face's pores and dust
    col = g.cmul(C, g.mul(value, face))
    # thin-bed mortar smeared over the joints and splashed on the faces: lighter, patchy
    smear = g.mul(g.remap(g.noise(p, 1 / 0.15, detail=3.0), 0.6, 0.7, smooth=True), 0.5)
    col = g.cmix(col, g.cmul(C, 1.25), smear)
    col = g.cmix(col, g.cmul(C, 0.45), joint)
    rough = g.lerp(ctx.roughness, 0.95, joint)
    height = g.add(g.mul(joint, -0.003), g.mul(g.noise(p, 1 / 0.01, detail=2.0), 0.0004))
    return Surface(col, rough, height)


def plaster(ctx: Ctx) -> Surface:
    g, p, C = ctx.g, ctx.p, ctx.colour
    # weathered render: its tone wanders by +-5-10 % over metres and decimetres (repairs, damp,
    # uneven dust), which a camera resolves on every facade in the sun (docs/sensors.md, Camera twins)
    patches = g.remap(g.noise(p, 1 / 2.0, detail=3.0), 0.3, 0.7, 0.9, 1.08)
    mid = g.remap(g.noise(p, 1 / 0.3, detail=3.0), 0.3, 0.7, 0.92, 1.07)
    # the render's sand grain: a faint speckle at millimetres to centimetres
    grain = g.remap(g.noise(p, 1 / 0.01, detail=3.0, roughness=0.7), 0.25, 0.75, 0.94, 1.06)
    # weathering: dust held in the render's pores, washed off unevenly, a mottle at 3-10 cm
    # (what a KITTI pixel sees of a facade 10-30 m away; the sand grain is sub-pixel there)
    mottle = g.remap(g.noise(p, 1 / 0.05, detail=4.0, roughness=0.65), 0.3, 0.7, 0.78, 1.14)
    mid = g.mul(g.mul(mid, grain), mottle)
    # grime running down the wall (object y is up): streaks stretched vertically
    streak_p = g.vmath("MULTIPLY", p, (6.0, 0.35, 6.0))
    streaks = g.remap(g.noise(streak_p, 1.0, detail=4.0), 0.5, 0.75, smooth=True)
    col = g.cmul(C, g.mul(g.mul(patches, mid), g.lerp(1.0, 0.72, g.mul(streaks, ctx.wear))))
    rough = g.remap(g.noise(p, 1 / 0.5, detail=2.0), 0.3, 0.7, ctx.roughness - 0.05, ctx.roughness + 0.05)
    # roughcast: 1-2 mm grains at 5 mm (the sun rakes them), over the trowel's waves
    roughcast = g.remap(g.voronoi(p, 1 / 0.005).outputs["Distance"], 0.0, 0.6, 1.0, 0.0)
    height = g.add(g.add(g.mul(roughcast, 0.0012), g.mul(g.noise(p, 1 / 0.004, detail=2.0), 0.0003)),
                   g.mul(g.noise(p, 1 / 0.25, detail=2.0), 0.0008))
    return Surface(col, rough, height)


def roof_tiles(ctx: Ctx) -> Surface:
    g, C = ctx.g, ctx.colour
    row = ctx.entry.scale_m                          # rows every 33 cm along v, tiles 20 cm wide
    rand, joint = g.bricks(ctx.uv, 0.20, row, 0.004, smooth=0.2)
    _, v, _ = g.sep(ctx.uv)
    t = g.math("FRACT", g.math("DIVIDE", v, row))    # 0 at a row's lower edge ... 1 at its top
    value = g.remap(rand, 0.0, 1.0, 0.72, 1.25)
    shade = g.remap(t, 0.78, 1.0, 1.0, 0.55)         # the shadow under the tile above
    col = g.hsv(g.cmul(C, g.mul(value, shade)), g.madd(g.white(rand), 0.04, 0.48), 1.0, 1.0)
    moss = g.mul(g.remap(g.noise(ctx.p, 1 / 0.15, detail=4.0), 0.55, 0.7, smooth=True),
                 g.mul(g.remap(t, 0.0, 0.35, 1.0, 0.2), ctx.wear))
    col = g.cmix(col, (0.06, 0.08, 0.03), moss)
    col = g.cmix(col, (0.05, 0.04, 0.035), g.mul(joint, 0.7))
    rough = g.lerp(ctx.roughness, 0.95, moss)
    height = g.add(g.mul(g.sub(1.0, t), 0.012), g.mul(g.noise(ctx.p, 1 / 0.02, detail=2.0), 0.0006))
    return Surface(col, rough, height)


RECIPES = {"asphalt": asphalt, "lane_marking": lane_marking, "concrete": concrete, "paving": paving, "setts": setts,
           "granite": granite, "brick": brick, "blockwork": blockwork,
           "plaster": plaster, "roof_tiles": roof_tiles}
