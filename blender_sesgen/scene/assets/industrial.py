"""Industrial-hall assets: steel columns and girders, pallet racks with loads, machines,
tanks, crates, pallets, barrels, stairs, railings, pipe runs.

Asset frame: ``size`` = (x, y, z) extents, floor at y = 0, front towards +z. A girder's
origin is the middle of its bottom flange (place it at the height it hangs at).
"""
from __future__ import annotations

import numpy as np

from .mesh import MeshData, pose, rot_z, start
from .palette import pick, scaled

STEEL_PAINT = ((0.30, 0.31, 0.32), (0.02, 0.06, 0.18), (0.40, 0.12, 0.02), (0.35, 0.30, 0.02),
               (0.05, 0.12, 0.08), (0.55, 0.55, 0.52))
MACHINE_PAINT = ((0.20, 0.30, 0.22), (0.45, 0.46, 0.44), (0.08, 0.15, 0.30), (0.50, 0.48, 0.40),
                 (0.35, 0.36, 0.38), (0.55, 0.30, 0.05))
CARDBOARD = ((0.35, 0.24, 0.13), (0.40, 0.30, 0.18), (0.30, 0.20, 0.11))
PALLET_WOOD = ((0.40, 0.30, 0.18), (0.33, 0.25, 0.15))


def column(size, seed: int) -> MeshData:
    """A steel H-section column on a base plate, or a concrete column with a plinth."""
    rng, W, H, D, b = start(size, seed)
    if rng.random() < 0.7:
        steel = b.surface("metal_painted", pick(rng, STEEL_PAINT))
        tf, tw = 0.02, 0.012
        b.box((-W / 2, 0.02, -D / 2), (W / 2, H, -D / 2 + tf), steel)
        b.box((-W / 2, 0.02, D / 2 - tf), (W / 2, H, D / 2), steel)
        b.box((-tw / 2, 0.02, -D / 2 + tf), (tw / 2, H, D / 2 - tf), steel)
        b.box((-W / 2 - 0.08, 0, -D / 2 - 0.08), (W / 2 + 0.08, 0.02, D / 2 + 0.08), steel)
        stripe = b.surface("metal_painted", (0.55, 0.42, 0.02))
        dark = b.surface("metal_painted", (0.02, 0.02, 0.02))
        for i in range(6):   # warning stripes at the foot
            y = 0.02 + i * 0.1
            b.box((-W / 2 - 0.003, y, D / 2), (W / 2 + 0.003, y + 0.1, D / 2 + 0.002), stripe if i % 2 else dark)
    else:
        conc = b.surface("concrete")
        b.box((-W / 2, 0, -D / 2), (W / 2, H, D / 2), conc)
        b.box((-W / 2 - 0.03, 0, -D / 2 - 0.03), (W / 2 + 0.03, 0.15, D / 2 + 0.03), conc)
    return b.build()


def girder(size, seed: int) -> MeshData:
    """An I-beam along x: size = (length, depth, flange width); origin at the middle of
    the bottom flange."""
    rng, L, Hd, Wf, b = start(size, seed)
    steel = b.surface("metal_painted", pick(rng, STEEL_PAINT))
    tf, tw = 0.018, 0.01
    b.box((-L / 2, 0, -Wf / 2), (L / 2, tf, Wf / 2), steel)
    b.box((-L / 2, Hd - tf, -Wf / 2), (L / 2, Hd, Wf / 2), steel)
    b.box((-L / 2, tf, -tw / 2), (L / 2, Hd - tf, tw / 2), steel)
    n = max(int(L / 1.5), 1)
    for i in range(n + 1):       # web stiffeners
        x = -L / 2 + L * i / n
        b.box((x - 0.006, tf, -Wf / 2 + 0.01), (x + 0.006, Hd - tf, Wf / 2 - 0.01), steel)
    return b.build()


def _pallet(b, x0, z0, w, d, y0, wood):
    for k in range(5):
        xb = x0 + k * (w - 0.1) / 4
        b.box((xb, y0 + 0.12, z0), (xb + 0.1, y0 + 0.14, z0 + d), wood)
    for k in range(3):
        zb = z0 + k * (d - 0.1) / 2
        b.box((x0, y0, zb), (x0 + w, y0 + 0.12, zb + 0.1), wood)


def pallet(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    _pallet(b, -W / 2, -D / 2, W, D, 0.0, b.surface("wood_planks", pick(rng, PALLET_WOOD)))
    return b.build()


def rack(size, seed: int) -> MeshData:
    """A pallet rack open towards +z and -z: upright frames with bracing, beam levels,
    pallets with cardboard loads (some shrink-wrapped, some empty slots)."""
    rng, L, H, D, b = start(size, seed)
    upright = b.surface("metal_painted", (0.03, 0.10, 0.35) if rng.random() < 0.6 else (0.30, 0.31, 0.32))
    beam = b.surface("metal_painted", (0.50, 0.18, 0.02))
    wood = b.surface("wood_planks", pick(rng, PALLET_WOOD))
    boxes = [b.surface("plastic", c) for c in CARDBOARD]
    wrap = b.surface("plastic", (0.55, 0.55, 0.55))
    bay = rng.uniform(2.4, 2.8)
    n = max(int(round(L / bay)), 1)
    xs = np.linspace(-L / 2, L / 2, n + 1)
    levels = np.arange(0.0, H - 1.0, rng.uniform(1.4, 1.8))
    for x in xs:
        for z in (-D / 2, D / 2 - 0.09):
            b.box((x - 0.045, 0, z), (x + 0.045, H, z + 0.09), upright)
        for y in np.arange(0.3, H, 0.6):  # bracing
            b.box((x - 0.015, y, -D / 2 + 0.09), (x + 0.015, y + 0.03, D / 2 - 0.09), upright)
    for y in levels[1:]:
        for i in range(n):
            for z in (-D / 2, D / 2 - 0.06):
                b.box((xs[i] + 0.045, y - 0.12, z), (xs[i + 1] - 0.045, y, z + 0.06), beam)
    for y in levels:
        for i in range(n):
            for k in range(2):
                if rng.random() < 0.2:
                    continue
                w = (xs[i + 1] - xs[i] - 0.2) / 2
                x0 = xs[i] + 0.1 + k * (w + 0.0)
                y0 = y + (0.0 if y == levels[0] else 0.0)
                _pallet(b, x0 + 0.02, -D / 2 + 0.05, w - 0.04, D - 0.1, y0, wood)
                top = min(y0 + 0.14 + rng.uniform(0.6, 1.2), y + (levels[1] - levels[0]) - 0.2 if len(levels) > 1 else H)
                if rng.random() < 0.3:
                    b.box((x0 + 0.04, y0 + 0.14, -D / 2 + 0.07), (x0 + w - 0.06, top, D / 2 - 0.07), wrap)
                else:
                    nb = int(rng.integers(2, 5))
                    ys = np.linspace(y0 + 0.14, top, nb + 1)
                    for j in range(nb):
                        for zz in (0, 1):
                            z0 = -D / 2 + 0.07 + zz * (D - 0.14) / 2
                            b.box((x0 + 0.04, ys[j], z0 + 0.005), (x0 + w - 0.06, ys[j + 1] - 0.005, z0 + (D - 0.14) / 2 - 0.005),
                                  boxes[rng.integers(len(boxes))])
    return b.build()


def machine(size, seed: int) -> MeshData:
    """An industrial machine: plinth, main housing with access panels and a window, a
    control cabinet with buttons, a motor, ducting, warning stripes on the plinth."""
    rng, W, H, D, b = start(size, seed)
    paint = b.surface("metal_painted", pick(rng, MACHINE_PAINT))
    dark = b.surface("metal_painted", (0.03, 0.03, 0.03))
    steel = b.surface("metal_brushed")
    glass = b.surface("glass_window")
    yellow = b.surface("metal_painted", (0.55, 0.42, 0.02))
    b.box((-W / 2, 0, -D / 2), (W / 2, 0.15, D / 2), dark)
    for i in range(int(W / 0.2)):
        x = -W / 2 + i * 0.2
        if i % 2 == 0:
            b.box((x, 0.02, D / 2), (x + 0.2, 0.13, D / 2 + 0.003), yellow)
    hw = W * rng.uniform(0.55, 0.8)
    b.box((-W / 2 + 0.05, 0.15, -D / 2 + 0.05), (-W / 2 + 0.05 + hw, H * rng.uniform(0.7, 1.0), D / 2 - 0.05), paint)
    top = H * 0.7
    n = int(rng.integers(2, 4))
    for k in range(n):   # access panels with handles
        x0 = -W / 2 + 0.1 + k * (hw - 0.1) / n
        b.box((x0, 0.3, D / 2 - 0.05), (x0 + (hw - 0.1) / n - 0.04, top - 0.1, D / 2 - 0.035), paint)
        b.box((x0 + 0.05, top * 0.5, D / 2 - 0.035), (x0 + 0.08, top * 0.5 + 0.2, D / 2 - 0.005), steel)
    wx = -W / 2 + 0.05 + hw * 0.5
    b.box((wx - 0.25, top - 0.05, D / 2 - 0.045), (wx + 0.25, min(top + 0.25, H - 0.05), D / 2 - 0.03), glass)
    cab = b.surface("metal_painted", (0.55, 0.55, 0.52))
    cx0 = -W / 2 + 0.1 + hw
    b.box((cx0, 0.15, D / 2 - 0.5), (W / 2 - 0.05, min(1.9, H), D / 2 - 0.05), cab)
    red = b.surface("plastic", (0.4, 0.02, 0.02))
    green = b.surface("plastic", (0.02, 0.25, 0.05))
    for i in range(3):
        for j in range(2):
            b.cylinder(0.02, 0.0, 0.02, 10, red if (i + j) % 3 == 0 else green,
                       T=pose(np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]]), (cx0 + 0.1 + i * 0.08, 1.2 + j * 0.1, D / 2 - 0.05)))
    b.cylinder(0.18, -W / 2 + 0.05, -W / 2 - 0.4, 16, paint, T=pose(rot_z(90), (0, 0.5, -D / 4)))
    # louvred vents on the housing's side, a warning plate, pipes down to the floor
    vx0 = -W / 2 + 0.05 + hw * 0.15
    for k in range(int(rng.integers(6, 14))):
        y = 0.4 + k * 0.06
        if y > top - 0.2:
            break
        b.box((vx0, y, D / 2 - 0.05), (vx0 + min(0.6, hw * 0.3), y + 0.025, D / 2 - 0.02), dark)
    warn = b.surface("metal_painted", (0.55, 0.42, 0.02))
    b.box((wx + 0.35, top - 0.3, D / 2 - 0.05), (wx + 0.55, top - 0.12, D / 2 - 0.035), warn)
    rust = b.surface("metal_rusty")
    for k in range(int(rng.integers(1, 4))):
        px = -W / 2 + 0.2 + rng.uniform(0, hw - 0.3)
        b.tube([(px, 0.15, -D / 2 + 0.1 + 0.25 * k), (px, top * 0.6, -D / 2 + 0.1 + 0.25 * k),
                (px + 0.3, top * 0.6 + 0.3, -D / 2 + 0.1 + 0.25 * k)], 0.04, 8, rust)
    if rng.random() < 0.7:   # duct up from the housing
        b.tube([(-W / 2 + hw * 0.3, H * 0.6, -D / 4), (-W / 2 + hw * 0.3, H + 0.6, -D / 4), (-W / 2 + hw * 0.3 + 0.5, H + 1.0, -D / 4)],
               0.12, 12, steel)
    return b.build()


def tank(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    shell = b.surface("metal_brushed") if rng.random() < 0.5 else b.surface("metal_painted", pick(rng, MACHINE_PAINT))
    legs = b.surface("metal_painted", (0.05, 0.05, 0.05))
    r = min(W, D) / 2
    leg_h = H * 0.15
    prof = [(0, leg_h), (r * 0.7, leg_h), (r, leg_h + r * 0.2), (r, H - r * 0.35), (r * 0.8, H - r * 0.12),
            (r * 0.4, H - 0.02), (0, H)]
    b.revolve(prof, 32, shell)
    for k in range(4):
        a = np.pi / 4 + k * np.pi / 2
        b.box((r * 0.75 * np.cos(a) - 0.04, 0, r * 0.75 * np.sin(a) - 0.04),
              (r * 0.75 * np.cos(a) + 0.04, leg_h + r * 0.3, r * 0.75 * np.sin(a) + 0.04), legs)
    for y in np.arange(leg_h + 0.3, H - r * 0.4, 0.3):   # ladder rungs on the front
        b.box((-0.2, y, r + 0.12), (0.2, y + 0.025, r + 0.145), legs)
    for sx in (-1, 1):
        b.box((sx * 0.2 - 0.02, leg_h, r + 0.1), (sx * 0.2 + 0.02, H - r * 0.3, r + 0.16), legs)
    return b.build()


def crate(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    wood = b.surface("wood_planks", pick(rng, PALLET_WOOD))
    frame = b.surface("wood_planks", scaled(pick(rng, PALLET_WOOD), 0.8))
    b.box((-W / 2 + 0.02, 0, -D / 2 + 0.02), (W / 2 - 0.02, H - 0.02, D / 2 - 0.02), wood)
    t = 0.02
    for (x0, x1, z0, z1) in ((-W / 2, W / 2, D / 2 - t, D / 2), (-W / 2, W / 2, -D / 2, -D / 2 + t)):
        for y0, y1 in ((0, 0.1), (H - 0.12, H - 0.02)):
            b.box((x0, y0, z0), (x1, y1, z1), frame)
        b.box((x0, 0, z0), (x0 + 0.1, H - 0.02, z1), frame)
        b.box((x1 - 0.1, 0, z0), (x1, H - 0.02, z1), frame)
    b.box((-W / 2 + 0.01, H - 0.02, -D / 2 + 0.01), (W / 2 - 0.01, H, D / 2 - 0.01), frame)
    return b.build()


def barrel(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    paint = b.surface("metal_painted", pick(rng, STEEL_PAINT + ((0.35, 0.02, 0.02),)))
    r = min(W, D) / 2
    prof = [(0, 0), (r * 0.95, 0), (r, 0.02), (r, H * 0.3), (r * 1.02, H * 0.32), (r, H * 0.34), (r, H * 0.66),
            (r * 1.02, H * 0.68), (r, H * 0.7), (r, H - 0.02), (r * 0.95, H), (0, H - 0.01)]
    b.revolve(prof, 24, paint)
    return b.build()


def stairs(size, seed: int) -> MeshData:
    """A steel stair rising towards -z: stringers, treads, a handrail on each side."""
    rng, W, H, D, b = start(size, seed)
    steel = b.surface("metal_painted", pick(rng, STEEL_PAINT))
    tread = b.surface("metal_rusty")
    n = max(int(round(H / 0.18)), 2)
    rise, run = H / n, D / n
    for i in range(n):
        z0 = D / 2 - (i + 1) * run
        b.box((-W / 2 + 0.03, (i + 1) * rise - 0.03, z0), (W / 2 - 0.03, (i + 1) * rise, z0 + run + 0.02), tread)
    ang = np.degrees(np.arctan2(H, D))
    for sx in (-1, 1):
        x = sx * (W / 2 - 0.015)
        # stringer: an oriented slab along the slope
        b.oriented_box((x - 0.015, 0.0, D / 2), (0.03, 0, 0), (0, H, -D), (0, 0.2 * np.cos(np.radians(ang)), 0.2 * np.sin(np.radians(ang))), steel)
        b.tube([(x, 1.0, D / 2), (x, H + 1.0, -D / 2)], 0.02, 8, steel)
        for i in range(0, n + 1, max(n // 4, 1)):
            z = D / 2 - i * run
            b.box((x - 0.02, i * rise, z - 0.02), (x + 0.02, i * rise + 1.0, z + 0.02), steel)
    return b.build()


def railing(size, seed: int) -> MeshData:
    rng, L, H, _, b = start(size, seed)
    paint = b.surface("metal_painted", (0.55, 0.42, 0.02) if rng.random() < 0.6 else pick(rng, STEEL_PAINT))
    n = max(int(L / 1.5), 1)
    for i in range(n + 1):
        x = -L / 2 + L * i / n
        b.box((x - 0.025, 0, -0.025), (x + 0.025, H, 0.025), paint)
    for y in (H - 0.04, H * 0.5):
        b.box((-L / 2, y, -0.02), (L / 2, y + 0.04, 0.02), paint)
    b.box((-L / 2, 0.0, -0.005), (L / 2, 0.12, 0.005), paint)
    return b.build()


def pipe(size, seed: int) -> MeshData:
    """A pipe run along x with flanges every few metres and floor supports: size =
    (length, height of its axis, diameter)."""
    rng, L, Hc, d, b = start(size, seed)
    paint = b.surface("metal_painted", pick(rng, STEEL_PAINT)) if rng.random() < 0.6 else b.surface("metal_brushed")
    support = b.surface("metal_painted", (0.05, 0.05, 0.05))
    R = pose(rot_z(90), (0, Hc, 0))
    b.cylinder(d / 2, -L / 2, L / 2, 20, paint, T=R)
    n = max(int(L / 3.0), 1)
    for i in range(n + 1):
        x = -L / 2 + L * i / n
        b.cylinder(d / 2 + 0.03, x - 0.02, x + 0.02, 20, paint, T=R)
        if i % 2 == 0:
            b.box((x - 0.04, 0, -0.04), (x + 0.04, Hc - d / 2, 0.04), support)
    return b.build()
