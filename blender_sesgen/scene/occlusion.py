"""Rays against triangles (pure): what shades a glowing pane (``blender/glazing.py``).

``blocked`` is the Moller-Trumbore test of every ray against every triangle (the reference).
``blocked_grid`` answers the same question for the rays of a set of points along a set of
directions (a pane's sky and sun visibility), the same bit for bit at a fraction of the tests:
per direction, a triangle whose footprint seen along it (its box in a plane across the
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


def _across(dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (K, 3) each across unit ``dirs`` (K, 3), and across each other."""
    helper = np.where((np.abs(dirs[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    s = np.cross(dirs, helper)
    s /= np.linalg.norm(s, axis=1, keepdims=True)
    return s, np.cross(dirs, s)


def candidate_pairs(points: np.ndarray, dirs: np.ndarray, tris: np.ndarray, pad: float = PAD_M,
                    chunk: int = 1 << 22) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(k, p, t) index arrays of the (direction, point, triangle) triples whose ray (from
    point p along direction k) can meet triangle t: the point inside the triangle's box in a
    plane across the direction (widened by ``pad``) and not ahead of all its corners; a
    triangle within ``GRAZING`` of the direction's line (cosine to its normal) or without an
    area is kept for every point (there Moller-Trumbore's rounding can exceed ``pad``)."""
    K, P, T = len(dirs), len(points), len(tris)
    s, r = _across(dirs)
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    size = np.linalg.norm(n, axis=1)
    n = n / np.where(size > 0, size, 1.0)[:, None]
    flat = tris.reshape(3 * T, 3)
    out = ([], [], [])
    step = max(1, chunk // max(1, P * T))
    for k0 in range(0, K, step):
        ks = slice(k0, k0 + step)
        axes = np.concatenate([s[ks], r[ks], dirs[ks]])                    # (3k, 3): across, across, along
        c = (flat @ axes.T).reshape(T, 3, 3, -1)                              # (T, corner, axis, k)
        lo = np.minimum(np.minimum(c[:, 0], c[:, 1]), c[:, 2]).transpose(1, 2, 0)   # (axis, k, T)
        hi = np.maximum(np.maximum(c[:, 0], c[:, 1]), c[:, 2]).transpose(1, 2, 0)
        x = (points @ axes.T).reshape(P, 3, -1).transpose(1, 2, 0)[..., None]       # (axis, k, P, 1)
        # (direction, triangle) pairs whose box meets the points' box, then each point
        xlo, xhi = x.min(axis=2), x.max(axis=2)                               # (axis, k, 1)
        keep = (xlo[0] <= hi[0] + pad) & (xhi[0] >= lo[0] - pad) & (xlo[1] <= hi[1] + pad) \
            & (xhi[1] >= lo[1] - pad) & (xlo[2] < hi[2] + pad)
        keep |= (np.abs(dirs[ks] @ n.T) < GRAZING) | (size <= 0)[None]        # (k, T)
        kk, tt = np.nonzero(keep)
        xs = x[..., 0][:, kk]                                                  # (axis, N, P)
        lo, hi = lo[:, kk, tt][..., None] - pad, hi[:, kk, tt][..., None] + pad  # (axis, N, 1)
        each = (xs[0] >= lo[0]) & (xs[0] <= hi[0]) & (xs[1] >= lo[1]) & (xs[1] <= hi[1]) & (xs[2] < hi[2])
        each |= ((np.abs(np.einsum("nx,nx->n", dirs[ks][kk], n[tt])) < GRAZING) | (size[tt] <= 0))[:, None]
        m, p = np.nonzero(each)
        out[0].append(kk[m] + k0)
        out[1].append(p)
        out[2].append(tt[m])
    return tuple(np.concatenate(x) if x else np.zeros(0, dtype=np.intp) for x in out)


def blocked_grid(points: np.ndarray, dirs: np.ndarray, tris: np.ndarray, stats: dict | None = None) -> np.ndarray:
    """(K, P): whether the ray from each of ``points`` (P, 3) along each unit direction of
    ``dirs`` (K, 3) hits one of ``tris`` (T, 3, 3) ahead of it; equal to ``blocked`` of every
    (point, direction) ray, testing only ``candidate_pairs``. ``stats``: gets ``tests`` (the
    ray-triangle tests made) and ``all`` (K P T, the reference's)."""
    points, dirs = np.asarray(points, dtype=float), np.asarray(dirs, dtype=float)
    out = np.zeros((len(dirs), len(points)), dtype=bool)
    k = p = np.zeros(0, dtype=np.intp)
    if len(tris):
        k, p, t = candidate_pairs(points, dirs, tris)
        a, e1, e2 = (x[:, t] for x in _edges(tris))
        hit = _hits(points[p].T, dirs[k].T, a, e1, e2)
        out[k[hit], p[hit]] = True
    if stats is not None:
        stats["tests"] = stats.get("tests", 0) + len(k)
        stats["all"] = stats.get("all", 0) + len(dirs) * len(points) * len(tris)
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
