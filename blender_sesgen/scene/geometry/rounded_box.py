"""Mesh geometry computed in numpy (pure): the rounded (bevelled) box of ``CUBOID ... bevel r``.

A box with edges rounded to radius r is the set of points within r of a smaller box
(half sizes h - r): flat faces, quarter cylinders along the edges and sphere octants at
the corners. :func:`rounded_box` tessellates it with every vertex *on* that surface, the
arcs cut into equal angles, and returns the exact surface normal at each vertex (the
surface is smooth, so per-vertex normals shade it without facets). Because the bevel is
real geometry, depth and ids follow it; the tessellation's deviation from the ideal
surface is r(1 - cos(step / 2)) (the builder picks the step from its depth tolerance).
"""
from __future__ import annotations

import math

import numpy as np


def rounded_box(size, radius: float, segments_per_quarter: int) -> tuple[np.ndarray, list, np.ndarray]:
    """(vertices (n, 3), quad faces (outward), unit normals (n, 3)) of a box of full edge
    lengths ``size`` centred at the origin, edges rounded to ``radius`` (0 < radius <=
    min(size) / 2), each 90 deg arc in ``segments_per_quarter`` (even, >= 2) steps."""
    h = np.asarray(size, dtype=float) / 2.0
    r = float(radius)
    if not 0.0 < r <= h.min() + 1e-12:
        raise ValueError(f"bevel radius {r} must lie in (0, {h.min():g}] (half the smallest edge)")
    m = max(1, (int(segments_per_quarter) + 1) // 2)          # steps per 45 deg on each face
    inner = np.maximum(h - r, 0.0)
    t = np.tan(np.linspace(0.0, math.pi / 4, m + 1))          # 0 .. 1, equal angles
    verts: list = []
    index: dict = {}
    faces: list = []

    def vertex(p: np.ndarray) -> int:
        c = np.clip(p, -inner, inner)
        d = p - c
        n = d / np.linalg.norm(d)
        q = c + r * n                                         # onto the rounded surface
        key = tuple(np.round(q / max(r, 1e-12) * 1e6).astype(np.int64))
        if key not in index:
            index[key] = len(verts)
            verts.append((q, n))
        return index[key]

    for axis in range(3):
        for sign in (-1.0, 1.0):
            a, b = [i for i in range(3) if i != axis]

            def coords(i):  # the grid lines along one in-face axis: arc, flat, arc
                arc = inner[i] + r * t
                return np.unique(np.concatenate([-arc[::-1], arc]))
            ua, ub = coords(a), coords(b)
            grid = np.empty((len(ua), len(ub)), dtype=np.int64)
            for i, x in enumerate(ua):
                for j, y in enumerate(ub):
                    p = np.zeros(3)
                    p[axis], p[a], p[b] = sign * h[axis], x, y
                    grid[i, j] = vertex(p)
            for i in range(len(ua) - 1):
                for j in range(len(ub) - 1):
                    quad = [grid[i, j], grid[i + 1, j], grid[i + 1, j + 1], grid[i, j + 1]]
                    if len(set(quad)) < 3:
                        continue
                    # outward: (a, b, axis) right-handed for +, reversed for -
                    right_handed = (b - a) % 3 == 1
                    if (sign > 0) != right_handed:
                        quad = quad[::-1]
                    faces.append(_dedupe(quad))
    V = np.array([q for q, _ in verts])
    N = np.array([n for _, n in verts])
    return V, faces, N


def _dedupe(face: list) -> tuple:
    out = []
    for v in face:
        if not out or out[-1] != v:
            out.append(int(v))
    if len(out) > 1 and out[0] == out[-1]:
        out.pop()
    return tuple(out)
