"""Ground and natural clutter: rolling terrain with a trail, rocks, fallen logs, stumps,
ferns and grass tufts.

``terrain``: size = (width x, relief amplitude y, depth z), origin at the middle of the
ground; a heightfield on a 0.5 m grid, a trail running along z (meandering with the seed)
worn into it as bare soil with grassy margins, the rest a leaf-litter forest floor. Scene generators
place things on it with :func:`terrain_height` and follow the trail with :func:`trail_x`
(the same functions the mesh is built from).
"""
from __future__ import annotations

import functools

import numpy as np

from . import palette
from .mesh import MeshBuilder, MeshData, start
from .palette import pick, scaled
from .vegetation import _unit, add_leaves

TRAIL_HALF_WIDTH = 0.8
ROCK = ((0.12, 0.115, 0.11), (0.16, 0.15, 0.14), (0.10, 0.10, 0.095), (0.18, 0.16, 0.13))
LITTER = ((0.20, 0.11, 0.04), (0.14, 0.08, 0.035), (0.25, 0.16, 0.05), (0.10, 0.07, 0.04), (0.18, 0.15, 0.06))


def _waves(seed: int, n: int, wl_min: float, wl_max: float):
    rng = np.random.default_rng([seed, 4242])
    ang = rng.uniform(0, np.pi, n)
    k = 2 * np.pi / rng.uniform(wl_min, wl_max, n)
    return np.cos(ang) * k, np.sin(ang) * k, rng.uniform(0, 2 * np.pi, n), rng.uniform(0.5, 1.0, n)


def trail_x(size, seed: int, z) -> np.ndarray:
    """The trail's centre x at z (terrain frame)."""
    W, _, D = size
    rng = np.random.default_rng([seed, 777])
    z = np.asarray(z, float)
    a1, a2 = rng.uniform(0.06, 0.1) * W, rng.uniform(0.02, 0.04) * W
    return (a1 * np.sin(2 * np.pi * z / rng.uniform(60, 90) + rng.uniform(0, 6.3)) +
            a2 * np.sin(2 * np.pi * z / rng.uniform(20, 30) + rng.uniform(0, 6.3)))


def _raw_height(size, seed, x, z):
    W, A, D = size
    kx, kz, ph, amp = _waves(seed, 7, 15.0, 60.0)
    h = np.zeros(np.broadcast(x, z).shape)
    for i in range(len(kx)):
        h = h + amp[i] * np.sin(kx[i] * x + kz[i] * z + ph[i])
    kx, kz, ph, amp = _waves(seed + 1, 6, 3.0, 8.0)
    for i in range(len(kx)):
        h = h + 0.12 * amp[i] * np.sin(kx[i] * x + kz[i] * z + ph[i])
    return A * h / 5.0


def terrain_height(size, seed: int, x, z) -> np.ndarray:
    """Ground height at (x, z) (terrain frame): rolling relief, with the trail's band
    levelled across (its height that of its centre line) and sunk 4 cm."""
    x, z = np.asarray(x, float), np.asarray(z, float)
    h = _raw_height(size, seed, x, z)
    xt = trail_x(size, seed, z)
    ht = _raw_height(size, seed, xt, z) - 0.04
    w = np.clip((np.abs(x - xt) - TRAIL_HALF_WIDTH) / 1.5, 0.0, 1.0)
    w = w * w * (3 - 2 * w)
    return ht * (1 - w) + h * w


def terrain(size, seed: int) -> MeshData:
    """The terrain's grid follows the trail: x = trail_x(z) + u, u in [-W/2, W/2] on a 0.5 m
    grid with lines on the trail's edges, so the bare trail, its worn grassy margins and the
    leaf-litter floor meet along smooth curves (the terrain's side edges follow the trail's
    meander too)."""
    W, A, D = (float(x) for x in size)
    b = MeshBuilder()
    trail = b.surface("soil", (0.16, 0.12, 0.08))
    margin = b.surface("grass", (0.05, 0.08, 0.025))
    floor = b.surface("soil", (0.085, 0.065, 0.04))
    edge = TRAIL_HALF_WIDTH + 0.5
    us = np.concatenate([np.arange(-W / 2, -edge, 0.5), [-edge, -TRAIL_HALF_WIDTH, 0.0, TRAIL_HALF_WIDTH],
                         np.arange(edge, W / 2 + 1e-9, 0.5)])
    zs = np.linspace(D / 2, -D / 2, int(np.ceil(D / 0.5)) + 1)     # rows along -z
    U, Z = np.meshgrid(us, zs)
    X = trail_x((W, A, D), seed, Z) + U
    Y = terrain_height((W, A, D), seed, X, Z)
    top = np.stack([X, Y, Z], axis=-1)
    um = 0.5 * (U[1:, 1:] + U[:-1, :-1])
    cells = np.where(np.abs(um) < TRAIL_HALF_WIDTH, trail, np.where(np.abs(um) < edge, margin, floor))
    b.sheet(top, floor, cell_surf=cells)
    # fallen leaves lying on the floor near the trail (and a few on it), on the exact surface
    rng = np.random.default_rng([seed, 99])
    n = int(60 * 2 * 11.0 * D)
    u = rng.uniform(-12.0, 12.0, n)
    keep = (np.abs(u) > TRAIL_HALF_WIDTH - 0.2) | (rng.random(n) < 0.1)
    u, z = u[keep], rng.uniform(-D / 2, D / 2, keep.sum())
    x = trail_x((W, A, D), seed, z) + u
    _fallen_leaves(b, rng, np.column_stack([x, _surface_height(top, us, zs, u, z) + 0.004, z]),
                   [b.surface("leaves", c) for c in LITTER])
    # skirt: the four sides down to a flat bottom (a closed slab)
    y_bot = float(Y.min()) - 0.5
    for e in (top[0, :], top[:, -1], top[-1, ::-1], top[::-1, 0]):
        for i in range(len(e) - 1):
            p, q = e[i], e[i + 1]
            b.quad(p, (p[0], y_bot, p[2]), (q[0], y_bot, q[2]), q, floor)
    corners = [top[-1, 0], top[0, 0], top[0, -1], top[-1, -1]]
    b.quad(*[(c[0], y_bot, c[2]) for c in corners], floor)
    return b.build()


def _surface_height(top, us, zs, u, z):
    """Height of the terrain mesh (its triangles, split as ``MeshBuilder.sheet`` splits a
    cell) at grid coordinates (u, z)."""
    i = np.clip(np.searchsorted(-zs, -z) - 1, 0, len(zs) - 2)          # zs decrease
    j = np.clip(np.searchsorted(us, u) - 1, 0, len(us) - 2)
    fz = (zs[i] - z) / (zs[i] - zs[i + 1])
    fu = (u - us[j]) / (us[j + 1] - us[j])
    y00, y01, y10, y11 = top[i, j, 1], top[i, j + 1, 1], top[i + 1, j, 1], top[i + 1, j + 1, 1]
    # a cell is split along its (i, j)-(i+1, j+1) diagonal
    lower = fu >= fz
    return np.where(lower, y00 + fu * (y01 - y00) + fz * (y11 - y01), y00 + fz * (y10 - y00) + fu * (y11 - y10))


def _fallen_leaves(b, rng, P, surfs) -> None:
    """Flat leaves lying at points P (n, 3): tips a little up or down, a slight curl."""
    n = len(P)
    a = rng.uniform(0, 2 * np.pi, n)
    d = _unit(np.column_stack([np.cos(a), rng.normal(0, 0.08, n), np.sin(a)]))
    side = _unit(np.cross(d, [0, 1, 0]) + rng.normal(size=(n, 3)) * [0, 0.15, 0])
    ls = rng.uniform(0.05, 0.1, n)[:, None]
    curl = 0.1 * ls * np.array([0, 1, 0])
    V = np.stack([P, P + 0.42 * ls * d - 0.3 * ls * side + curl, P + ls * d, P + 0.42 * ls * d + 0.3 * ls * side + curl],
                 axis=1).reshape(-1, 3)
    idx = (np.arange(n) * 4)[:, None]
    F = np.concatenate([idx + [0, 1, 2], idx + [0, 2, 3]])
    sf = np.asarray(surfs)[rng.integers(len(surfs), size=n)]
    b.add(V, F, np.concatenate([sf, sf]))


def rock(size, seed: int) -> MeshData:
    """A boulder: a subdivided icosahedron displaced by seeded noise at several scales
    (rounded mass, facets, cracks' roughness), flattened below, moss on its top faces."""
    rng, W, H, D, b = start(size, seed)
    stone = b.surface("concrete", pick(rng, ROCK))
    moss = b.surface("grass", (0.04, 0.06, 0.02))
    V, F = _icosphere(4)
    disp = np.ones(len(V))
    for n_waves, freq, amp in ((8, 2.5, 0.12), (12, 6.0, 0.05), (16, 14.0, 0.02)):
        n = rng.normal(size=(n_waves, 3))
        disp += amp * np.sum(np.sin(V @ n.T * freq + rng.uniform(0, 6.3, n_waves)), axis=1) / np.sqrt(n_waves)
    V = V * disp[:, None] * np.array([W / 2, H, D / 2])
    V[:, 1] = np.maximum(V[:, 1], -0.15 * H)
    V[:, 1] += 0.1 * H
    up = _face_up(V, F)
    s = np.where(up > 0.7 + 0.2 * rng.random(len(F)), moss, stone)
    b.add(V, F, s, smooth=False, closed=True)
    return b.build()


def litter(size, seed: int) -> MeshData:
    """Fallen leaves and twigs lying on the ground over a patch (size = width, -, depth):
    flat leaves of browns and yellows, slightly tilted, a few twigs."""
    rng, W, H, D, b = start(size, seed)
    browns = [b.surface("leaves", c) for c in LITTER]
    bark = b.surface("bark", pick(rng, palette.BARK))
    n = int(180 * W * D) + 20
    P = np.column_stack([rng.uniform(-W / 2, W / 2, n), rng.uniform(0.005, 0.03, n), rng.uniform(-D / 2, D / 2, n)])
    _fallen_leaves(b, rng, P, browns)
    for _ in range(int(rng.integers(2, 6))):
        p0 = np.array([rng.uniform(-W / 2, W / 2), 0.02, rng.uniform(-D / 2, D / 2)])
        d = _unit(rng.normal(size=3) * [1, 0.05, 1])
        L = rng.uniform(0.2, 0.6)
        b.tube([p0, p0 + d * L / 2 + [0, 0.01, 0], p0 + d * L], 0.008, 4, bark)
    return b.build()


def _face_up(V, F):
    a, b_, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    n = np.cross(b_ - a, c - a)
    return n[:, 1] / np.maximum(np.linalg.norm(n, axis=1), 1e-12)


def _icosphere(levels: int):
    """(vertices, triangles) of the unit icosphere of ``levels`` subdivisions (fresh arrays)."""
    V, F = _unit_icosphere(levels)
    return V.copy(), F.copy()


@functools.lru_cache(maxsize=None)
def _unit_icosphere(levels: int):
    # made once per process: level 4 is ~5,000 Python midpoints (~30 ms), the same for every rock
    t = (1 + 5 ** 0.5) / 2
    V = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
         (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
         (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    V = [np.array(v, float) / np.linalg.norm(v) for v in V]
    for _ in range(levels):
        cache, F2 = {}, []

        def mid(i, j):
            key = (min(i, j), max(i, j))
            if key not in cache:
                m = V[i] + V[j]
                V.append(m / np.linalg.norm(m))
                cache[key] = len(V) - 1
            return cache[key]
        for a, b_, c in F:
            ab, bc, ca = mid(a, b_), mid(b_, c), mid(c, a)
            F2 += [(a, ab, ca), (b_, bc, ab), (c, ca, bc), (ab, bc, ca)]
        F = F2
    return np.array(V), np.array(F)


def log(size, seed: int) -> MeshData:
    """A fallen log along x: a slightly bent, tapering trunk with bark, cut ends in wood."""
    rng, L, dia, _, b = start(size, seed)
    bark = b.surface("bark", pick(rng, palette.BARK))
    xs = np.linspace(-L / 2, L / 2, 9)
    bend = rng.normal(size=3) * 0.05
    pts = np.stack([xs, dia / 2 + bend[1] * np.sin(np.pi * (xs / L + 0.5)), bend[2] * np.sin(np.pi * (xs / L + 0.5))], 1)
    b.tube(pts, np.linspace(dia / 2, dia / 2 * 0.75, len(xs)), 12, bark)
    for _ in range(int(rng.integers(1, 4))):   # broken branch stubs
        x = rng.uniform(-L / 3, L / 3)
        d = _unit(rng.normal(size=3) * [0.3, 1, 1])
        p0 = np.array([x, dia / 2, 0.0])
        b.tube([p0, p0 + d * rng.uniform(0.3, 0.7)], dia * 0.12, 6, bark)
    return b.build()


def stump(size, seed: int) -> MeshData:
    rng, W, H, D, b = start(size, seed)
    bark = b.surface("bark", pick(rng, palette.BARK))
    wood = b.surface("wood_planks", (0.35, 0.25, 0.14))
    r = min(W, D) / 2
    b.frustum(r * 1.25, r, -0.05, H, 14, bark, cap_surf=wood)
    for k in range(4):   # root flares
        a = k * np.pi / 2 + rng.uniform(-0.3, 0.3)
        d = np.array([np.cos(a), 0, np.sin(a)])
        b.tube([(0, 0.15, 0), tuple(d * r * 2.0 + (0, -0.05, 0))], r * 0.3, 6, bark)
    return b.build()


def fern(size, seed: int) -> MeshData:
    """Arching fronds of small leaflets from a centre (ground cover)."""
    rng, W, H, D, b = start(size, seed)
    greens = [b.surface("leaves", scaled((0.06, 0.11, 0.03), f)) for f in (0.8, 1.0, 1.25)]
    pts, outs, lens = [], [], []
    for k in range(int(rng.integers(8, 16))):
        a = rng.uniform(0, 2 * np.pi)
        d = np.array([np.cos(a) * W / 2, 0, np.sin(a) * D / 2]) * rng.uniform(0.7, 1.0)
        t = np.linspace(0.1, 1, 14)
        rach = np.outer(t, d) + np.outer(H * 4 * t * (1 - t) * rng.uniform(0.7, 1.1), [0, 1, 0])
        side = _unit(np.cross(d, [0, 1, 0]))
        for sgn in (-1, 1):
            pts.append(rach)
            outs.append(np.tile(side * sgn, (len(t), 1)) + [0, 0.3, 0])
            lens.append(0.12 * (1.1 - t))
    add_leaves(b, rng, np.concatenate(pts), np.concatenate(outs), np.concatenate(lens), greens, width=0.4, droop=0.5)
    return b.build()


TUFT_H_M = 0.35      # the forest's tufts' blade height, at 800 blades per m^2
CLUMP_M = 0.06       # a mown sward's clumps (below TUFT_H_M): blades of one clump share a height and tone


def grass_tuft(size, seed: int) -> MeshData:
    """A clump of grass blades (thin curved triangles) over a small patch. Its blades' leaf area
    per ground area is at least that of a 35 cm tuft at 800 blades per m^2 (~1.8): shorter blades
    stand denser (a mown lawn's ~4000 per m^2 at 8 cm: the shoots of a mown sward, whose
    blades hide the ground at the grazing views of a street camera)."""
    rng, W, H, D, b = start(size, seed)
    greens = [b.surface("grass", scaled((0.06, 0.1, 0.03), f)) for f in (0.8, 1.0, 1.3, 1.6)]
    n = int(200 * W * D / 0.25 * max(1.0, TUFT_H_M / H)) + 30
    base = np.column_stack([rng.uniform(-W / 2, W / 2, n), np.full(n, -0.02), rng.uniform(-D / 2, D / 2, n)])
    lean = _unit(rng.normal(size=(n, 3)) * [1, 0, 1]) * rng.uniform(0.05, 0.4, n)[:, None]
    h = H * rng.uniform(0.5, 1.0, n)
    clump = None
    if H < TUFT_H_M:   # a mown sward: shoots in clumps (one plant's tillers, ~6 cm), each cut and toned alike
        crng = np.random.default_rng([seed, 0xC1])
        cell = np.floor((base[:, [0, 2]] + [W / 2, D / 2]) / CLUMP_M).astype(int)
        table = crng.uniform(0.0, 1.0, (*(cell.max(axis=0) + 1), 2))
        clump = table[cell[:, 0], cell[:, 1]]
        h *= 0.6 + 0.4 * clump[:, 0]
    w = rng.uniform(0.004, 0.008, n)
    side = _unit(np.cross(lean + [0, 1e-3, 0], [0, 1, 0]) + rng.normal(size=(n, 3)) * 0.3)
    mid = base + np.column_stack([lean[:, 0] * h * 0.3, h * 0.55, lean[:, 2] * h * 0.3])
    tip = base + np.column_stack([lean[:, 0] * h, h, lean[:, 2] * h])
    V = np.stack([base - side * w[:, None], base + side * w[:, None], mid + side * (0.7 * w)[:, None],
                  mid - side * (0.7 * w)[:, None], tip], axis=1).reshape(-1, 3)
    idx = (np.arange(n) * 5)[:, None]
    F = np.concatenate([idx + [0, 1, 2], idx + [0, 2, 3], idx + [3, 2, 4]])
    pick_ = rng.integers(len(greens), size=n)
    if clump is not None:
        pick_ = np.minimum((clump[:, 1] * len(greens)).astype(int), len(greens) - 1)
    s = np.asarray(greens)[pick_]
    b.add(V, F, np.concatenate([s, s, s]))
    return b.build()
