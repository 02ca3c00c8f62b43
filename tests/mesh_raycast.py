"""Ray casting against triangle soups (numpy only): the oracle for procedural assets.

Independent of Blender: rays from an OpenCV pinhole or any origins/directions, closest
intersections in float64 (each triangle's plane and barycentric dual vectors, precomputed per
mesh: matrix products over rays x triangles), with a per-part bounding-box cull.
"""
from __future__ import annotations

import numpy as np


def triangle_planes(tris: np.ndarray):
    """What the ray test needs of triangles (m,3,3), once per mesh: each one's normal n = e1 x e2,
    n.a, and the two dual vectors U = (e2 x n) / |n|^2, V = (n x e1) / |n|^2 whose dot products
    with p - a are the barycentric u, v of a point p of its plane, with U.a and V.a (a degenerate
    triangle: n = 0, never hit)."""
    a = tris[:, 0]
    e1, e2 = tris[:, 1] - a, tris[:, 2] - a
    n = np.cross(e1, e2)
    with np.errstate(divide="ignore", invalid="ignore"):
        nn = (n * n).sum(1)[:, None]
        U, V = np.cross(e2, n) / nn, np.cross(n, e1) / nn
    return n, (n * a).sum(1), U, (U * a).sum(1), V, (V * a).sum(1)


def rays_hit_planes(o: np.ndarray, d: np.ndarray, planes, chunk: int = 400_000):
    """Closest positive hit of rays (o (n,3), d (n,3)) with triangles given as ``triangle_planes``:
    (t (n,) with inf for a miss, index of the triangle (n,) with -1 for a miss). The ray meets
    a triangle's plane at t = (n.a - n.o) / n.d, at barycentrics u = U.o - U.a + t U.d (and v
    alike): a few (rays x triangles) matrix products instead of Moller-Trumbore's crosses per pair;
    the conditions are Moller-Trumbore's (|n.d| = |det| > 1e-15, u, v >= 0, u + v <= 1, t > 1e-9)."""
    N, Na, U, Ua, V, Va = planes
    n, m = len(o), len(N)
    t_best = np.full(n, np.inf)
    i_best = np.full(n, -1, dtype=np.int64)
    if m == 0 or n == 0:
        return t_best, i_best
    step = max(1, chunk // n)
    for s in range(0, m, step):
        sl = slice(s, s + step)
        dn = d @ N[sl].T
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t = (Na[sl] - o @ N[sl].T) / dn
            u = (o @ U[sl].T - Ua[sl]) + t * (d @ U[sl].T)
            v = (o @ V[sl].T - Va[sl]) + t * (d @ V[sl].T)
            ok = (np.abs(dn) > 1e-15) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-9)
        t = np.where(ok, t, np.inf)
        k = np.argmin(t, axis=1)
        tk = t[np.arange(n), k]
        better = tk < t_best
        t_best[better] = tk[better]
        i_best[better] = k[better] + s
    return t_best, i_best


def rays_hit_triangles(o: np.ndarray, d: np.ndarray, tris: np.ndarray):
    """Closest positive hit of rays (o (n,3), d (n,3)) with triangles (m,3,3):
    (t (n,) with inf for a miss, index of the triangle (n,) with -1 for a miss)."""
    return rays_hit_planes(np.asarray(o, float), np.asarray(d, float), triangle_planes(np.asarray(tris, float)))


def box_hit(o, d, lo, hi) -> np.ndarray:
    """Whether each ray meets the axis-aligned box [lo, hi] (slab test)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - o) / d, (hi - o) / d
    tn = np.nanmax(np.minimum(t1, t2), axis=1)
    tf = np.nanmin(np.maximum(t1, t2), axis=1)
    return (tf >= np.maximum(tn, 0.0))


def _leaves(tris: np.ndarray, leaf: int):
    """Split triangles by median cuts along the longest axis until each part has at most
    ``leaf`` of them: a flat list of (triangles, lo, hi) - a one-level bounding-box tree.
    (Index arrays and a partition, not a sort, per cut: the same parts, ties at the median aside.)"""
    if len(tris) <= leaf:
        flat = tris.reshape(-1, 3)
        return [(tris, flat.min(0) - 1e-9, flat.max(0) + 1e-9)]
    centre, t_lo, t_hi = tris.mean(axis=1), tris.min(axis=1), tris.max(axis=1)
    out, stack = [], [np.arange(len(tris))]
    while stack:
        idx = stack.pop()
        lo, hi = t_lo[idx].min(0) - 1e-9, t_hi[idx].max(0) + 1e-9
        if len(idx) <= leaf:
            out.append((tris[idx], lo, hi))
            continue
        axis = int(np.argmax(hi - lo))
        half = len(idx) // 2
        order = np.argpartition(centre[idx, axis], half)
        stack += [idx[order[:half]], idx[order[half:]]]
    return out


class TriangleScene:
    """Meshes in world coordinates with ids; ``cast`` gives the closest hit's distance and id."""

    def __init__(self, leaf: int = 256):
        self.leaf = leaf
        self.parts: list[tuple] = []   # (id, (centre, triangle_planes about it), lo, hi)
        self._boxes = None                                                      # (LO, HI) of the parts

    def add(self, obj_id: int, vertices: np.ndarray, faces: np.ndarray, T_world: np.ndarray = None) -> None:
        V = np.asarray(vertices, float)
        if T_world is not None:
            V = V @ T_world[:3, :3].T + T_world[:3, 3]
        for tris, lo, hi in _leaves(V[np.asarray(faces)], self.leaf):
            c = (lo + hi) / 2     # the part's planes about its centre: small numbers far from the origin
            self.parts.append((int(obj_id), (c, triangle_planes(tris - c)), lo, hi))
        self._boxes = None

    def cast(self, o, d, block: int = 4_000_000):
        """Closest hit (distance, id; inf and 0 for a miss) of each ray; any number of rays,
        in blocks of at most ``block`` ray-part box tests."""
        o, d = np.asarray(o, float), np.asarray(d, float)
        if self._boxes is None and self.parts:
            self._boxes = (np.array([p[2] for p in self.parts]), np.array([p[3] for p in self.parts]))
        step = max(1, block // max(1, len(self.parts)))
        if len(o) <= step:
            return self._cast(o, d)
        hits = [self._cast(o[s:s + step], d[s:s + step]) for s in range(0, len(o), step)]
        return np.concatenate([h[0] for h in hits]), np.concatenate([h[1] for h in hits])

    def _cast(self, o, d):
        t_best = np.full(len(o), np.inf)
        id_best = np.zeros(len(o), dtype=np.int64)
        if not self.parts:
            return t_best, id_best
        LO, HI = self._boxes
        # the slab test per axis on (parts, rays) arrays (a part's row contiguous); an axis whose
        # slab bound is NaN (a ray parallel to it, its origin on the plane) bounds nothing
        tn, tf = np.full((len(LO), len(o)), -np.inf), np.full((len(LO), len(o)), np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            for ax in range(3):
                t1 = (LO[:, ax, None] - o[None, :, ax]) / d[None, :, ax]
                t2 = (HI[:, ax, None] - o[None, :, ax]) / d[None, :, ax]
                np.fmax(tn, np.minimum(t1, t2), out=tn)
                np.fmin(tf, np.maximum(t1, t2), out=tf)
        meets = tf >= np.maximum(tn, 0.0)                          # (parts, rays)
        # nearest parts first: once a ray has hit something, the parts behind it are skipped
        entry = np.where(meets, np.maximum(tn, 0.0), np.inf).min(axis=1)
        order = np.argsort(entry, kind="stable")
        for j in order[np.isfinite(entry[order])]:
            sel = np.flatnonzero(meets[j] & (tn[j] < t_best))
            if len(sel) == 0:
                continue
            obj_id, (c, planes), _, _ = self.parts[j]
            t, _ = rays_hit_planes(o[sel] - c, d[sel], planes)
            better = t < t_best[sel]
            t_best[sel[better]] = t[better]
            id_best[sel[better]] = obj_id
        return t_best, id_best


def pinhole_rays(K: np.ndarray, T_world_cam: np.ndarray, pixels: np.ndarray):
    """World origins, unit directions and the cosine to the optical axis (planar depth =
    distance * cosine) of rays through pixel centres ``pixels`` (n, 2) of an OpenCV camera."""
    uv1 = np.column_stack([pixels, np.ones(len(pixels))])
    r_cam = uv1 @ np.linalg.inv(K).T
    norm = np.linalg.norm(r_cam, axis=1)
    d = (r_cam / norm[:, None]) @ T_world_cam[:3, :3].T
    o = np.broadcast_to(T_world_cam[:3, 3], d.shape)
    return np.array(o), d, 1.0 / norm
