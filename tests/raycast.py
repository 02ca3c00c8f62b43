"""An independent analytic ray caster: the oracle of the render tests (numpy only).

It knows nothing of Blender or of blender_sesgen's pose code: primitives are given in the
SES world (Y up) by their defining numbers, rays come from an OpenCV pinhole (K, T_world_cam),
and every intersection is closed form in float64:
- quad: plane through the 4 vertices, inside test on the two triangles (0,1,2), (0,2,3);
- box: slab test in the box's own frame (R from XYZ Euler degrees, R = Rz Ry Rx);
- sphere: the quadratic;
- cylinder (axis along local Y): the quadratic on x,z plus the two caps;
- rounded box (CUBOID bevel): the union of 3 slabs, 12 edge cylinders and 8 corner spheres.
Depth is planar z in the camera frame (what Cycles' Depth pass holds); misses are inf.

Moving objects: ``Moved(prim, M)`` is ``prim`` carried by the rigid motion M (4x4, world to
world): a ray is taken into the primitive's original frame by M⁻¹, intersected there, and
its parameter t is the same. ``hit_point`` gives the world point and id a pixel centre sees.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def euler_xyz_deg(rx, ry, rz) -> np.ndarray:
    ax, ay, az = np.radians([rx, ry, rz])
    Rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    Ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    Rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


@dataclass
class QuadP:
    id: int
    vertices: np.ndarray  # (4, 3)


@dataclass
class BoxP:
    id: int
    centre: np.ndarray
    rotation_deg: tuple
    size: np.ndarray


@dataclass
class SphereP:
    id: int
    centre: np.ndarray
    radius: float


@dataclass
class CylinderP:
    id: int
    centre: np.ndarray
    rotation_deg: tuple
    radius: float
    height: float


@dataclass
class Moved:
    """``prim`` moved by the rigid world-to-world motion ``M`` (4x4)."""
    prim: object
    M: np.ndarray

    @property
    def id(self):
        return self.prim.id


def _tri_hit(o, d, a, b, c):
    """Moller-Trumbore for many rays (o (3,), d (n,3)) against one triangle: t or inf."""
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = p @ e1
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - a
        u = (p @ s) * inv
        q = np.cross(s, e1)
        v = (d @ q) * inv
        t = (q @ e2) * inv
    ok = (np.abs(det) > 1e-15) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.where(ok, t, np.inf)


def hit_t(prim, o, d):
    """Ray parameter t (ray o + t d) of the first hit, inf if none. d: (n, 3)."""
    if isinstance(prim, RoundedBoxP):
        return _rounded_box_t(prim, o, d)
    if isinstance(prim, Moved):
        M = np.asarray(prim.M, dtype=float)
        R, t = M[:3, :3], M[:3, 3]
        return hit_t(prim.prim, R.T @ (np.asarray(o, dtype=float) - t), d @ R)  # rows: R^T d
    if isinstance(prim, QuadP):
        V = np.asarray(prim.vertices, dtype=float)
        return np.minimum(_tri_hit(o, d, V[0], V[1], V[2]), _tri_hit(o, d, V[0], V[2], V[3]))
    if isinstance(prim, SphereP):
        oc = o - prim.centre
        a = np.einsum("ij,ij->i", d, d)
        b = 2 * d @ oc
        c = oc @ oc - prim.radius**2
        disc = b * b - 4 * a * c
        sq = np.sqrt(np.where(disc >= 0, disc, 0))
        t1 = (-b - sq) / (2 * a)
        t2 = (-b + sq) / (2 * a)
        t = np.where(t1 > 0, t1, np.where(t2 > 0, t2, np.inf))
        return np.where(disc >= 0, t, np.inf)
    R = euler_xyz_deg(*prim.rotation_deg)
    ol = R.T @ (o - prim.centre)
    dl = d @ R  # rows: R^T d
    if isinstance(prim, BoxP):
        h = np.asarray(prim.size, dtype=float) / 2
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-h - ol) / dl
            t2 = (h - ol) / dl
        tmin = np.nanmax(np.minimum(t1, t2), axis=1)
        tmax = np.nanmin(np.maximum(t1, t2), axis=1)
        return np.where((tmax >= tmin) & (tmax > 0), np.where(tmin > 0, tmin, tmax), np.inf)
    if isinstance(prim, CylinderP):
        r, h2 = prim.radius, prim.height / 2
        a = dl[:, 0] ** 2 + dl[:, 2] ** 2
        b = 2 * (ol[0] * dl[:, 0] + ol[2] * dl[:, 2])
        c = ol[0] ** 2 + ol[2] ** 2 - r * r
        disc = b * b - 4 * a * c
        sq = np.sqrt(np.where(disc >= 0, disc, 0))
        best = np.full(len(d), np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            for t in ((-b - sq) / (2 * a), (-b + sq) / (2 * a)):
                y = ol[1] + t * dl[:, 1]
                ok = (disc >= 0) & (t > 0) & (np.abs(y) <= h2)
                best = np.where(ok & (t < best), t, best)
            for yc in (-h2, h2):
                t = (yc - ol[1]) / dl[:, 1]
                x = ol[0] + t * dl[:, 0]
                z = ol[2] + t * dl[:, 2]
                ok = (t > 0) & (x * x + z * z <= r * r)
                best = np.where(ok & (t < best), t, best)
        return best
    raise TypeError(prim)


def _bounding_sphere(prim) -> tuple[np.ndarray, float]:
    """A sphere holding the whole primitive (centre, radius)."""
    if isinstance(prim, Moved):
        c, r = _bounding_sphere(prim.prim)
        M = np.asarray(prim.M, dtype=float)
        return M[:3, :3] @ c + M[:3, 3], r
    if isinstance(prim, QuadP):
        V = np.asarray(prim.vertices, dtype=float)
        c = V.mean(axis=0)
        return c, float(np.linalg.norm(V - c, axis=1).max())
    if isinstance(prim, SphereP):
        return np.asarray(prim.centre, dtype=float), float(prim.radius)
    if isinstance(prim, CylinderP):
        return np.asarray(prim.centre, dtype=float), float(np.hypot(prim.radius, prim.height / 2))
    return np.asarray(prim.centre, dtype=float), float(np.linalg.norm(prim.size) / 2)   # (rounded) box


def hit_t_bounded(prim, o, d):
    """``hit_t`` computed only for the rays that meet the primitive's bounding sphere (the
    others cannot hit it: inf): the same values, for a fraction of the work on small objects."""
    c, r = _bounding_sphere(prim)
    oc = c - np.asarray(o, dtype=float)
    dd = np.einsum("ij,ij->i", d, d)
    along = d @ oc
    dist2 = np.where(along > 0, oc @ oc - along * along / dd, oc @ oc)   # from the half-line
    near = dist2 <= (r * (1 + 1e-6) + 1e-9) ** 2
    t = np.full(len(d), np.inf)
    if near.any():
        t[near] = hit_t(prim, o, d[near])
    return t


def cast(prims, K, T_world_cam, u, v):
    """Depth (planar z) and id seen through pixel coordinates (u, v) (OpenCV; arrays)."""
    K = np.asarray(K, dtype=float)
    T = np.asarray(T_world_cam, dtype=float)
    u = np.asarray(u, dtype=float).ravel()
    v = np.asarray(v, dtype=float).ravel()
    rays_cam = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=1)
    d = rays_cam @ T[:3, :3].T  # world directions with unit camera z: t == planar depth
    o = T[:3, 3]
    depth = np.full(len(u), np.inf)
    ids = np.zeros(len(u), dtype=np.int64)
    for p in prims:
        t = hit_t_bounded(p, o, d)
        closer = t < depth
        depth = np.where(closer, t, depth)
        ids = np.where(closer, p.id, ids)
    return depth, ids


def render_truth(prims, K, T_world_cam, width, height, edge_eps_px=1e-3):
    """Per pixel centre: depth (H, W), id (H, W) and a mask of pixels whose centre lies
    within ``edge_eps_px`` of a silhouette edge (the id changes within that distance)."""
    vv, uu = np.mgrid[0:height, 0:width].astype(float)
    depth, ids = cast(prims, K, T_world_cam, uu, vv)
    near_edge = np.zeros(depth.shape, dtype=bool)
    for a in np.linspace(0, 2 * np.pi, 16, endpoint=False):
        _, ids2 = cast(prims, K, T_world_cam, uu + edge_eps_px * np.cos(a), vv + edge_eps_px * np.sin(a))
        near_edge |= ids2 != ids
    return depth.reshape(height, width), ids.reshape(height, width), near_edge.reshape(height, width)


@dataclass
class RoundedBoxP:
    """A box (full edge lengths ``size``) with edges rounded to ``radius``: the points within
    ``radius`` of the inner box of half sizes size/2 - radius (Minkowski sum)."""
    id: int
    centre: np.ndarray
    rotation_deg: tuple
    size: np.ndarray
    radius: float


def _rounded_box_t(prim: RoundedBoxP, o, d):
    """First hit on a rounded box: the union of three slabs (the inner box grown by r along
    one axis), twelve edge cylinders and eight corner spheres, all convex: min of their t."""
    R = euler_xyz_deg(*prim.rotation_deg)
    ol = R.T @ (o - prim.centre)
    dl = d @ R
    r = float(prim.radius)
    inner = np.asarray(prim.size, dtype=float) / 2 - r
    best = np.full(len(d), np.inf)
    for axis in range(3):  # slabs
        grow = inner.copy()
        grow[axis] += r
        best = np.minimum(best, hit_t(BoxP(0, np.zeros(3), (0, 0, 0), 2 * grow), ol, dl))
    for axis in range(3):  # edge cylinders along ``axis``
        a, b = [i for i in range(3) if i != axis]
        for sa in (-1, 1):
            for sb in (-1, 1):
                c = np.zeros(3)
                c[a], c[b] = sa * inner[a], sb * inner[b]
                oc = ol - c
                A = dl[:, a] ** 2 + dl[:, b] ** 2
                B = 2 * (oc[a] * dl[:, a] + oc[b] * dl[:, b])
                C = oc[a] ** 2 + oc[b] ** 2 - r * r
                disc = B * B - 4 * A * C
                sq = np.sqrt(np.where(disc >= 0, disc, 0))
                with np.errstate(divide="ignore", invalid="ignore"):
                    for t in ((-B - sq) / (2 * A), (-B + sq) / (2 * A)):
                        along = oc[axis] + t * dl[:, axis]
                        ok = (disc >= 0) & (t > 0) & (np.abs(along) <= inner[axis])
                        best = np.where(ok & (t < best), t, best)
    for sx in (-1, 1):  # corner spheres
        for sy in (-1, 1):
            for sz in (-1, 1):
                best = np.minimum(best, hit_t(SphereP(0, inner * np.array([sx, sy, sz]), r), ol, dl))
    return best
def hit_point(prims, K, T_world_cam, u, v):
    """World points (n, 3) and ids (n,) seen through pixel coordinates (u, v); inf / 0 where
    nothing is hit."""
    depth, ids = cast(prims, K, T_world_cam, u, v)
    K = np.asarray(K, dtype=float)
    T = np.asarray(T_world_cam, dtype=float)
    u = np.asarray(u, dtype=float).ravel()
    v = np.asarray(v, dtype=float).ravel()
    rays_cam = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=1)
    with np.errstate(invalid="ignore"):
        X = T[:3, 3] + (rays_cam * depth[:, None]) @ T[:3, :3].T
    return X, ids


def visible(prims, T_world_cam, X_world, eps=1e-6):
    """bool (n,): nothing of ``prims`` lies between the camera centre and each world point."""
    o = np.asarray(T_world_cam, dtype=float)[:3, 3]
    d = np.asarray(X_world, dtype=float) - o   # the point at t = 1
    t = np.full(len(d), np.inf)
    for p in prims:
        t = np.minimum(t, hit_t_bounded(p, o, d))
    return ~(t < 1.0 - eps)
