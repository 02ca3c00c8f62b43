"""What lies about a drone test area (EuRoC V1_01's near field, docs/sensors.md, Camera
twins): quilted crash mats, a printed play mat, cables on the floor.

Asset frame as the indoor assets' (``size`` = x, y, z extents, floor at y = 0, front +z).
"""
from __future__ import annotations

import numpy as np

from .indoor import _soft_block
from .mesh import MeshData, start
from .palette import pick

# vinyl covers of gym landing mats: greys and the usual blue, red, green (linear albedo)
MAT_COVERS = (((0.42, 0.42, 0.41), 4), ((0.26, 0.27, 0.28), 3), ((0.05, 0.11, 0.32), 2),
              ((0.32, 0.05, 0.04), 1), ((0.06, 0.2, 0.09), 1))
CABLE_SHEATHS = ((0.03, 0.03, 0.03), (0.03, 0.03, 0.03), (0.5, 0.5, 0.48), (0.45, 0.15, 0.02), (0.05, 0.1, 0.3))
QUILT_M = (0.14, 0.22)           # quilting channel pitch of a landing mat (m)
MAT_HANDLE_M = 0.02              # how far a landing mat's handle loops stand off its long sides (m)


def crash_mat(size, seed: int) -> MeshData:
    """A gym landing (crash) mat lying flat: foam in a vinyl cover quilted into channels across
    its length (x) every 14-22 cm, rounded edges, webbing handles on the long sides, a label
    on one end. size = (length x, thickness y, width z); stood on an edge by the ASSET's
    rotation (a mat stands on its long edge against a wall or at a test area's edge)."""
    rng, W, H, D, b = start(size, seed)
    cover = b.surface("fabric", pick(rng, MAT_COVERS))
    strap = b.surface("fabric", (0.03, 0.03, 0.035))
    label = b.surface("plastic", (0.7, 0.7, 0.68))
    r = min(0.3 * H, 0.035)          # shallow channels: the quilting shades, not folds
    n = max(int(round(W / rng.uniform(*QUILT_M))), 1)
    edges = np.linspace(-W / 2, W / 2, n + 1)
    gap = min(0.012, 0.2 * (edges[1] - edges[0]))
    # the cover's channels: one rounded pillow each, the stitched crease between them showing the
    # core; the core a little inside, so the creases are dark grooves, not holes
    b.box((-W / 2 + r / 2, r / 3, -D / 2 + r / 3), (W / 2 - r / 2, H - r / 3, D / 2 - r / 3), cover)
    for x0, x1 in zip(edges[:-1], edges[1:]):
        _soft_block(b, (x0 + gap / 2, 0.0, -D / 2), (x1 - gap / 2, H, D / 2), r, cover, axis=2)
    hw, hl = 0.04, 0.22                           # webbing 4 cm, a handle loop 22 cm long
    for sz in (-1, 1):
        for xc in np.linspace(-W / 2, W / 2, 4)[1:-1] + rng.uniform(-0.05, 0.05, 2):
            z0 = sz * D / 2
            lo, hi = sorted((z0, z0 + sz * 0.006))
            b.box((xc - hl / 2, 0.35 * H, lo), (xc + hl / 2, 0.35 * H + hw, hi), strap)
            lo, hi = sorted((z0 + sz * 0.006, z0 + sz * MAT_HANDLE_M))
            b.box((xc - hl / 2 + 0.02, 0.35 * H, lo), (xc + hl / 2 - 0.02, 0.35 * H + hw, hi), strap)
    lw, lh = min(0.3, 0.4 * D), min(0.12, max(H - 2 * r, 0.02))     # on the end's flat part
    zc = rng.uniform(-D / 4, D / 4)
    b.box((W / 2, H / 2 - lh / 2, zc - lw / 2), (W / 2 + 0.003, H / 2 + lh / 2, zc + lw / 2), label)
    return b.build()


def play_mat(size, seed: int) -> MeshData:
    """A printed vinyl play mat lying on the floor: a light base printed with a town's roads
    (dark grey, white dashed centre lines), blocks of colour between them and a roundabout,
    each print a film a sixteenth of the thickness above the last (its top at 1.375 x the
    thickness), so no two faces are coplanar. size = (width x, thickness y, depth z)."""
    rng, W, H, D, b = start(size, seed)
    base = b.surface("plastic", (0.72, 0.72, 0.69))
    road = b.surface("plastic", (0.12, 0.12, 0.13))
    dash = b.surface("plastic", (0.78, 0.78, 0.76))
    blocks = [b.surface("plastic", c) for c in ((0.1, 0.35, 0.12), (0.05, 0.2, 0.5), (0.6, 0.45, 0.05),
                                                 (0.5, 0.08, 0.05), (0.45, 0.45, 0.43))]
    f = H / 16
    b.box((-W / 2, 0.0, -D / 2), (W / 2, H, D / 2), base, skip=())
    rw = rng.uniform(0.14, 0.2)
    xs = np.sort(rng.uniform(-W / 2 + 0.2, W / 2 - 0.2, max(int(W / 0.6), 1)))
    zs = np.sort(rng.uniform(-D / 2 + 0.2, D / 2 - 0.2, max(int(D / 0.6), 1)))
    for x in xs:                                  # roads along z, then across x one film higher
        b.box((x - rw / 2, H, -D / 2 + 0.03), (x + rw / 2, H + f, D / 2 - 0.03), road)
        for z in np.arange(-D / 2 + 0.06, D / 2 - 0.1, 0.1):
            b.box((x - 0.006, H + f, z), (x + 0.006, H + 2 * f, z + 0.05), dash)
    for z in zs:
        b.box((-W / 2 + 0.03, H + 2 * f, z - rw / 2), (W / 2 - 0.03, H + 3 * f, z + rw / 2), road)
        for x in np.arange(-W / 2 + 0.06, W / 2 - 0.1, 0.1):
            b.box((x, H + 3 * f, z - 0.006), (x + 0.05, H + 4 * f, z + 0.006), dash)
    cx, cz = np.concatenate([[-W / 2], xs, [W / 2]]), np.concatenate([[-D / 2], zs, [D / 2]])
    for x0, x1 in zip(cx[:-1], cx[1:]):           # a block of colour (a park, a lake, houses) in some cells
        for z0, z1 in zip(cz[:-1], cz[1:]):
            a0, a1, c0, c1 = x0 + rw / 2 + 0.04, x1 - rw / 2 - 0.04, z0 + rw / 2 + 0.04, z1 - rw / 2 - 0.04
            if a1 - a0 < 0.08 or c1 - c0 < 0.08 or rng.random() < 0.3:
                continue
            u0, u1 = sorted(rng.uniform(a0, a1, 2))
            v0, v1 = sorted(rng.uniform(c0, c1, 2))
            if u1 - u0 > 0.05 and v1 - v0 > 0.05:
                b.box((u0, H, v0), (u1, H + f, v1), blocks[int(rng.integers(len(blocks)))])
    if len(xs) and len(zs):                       # a roundabout on one crossing
        x, z = xs[int(rng.integers(len(xs)))], zs[int(rng.integers(len(zs)))]
        b.cylinder(rw * 1.1, H + 4 * f, H + 5 * f, 20, road, T=_at(x, z))
        b.cylinder(rw * 0.45, H + 5 * f, H + 6 * f, 16, blocks[0], T=_at(x, z))
    return b.build()


def _at(x, z):
    T = np.eye(4)
    T[0, 3], T[2, 3] = x, z
    return T


def cable(size, seed: int) -> MeshData:
    """A cable lying on the floor, wandering along x within the depth z, a plug at one end.
    size = (length x, diameter y, wander z)."""
    rng, W, H, D, b = start(size, seed)
    sheath = b.surface("rubber", pick(rng, CABLE_SHEATHS))
    plug = b.surface("plastic", (0.05, 0.05, 0.05))
    x = np.linspace(-W / 2, W / 2, max(int(W / 0.05), 8))
    t = (x + W / 2) / W
    z = sum(rng.uniform(-1, 1) * np.sin(np.pi * k * t + rng.uniform(0, 2 * np.pi)) / k for k in (1, 2, 3))
    z = D / 2 * z / max(np.abs(z).max(), 1e-9)
    pts = np.stack([x, np.full_like(x, H / 2), z], axis=1)
    b.tube(pts, np.full(len(x), H / 2), 8, sheath)
    d = pts[-1] - pts[-2]
    d /= np.linalg.norm(d)
    c = pts[-1] + d * 0.03
    ang = np.arctan2(-d[2], d[0])
    R = np.array([[np.cos(ang), 0, np.sin(ang)], [0, 1, 0], [-np.sin(ang), 0, np.cos(ang)]])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, c - np.array([0.0, H / 2, 0.0])
    b.box((-0.03, 0.0, -0.015), (0.03, max(H, 0.02), 0.015), plug, T=T)
    return b.build()

