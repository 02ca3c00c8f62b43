"""Indoor assets: tables, desks, chairs, shelves with books, cabinets, sofas, doors in their
frames, picture frames, ceiling lights, window frames, plants, monitors, rugs.

Asset frame: ``size`` = (width x, height y, depth z), floor at y = 0, front towards +z
(a chair's seat faces +z, a shelf opens towards +z, a door's handle side is +x).
"""
from __future__ import annotations

import numpy as np

from . import palette
from .mesh import MeshBuilder, MeshData, pose, start
from .palette import pick, scaled
from .vegetation import add_leaves

BOOK_COLOURS = ((0.30, 0.03, 0.03), (0.03, 0.06, 0.20), (0.05, 0.12, 0.05), (0.55, 0.50, 0.40),
                (0.06, 0.06, 0.06), (0.45, 0.25, 0.05), (0.60, 0.60, 0.58), (0.15, 0.05, 0.15),
                (0.50, 0.38, 0.05), (0.02, 0.20, 0.25), (0.35, 0.20, 0.12), (0.65, 0.15, 0.05))


def _legs(b, W, D, h, t, s, inset=0.04, round_=False):
    for sx in (-1, 1):
        for sz in (-1, 1):
            x, z = sx * (W / 2 - inset - t / 2), sz * (D / 2 - inset - t / 2)
            if round_:
                b.cylinder(t / 2, 0.0, h, 12, s, T=pose(None, (x, 0, z)))
            else:
                b.box((x - t / 2, 0.0, z - t / 2), (x + t / 2, h, z + t / 2), s)


def table(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    top = b.surface("wood_planks", pick(rng, palette.WOOD)) if rng.random() < 0.6 else \
        b.surface("plastic", (0.65, 0.64, 0.6))
    leg = b.surface("metal_painted", (0.05, 0.05, 0.05)) if rng.random() < 0.5 else b.surface("metal_brushed")
    t = rng.uniform(0.025, 0.04)
    b.box((-W / 2, H - t, -D / 2), (W / 2, H, D / 2), top)
    _legs(b, W, D, H - t, rng.uniform(0.035, 0.05), leg, round_=rng.random() < 0.4)
    b.box((-W / 2 + 0.06, H - t - 0.08, -D / 2 + 0.06), (W / 2 - 0.06, H - t, -D / 2 + 0.08), leg)
    return b.build()


def desk(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    top = b.surface("wood_planks", pick(rng, palette.WOOD)) if rng.random() < 0.5 else \
        b.surface("plastic", (0.55, 0.55, 0.52))
    body = b.surface("plastic", pick(rng, ((0.55, 0.55, 0.52), (0.08, 0.08, 0.08), (0.5, 0.45, 0.38))))
    handle = b.surface("metal_brushed")
    t = 0.025
    b.box((-W / 2, H - t, -D / 2), (W / 2, H, D / 2), top)
    b.box((-W / 2, 0, -D / 2 + 0.02), (-W / 2 + 0.025, H - t, D / 2 - 0.02), body)     # side panel
    dw = min(0.45, W * 0.35)                                                           # drawer block
    b.box((W / 2 - dw, 0.0, -D / 2 + 0.05), (W / 2, H - t, D / 2 - 0.02), body)
    for i in range(3):
        y0 = 0.05 + i * (H - t - 0.08) / 3
        y1 = y0 + (H - t - 0.08) / 3 - 0.01
        b.box((W / 2 - dw + 0.01, y0, D / 2 - 0.02), (W / 2 - 0.01, y1, D / 2 - 0.005), body)
        b.box((W / 2 - dw / 2 - 0.06, y1 - 0.06, D / 2 - 0.005), (W / 2 - dw / 2 + 0.06, y1 - 0.045, D / 2 + 0.02), handle)
    b.box((-W / 2 + 0.025, 0.25, -D / 2 + 0.02), (W / 2 - dw, H - t - 0.05, -D / 2 + 0.04), body)  # modesty panel
    _desk_clutter(b, rng, W, H, D)
    return b.build()


def _desk_clutter(b, rng, W, H, D):
    """What lies on a desk in use: keyboard and mouse, papers, a mug, books, a pen pot."""
    dark = b.surface("plastic", (0.03, 0.03, 0.03) if rng.random() < 0.7 else (0.6, 0.6, 0.58))
    paper = b.surface("plastic", (0.78, 0.78, 0.75))
    books = [b.surface("fabric", c) for c in BOOK_COLOURS]
    cup = b.surface("plastic", pick(rng, ((0.7, 0.7, 0.68), (0.3, 0.02, 0.02), (0.02, 0.05, 0.2), (0.05, 0.05, 0.05))))
    kx = rng.uniform(-0.15, 0.1)
    b.box((kx - 0.22, H, 0.02), (kx + 0.22, H + 0.025, 0.17), dark)                   # keyboard
    for i in range(5):                                                               # key rows
        z = 0.035 + i * 0.026
        b.box((kx - 0.2, H + 0.025, z), (kx + 0.2, H + 0.03, z + 0.018), dark)
    b.box((kx + 0.3, H, 0.06), (kx + 0.36, H + 0.03, 0.16), dark)                     # mouse
    for _ in range(int(rng.integers(1, 5))):                                         # papers
        a = rng.uniform(-40, 40)
        c, sn = np.cos(np.radians(a)), np.sin(np.radians(a))
        T = pose(np.array([[c, 0, sn], [0, 1, 0], [-sn, 0, c]]), (rng.uniform(-W / 2 + 0.3, W / 2 - 0.3), H,
                                                                   rng.uniform(-0.05, D / 2 - 0.2)))
        b.box((-0.105, 0.0, -0.148), (0.105, 0.002 + 0.001 * rng.random(), 0.148), paper, T=T)
    if rng.random() < 0.8:                                                           # a mug
        mx, mz = rng.uniform(-W / 2 + 0.1, W / 2 - 0.1), rng.uniform(0.05, D / 2 - 0.1)
        b.revolve([(0, 0), (0.04, 0), (0.042, 0.095), (0.0, 0.095)], 14, cup, T=pose(None, (mx, H, mz)))
    y = H
    bx, bz = rng.choice([-1, 1]) * (W / 2 - 0.2), -D / 2 + 0.2
    for _ in range(int(rng.integers(0, 5))):                                         # a stack of books
        th = rng.uniform(0.02, 0.05)
        w, d = rng.uniform(0.15, 0.24), rng.uniform(0.2, 0.3)
        b.box((bx - w / 2, y, bz - d / 2), (bx + w / 2, y + th, bz + d / 2), books[rng.integers(len(books))])
        y += th


def chair(size, seed: int) -> MeshData:
    """A four-legged chair (wood or plastic seat and back) or an office chair (five-star
    base, gas column, upholstered seat and back)."""
    rng, W, H, D, b = start(size, seed)
    seat_y = 0.46
    if rng.random() < 0.5:
        fabric = b.surface("fabric", pick(rng, palette.FABRIC))
        dark = b.surface("plastic", (0.03, 0.03, 0.03))
        metal = b.surface("metal_brushed")
        for k in range(5):
            a = 2 * np.pi * k / 5
            d = np.array([np.sin(a), 0, np.cos(a)])
            b.tube([(0, 0.08, 0), tuple(d * 0.3 + (0, 0.06, 0))], 0.02, 6, dark)
            b.cylinder(0.03, 0.0, 0.05, 10, dark, T=pose(None, tuple(d * 0.3)))
        b.cylinder(0.025, 0.08, seat_y - 0.05, 10, metal)
        b.box((-W / 2, seat_y - 0.06, -D / 2), (W / 2, seat_y + 0.03, D / 2), fabric)
        b.box((-W / 2 + 0.03, seat_y + 0.08, -D / 2 - 0.02), (W / 2 - 0.03, H, -D / 2 + 0.06), fabric)
        b.box((-0.03, seat_y - 0.05, -D / 2 - 0.01), (0.03, seat_y + 0.12, -D / 2 + 0.04), dark)
        return b.build()
    wood = b.surface("wood_planks", pick(rng, palette.WOOD)) if rng.random() < 0.6 else \
        b.surface("plastic", pick(rng, ((0.6, 0.6, 0.58), (0.05, 0.05, 0.05), (0.3, 0.05, 0.03))))
    leg = b.surface("metal_painted", (0.05, 0.05, 0.05)) if rng.random() < 0.5 else wood
    _legs(b, W, D, seat_y - 0.03, 0.03, leg, inset=0.02, round_=rng.random() < 0.5)
    b.box((-W / 2, seat_y - 0.03, -D / 2), (W / 2, seat_y, D / 2), wood)
    for sx in (-1, 1):
        x = sx * (W / 2 - 0.035)
        b.box((x - 0.015, seat_y, -D / 2 + 0.005), (x + 0.015, H, -D / 2 + 0.035), leg)
    b.box((-W / 2 + 0.02, H - 0.2, -D / 2), (W / 2 - 0.02, H - 0.02, -D / 2 + 0.025), wood)
    return b.build()


def shelf(size, seed: int) -> MeshData:
    """A bookcase open towards +z: sides, top, bottom, back, shelves filled with books of
    varied size and colour (some leaning, some gaps), boxes and a few lying stacks."""
    rng, W, H, D, b = start(size, seed)
    wood = b.surface("wood_planks", pick(rng, palette.WOOD)) if rng.random() < 0.6 else \
        b.surface("plastic", pick(rng, ((0.65, 0.64, 0.6), (0.05, 0.05, 0.05))))
    books = [b.surface("fabric", c) for c in BOOK_COLOURS]
    box_s = b.surface("plastic", (0.35, 0.25, 0.15))
    t = 0.02
    b.box((-W / 2, 0, -D / 2), (-W / 2 + t, H, D / 2), wood)
    b.box((W / 2 - t, 0, -D / 2), (W / 2, H, D / 2), wood)
    b.box((-W / 2 + t, H - t, -D / 2), (W / 2 - t, H, D / 2), wood)
    b.box((-W / 2 + t, 0, -D / 2), (W / 2 - t, 0.08, D / 2), wood)
    b.box((-W / 2 + t, 0.08, -D / 2), (W / 2 - t, H - t, -D / 2 + 0.01), wood)
    n = max(int((H - 0.1) / rng.uniform(0.32, 0.4)), 1)
    levels = np.linspace(0.08, H - t, n + 1)
    for i in range(n):
        y0 = levels[i] + (t if i > 0 else 0.0)
        if i > 0:
            b.box((-W / 2 + t, levels[i], -D / 2 + 0.01), (W / 2 - t, levels[i] + t, D / 2 - 0.01), wood)
        clear = levels[i + 1] - y0
        x = -W / 2 + t + 0.005
        end = W / 2 - t - 0.005
        while x < end - 0.02:
            r = rng.random()
            if r < 0.06:                              # a gap
                x += rng.uniform(0.05, 0.2)
                continue
            if r < 0.12 and end - x > 0.3:            # a box
                bw = rng.uniform(0.2, 0.3)
                bh = min(rng.uniform(0.12, 0.25), clear - 0.02)
                b.box((x, y0, -D / 2 + 0.02), (x + bw, y0 + bh, D / 2 - 0.04), box_s)
                x += bw + 0.01
                continue
            if r < 0.17 and end - x > 0.3:            # a lying stack
                sw = rng.uniform(0.18, 0.26)
                y = y0
                for _ in range(int(rng.integers(2, 6))):
                    th = rng.uniform(0.02, 0.05)
                    if y + th > levels[i + 1] - 0.02:
                        break
                    s = books[rng.integers(len(books))]
                    b.box((x, y, -D / 2 + 0.03), (x + sw - rng.uniform(0, 0.04), y + th, D / 2 - 0.03), s)
                    y += th
                x += sw + 0.01
                continue
            bw = rng.uniform(0.015, 0.055)
            bh = min(rng.uniform(0.16, 0.31), clear - 0.015)
            bd = min(rng.uniform(0.13, 0.24), D - 0.04)
            if x + bw > end:
                break
            s = books[rng.integers(len(books))]
            z1 = D / 2 - rng.uniform(0.005, 0.03)
            lean = rng.random() < 0.05
            if lean and x + bh * 0.5 < end:
                ang = -rng.uniform(10, 25)
                T = pose(np.array([[np.cos(np.radians(ang)), -np.sin(np.radians(ang)), 0],
                                   [np.sin(np.radians(ang)), np.cos(np.radians(ang)), 0], [0, 0, 1]]), (x, y0, 0))
                b.box((0, 0, z1 - bd), (bw, bh * 0.95, z1), s, T=T)
                x += bh * 0.5
            else:
                b.box((x, y0, z1 - bd), (x + bw, y0 + bh, z1), s)
                x += bw + rng.uniform(0.0, 0.004)
    return b.build()


def cabinet(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    body = b.surface("plastic", pick(rng, ((0.65, 0.64, 0.6), (0.35, 0.36, 0.37), (0.06, 0.06, 0.06))))
    front = b.surface("wood_planks", pick(rng, palette.WOOD)) if rng.random() < 0.5 else body
    handle = b.surface("metal_brushed")
    b.box((-W / 2, 0.05, -D / 2), (W / 2, H, D / 2 - 0.02), body)
    b.box((-W / 2 + 0.03, 0.0, -D / 2 + 0.03), (W / 2 - 0.03, 0.05, D / 2 - 0.06), body)
    n = 2 if W > 0.7 else 1
    drawers = rng.random() < 0.4
    rows = 3 if drawers else 1
    for i in range(n):
        for j in range(rows):
            x0 = -W / 2 + i * W / n + 0.004
            x1 = -W / 2 + (i + 1) * W / n - 0.004
            y0 = 0.05 + j * (H - 0.05) / rows + 0.004
            y1 = 0.05 + (j + 1) * (H - 0.05) / rows - 0.004
            b.box((x0, y0, D / 2 - 0.02), (x1, y1, D / 2), front)
            if drawers:
                xm = 0.5 * (x0 + x1)
                b.box((xm - 0.06, y1 - 0.05, D / 2), (xm + 0.06, y1 - 0.035, D / 2 + 0.025), handle)
            else:
                xh = x1 - 0.05 if i == 0 and n == 2 else x0 + 0.05 if n == 2 else x1 - 0.05
                b.box((xh - 0.008, y1 - 0.3, D / 2), (xh + 0.008, y1 - 0.1, D / 2 + 0.025), handle)
    return b.build()


def _soft_block(b, lo, hi, r, s, axis=0, segs=3):
    """A block with rounded long edges: a loft along ``axis`` of a rounded rectangle."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    other = [a for a in range(3) if a != axis]
    u0, u1 = lo[other[0]], hi[other[0]]
    v0, v1 = lo[other[1]], hi[other[1]]
    r = min(r, (u1 - u0) / 2 - 1e-4, (v1 - v0) / 2 - 1e-4)
    pts = []
    for cu, cv, a0 in ((u1 - r, v0 + r, -90), (u1 - r, v1 - r, 0), (u0 + r, v1 - r, 90), (u0 + r, v0 + r, 180)):
        for k in range(segs + 1):
            a = np.radians(a0 + 90 * k / segs)
            pts.append((cu + r * np.cos(a), cv + r * np.sin(a)))
    loops = []
    for t in (lo[axis], hi[axis]):
        loop = []
        for u, v in pts:
            p = np.zeros(3)
            p[axis], p[other[0]], p[other[1]] = t, u, v
            loop.append(p)
        loops.append(loop)
    k = len(pts)
    b.loft(np.array(loops), [[s] * k], s, smooth=True)


def sofa(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    fabric = b.surface("fabric", pick(rng, palette.FABRIC))
    foot = b.surface("wood_planks", (0.1, 0.06, 0.03))
    arm = rng.uniform(0.15, 0.25)
    seat_y = rng.uniform(0.38, 0.45)
    for sx in (-1, 1):
        for sz in (-1, 1):
            x, z = sx * (W / 2 - 0.08), sz * (D / 2 - 0.08)
            b.cylinder(0.025, 0.0, 0.1, 10, foot, T=pose(None, (x, 0, z)))
    b.box((-W / 2 + arm, 0.1, -D / 2 + 0.05), (W / 2 - arm, seat_y - 0.12, D / 2 - 0.02), fabric)   # base
    for sx in (-1, 1):                                                                              # arms
        _soft_block(b, (sx * W / 2 - (arm if sx > 0 else 0), 0.1, -D / 2), (sx * W / 2 + (0 if sx > 0 else arm), seat_y + 0.22, D / 2),
                    0.06, fabric, axis=2)
    _soft_block(b, (-W / 2 + arm, 0.1, -D / 2), (W / 2 - arm, H, -D / 2 + 0.2), 0.06, fabric, axis=0)  # back frame
    n = 2 if W < 1.8 else 3
    cw = (W - 2 * arm) / n
    for i in range(n):
        x0 = -W / 2 + arm + i * cw + 0.005
        _soft_block(b, (x0, seat_y - 0.13, -D / 2 + 0.2), (x0 + cw - 0.01, seat_y, D / 2), 0.05, fabric, axis=0)
        _soft_block(b, (x0, seat_y, -D / 2 + 0.12), (x0 + cw - 0.01, H - 0.08, -D / 2 + 0.34), 0.07, fabric, axis=0)
    return b.build()


def door(size, seed: int) -> MeshData:
    """A door leaf in its frame (architraves on both faces), centred in the x-y plane of
    the wall opening it fills: size = (opening width, opening height, wall thickness)."""
    rng, W, H, T, b = start(size, seed)
    leaf = b.surface("wood_planks", pick(rng, palette.WOOD)) if rng.random() < 0.5 else \
        b.surface("plastic", pick(rng, ((0.68, 0.67, 0.64), (0.35, 0.36, 0.37))))
    frame = b.surface("plastic", (0.68, 0.67, 0.64))
    metal = b.surface("metal_brushed")
    fw = 0.06
    for z0, z1 in ((T / 2, T / 2 + 0.015), (-T / 2 - 0.015, -T / 2)):
        b.box((-W / 2 - fw, 0, z0), (-W / 2, H + fw, z1), frame)
        b.box((W / 2, 0, z0), (W / 2 + fw, H + fw, z1), frame)
        b.box((-W / 2, H, z0), (W / 2, H + fw, z1), frame)
    b.box((-W / 2, 0, -T / 2), (-W / 2 + 0.02, H, T / 2), frame)
    b.box((W / 2 - 0.02, 0, -T / 2), (W / 2, H, T / 2), frame)
    b.box((-W / 2 + 0.02, H - 0.02, -T / 2), (W / 2 - 0.02, H, T / 2), frame)
    lt = 0.04
    b.box((-W / 2 + 0.023, 0.008, -lt / 2), (W / 2 - 0.023, H - 0.023, lt / 2), leaf)
    if rng.random() < 0.5:   # panels
        for y0, y1 in ((0.15, H * 0.45), (H * 0.5, H - 0.15)):
            b.box((-W / 2 + 0.12, y0, lt / 2), (W / 2 - 0.12, y1, lt / 2 + 0.008), leaf)
    for sz in (1, -1):
        z = sz * lt / 2
        b.box((W / 2 - 0.14, 1.0, min(z, z + sz * 0.06)), (W / 2 - 0.12, 1.1, max(z, z + sz * 0.06)), metal)
        b.box((W / 2 - 0.25, 1.03, min(z + sz * 0.05, z + sz * 0.07)), (W / 2 - 0.12, 1.05, max(z + sz * 0.05, z + sz * 0.07)), metal)
    return b.build()


def picture(size, seed: int) -> MeshData:
    """A framed picture hanging on a wall (its back at z = 0, facing +z): a moulded frame,
    a mat and a picture of coloured patches (an abstract print). size = (width, height of
    its centre, depth)."""
    rng = np.random.default_rng(seed)
    W, yc, Dp = (float(x) for x in size)
    Hp = W * rng.uniform(0.65, 1.3)
    b = MeshBuilder()
    frame = b.surface("wood_planks", pick(rng, palette.WOOD)) if rng.random() < 0.5 else \
        b.surface("metal_painted", (0.03, 0.03, 0.03))
    mat = b.surface("plastic", (0.75, 0.74, 0.7))
    fw = 0.04
    y0, y1 = yc - Hp / 2, yc + Hp / 2
    for lo, hi in [((-W / 2, y0, 0), (W / 2, y0 + fw, Dp)), ((-W / 2, y1 - fw, 0), (W / 2, y1, Dp)),
                   ((-W / 2, y0 + fw, 0), (-W / 2 + fw, y1 - fw, Dp)), ((W / 2 - fw, y0 + fw, 0), (W / 2, y1 - fw, Dp))]:
        b.box(lo, hi, frame)
    b.box((-W / 2 + fw, y0 + fw, 0), (W / 2 - fw, y1 - fw, Dp * 0.4), mat)
    m = W * 0.12
    nx, ny = int(rng.integers(3, 7)), int(rng.integers(3, 7))
    xs = np.linspace(-W / 2 + fw + m, W / 2 - fw - m, nx + 1)
    ys = np.linspace(y0 + fw + m, y1 - fw - m, ny + 1)
    base = rng.uniform(0.05, 0.6, 3)
    for i in range(nx):
        for j in range(ny):
            c = np.clip(base * rng.uniform(0.3, 1.4, 3), 0.02, 0.8)
            s = b.surface("plastic", tuple(np.round(c, 1)))
            b.box((xs[i], ys[j], Dp * 0.4), (xs[i + 1], ys[j + 1], Dp * 0.4 + 0.002), s)
    return b.build()


def ceiling_light(size, seed: int) -> MeshData:
    """A recessed or suspended light panel whose diffuser faces down (-y), its top at
    y = 0 (hang it from the ceiling: position = the ceiling point). The diffuser's material
    is ``light_panel`` (emissive)."""
    rng, W, Hh, D, b = start(size, seed)
    housing = b.surface("metal_painted", pick(rng, ((0.7, 0.7, 0.7), (0.05, 0.05, 0.05), (0.4, 0.41, 0.42))))
    diffuser = b.surface("light_panel")
    louvres = int(rng.integers(0, 4))
    hang = Hh > 0.1
    if hang:   # suspended: two wires
        for sx in (-1, 1):
            b.cylinder(0.003, -Hh + 0.05, 0.0, 6, housing, T=pose(None, (sx * W * 0.35, 0, 0)))
        b.cylinder(0.04, -0.01, 0.0, 12, housing)
    y1 = -Hh + 0.05 if hang else 0.0
    b.box((-W / 2, y1 - 0.05, -D / 2), (W / 2, y1, D / 2), housing)
    b.box((-W / 2 + 0.02, y1 - 0.052, -D / 2 + 0.02), (W / 2 - 0.02, y1 - 0.049, D / 2 - 0.02), diffuser)
    for k in range(1, louvres + 1):   # cross bars under the diffuser
        x = -W / 2 + W * k / (louvres + 1)
        b.box((x - 0.01, y1 - 0.07, -D / 2 + 0.02), (x + 0.01, y1 - 0.052, D / 2 - 0.02), housing)
    return b.build()


def window_frame(size, seed: int) -> MeshData:
    """A window for a wall opening seen from inside: frame, mullion/transom bars, a sill
    board; open (no pane), so daylight comes in. size = (opening width, opening height,
    wall thickness); the opening's bottom centre is the origin, the room side +z."""
    rng, W, H, T, b = start(size, seed)
    frame = b.surface("metal_painted", pick(rng, palette.FRAME))
    sill = b.surface("plastic", (0.7, 0.69, 0.66))
    fw, fd = 0.07, 0.07
    z0, z1 = -fd / 2, fd / 2
    bars = [((-W / 2, 0, z0), (W / 2, fw, z1)), ((-W / 2, H - fw, z0), (W / 2, H, z1)),
            ((-W / 2, 0, z0), (-W / 2 + fw, H, z1)), ((W / 2 - fw, 0, z0), (W / 2, H, z1))]
    n = 2 if W < 2.2 else 3
    for k in range(1, n):
        x = -W / 2 + W * k / n
        bars.append(((x - 0.04, 0, z0), (x + 0.04, H, z1)))
    if rng.random() < 0.5:
        bars.append(((-W / 2, H * 0.75 - 0.035, z0), (W / 2, H * 0.75 + 0.035, z1)))
    for lo, hi in bars:
        b.box(lo, hi, frame)
    b.box((-W / 2 - 0.05, -0.02, fd / 2), (W / 2 + 0.05, 0.0, T / 2 + 0.05), sill)
    return b.build()


def plant(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    pot = b.surface("plastic", pick(rng, ((0.35, 0.15, 0.08), (0.6, 0.6, 0.58), (0.05, 0.05, 0.05))))
    soil = b.surface("soil")
    stem = b.surface("bark", (0.08, 0.1, 0.04))
    greens = [b.surface("leaves", scaled(pick(rng, palette.LEAVES), f)) for f in (0.9, 1.2, 1.5)]
    pr = min(W, D) * 0.3
    ph = H * 0.28
    b.revolve([(0, 0), (pr * 0.8, 0), (pr, ph), (pr * 0.93, ph), (0, ph - 0.01)], 20, pot)
    b.cylinder(pr * 0.92, ph - 0.04, ph - 0.02, 20, soil)
    n_stems = int(rng.integers(4, 9))
    pts, outs = [], []
    for _ in range(n_stems):
        d = rng.normal(size=3) * np.array([0.4, 0, 0.4]) + np.array([0, 1, 0])
        d /= np.linalg.norm(d)
        top = np.array([0, ph, 0]) + d * (H - ph) * rng.uniform(0.6, 1.0)
        reach = np.hypot(top[0] / (W / 2), top[2] / (D / 2))   # stems stay over the footprint (culling boxes rely on it)
        if reach > 1.0:
            top[[0, 2]] /= reach
        b.tube([(0, ph - 0.03, 0), tuple(top)], 0.006, 4, stem)
        t = rng.uniform(0.3, 1.0, 30)
        q = np.array([0, ph, 0]) + np.outer(t, top - np.array([0, ph, 0]))
        pts.append(q)
        outs.append(np.tile(d, (30, 1)) + rng.normal(size=(30, 3)) * 0.6)
    add_leaves(b, rng, np.concatenate(pts), np.concatenate(outs), rng.uniform(0.08, 0.14), greens, width=0.5,
               droop=0.6)
    return b.build()


def monitor(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    body = b.surface("plastic", (0.03, 0.03, 0.03) if rng.random() < 0.7 else (0.5, 0.5, 0.5))
    screen = b.surface("glass_window", (0.01, 0.012, 0.015))
    sh = W * 0.6
    y0 = H - sh
    b.box((-W / 2, y0, -0.02), (W / 2, H, 0.01), body)
    b.box((-W / 2 + 0.01, y0 + 0.012, 0.01), (W / 2 - 0.01, H - 0.01, 0.012), screen)
    b.box((-0.03, 0.01, -0.06), (0.03, y0 + 0.05, -0.03), body)
    b.box((-0.12, 0.0, -D / 2), (0.12, 0.012, D / 2 - 0.03), body)
    return b.build()


def rug(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    base = pick(rng, palette.FABRIC)
    border = b.surface("fabric", scaled(base, 0.6))
    field = b.surface("fabric", base)
    h = max(H, 0.005)
    b.box((-W / 2, 0, -D / 2), (W / 2, h, D / 2), border)
    b.box((-W / 2 + 0.1, h, -D / 2 + 0.1), (W / 2 - 0.1, h + 0.001, D / 2 - 0.1), field)
    return b.build()


def radiator(size, seed: int) -> MeshData:
    """A panel radiator on two brackets, its back at z = 0 (hang it on a wall), fins on top,
    a valve. size = (width, height of its top, depth)."""
    rng, W, H, D, b = start(size, seed)
    paint = b.surface("metal_painted", pick(rng, ((0.72, 0.72, 0.70), (0.65, 0.65, 0.62), (0.35, 0.36, 0.37))))
    chrome = b.surface("chrome")
    h = min(rng.uniform(0.4, 0.6), H - 0.12)
    y0 = H - h
    n = int(W / 0.05)
    for k in range(n):                      # vertical convector channels
        x = -W / 2 + (k + 0.5) * W / n
        b.box((x - 0.022, y0, 0.03), (x + 0.022, H, D), paint)
    b.box((-W / 2, y0 + 0.01, 0.03), (W / 2, H - 0.01, D - 0.02), paint)
    for sx in (-1, 1):
        b.box((sx * (W / 2 - 0.15) - 0.02, y0 + 0.1, 0.0), (sx * (W / 2 - 0.15) + 0.02, y0 + 0.14, 0.03), paint)
    vx = (W / 2 - 0.05) * (1 if rng.random() < 0.5 else -1)
    b.cylinder(0.015, y0 - 0.12, y0, 8, chrome, T=pose(None, (vx, 0, D / 2)))
    b.cylinder(0.025, y0 - 0.17, y0 - 0.12, 10, chrome, T=pose(None, (vx, 0, D / 2)))
    return b.build()


def whiteboard(size, seed: int) -> MeshData:
    """A whiteboard on a wall (back at z = 0, facing +z) with an aluminium frame, a marker
    tray and some writing (dark strokes of boxes). size = (width, height of its centre, depth)."""
    rng = np.random.default_rng(seed)
    W, yc, D = (float(x) for x in size)
    Hb = W * 0.6
    b = MeshBuilder()
    board = b.surface("plastic", (0.8, 0.8, 0.78))
    frame = b.surface("metal_brushed")
    ink = [b.surface("plastic", c) for c in ((0.02, 0.02, 0.03), (0.02, 0.05, 0.3), (0.35, 0.02, 0.02))]
    y0, y1 = yc - Hb / 2, yc + Hb / 2
    b.box((-W / 2, y0, 0), (W / 2, y1, D * 0.6), board)
    for lo, hi in [((-W / 2, y0, 0), (W / 2, y0 + 0.02, D)), ((-W / 2, y1 - 0.02, 0), (W / 2, y1, D)),
                   ((-W / 2, y0, 0), (-W / 2 + 0.02, y1, D)), ((W / 2 - 0.02, y0, 0), (W / 2, y1, D))]:
        b.box(lo, hi, frame)
    b.box((-W / 3, y0 - 0.03, 0), (W / 3, y0, 0.07), frame)
    for _ in range(int(rng.integers(4, 12))):             # lines of writing
        x0 = rng.uniform(-W / 2 + 0.1, W / 4)
        yl = rng.uniform(y0 + 0.1, y1 - 0.1)
        s = ink[int(rng.integers(3))]
        x = x0
        for _ in range(int(rng.integers(3, 9))):
            w = rng.uniform(0.03, 0.12)
            if x + w > W / 2 - 0.05:
                break
            b.box((x, yl, D * 0.6), (x + w, yl + rng.uniform(0.01, 0.03), D * 0.6 + 0.001), s)
            x += w + rng.uniform(0.02, 0.05)
    return b.build()
