"""Rays against triangles (pure): what shades a glowing pane (``blender/glazing.py``).

``blocked`` is the Moller-Trumbore test of every ray against every triangle (the reference).
``blocked_grid`` answers the same question for the rays of a set of points along a set of
directions (a pane's sky and sun visibility), the same bit for bit at a fraction of the tests:
per direction, a triangle whose footprint seen along it (its box on a plane across the
direction, widened by ``PAD_M``) misses a point, or which lies wholly behind the point, cannot
be hit by that point's ray, so only the pairs left are tested, with the same arithmetic.
``shading_triangles`` keeps the triangles that can stand before a face within reach.
"""
from __future__ import annotations

import numpy as np

# what a ray's footprint test leaves around a triangle (m): far above Moller-Trumbore's
# rounding (~1e-13 m at the scenes' ~100 m), far below a texel
PAD_M = 1e-6
# ...so long as the ray is not within 1e-6 (cosine) of the triangle's plane: its rounding there
# grows as 1 / cosine (1e-15 m / cosine at ~10 m)
GRAZING = 1e-6


def _cross(x, y):
    return (x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0])


def _dot(x, y):
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


def _hits(o, d, a, e1, e2):
    """Moller-Trumbore, component by component (each argument a tuple or (3, ...) array,
    broadcast): whether the ray o + t d (t > 1e-6) meets the triangle (a, a + e1, a + e2)."""
    p = _cross(d, e2)
    det = _dot(p, e1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        tv = (o[0] - a[0], o[1] - a[1], o[2] - a[2])
        u = _dot(tv, p) * inv
        q = _cross(tv, e1)
        v = _dot(d, q) * inv
        t = _dot(q, e2) * inv
        return (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)


def _edges(tris: np.ndarray):
    """(a, e1, e2) of triangles (T, 3, 3), each (3, T)."""
    return tris[:, 0].T, (tris[:, 1] - tris[:, 0]).T, (tris[:, 2] - tris[:, 0]).T


def blocked(origins: np.ndarray, dirs: np.ndarray, tris: np.ndarray, chunk: int = 1 << 18) -> np.ndarray:
    """Whether each ray (origins (R, 3), unit dirs (R, 3)) hits one of ``tris`` (T, 3, 3) ahead
    of it: every ray against every triangle."""
    out = np.zeros(len(origins), dtype=bool)
    if not len(tris):
        return out
    a, e1, e2 = (x[:, None, :] for x in _edges(tris))                     # (3, 1, T)
    step = max(1, chunk // len(tris))
    for i in range(0, len(origins), step):
        o, d = origins[i:i + step].T[:, :, None], dirs[i:i + step].T[:, :, None]   # (3, R, 1)
        out[i:i + step] = _hits(o, d, a, e1, e2).any(axis=1)
    return out


def blocked_grid(points: np.ndarray, dirs: np.ndarray, tris: np.ndarray, stats: dict | None = None,
                 pad: float = PAD_M, chunk: int = 1 << 21) -> np.ndarray:
    """(K, P): whether the ray from each of ``points`` (P, 3) along each unit direction of
    ``dirs`` (K, 3) hits one of ``tris`` (T, 3, 3) ahead of it; equal to ``blocked`` of every
    (point, direction) ray bit for bit. Only the pairs that can meet are tested: per direction,
    the triangles' corners sheared along it onto the plane across its largest component (a
    ray's points all fall on its origin's spot there) give each triangle's box; a point
    outside a box widened by ``pad``, or ahead of all the triangle's corners along the
    direction, cannot hit it (first for the points' box, then point by point); a triangle
    within ``GRAZING`` of the direction's line (cosine to its normal) or without an area is
    tested for every point (there Moller-Trumbore's rounding can exceed ``pad``). Moller-
    Trumbore's terms of a direction and a triangle alone are computed once per pair of them,
    with the same arithmetic. ``stats``: gets ``tests`` (the ray-triangle tests made) and
    ``all`` (K P T, the reference's)."""
    points, dirs = np.asarray(points, dtype=float), np.asarray(dirs, dtype=float)
    K, P, T = len(dirs), len(points), len(tris)
    out = np.zeros((K, P), dtype=bool)
    tests = 0
    if not (T and P and K):
        dirs = dirs[:0]
    a, e1, e2 = _edges(tris)                                                  # (3, T)
    n = np.cross(e1.T, e2.T)
    size = np.linalg.norm(n, axis=1)
    n = n / np.where(size > 0, size, 1.0)[:, None]
    c = tris.transpose(2, 1, 0)                                               # (axis, corner, T)
    major = np.abs(dirs).argmax(axis=1)
    step = max(1, chunk // max(1, P * T))
    for z in range(3):                     # the directions by their largest component
        x, y = (z + 1) % 3, (z + 2) % 3
        group = np.flatnonzero(major == z)
        for k0 in range(0, len(group), step):
            ks = group[k0:k0 + step]
            d = dirs[ks]
            sx, sy = (d[:, x] / d[:, z])[:, None], (d[:, y] / d[:, z])[:, None]      # (k, 1)
            # the corners sheared along each direction (k, T), and the points (k, P)
            X = [c[x, i] - sx * c[z, i] for i in range(3)]
            Y = [c[y, i] - sy * c[z, i] for i in range(3)]
            pX, pY = points[:, x] - sx * points[:, z], points[:, y] - sy * points[:, z]
            box = (np.minimum(np.minimum(X[0], X[1]), X[2]) - pad, np.maximum(np.maximum(X[0], X[1]), X[2]) + pad,
                   np.minimum(np.minimum(Y[0], Y[1]), Y[2]) - pad, np.maximum(np.maximum(Y[0], Y[1]), Y[2]) + pad)
            along = d @ points.T                                                           # (k, P)
            far = np.maximum(np.maximum(d @ c[:, 0], d @ c[:, 1]), d @ c[:, 2]) + pad       # (k, T)
            grazing = (np.abs(d @ n.T) < GRAZING) | (size <= 0)[None]
            # the (direction, triangle) pairs whose box meets the points' box...
            keep = (pX.max(axis=1)[:, None] >= box[0]) & (pX.min(axis=1)[:, None] <= box[1]) \
                & (pY.max(axis=1)[:, None] >= box[2]) & (pY.min(axis=1)[:, None] <= box[3]) \
                & (along.min(axis=1)[:, None] < far)
            kk, tt = np.nonzero(keep | grazing)
            # ... then point by point
            each = (pX[kk] >= box[0][kk, tt, None]) & (pX[kk] <= box[1][kk, tt, None]) \
                & (pY[kk] >= box[2][kk, tt, None]) & (pY[kk] <= box[3][kk, tt, None]) \
                & (along[kk] < far[kk, tt, None])
            each |= grazing[kk, tt][:, None]
            m, p = np.nonzero(each)
            tests += len(m)
            # Moller-Trumbore (``_hits``), its direction x triangle terms once per (kk, tt)
            dd = d[kk].T
            pv = _cross(dd, e2[:, tt])
            det = _dot(pv, e1[:, tt])
            with np.errstate(divide="ignore", invalid="ignore"):
                inv = (1.0 / det)[m]
                t_, o = tt[m], points[p].T
                tv = (o[0] - a[0, t_], o[1] - a[1, t_], o[2] - a[2, t_])
                u = _dot(tv, tuple(v[m] for v in pv)) * inv
                q = _cross(tv, e1[:, t_])
                v = _dot(dd[:, m], q) * inv
                t = _dot(q, e2[:, t_]) * inv
                hit = (np.abs(det[m]) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)
            out[ks[kk[m[hit]]], p[hit]] = True
    if stats is not None:
        stats["tests"] = stats.get("tests", 0) + tests
        stats["all"] = stats.get("all", 0) + K * P * T
    return out


def shading_triangles(tris: np.ndarray, centre: np.ndarray, normal: np.ndarray, radius: float) -> np.ndarray:
    """The triangles (T, 3, 3) that can shade a face through ``centre`` with outward unit
    ``normal`` from within ``radius`` of it: a corner on its outer side, and their bounding
    sphere (about the corners' mean) reaching into the ball of ``radius``."""
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    ahead = ((tris - centre) @ normal).max(axis=1) > 0
    mid = tris.mean(axis=1)
    near = np.linalg.norm(mid - centre, axis=1) - np.linalg.norm(tris - mid[:, None], axis=2).max(axis=1) < radius
    return tris[ahead & near]
