"""Trees, conifers, bushes and hedges with real geometry: branching tubes of bark and
thousands of individual leaves (two-triangle kites folded along the mid-rib) or needle
sprays, so that depth and ids are those of the leaves themselves (no alpha cut-outs).

Asset frame: ``size`` = (crown width x, total height y, crown depth z), ground at y = 0.
"""
from __future__ import annotations

import numpy as np

from . import palette
from .mesh import cross3, MeshBuilder, MeshData, start
from .palette import pick, scaled

# A broadleaf crown's leaves grow in sprays (a shoot's leaves, 20-30 cm across) at the twigs'
# ends and nodes, with sky and shade between the sprays and between branch systems: a street
# tree seen from 10-30 m is a mosaic of lit sprays, dark interior and sky gaps (KITTI
# sequence_1's crowns show 25-35 % sky inside their outline). Leaves spread evenly along the
# twigs instead made a closed green shell (18 % sky seen from the side, 27 % in sprays: tests/test_assets.py).
SPRAY_SPACING_M = 0.7      # sprays along a twig
SPRAY_RADIUS_M = 0.08      # a spray's leaf bunches around its centre (standard deviation)
LEAF_JITTER_M = 0.05       # a bunch's leaves around it


def _unit(v):
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def add_leaves(b: MeshBuilder, rng, points, outward, length, surfs, width=0.45, droop=0.0) -> None:
    """One leaf per point: a kite of ``length`` (per point or scalar) pointing away from
    the point, biased along ``outward``; its surface drawn from ``surfs``."""
    P = np.asarray(points, float).reshape(-1, 3)
    n = len(P)
    if n == 0:
        return
    ls = np.broadcast_to(np.asarray(length, float), (n,))[:, None]
    d = _unit(rng.normal(size=(n, 3)) + 0.9 * _unit(np.asarray(outward, float)) + [0, -droop, 0])
    nrm = rng.normal(size=(n, 3)) * 0.7 + [0, 1.0, 0]
    nrm = _unit(nrm - np.sum(nrm * d, axis=1, keepdims=True) * d)
    w = np.cross(d, nrm)
    fold = 0.12 * ls * nrm
    base, tip = P, P + ls * d
    left = P + 0.42 * ls * d + 0.5 * width * ls * w + fold
    right = P + 0.42 * ls * d - 0.5 * width * ls * w + fold
    V = np.stack([base, right, tip, left], axis=1).reshape(-1, 3)
    idx = (np.arange(n) * 4)[:, None]
    F = np.concatenate([idx + [0, 1, 2], idx + [0, 2, 3]])
    s = np.asarray(surfs)[rng.integers(len(surfs), size=n)]
    b.add(V, F, np.concatenate([s, s]))


class _Branches:
    """A branching skeleton: polylines with radii, grown recursively inside an envelope."""

    def __init__(self, rng, centre, radii):
        self.rng, self.c, self.r = rng, np.asarray(centre, float), np.asarray(radii, float)
        self.paths: list[tuple[np.ndarray, np.ndarray, int]] = []   # (points, radii, level)

    def inside(self, p) -> float:
        return float(np.sum(((p - self.c) / self.r) ** 2))

    def grow(self, p0, d, length, radius, level, max_level, children, segs=5, up=0.15):
        rng = self.rng
        pts, rad = [np.asarray(p0, float)], [radius]
        d = _unit(np.asarray(d, float))
        step = length / segs
        for i in range(segs):
            d = _unit(d + rng.normal(size=3) * 0.18 + [0, up, 0])
            q = pts[-1] + step * d
            if self.inside(q) > 1.0:       # bend back towards the crown
                d = _unit(d + 0.8 * _unit(self.c - q))
                q = pts[-1] + step * d
                if self.inside(q) > 1.0:   # and never leave it: the kind's size bounds the tree (culling boxes rely on it)
                    q = self.c + (q - self.c) / np.sqrt(self.inside(q))
            pts.append(q)
            rad.append(radius * (1 - 0.55 * (i + 1) / segs))
        pts, rad = np.array(pts), np.array(rad)
        self.paths.append((pts, rad, level))
        if level >= max_level:
            return
        n = children[level]
        golden = 2.39996
        phi0 = rng.uniform(0, 2 * np.pi)
        for k in range(n):
            t = rng.uniform(0.3, 0.95) if level > 0 else rng.uniform(0.0, 1.0)
            i = min(int(t * segs), segs - 1)
            f = t * segs - i
            q = pts[i] * (1 - f) + pts[i + 1] * f
            axis = _unit(pts[i + 1] - pts[i])
            ortho = _unit(cross3(axis, (0.3, 1.0, 0.1)))
            phi = phi0 + golden * k
            side = ortho * np.cos(phi) + cross3(axis, ortho) * np.sin(phi)
            ang = np.radians(rng.uniform(35, 65))
            cd = _unit(np.cos(ang) * axis + np.sin(ang) * side)
            scale = rng.uniform(0.45, 0.7) if level > 0 else rng.uniform(0.6, 0.9)
            self.grow(q, cd, length * scale * (1.15 - 0.5 * t if level == 0 else 1.0),
                      max(rad[i] * 0.55, 0.004), level + 1, max_level, children, max(segs - 1, 3), up * 0.8)


def _sprays(rng, path, t0: float, bunch_m: float, spray_m: float, spray_r: float) -> np.ndarray:
    """Leaf-bunch centres along a twig ``path`` from ``t0`` of its length to its tip: one per
    ``bunch_m`` of it, gathered in sprays ``spray_m`` apart (the bunches' spread ``spray_r``,
    a standard deviation): open gaps between sprays, as real crowns show them."""
    seg_len = np.linalg.norm(np.diff(path, axis=0), axis=1)
    tot = seg_len.sum()
    m = max(int(tot * (1 - t0) / bunch_m), 2)
    n_spray = max(int(tot * (1 - t0) / spray_m), 1)
    t = np.sort(rng.uniform(t0, 1.0, n_spray))
    cum = np.concatenate([[0], np.cumsum(seg_len)]) / tot
    c = np.stack([np.interp(t, cum, path[:, i]) for i in range(3)], axis=1)
    return c[rng.integers(n_spray, size=m)] + rng.normal(size=(m, 3)) * spray_r


def _bark_and_greens(b: MeshBuilder, rng, shades, yellowed) -> tuple:
    """A tree's bark surface and its leaves' greens: one green of the palette in ``shades``
    (brightness factors) and a yellower one (red x ``yellowed[0]``, blue x 0.8, brightness
    ``yellowed[1]``): leaves of one tree differ in age and light, not in species."""
    bark = b.surface("bark", pick(rng, palette.BARK))
    base = pick(rng, palette.LEAVES)
    greens = [b.surface("leaves", scaled(base, f)) for f in shades]
    greens.append(b.surface("leaves", scaled((base[0] * yellowed[0], base[1], base[2] * 0.8), yellowed[1])))
    return bark, greens


def _tube_sides(radius: float) -> int:
    return 10 if radius > 0.1 else 7 if radius > 0.04 else 5 if radius > 0.015 else 4


def tree(size, seed: int) -> MeshData:
    """A broadleaf tree: trunk, 3 levels of branches, leaf clusters along the outer twigs
    (~40-100 thousand leaves)."""
    rng, Wc, H, Dc, b = start(size, seed)
    bark, greens = _bark_and_greens(b, rng, (0.8, 1.0, 1.2), (1.4, 1.1))
    clear = H * rng.uniform(0.25, 0.4)
    crown_c = (0.0, clear + (H - clear) * 0.5, 0.0)
    crown_r = (Wc / 2, (H - clear) / 2, Dc / 2)
    sk = _Branches(rng, crown_c, crown_r)
    r0 = float(np.clip(0.012 * H + rng.uniform(0.0, 0.05), 0.05, 0.45))
    # trunk: from slightly below ground to the crown, then the leader up to ~0.9 H
    trunk = [np.array([0.0, -0.1, 0.0])]
    d = np.array([0.0, 1.0, 0.0])
    for i in range(6):
        d = _unit(d + rng.normal(size=3) * 0.05 * np.array([1, 0, 1]))
        trunk.append(trunk[-1] + d * (clear + 0.1) / 6)
    sk.paths.append((np.array(trunk), np.linspace(r0, r0 * 0.8, len(trunk)), 0))
    n_main = int(rng.integers(5, 9))
    sk.grow(trunk[-1], [0, 1, 0], (H - clear) * 0.85, r0 * 0.8, 0, 3, (n_main, 4, 3), segs=6, up=0.0)
    leaf_pts, leaf_out = [], []
    b.tubes([(pts, rad, _tube_sides(float(rad[0]))) for pts, rad, _ in sk.paths], bark, smooth=True)
    for pts, rad, level in sk.paths:
        if level >= 1:   # twigs on the outer parts of the main branches and everything finer
            # leaf bunches: one per 5 cm of twig
            q = _sprays(rng, pts, 0.3 if level >= 2 else 0.6, 0.05, SPRAY_SPACING_M, SPRAY_RADIUS_M)
            leaf_pts.append(q)
            leaf_out.append(q - np.asarray(crown_c))
    P = np.concatenate(leaf_pts)
    O = np.concatenate(leaf_out)
    reps = int(rng.integers(6, 9))     # a cluster of leaves around each twig point
    jitter = rng.normal(size=(len(P) * reps, 3)) * LEAF_JITTER_M
    pts = np.repeat(P, reps, axis=0) + jitter
    out = np.repeat(O, reps, axis=0) + jitter * 4
    ls = rng.uniform(0.09, 0.15) * rng.uniform(0.8, 1.2, len(pts))
    add_leaves(b, rng, pts, out, ls, greens, droop=0.3)
    return b.build()


# A young garden tree (a nursery's feathered ornamental tree - hornbeam, field maple, ornamental
# pear or cherry - planted in a front garden), as KITTI sequence_1's front gardens show them
# (full-size SGBM, frames 0-18: clusters every ~12 m 7.3-9 m right of the camera, 4.5-6 m tall,
# their crowns from ~1.5-2.5 m up; the images: a slim stem, short ascending laterals all the way
# up the leader, small leaves in loose sprays with the white wall showing between them - where
# that sequence's upper-right ORB keypoints lie): a leader to the top, laterals every 0.3-0.5 m
# from the clear stem up, each with twigs, leaves 5-8 cm (a street tree's are 9-15 cm) in sprays
# ~0.45 m apart along the twigs: 22-34 % of the crown's outline open seen from the side (seeds
# 0-3; the street trees' crowns in KITTI: 25-35 %, tests/test_assets.py).
GARDEN_TREE_SPRAY_M = 0.45     # sprays along a twig ...
GARDEN_TREE_SPRAY_R = 0.05     # ... their leaf bunches around their centre (standard deviation)
GARDEN_TREE_LEAF_M = (0.05, 0.08)


def garden_tree(size, seed: int) -> MeshData:
    """A young garden tree: a slim stem clear to 30-45 % of the height, laterals all the way up
    the leader (an ovoid crown of ``size``'s width and depth), twigs, small leaves in sprays."""
    rng, Wc, H, Dc, b = start(size, seed)
    bark, greens = _bark_and_greens(b, rng, (0.75, 0.95, 1.15), (1.3, 1.05))
    clear = H * rng.uniform(0.3, 0.45)
    crown_c = np.array([0.0, clear + (H - clear) * 0.48, 0.0])
    crown_r = np.array([Wc / 2, (H - clear) / 2 + 0.05, Dc / 2])
    sk = _Branches(rng, crown_c, crown_r)
    r0 = float(rng.uniform(0.025, 0.04))           # a stem of 16-25 cm girth
    ys = np.linspace(-0.1, H - 0.15, 12)
    lean = np.cumsum(rng.normal(size=(12, 2)) * 0.015, axis=0)
    leader = np.column_stack([lean[:, 0], ys, lean[:, 1]])
    sk.paths.append((leader, np.linspace(r0, 0.006, 12), 0))
    y, phi = clear, rng.uniform(0, 2 * np.pi)
    while y < H - 0.4:
        q = np.array([np.interp(y, ys, leader[:, 0]), y, np.interp(y, ys, leader[:, 2])])
        t = (y - crown_c[1]) / crown_r[1]
        reach = np.sqrt(max(1.0 - t * t, 0.05))      # the ovoid's half-width at this height, as a share
        for _ in range(int(rng.integers(1, 3))):
            phi += 2.39996 + rng.normal() * 0.3
            side = np.array([np.cos(phi), 0.0, np.sin(phi)])
            radius = np.hypot(np.cos(phi) * crown_r[0], np.sin(phi) * crown_r[2])
            ang = np.radians(rng.uniform(35, 60))      # ascending, from the vertical
            d = np.cos(ang) * np.array([0.0, 1.0, 0.0]) + np.sin(ang) * side
            length = radius * reach * rng.uniform(0.8, 1.1) / np.sin(ang)
            rad = max(r0 * (1 - y / H) * 0.6, 0.006)
            sk.grow(q, d, length, rad, 1, 3, (0, 3, 2), segs=4, up=0.1)
        y += rng.uniform(0.3, 0.5)
    b.tubes([(pts, rad, _tube_sides(float(rad[0]))) for pts, rad, _ in sk.paths], bark, smooth=True)
    leaf_pts, leaf_out = [], []
    for pts, rad, level in sk.paths:
        if level == 0 and pts[-1, 1] < H - 0.5:
            continue
        t0 = 0.85 if level == 0 else 0.35 if level == 1 else 0.1
        # leaf bunches: one per 3 cm of twig
        q = _sprays(rng, pts, t0, 0.03, GARDEN_TREE_SPRAY_M, GARDEN_TREE_SPRAY_R)
        leaf_pts.append(q)
        leaf_out.append(q - crown_c)
    P, O = np.concatenate(leaf_pts), np.concatenate(leaf_out)
    reps = int(rng.integers(4, 7))
    jitter = rng.normal(size=(len(P) * reps, 3)) * 0.04
    pts = np.repeat(P, reps, axis=0) + jitter
    inside = np.sum(((pts - crown_c) / (crown_r + 0.1)) ** 2, axis=1) <= 1.0
    pts, out = pts[inside], (np.repeat(O, reps, axis=0) + jitter * 4)[inside]
    ls = rng.uniform(*GARDEN_TREE_LEAF_M) * rng.uniform(0.8, 1.2, len(pts))
    add_leaves(b, rng, pts, out, ls, greens, droop=0.2)
    return b.build()


def conifer(size, seed: int) -> MeshData:
    """A spruce-like conifer: a straight trunk, whorls of drooping branches carrying flat
    needle sprays, a narrow cone."""
    rng, Wc, H, Dc, b = start(size, seed)
    bark = b.surface("bark", scaled(pick(rng, palette.BARK), 0.8))
    base_green = pick(rng, palette.NEEDLES)
    greens = [b.surface("leaves", scaled(base_green, f)) for f in (0.8, 1.0, 1.2)]
    clear = H * rng.uniform(0.05, 0.2)
    r0 = float(np.clip(0.015 * H, 0.06, 0.35))
    b.frustum(r0, 0.01, -0.1, H, 9, bark)
    y = clear
    branches, sprays, outs, lens = [], [], [], []
    while y < H - 0.3:
        frac = (H - y) / (H - clear)
        R = 0.5 * min(Wc, Dc) * frac ** 0.9
        n = int(rng.integers(5, 8))
        phi0 = rng.uniform(0, 2 * np.pi)
        for k in range(n):
            phi = phi0 + 2 * np.pi * k / n + rng.normal() * 0.2
            L = R * rng.uniform(0.85, 1.1)
            dirn = np.array([np.cos(phi), 0.0, np.sin(phi)])
            m = 5
            s = np.linspace(0, 1, m)
            pts = np.array([0, y, 0]) + np.outer(s * L, dirn) + np.outer(-0.25 * L * s ** 2 + 0.05 * L * s, [0, 1, 0])
            branches.append((pts, np.linspace(max(r0 * frac * 0.3, 0.008), 0.004, m), 4))
            cnt = max(int(L / 0.05), 2)
            t = rng.uniform(0.05, 1.0, cnt)
            q = np.array([0, y, 0]) + np.outer(t * L, dirn) + np.outer(-0.25 * L * t ** 2 + 0.05 * L * t, [0, 1, 0])
            q += rng.normal(size=q.shape) * 0.06
            sprays.append(q)
            outs.append(np.outer(np.ones(cnt), dirn) + [0, -0.3, 0])
            lens.append(rng.uniform(0.18, 0.3, cnt) * (0.6 + 0.4 * frac))
        y += rng.uniform(0.28, 0.45)
    b.tubes(branches, bark, smooth=True)
    P, O, Lp = np.concatenate(sprays), np.concatenate(outs), np.concatenate(lens)
    reps = 3
    add_leaves(b, rng, np.repeat(P, reps, axis=0) + rng.normal(size=(len(P) * reps, 3)) * 0.05,
               np.repeat(O, reps, axis=0), np.repeat(Lp, reps), greens, width=0.55, droop=0.5)
    # the leader's tip
    add_leaves(b, rng, np.array([0, H - 0.3, 0]) + rng.normal(size=(40, 3)) * [0.08, 0.15, 0.08],
               np.tile([0, 1.0, 0], (40, 1)), 0.2, greens, width=0.5)
    return b.build()


def bush(size, seed: int) -> MeshData:
    """A shrub: stems fanning out from the ground, dense leaf clusters in an ellipsoid."""
    rng, Wc, H, Dc, b = start(size, seed)
    bark = b.surface("bark", pick(rng, palette.BARK))
    base_green = pick(rng, palette.LEAVES)
    greens = [b.surface("leaves", scaled(base_green, f)) for f in (0.7, 0.85, 1.0, 1.2)]
    c = np.array([0.0, H / 2, 0.0])
    r = np.array([Wc / 2, H / 2, Dc / 2])
    stems = []
    for k in range(int(rng.integers(5, 10))):
        phi = rng.uniform(0, 2 * np.pi)
        top = c + r * 0.7 * np.array([np.cos(phi) * rng.uniform(0.3, 1), rng.uniform(-0.1, 0.8), np.sin(phi) * rng.uniform(0.3, 1)])
        pts = np.linspace([0, -0.05, 0], top, 4) + np.outer(np.sin(np.linspace(0, np.pi, 4)), rng.normal(size=3) * 0.08)
        stems.append((pts, np.linspace(0.025, 0.008, 4), 5))
    b.tubes(stems, bark)
    n = int(2200 * Wc * H * Dc / 1.0 ** 3 * rng.uniform(0.8, 1.2)) + 200
    u = _unit(rng.normal(size=(n, 3)))
    rad = rng.uniform(0.55, 1.0, n) ** 0.5
    P = c + u * rad[:, None] * r
    P[:, 1] = np.maximum(P[:, 1], 0.05)
    add_leaves(b, rng, P, u, rng.uniform(0.07, 0.12, n), greens, droop=0.2)
    return b.build()


def hedge(size, seed: int) -> MeshData:
    """A clipped hedge: a dark leafy core box wrapped in a layer of leaves."""
    rng, W, H, D, b = start(size, seed)
    base_green = pick(rng, palette.LEAVES)
    core = b.surface("leaves", scaled(base_green, 0.4))
    greens = [b.surface("leaves", scaled(base_green, f)) for f in (0.7, 0.85, 1.0, 1.2)]
    b.box((-W / 2 + 0.08, 0.0, -D / 2 + 0.08), (W / 2 - 0.08, H - 0.08, D / 2 - 0.08), core)
    area = np.array([W * H, W * H, D * H, D * H, W * D])
    n_tot = int(700 * area.sum())
    face = rng.choice(5, size=n_tot, p=area / area.sum())
    u, v = rng.random(n_tot), rng.random(n_tot)
    P = np.zeros((n_tot, 3))
    O = np.zeros((n_tot, 3))
    off = rng.uniform(-0.06, 0.06, n_tot)
    for f, (axis, sign) in enumerate([(2, 1), (2, -1), (0, 1), (0, -1), (1, 1)]):
        m = face == f
        if axis == 2:
            P[m] = np.column_stack([(u[m] - 0.5) * W, v[m] * H, np.full(m.sum(), sign * D / 2)])
        elif axis == 0:
            P[m] = np.column_stack([np.full(m.sum(), sign * W / 2), v[m] * H, (u[m] - 0.5) * D])
        else:
            P[m] = np.column_stack([(u[m] - 0.5) * W, np.full(m.sum(), H), (v[m] - 0.5) * D])
        O[m, axis] = sign
        P[m, axis] += sign * (off[m] - 0.03)
    P[:, 1] = np.clip(P[:, 1], 0.03, None)
    add_leaves(b, rng, P, O, rng.uniform(0.06, 0.1, n_tot), greens, droop=0.1)
    return b.build()
