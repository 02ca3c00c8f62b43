"""Near-field street detail: facade scaffolding, mobile construction fences, staked young
trees and bike racks with bicycles - the thin, contrasty things a street camera sees at
5-30 m (KITTI sequence_1's right side is a building under scaffolding with fence panels,
bikes at an entrance; its lawn's young trees stand in three stakes; docs/sensors.md,
Camera twins).

Every part is a closed tube or box (the kinds are ``closed``); straight tubes go through
``MeshBuilder.tubes`` in one vectorised pass. Frames as every asset's: Y up, metres, the
origin at the middle of the footprint, the front towards +z.
"""
from __future__ import annotations

import numpy as np

from . import palette
from .mesh import MeshBuilder, MeshData, start
from .palette import pick, scaled

TUBE_R = 0.024        # scaffold tube: 48.3 mm outside diameter (EN 39)
GALVANISED = (0.42, 0.42, 0.40)


def _rods(b: MeshBuilder, segments, radius: float, surf, sides: int = 6) -> None:
    """Straight round rods, one per (start, end) pair, in one vectorised pass."""
    b.tubes([(np.array([p, q], float), radius, sides) for p, q in segments], surf, smooth=True)


def scaffold(size, seed: int) -> MeshData:
    """Facade scaffolding (system scaffold, EN 12811 class 3-4): two rows of standards, bays of
    the systems' ledger lengths (2.07, 2.57, 3.07 m, mixed, scaled to the length), lifts every
    2 m with ledgers, transoms and boarded decks (planks of a few tones, some bays unboarded),
    guard rails and toe boards on the outer (+z) face, diagonal braces in some bays, an access
    ladder per lift in a bay of its own, base plates. The wall side is -z. size = (length,
    height, depth)."""
    rng, L, H, D, b = start(size, seed)
    steel = b.surface("galvanised", GALVANISED)
    woods = [b.surface("wood_planks", scaled(pick(rng, palette.WOOD), f)) for f in (0.8, 1.0, 1.25)]
    toe = b.surface("wood_planks", scaled(pick(rng, palette.WOOD), 0.9))
    bays = []
    while sum(bays) < L - 0.2 - 1.5 or not bays:
        bays.append(float(rng.choice([2.07, 2.57, 3.07], p=[0.25, 0.5, 0.25])))
    xs = -L / 2 + 0.1 + np.concatenate([[0.0], np.cumsum(bays)]) * (L - 0.2) / sum(bays)
    n_bays = len(bays)
    z_in, z_out = -D / 2 + 0.05, D / 2 - 0.05
    lift = 2.0
    decks = np.arange(lift, H - 0.9, lift)
    rods = []
    for x in xs:
        for z in (z_in, z_out):
            rods.append(((x, 0.02, z), (x, H, z)))                       # standards
        for y in np.concatenate([[0.15], decks]):
            rods.append(((x, y, z_in - 0.05), (x, y, z_out + 0.05)))     # transoms
    for y in np.concatenate([[0.15], decks]):
        for z in (z_in, z_out):
            rods.append(((xs[0] - 0.1, y + 0.05, z), (xs[-1] + 0.1, y + 0.05, z)))   # ledgers
    for y in decks:                                                       # guard rails, outer face
        for dy in (0.5, 1.0):
            if y + dy < H:
                rods.append(((xs[0] - 0.1, y + dy, z_out + 0.05), (xs[-1] + 0.1, y + dy, z_out + 0.05)))
    braced = rng.random(n_bays) < 0.4
    braced[int(rng.integers(n_bays))] = True
    levels = np.concatenate([[0.15], decks, [H - 0.1]])
    for i in np.flatnonzero(braced):                                       # diagonal braces, zig-zag
        for k in range(len(levels) - 1):
            a, c = (xs[i], xs[i + 1]) if k % 2 == 0 else (xs[i + 1], xs[i])
            rods.append(((a, levels[k], z_out + 0.06), (c, levels[k + 1], z_out + 0.06)))
    for k, y in enumerate(np.concatenate([[0.0], decks[:-1]])):            # access ladders, one bay a lift
        i = int(rng.integers(n_bays))
        xa, xb = xs[i] + 0.35, xs[i] + 0.75
        for x in (xa, xb):
            rods.append(((x, y + 0.1, z_in + 0.2), (x, y + lift + 0.9, z_in + 0.55)))
        for r_ in np.arange(0.3, lift + 0.8, 0.28):
            t = r_ / (lift + 0.8)
            rods.append(((xa, y + 0.1 + r_, z_in + 0.2 + 0.35 * t), (xb, y + 0.1 + r_, z_in + 0.2 + 0.35 * t)))
    _rods(b, rods, TUBE_R, steel)
    for x in xs:                                                           # base plates
        for z in (z_in, z_out):
            b.box((x - 0.075, 0.0, z - 0.075), (x + 0.075, 0.02, z + 0.075), steel)
    n_boards = max(int((D - 0.1) / 0.24), 1)
    w = (D - 0.1) / n_boards
    for y in decks:
        for i in range(n_bays):
            if rng.random() < 0.12:                 # an unboarded bay
                continue
            for j in range(n_boards):
                z0 = z_in + j * w
                b.box((xs[i] + 0.02, y + 0.08, z0 + 0.01), (xs[i + 1] - 0.02, y + 0.12, z0 + w - 0.01),
                      woods[int(rng.integers(len(woods)))])
            b.box((xs[i] + 0.02, y + 0.12, z_out + 0.01), (xs[i + 1] - 0.02, y + 0.27, z_out + 0.04), toe)
    return b.build()


def site_fence(size, seed: int) -> MeshData:
    """A mobile construction fence along x: welded-mesh panels (3.5 m standard, tube frame,
    vertical wires 10 cm apart and horizontal ones every 25-30 cm) standing in concrete feet,
    joined by clamps; a seeded few carry a printed banner. size = (length, height, depth of
    the feet)."""
    rng, L, H, D, b = start(size, seed)
    steel = b.surface("galvanised", GALVANISED)
    foot = b.surface("concrete", (0.42, 0.41, 0.39) if rng.random() < 0.6 else (0.10, 0.10, 0.10))
    banner = b.surface("fabric", pick(rng, ((0.03, 0.08, 0.25), (0.70, 0.70, 0.68), (0.35, 0.03, 0.02),
                                            (0.05, 0.18, 0.07))))
    n = max(int(round(L / 3.5)), 1)
    pw = L / n
    ys = (0.12, H)
    rods, wires = [], []
    for i in range(n):
        x0, x1 = -L / 2 + i * pw + 0.03, -L / 2 + (i + 1) * pw - 0.03
        for x in (x0, x1):
            rods.append(((x, ys[0], 0.0), (x, ys[1], 0.0)))
        for y in ys:
            rods.append(((x0, y, 0.0), (x1, y, 0.0)))
        for x in np.arange(x0 + 0.1, x1 - 0.05, 0.1):
            wires.append(((x - 0.002, ys[0] + 0.02, -0.002), (x + 0.002, ys[1] - 0.02, 0.002)))
        h_step = float(rng.uniform(0.25, 0.3))
        for y in np.arange(ys[0] + h_step, ys[1] - 0.05, h_step):
            wires.append(((x0 + 0.02, y - 0.002, 0.003), (x1 - 0.02, y + 0.002, 0.007)))
        if rng.random() < 0.25:                    # a banner on the panel's front
            b.box((x0 + 0.1, 0.45, 0.008), (x1 - 0.1, min(1.6, H - 0.1), 0.012), banner)
    _rods(b, rods, 0.02, steel)
    for lo, hi in wires:
        b.box(lo, hi, steel)
    for i in range(n + 1):                         # feet under the panels' joints (and the ends)
        x = float(np.clip(-L / 2 + i * pw, -L / 2 + 0.33, L / 2 - 0.33))
        b.box((x - 0.33, 0.0, -D / 2), (x + 0.33, 0.12, D / 2), foot)
    return b.build()


def tree_stakes(size, seed: int) -> MeshData:
    """The stakes of a newly planted street tree (its trunk at the origin, not part of it):
    three (or, seeded, two or four) peeled round posts around the trunk, joined near the top
    and near the ground by half-round battens, with rubber ties reaching towards the trunk.
    size = (spread: the posts' circle diameter, height, spread)."""
    rng, S, H, _, b = start(size, seed)
    post = b.surface("wood_planks", scaled(pick(rng, palette.WOOD), 1.2))
    batten = b.surface("wood_planks", scaled(pick(rng, palette.WOOD), 1.0))
    tie = b.surface("rubber")
    k = int(rng.choice([2, 3, 3, 3, 4]))
    a0 = rng.uniform(0, 2 * np.pi)
    ang = a0 + 2 * np.pi * np.arange(k) / k
    P = np.column_stack([S / 2 * np.cos(ang), np.zeros(k), S / 2 * np.sin(ang)])
    r = 0.035
    heights = H - rng.uniform(0.0, 0.08, k)
    _rods(b, [((p[0], -0.05, p[2]), (p[0], h, p[2])) for p, h in zip(P, heights)], r, post, sides=8)
    pairs = [(i, (i + 1) % k) for i in range(k if k > 2 else 1)]
    battens = []
    for y in (0.35, H - 0.25):
        for i, j in pairs:
            d = (P[j] - P[i]) / np.linalg.norm(P[j] - P[i])
            out = np.array([d[2], 0.0, -d[0]]) * 0.045          # beside the posts, not through them
            if np.dot(out, P[i] + P[j]) < 0:
                out = -out
            battens.append(((P[i] - 0.06 * d + out + [0, y, 0]), (P[j] + 0.06 * d + out + [0, y, 0])))
    _rods(b, battens, 0.022, batten, sides=6)
    y_tie = H - 0.45
    _rods(b, [((p[0] * 0.9, y_tie, p[2] * 0.9), (p[0] * 0.22, y_tie, p[2] * 0.22)) for p in P], 0.012, tie, sides=4)
    return b.build()


def _wheel(b: MeshBuilder, centre, radius: float, tyre, rim, spokes: int = 16) -> None:
    """A bicycle wheel in the y-z plane: tyre and rim as tubes round the circle, spokes, hub."""
    cx, cy, cz = centre
    t = 2 * np.pi * np.arange(25) / 24
    for rad, surf, tr in ((radius - 0.02, tyre, 0.02), (radius - 0.045, rim, 0.008)):
        ring = np.column_stack([np.full(25, cx), cy + rad * np.cos(t), cz + rad * np.sin(t)])
        ring[-1] = ring[0] + [0.0, 0.0, 1e-4]       # a hair's gap: the closed tube's two ends
        b.tube(ring, tr, 6, surf)
    a = 2 * np.pi * np.arange(spokes) / spokes
    hub = [(cx + (0.03 if i % 2 else -0.03), cy, cz) for i in range(spokes)]
    ends = [(cx, cy + (radius - 0.05) * np.cos(v), cz + (radius - 0.05) * np.sin(v)) for v in a]
    _rods(b, list(zip(hub, ends)), 0.0015, rim, sides=3)
    _rods(b, [((cx - 0.05, cy, cz), (cx + 0.05, cy, cz))], 0.02, rim)


def bicycle_parts(b: MeshBuilder, rng, x: float, length: float, surfaces) -> None:
    """One bicycle of ``length`` standing along z at x (front wheel towards +z): wheels, a diamond frame
    (or a step-through one), fork, handlebar, saddle, pedals."""
    tyre, rim, dark = surfaces
    frame = b.surface("metal_painted", pick(rng, ((0.03, 0.03, 0.03), (0.55, 0.55, 0.54), (0.30, 0.03, 0.02),
                                                   (0.02, 0.06, 0.20), (0.05, 0.14, 0.06), (0.45, 0.42, 0.35))))
    R = float(rng.uniform(0.33, 0.35))
    wb = max(length - 2 * R, 0.9)
    rear, front = np.array([x, R, -wb / 2]), np.array([x, R, wb / 2])
    for c in (rear, front):
        _wheel(b, c, R, tyre, rim)
    bb = np.array([x, 0.28, -0.02])
    seat_top = np.array([x, R + float(rng.uniform(0.5, 0.6)), -0.18])
    head_top = np.array([x, R + 0.55, wb / 2 - 0.2])
    head_bot = np.array([x, R + 0.35, wb / 2 - 0.15])
    step = rng.random() < 0.35
    tubes = [(bb, seat_top), (bb, head_bot), (rear, bb), (rear, seat_top - [0, 0.08, -0.03]),
             (head_bot, head_top), (head_bot, front)]
    tubes.append((bb + [0, 0.1, 0.05], head_bot) if step else (seat_top - [0, 0.08, -0.03], head_top - [0, 0.05, 0]))
    _rods(b, [(p, q) for p, q in tubes], 0.016, frame)
    bar = head_top + [0, 0.12, -0.05]
    _rods(b, [(head_top, bar), (bar - [0.28, 0, 0.04], bar + [0.28, 0, -0.04])], 0.012, dark)
    b.box(seat_top + [-0.07, 0.0, -0.12], seat_top + [0.07, 0.06, 0.12], dark)         # saddle
    for s in (-1, 1):                                                                    # pedals
        b.box(bb + [s * 0.14 - 0.05, -0.12 * s - 0.01, -0.04], bb + [s * 0.14 + 0.05, -0.12 * s + 0.01, 0.04], dark)


def bike_rack(size, seed: int) -> MeshData:
    """A row of Sheffield stands (inverted-U steel tubes) along x with bicycles parked at a
    seeded few of them, each standing along z beside its stand. size = (row length, stand
    height, depth: a bicycle's length)."""
    rng, L, H, D, b = start(size, seed)
    steel = b.surface("galvanised", GALVANISED) if rng.random() < 0.6 else \
        b.surface("metal_painted", pick(rng, palette.METAL_PAINT))
    surfaces = (b.surface("rubber"), b.surface("chrome"), b.surface("rubber", (0.02, 0.02, 0.02)))
    n = max(int(L / 0.9), 1)
    xs = -L / 2 + (np.arange(n) + 0.5) * L / n
    q = np.linspace(0, np.pi / 2, 5)
    bend_r = 0.15                                  # the U's corners: quarter circles
    corner = np.column_stack([-bend_r * np.cos(q), bend_r * np.sin(q)])        # (z, y) from the corner's centre
    zy = np.concatenate([[(-0.35, -0.05)], corner + (-0.35 + bend_r, H - bend_r),
                         (corner * (-1, 1))[::-1] + (0.35 - bend_r, H - bend_r), [(0.35, -0.05)]])
    for x in xs:                                   # the stands: 0.7 m long inverted U along z
        b.tube(np.column_stack([np.full(len(zy), x), zy[:, 1], zy[:, 0]]), 0.024, 8, steel)
    for x in xs:
        if rng.random() < 0.6:
            bicycle_parts(b, rng, x + 0.15, D, surfaces)
    return b.build()


def bicycles(size, seed: int) -> MeshData:
    """Bicycles standing on their kickstands side by side along x, each along z (front wheel
    towards +z), spaced evenly (0.6 m or more), about half turned round, each shifted along z by
    up to 12 cm (as bikes stand in a front garden or by a wall, without a rack). size = (row length,
    height: the handlebar's, a bicycle's length); a row shorter than two bikes holds one."""
    rng, L, H, D, b = start(size, seed)
    n = max(int(L / 0.6), 1)
    xs = -L / 2 + (np.arange(n) + 0.5) * L / n
    for x in xs:
        sub = MeshBuilder()
        parts = (sub.surface("rubber"), sub.surface("chrome"), sub.surface("rubber", (0.02, 0.02, 0.02)))
        bicycle_parts(sub, rng, 0.0, D, parts)
        # the kickstand: from behind the bottom bracket down and out to the ground
        _rods(sub, [((0.0, 0.26, -0.08), (0.16, 0.0, -0.2))], 0.01, parts[1])
        turn = -1.0 if rng.random() < 0.5 else 1.0     # half face the other way (a half turn about y)
        T = np.diag([turn, H / 1.05, turn, 1.0])       # a bike's bar stands ~1.0-1.05 m up
        T[:3, 3] = (x, 0.0, float(rng.uniform(-0.12, 0.12)))
        b.merge(sub, T)
    return b.build()


def bin_store(size, seed: int) -> MeshData:
    """A front garden's bin enclosure (KITTI sequence_1's frame 12: a weathered timber box beside
    the path): a frame of 7 cm posts, walls of horizontal slats 9-12 cm wide with 1.5-3 cm gaps
    into its dark inside, two or three slatted front doors (one bay a bin, each with a handle),
    a lid of boards; inside, at the back, the bins' dark bodies. size = (length along x, height,
    depth); the doors face +z."""
    rng, L, H, D, b = start(size, seed)
    wood = b.surface("wood_planks", scaled(pick(rng, palette.WOOD), float(rng.uniform(0.8, 1.1))))
    grey = b.surface("wood_planks", scaled((0.36, 0.33, 0.29), float(rng.uniform(0.8, 1.1))))   # weathered
    slat_s = grey if rng.random() < 0.6 else wood
    bin_s = b.surface("plastic", pick(rng, palette.PLASTIC_BIN))
    metal = b.surface("metal_painted", (0.05, 0.05, 0.05))
    p = 0.035
    for x in (-L / 2 + p, L / 2 - p):
        for z in (-D / 2 + p, D / 2 - p):
            b.box((x - p, 0.0, z - p), (x + p, H - 0.04, z + p), wood)
    w, gap = float(rng.uniform(0.09, 0.12)), float(rng.uniform(0.015, 0.03))
    ys = np.arange(0.08, H - 0.1 - w, w + gap)
    n_doors = 3 if L >= 1.9 else 2
    bay = (L - 0.1) / n_doors
    for y in ys:
        for z in (-D / 2 + 0.01, ):                                 # back wall
            b.box((-L / 2 + 0.07, y, z), (L / 2 - 0.07, y + w, z + 0.018), slat_s)
        for x in (-L / 2 + 0.005, L / 2 - 0.023):                   # end walls
            b.box((x, y, -D / 2 + 0.07), (x + 0.018, y + w, D / 2 - 0.07), slat_s)
        for i in range(n_doors):                                    # the doors' slats, a door ajar now and then
            x0 = -L / 2 + 0.05 + i * bay
            b.box((x0 + 0.01, y, D / 2 - 0.02), (x0 + bay - 0.01, y + w, D / 2 - 0.002), slat_s)
    for i in range(n_doors):                                        # the doors' frames (a Z of battens) and handles
        x0 = -L / 2 + 0.05 + i * bay
        for x in (x0 + 0.03, x0 + bay - 0.07):
            b.box((x, 0.08, D / 2 - 0.045), (x + 0.04, ys[-1] + w, D / 2 - 0.02), wood)
        b.box((x0 + bay - 0.16, H * 0.62, D / 2), (x0 + bay - 0.12, H * 0.62 + 0.12, D / 2 + 0.03), metal)
        bw = min(bay - 0.12, 0.6)                                   # a bin inside, its lid under the store's
        xc = x0 + bay / 2
        b.box((xc - bw / 2, 0.02, -D / 2 + 0.06), (xc + bw / 2, H - 0.2, D / 2 - 0.1), bin_s)
    for k, x in enumerate(np.arange(-L / 2, L / 2 - 0.05, 0.2)):  # the lid's boards, tilting back a little
        x1 = min(x + 0.19, L / 2)
        b.box((x, H - 0.04, -D / 2 - 0.02), (x1, H - 0.01 + 0.004 * (k % 2), D / 2 + 0.04), wood)
    return b.build()


def notice_board(size, seed: int) -> MeshData:
    """A notice board on two posts (KITTI sequence_1's frames 12-18: one stands by the gardens'
    boundary): square galvanised posts, a framed board (its face +z) from ~0.9 m up with
    notices - sheets of a few tones, lines of print on them - and a small roof. size = (width,
    height of the posts, depth)."""
    rng, W, H, D, b = start(size, seed)
    post = b.surface("galvanised", GALVANISED)
    frame = b.surface("metal_painted", pick(rng, palette.METAL_PAINT))
    board = b.surface("wood_planks", scaled(pick(rng, palette.WOOD), 0.9))
    ink = b.surface("plastic", (0.03, 0.03, 0.035))
    tones = ((0.78, 0.78, 0.74), (0.70, 0.68, 0.45), (0.72, 0.72, 0.70), (0.35, 0.45, 0.60), (0.75, 0.55, 0.45))
    y0, y1 = float(H * rng.uniform(0.5, 0.6)), H - 0.08
    for x in (-W / 2 + 0.04, W / 2 - 0.04):
        b.box((x - 0.03, -0.3, -0.03), (x + 0.03, H, 0.03), post)
    b.box((-W / 2 + 0.08, y0, 0.03), (W / 2 - 0.08, y1, 0.055), board)
    for (xa, xb), (ya, yb) in (((-W / 2 + 0.02, W / 2 - 0.02), (y0 - 0.05, y0)), ((-W / 2 + 0.02, W / 2 - 0.02), (y1, y1 + 0.05)),
                               ((-W / 2 + 0.07, -W / 2 + 0.1), (y0, y1)), ((W / 2 - 0.1, W / 2 - 0.07), (y0, y1))):
        b.box((xa, ya, 0.03), (xb, yb, 0.07), frame)
    b.box((-W / 2 - 0.05, y1 + 0.05, -0.08), (W / 2 + 0.05, y1 + 0.08, D), frame)      # its roof
    x = -W / 2 + 0.14
    while x < W / 2 - 0.3:                                          # the notices, A4 or A5, upright or across
        w_, h_ = (0.21, 0.297) if rng.random() < 0.6 else (0.297, 0.21)
        if x + w_ > W / 2 - 0.12:
            break
        ya = float(rng.uniform(y0 + 0.04, max(y1 - h_ - 0.04, y0 + 0.05)))
        z = 0.055 + 0.001 * float(rng.integers(1, 4))
        b.box((x, ya, 0.055), (x + w_, ya + h_, z), b.surface("plastic", tones[int(rng.integers(len(tones)))]))
        for k in range(int(rng.integers(3, 9))):                    # lines of print (a title, then text)
            yl = ya + h_ - 0.03 - k * (0.028 if k else 0.04)
            if yl < ya + 0.03:
                break
            lw = (w_ - 0.04) * float(rng.uniform(0.5, 1.0))
            b.box((x + 0.02, yl - (0.012 if k == 0 else 0.006), z), (x + 0.02 + lw, yl, z + 0.001), ink)
        x += w_ + float(rng.uniform(0.03, 0.12))
    return b.build()
