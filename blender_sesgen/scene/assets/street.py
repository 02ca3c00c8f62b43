"""Street strips (road, kerb, gutter, sidewalk, verge) along an arc, and street furniture
(pole, street light, traffic sign plate, traffic light, bin, bollard).

Strips: ``size`` = (width, height, length). A strip's centreline starts at the origin
heading along -z; its length is cut into as many equal pieces as ``bend`` has values,
piece i turning by bend[i] degrees at constant curvature (positive = left, counter-
clockwise seen from above): a tangent-continuous chain of arcs. The strip itself lies
``offset`` to the right of that centreline (negative: to the left); a point at arc length
s and lateral position o is c(s) + o n(s). Strips with the same position, rotation,
length and bend but different offsets (road, kerbs, sidewalks, verges of one street)
therefore fit side by side exactly. Each strip is a closed slab. The road side of a kerb
gutter or sidewalk is the side nearer the centreline.
- road: asphalt, top at y = 0 with a 2 % camber (centre highest), lane markings as their
  own faces of the top (dashed centre line, optional edge lines), height = slab depth;
- kerb: a kerb stone (granite), road side at o = -width/2, top at y = height;
- gutter: light concrete blocks flush with the road, top at y = height on its outer side,
  1.5 cm lower on its road side;
- sidewalk: paving (one surface: the pavers are the material's), top at y = height;
- verge: grass (a sward's tone, ``SWARD``), top at y = height with a gentle bumpy relief.
"""
from __future__ import annotations

import numpy as np

from . import palette
from .mesh import MeshBuilder, MeshData, pose, rot_x, start
from .palette import pick, scaled

ASPHALT = (0.085, 0.085, 0.082)
GRASS = (0.06, 0.10, 0.03)
# a verge's surface is a sward seen as a whole: its blades shade each other, so at a street
# camera's grazing views it is about half as bright as one blade's albedo (measured on
# city_kitti's frame 0, half size, the near lawn over the sunlit road: the bare slab 1.67,
# under grass_tuft's mown-sward blades 0.86 with the grass's former sheen; 1.18 and 0.53 without)
SWARD = 0.5


def _pieces(length: float, bends):
    """Start arc length, start point (x, z), start heading (rad) and turn (rad) of each of
    the equal pieces of a strip whose piece i turns by bends[i] degrees."""
    bends = np.atleast_1d(np.asarray(bends, float))
    n = len(bends)
    ell = length / n
    out, p, h = [], np.zeros(2), 0.0
    for i, bd in enumerate(bends):
        th = np.radians(bd)
        out.append((i * ell, p.copy(), h, th))
        if abs(th) < 1e-12:
            p = p + ell * np.array([-np.sin(h), -np.cos(h)])
        else:
            R = ell / th   # centre of curvature to the left of the heading
            p = p + R * np.array([-(np.cos(h) - np.cos(h + th)), -(np.sin(h + th) - np.sin(h))])
        h += th
    return out, ell


def arc_frame(s, length: float, bends):
    """Centre points c(s) (n, 3), right normals n(s) (n, 3) and headings (rad, left
    positive) of a strip of ``length`` whose equal pieces turn by ``bends`` (degrees)."""
    s = np.atleast_1d(np.asarray(s, float))
    pieces, ell = _pieces(length, bends)
    c = np.zeros((len(s), 3))
    head = np.zeros(len(s))
    idx = np.clip((s / ell).astype(int), 0, len(pieces) - 1)
    for i, (s0, p0, h0, th) in enumerate(pieces):
        m = idx == i
        u = s[m] - s0
        if abs(th) < 1e-12:
            c[m, 0], c[m, 2], head[m] = p0[0] - u * np.sin(h0), p0[1] - u * np.cos(h0), h0
        else:
            R = ell / th
            a = h0 + th * u / ell
            c[m, 0] = p0[0] - R * (np.cos(h0) - np.cos(a))
            c[m, 2] = p0[1] - R * (np.sin(a) - np.sin(h0))
            head[m] = a
    n = np.stack([np.cos(head), np.zeros_like(head), -np.sin(head)], axis=1)
    return c, n, head


def end_pose(length: float, bends) -> tuple[np.ndarray, float]:
    """(end point, heading change in degrees) of a strip."""
    c, _, h = arc_frame([length], length, bends)
    return c[0], float(np.degrees(h[0]))


def _stations(length: float, bends, extra=(), max_step=1.0) -> np.ndarray:
    bends = np.atleast_1d(np.asarray(bends, float))
    ell = length / len(bends)
    theta = float(np.max(np.abs(np.radians(bends))))
    step = max_step
    if theta > 1e-9:   # chord sagitta <= 2 mm on the sharpest piece
        step = min(step, np.sqrt(8 * (ell / theta) * 0.002))
    n = max(int(np.ceil(length / step)), 1)
    s = set(np.linspace(0.0, length, n + 1).round(6))
    s |= {round(float(x), 6) for x in extra if 0 < x < length}
    s |= {round(ell * i, 6) for i in range(1, len(bends))}
    return np.array(sorted(s))


def _slab(b: MeshBuilder, s, offsets, top_y, bottom_y, length, bend, cell_surf, side_surf) -> None:
    """A closed slab: a top grid (stations s x lateral offsets, heights top_y (len(s), len(o))),
    vertical sides at the first and last offset, flat bottom, end faces; cells' surfaces
    ``cell_surf`` (len(s)-1, len(o)-1)."""
    c, n, _ = arc_frame(s, length, bend)
    o = np.asarray(offsets, float)
    S, O = len(s), len(o)
    top = c[:, None, :] + o[None, :, None] * n[:, None, :]
    top[..., 1] = top_y
    bot_l = c + o[0] * n + [0, bottom_y, 0]
    bot_r = c + o[-1] * n + [0, bottom_y, 0]
    V = np.concatenate([top.reshape(-1, 3), bot_l, bot_r])
    t_idx = lambda i, j: i * O + j                        # noqa: E731
    bl = lambda i: S * O + i                              # noqa: E731
    br = lambda i: S * O + S + i                          # noqa: E731
    # per station interval i: its top cells (normal +y: stations run along -z, offsets along
    # +x), then the left side (offset o[0]), the right side (o[-1]) and the bottom
    i, j = np.arange(S - 1)[:, None], np.arange(O - 1)[None, :]
    a, bq, cq, d = t_idx(i, j), t_idx(i, j + 1), t_idx(i + 1, j + 1), t_idx(i + 1, j)
    top = np.stack([np.stack(np.broadcast_arrays(a, bq, cq), -1), np.stack(np.broadcast_arrays(a, cq, d), -1)],
                   axis=2).reshape(S - 1, 2 * (O - 1), 3)
    i = i[:, 0]
    sides = np.stack([np.stack(v, -1) for v in (
        (t_idx(i, 0), t_idx(i + 1, 0), bl(i + 1)), (t_idx(i, 0), bl(i + 1), bl(i)),
        (t_idx(i, O - 1), br(i), br(i + 1)), (t_idx(i, O - 1), br(i + 1), t_idx(i + 1, O - 1)),
        (bl(i), bl(i + 1), br(i + 1)), (bl(i), br(i + 1), br(i)))], axis=1)
    body = np.concatenate([top, sides], axis=1).reshape(-1, 3)
    cells = np.repeat(np.asarray(cell_surf, dtype=np.int64).reshape(S - 1, O - 1), 2, axis=1)
    body_surfs = np.concatenate([cells, np.full((S - 1, 6), side_surf, dtype=np.int64)], axis=1).ravel()
    ends, end_surfs = [], []
    for i, sign in ((0, 1), (S - 1, -1)):   # end faces: a fan over the top edge and the two bottom corners
        ring = [bl(i)] + [t_idx(i, j) for j in range(O)] + [br(i)]
        for j in range(1, len(ring) - 1):
            tri = (ring[0], ring[j], ring[j + 1])
            ends.append(tri[::-1] if sign > 0 else tri)
            end_surfs.append(side_surf)
    b.add(V, np.concatenate([body, np.array(ends, dtype=np.int64).reshape(-1, 3)]),
          np.concatenate([body_surfs, np.array(end_surfs, dtype=np.int64)]), closed=True)


def road(size, seed: int, bend, offset: float = 0.0) -> MeshData:
    rng, W, depth, L, b = start(size, seed)
    asphalt = b.surface("asphalt", scaled(ASPHALT, float(rng.choice([0.9, 1.0, 1.1]))))
    paint = b.surface("lane_marking")
    patch = b.surface("asphalt", scaled(ASPHALT, float(rng.choice([0.7, 0.8]))))
    iron = b.surface("metal_rusty", (0.12, 0.11, 0.10))
    style = int(rng.choice([0, 1, 2], p=[0.3, 0.45, 0.25])) if W >= 5.0 else 0
    line_w = 0.12
    offs = {-W / 2, W / 2, 0.0}
    if style >= 1:
        offs |= {-line_w / 2, line_w / 2}
    if style == 2:
        e = W / 2 - 0.25
        offs |= {-e - line_w, -e, e, e + line_w}
    # repairs (patched rectangles) and manhole / drain covers
    features = []
    for _ in range(int(rng.poisson(L / 25.0))):
        s0 = rng.uniform(0, L - 2.5)
        o0 = rng.uniform(-W / 2 + 0.5, W / 2 - 2.0)
        features.append((s0, s0 + rng.uniform(0.8, 2.5), o0, o0 + rng.uniform(0.6, 1.8), patch))
    for _ in range(int(rng.poisson(L / 30.0))):
        s0 = rng.uniform(0, L - 0.7)
        o0 = rng.choice([-1, 1]) * (W / 2 - 0.55) - 0.3 if rng.random() < 0.6 else rng.uniform(-1.5, 1.5)
        features.append((s0, s0 + 0.6, o0, o0 + 0.6, iron))
    for f in features:
        offs |= {f[2], f[3]}
    offs = np.array(sorted(o for o in offs if -W / 2 <= o <= W / 2))
    dash, gap = (3.0, 6.0) if rng.random() < 0.7 else (6.0, 12.0)
    phase = rng.uniform(0, dash + gap)
    dash_s = []
    t = -phase
    while t < L:
        dash_s += [t, t + dash]
        t += dash + gap
    s = _stations(L, bend, [x for f in features for x in f[:2]] + dash_s)
    cells = np.full((len(s) - 1, len(offs) - 1), asphalt)
    sm, om = 0.5 * (s[1:] + s[:-1]), 0.5 * (offs[1:] + offs[:-1])
    for i, si in enumerate(sm):
        for j, oj in enumerate(om):
            for s0, s1, o0, o1, surf in features:
                if s0 < si < s1 and o0 < oj < o1:
                    cells[i, j] = surf
            if style >= 1 and abs(oj) < line_w / 2 and any(a < si < a + dash for a in dash_s[::2]):
                cells[i, j] = paint
            if style == 2 and W / 2 - 0.25 < abs(oj) < W / 2 - 0.25 + line_w:
                cells[i, j] = paint
    camber = -0.02 * (W / 2) * (offs / (W / 2)) ** 2
    _slab(b, s, offs + offset, np.tile(camber, (len(s), 1)), -depth, L, bend, cells, asphalt)
    return b.build()


def _road_side(offs, tops, offset: float):
    """Cross-section built with its road side at -x; mirrored when the strip lies left of
    the centreline (offset < 0), so the road side always faces the centreline."""
    if offset >= 0:
        return offs + offset, tops
    return -offs[::-1] + offset, tops[:, ::-1]


def kerb(size, seed: int, bend, offset: float = 0.0) -> MeshData:
    W, h, L = (float(x) for x in size)
    rng = np.random.default_rng(seed)
    b = MeshBuilder()
    # grey granite, the library's albedo (0.26) give or take a tenth: KITTI sequence_1's sunlit kerb
    # tops are 2.4 x its asphalt (the former concrete at 0.42 rendered 3.7 x)
    stone = b.surface("granite", scaled((0.26, 0.26, 0.25), float(rng.choice([0.9, 1.0, 1.1]))))
    ch = min(0.03, W / 4)
    offs = np.array([-W / 2, -W / 2 + ch, W / 2])
    s = _stations(L, bend, np.arange(1.0, L, 1.0))   # one stone per metre
    offs, tops = _road_side(offs, np.tile([h - ch, h, h], (len(s), 1)), offset)
    cells = np.full((len(s) - 1, 2), stone)
    _slab(b, s, offs, tops, -0.25, L, bend, cells, stone)
    return b.build()


def sidewalk(size, seed: int, bend, offset: float = 0.0) -> MeshData:
    W, h, L = (float(x) for x in size)
    rng = np.random.default_rng(seed)
    b = MeshBuilder()
    # one surface (the pavers' tones are the paving material's own), so that an object's
    # ``material`` (a parking bay's setts) covers the whole strip
    paving = b.surface("paving", pick(rng, palette.PAVING))
    slab = rng.choice([0.3, 0.4, 0.5])
    n_o = max(int(round(W / slab)), 1)
    offs = np.linspace(-W / 2, W / 2, n_o + 1)
    s = _stations(L, bend, np.arange(slab, L, slab), max_step=slab)
    cells = np.full((len(s) - 1, n_o), paving)
    # a slight cross fall (1 %) towards the road side
    offs, tops = _road_side(offs, np.tile(h - 0.01 * (W / 2 - offs), (len(s), 1)), offset)
    _slab(b, s, offs, tops, -0.25, L, bend, cells, paving)
    return b.build()


def gutter(size, seed: int, bend, offset: float = 0.0) -> MeshData:
    """A gutter along the road's edge: rows of light concrete blocks (16 x 16-50 cm, per-block
    tone) flush with the road, falling 1.5 cm towards the road side, where the water runs."""
    W, h, L = (float(x) for x in size)
    rng = np.random.default_rng(seed)
    b = MeshBuilder()
    # weathered light concrete (albedo ~0.25, give or take a tenth, as the kerbs' granite): KITTI
    # sequence_1's sunlit gutter between its carriageway and parking bay is 2.3 x its asphalt, as
    # its kerb tops; the library's fresh concrete (0.37) rendered 3.4 x (city_kitti frame 12, draft)
    blocks = [b.surface("concrete", scaled((0.25, 0.245, 0.235), f)) for f in (0.9, 1.0, 1.1)]
    n_o = max(int(round(W / 0.16)), 1)
    along = float(rng.choice([0.16, 0.33, 0.5]))
    offs = np.linspace(-W / 2, W / 2, n_o + 1)
    s = _stations(L, bend, np.arange(along, L, along), max_step=along)
    cells = rng.choice(blocks, size=(len(s) - 1, n_o))
    offs, tops = _road_side(offs, np.tile(h - 0.015 * (W / 2 - offs) / W, (len(s), 1)), offset)
    _slab(b, s, offs, tops, -0.25, L, bend, cells, blocks[1])
    return b.build()


def verge(size, seed: int, bend, offset: float = 0.0) -> MeshData:
    W, h, L = (float(x) for x in size)
    rng = np.random.default_rng(seed)
    b = MeshBuilder()
    grass = [b.surface("grass", scaled(GRASS, SWARD * f)) for f in (0.85, 1.0, 1.15)]
    soil = b.surface("soil")
    step = 0.5 if W < 8 else 1.0
    offs = np.linspace(-W / 2, W / 2, max(int(np.ceil(W / step)), 1) + 1)
    s = _stations(L, bend, (), max_step=step)
    # gentle relief that vanishes at the strip's edges (so neighbours join at height h)
    ph = rng.uniform(0, 2 * np.pi, 4)
    edge = np.clip(np.minimum(offs + W / 2, W / 2 - offs) / 0.6, 0, 1)
    sx = s[:, None]
    relief = 0.04 * (np.sin(sx * 0.9 + ph[0]) * np.sin(offs[None, :] * 1.3 + ph[1]) +
                     0.5 * np.sin(sx * 2.3 + ph[2] + offs[None, :] * 0.7)) * edge[None, :]
    cells = rng.choice(grass, size=(len(s) - 1, len(offs) - 1))
    cells[rng.random(cells.shape) < 0.04] = soil
    _slab(b, s, offs + offset, h + relief, -0.25, L, bend, cells, soil)
    return b.build()


# --- street furniture ---------------------------------------------------------------------

def pole(size, seed: int) -> MeshData:
    """A plain round post (for signs): size = (diameter, height, diameter)."""
    rng, d, H, _, b = start(size, seed)
    metal = b.surface("metal_painted", pick(rng, palette.METAL_PAINT))
    b.cylinder(d / 2, -0.05, H, 12, metal)
    b.cylinder(d / 2 + 0.004, H - 0.01, H + 0.02, 12, metal)    # cap
    return b.build()


def streetlight(size, seed: int) -> MeshData:
    """A street lamp: tapered mast, an arm curving over the road (towards -x), a luminaire
    with a glass underside. size = (reach of the arm, height, base diameter)."""
    rng, reach, H, dia, b = start(size, seed)
    metal = b.surface("metal_painted", pick(rng, palette.METAL_PAINT))
    lamp_glass = b.surface("plastic", (0.7, 0.7, 0.66))
    b.frustum(dia / 2, dia / 4, -0.05, H - 0.3, 14, metal)
    b.frustum(dia / 2 + 0.03, dia / 2 + 0.02, 0.0, 0.6, 14, metal)          # base sleeve
    # arm: a quarter circle then straight, from the mast top towards -x
    t = np.linspace(0, np.pi / 2, 8)
    rr = 0.5
    arm = np.column_stack([-rr * (1 - np.cos(t)), H - 0.3 + rr * np.sin(t), np.zeros_like(t)])
    arm = np.concatenate([arm, [[-reach, H + rr - 0.3 + 0.12, 0.0]]])
    b.tube(arm, dia / 4, 8, metal)
    hx = -reach
    y = H + rr - 0.3 + 0.12
    b.box((hx - 0.35, y - 0.1, -0.16), (hx + 0.15, y + 0.06, 0.16), metal)
    b.box((hx - 0.32, y - 0.12, -0.13), (hx + 0.12, y - 0.1, 0.13), lamp_glass)
    return b.build()


def sign(size, seed: int) -> MeshData:
    """A traffic sign plate facing +z, its centre at height size y above the origin (mount
    it on a pole): a red-bordered triangle, a red-bordered disc, a blue disc or a blue
    rectangle with a white border; a grey back and a clamp. size = (width, height of the
    centre, thickness)."""
    rng, Wd, yc, th, b = start(size, seed)
    white = b.surface("metal_painted", (0.75, 0.75, 0.73))
    red = b.surface("metal_painted", (0.45, 0.02, 0.02))
    blue = b.surface("metal_painted", (0.02, 0.08, 0.35))
    back = b.surface("metal_brushed")
    dark = b.surface("metal_painted", (0.03, 0.03, 0.03))
    kind = int(rng.integers(4))
    r = Wd / 2
    if kind == 0:     # triangle (warning), apex up
        ang = np.radians([90, 210, 330])
        outer = np.column_stack([r * np.cos(ang), r * np.sin(ang)])
        inner = outer * 0.72
        ring_s, in_s = red, white
    else:
        m = 32
        ang = 2 * np.pi * np.arange(m) / m
        if kind == 3:  # rectangle
            outer = np.array([[-r, -r * 0.8], [r, -r * 0.8], [r, r * 0.8], [-r, r * 0.8]])
            inner = outer * [0.9, 0.86]
            ring_s, in_s = white, blue
        else:
            outer = np.column_stack([r * np.cos(ang), r * np.sin(ang)])
            inner = outer * (0.8 if kind == 1 else 0.92)
            ring_s, in_s = (red, white) if kind == 1 else (white, blue)
    z0 = 0.0
    k = len(outer)
    face = lambda xy, z: np.column_stack([xy[:, 0], xy[:, 1] + yc, np.full(len(xy), z)])  # noqa: E731
    # front: ring (outer-inner) + inner polygon; back plate; edge band: one closed solid
    Vo, Vi, Vb = face(outer, z0), face(inner, z0), face(outer, z0 - th)
    V = np.concatenate([Vo, Vi, Vb, [[0, yc, z0], [0, yc, z0 - th]]])
    c_f, c_b = 3 * k, 3 * k + 1
    tris, surfs = [], []
    for i in range(k):
        j = (i + 1) % k
        tris += [(i, j, k + j), (i, k + j, k + i)]; surfs += [ring_s] * 2          # ring
        tris += [(c_f, k + i, k + j)]; surfs += [in_s]                              # inner
        tris += [(c_b, 2 * k + j, 2 * k + i)]; surfs += [back]                       # back
        tris += [(i, 2 * k + i, 2 * k + j), (i, 2 * k + j, j)]; surfs += [back] * 2  # edge
    b.add(V, tris, surfs, closed=True)
    if kind in (1, 2):   # a simple symbol bar
        b.box((-0.45 * r, yc - 0.09 * r, z0), (0.45 * r, yc + 0.09 * r, z0 + 0.003), dark if kind == 1 else white)
    b.box((-0.05, yc - 0.25 * r - 0.03, z0 - th - 0.05), (0.05, yc - 0.25 * r + 0.03, z0 - th), back)
    b.box((-0.05, yc + 0.25 * r - 0.03, z0 - th - 0.05), (0.05, yc + 0.25 * r + 0.03, z0 - th), back)
    return b.build()


def traffic_light(size, seed: int) -> MeshData:
    """A traffic light: post with a three-lamp head facing +z. size = (head width, height
    of the head's top, post diameter)."""
    rng, w, H, dia, b = start(size, seed)
    body = b.surface("metal_painted", (0.03, 0.03, 0.03) if rng.random() < 0.5 else (0.30, 0.31, 0.32))
    post = b.surface("metal_painted", (0.30, 0.31, 0.32))
    lens = [b.surface("plastic", c) for c in ((0.3, 0.02, 0.01), (0.3, 0.18, 0.01), (0.01, 0.18, 0.06))]
    hh = w * 2.8
    b.cylinder(dia / 2, -0.05, H - hh, 12, post)
    b.box((-w / 2, H - hh, -0.12), (w / 2, H, 0.1), body)
    for i in range(3):
        yc = H - hh * (i + 0.5) / 3
        b.cylinder(w * 0.33, 0.1, 0.115, 16, lens[i], T=pose(rot_x(90), (0, yc, 0)))
        b.box((-w * 0.4, yc + w * 0.3, 0.1), (w * 0.4, yc + w * 0.34, 0.22), body)   # visor
    return b.build()


def bin_(size, seed: int) -> MeshData:
    """A wheelie bin (box body, lid, wheels) or a round litter bin on a post."""
    rng, W, H, D, b = start(size, seed)
    col = pick(rng, palette.PLASTIC_BIN)
    shell = b.surface("plastic", col)
    lid = b.surface("plastic", scaled(col, 0.8))
    rubber = b.surface("rubber")
    if rng.random() < 0.7:
        b.prism([(-W / 2 + 0.03, -D / 2 + 0.03), (W / 2 - 0.03, -D / 2 + 0.03), (W / 2, D / 2), (-W / 2, D / 2)],
                0.08, H - 0.05, shell)
        b.box((-W / 2 - 0.02, H - 0.05, -D / 2 - 0.02), (W / 2 + 0.02, H, D / 2 + 0.06), lid)
        for sx in (-1, 1):
            b.cylinder(0.1, -0.025, 0.025, 16, rubber, T=pose(np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]]),
                                                           (sx * (W / 2 - 0.08), 0.1, -D / 2 + 0.05)))
    else:
        metal = b.surface("metal_painted", pick(rng, palette.METAL_PAINT))
        b.cylinder(0.04, -0.05, H, 10, metal)
        b.frustum(W / 2, W / 2 * 1.05, H * 0.45, H * 0.95, 20, shell, T=pose(None, (0, 0, D / 2 + 0.02)))
    return b.build()


def bollard(size, seed: int) -> MeshData:
    rng, d, H, _, b = start(size, seed)
    metal = b.surface("metal_painted", pick(rng, palette.METAL_PAINT))
    band = b.surface("metal_painted", (0.75, 0.75, 0.73))
    b.cylinder(d / 2, -0.05, H - 0.1, 16, metal)
    b.cylinder(d / 2 + 0.003, H * 0.7, H * 0.78, 16, band)
    b.revolve([(0, H - 0.1), (d / 2, H - 0.1), (d / 2 * 0.8, H - 0.04), (0, H)], 16, metal)
    return b.build()


def bench(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    wood = b.surface("wood_planks", pick(rng, palette.WOOD))
    metal = b.surface("metal_painted", (0.05, 0.05, 0.05))
    seat_y = 0.45
    for sx in (-1, 1):
        x = sx * (W / 2 - 0.15)
        b.box((x - 0.03, 0, -D / 2), (x + 0.03, seat_y, -D / 2 + 0.06), metal)
        b.box((x - 0.03, 0, D / 2 - 0.06), (x + 0.03, seat_y, D / 2), metal)
        b.box((x - 0.03, seat_y, -D / 2), (x + 0.03, H, -D / 2 + 0.05), metal)
    for i in range(4):
        z = -D / 2 + 0.05 + i * (D - 0.05) / 4
        b.box((-W / 2, seat_y, z + 0.01), (W / 2, seat_y + 0.04, z + (D - 0.05) / 4 - 0.01), wood)
    for i in range(2):
        y = seat_y + 0.15 + i * 0.18
        b.box((-W / 2, y, -D / 2 + 0.05), (W / 2, y + 0.12, -D / 2 + 0.09), wood, T=None)
    return b.build()


def fence(size, seed: int) -> MeshData:
    """A garden fence along x: wooden pickets on two rails, or steel bars between a top and
    a bottom rail, or a low wall with a coping; posts every ~2 m. size = (length, height,
    thickness)."""
    rng, L, H, T, b = start(size, seed)
    style = int(rng.integers(3))
    n_posts = max(int(round(L / 2.0)), 1)
    xs = np.linspace(-L / 2, L / 2, n_posts + 1)
    if style == 0:      # wooden pickets
        wood = b.surface("wood_planks", pick(rng, palette.WOOD))
        for x in xs:
            b.box((x - 0.045, -0.05, -0.045), (x + 0.045, H + 0.05, 0.045), wood)
        for y in (0.2 * H, 0.75 * H):
            b.box((-L / 2, y, -T / 2 + 0.02), (L / 2, y + 0.07, -T / 2 + 0.045), wood)
        gap = rng.uniform(0.03, 0.07)
        w = rng.uniform(0.07, 0.1)
        x = -L / 2
        while x + w <= L / 2:
            top = H - 0.03 * rng.random()
            b.box((x, 0.03, -T / 2 + 0.045), (x + w, top, -T / 2 + 0.065), wood)
            x += w + gap
    elif style == 1:    # steel bars
        steel = b.surface("metal_painted", pick(rng, palette.METAL_PAINT))
        for x in xs:
            b.box((x - 0.03, -0.05, -0.03), (x + 0.03, H + 0.03, 0.03), steel)
        for y in (0.08, H - 0.06):
            b.box((-L / 2, y, -0.02), (L / 2, y + 0.04, 0.02), steel)
        n = int(L / 0.12)
        for k in range(n):
            x = -L / 2 + (k + 0.5) * L / n
            b.box((x - 0.008, 0.08, -0.008), (x + 0.008, H - 0.02, 0.008), steel)
    else:               # a low wall with a coping stone
        wall = b.surface("brick", pick(rng, palette.BRICK)) if rng.random() < 0.5 else \
            b.surface("plaster", pick(rng, palette.PLASTER))
        cap = b.surface("concrete", (0.45, 0.44, 0.42))
        b.box((-L / 2, -0.05, -T / 2), (L / 2, H - 0.06, T / 2), wall)
        b.box((-L / 2 - 0.02, H - 0.06, -T / 2 - 0.03), (L / 2 + 0.02, H, T / 2 + 0.03), cap)
    return b.build()
