"""Triangle meshes for procedural assets (numpy only; runs inside Blender's own Python).

An asset is one :class:`MeshData`: vertices in the asset's own frame (SES axes: Y up,
metres, origin at the middle of its base), triangles wound counter-clockwise seen from
outside (so their normals point out), and per triangle the index of its *surface* — a
material name of the library (``asphalt``, ``glass_window``, ...) with a colour tint.
The Blender layer turns this into one mesh object with one material slot per surface;
nothing here knows Blender.

Everything is triangles: how a renderer splits a non-planar quad is then never a
question, and ground truth (depth, ids) is that of exactly these triangles.
:class:`MeshBuilder` collects parts (boxes, prisms, lofts, surfaces of revolution, tubes
along a path); each closed part is watertight on its own (every edge shared by exactly
two triangles with opposite directions), which ``edge_report`` checks.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Surface:
    """One material slot of an asset: a material name (of the built-in library unless the
    script defines a MATERIAL of that name) and optionally the colour it takes. ``part`` names
    a slot an ASSET tag may re-material (``ground``: a building's ground-floor walls, which
    ``ground_material`` replaces); "" for the rest."""
    material: str
    colour: Optional[Vec3] = None   # linear albedo replacing the material's own; None = its own
    part: str = ""


@dataclass
class MeshData:
    vertices: np.ndarray      # (n, 3) float64, asset frame (SES axes), metres
    faces: np.ndarray         # (m, 3) int32 triangles, counter-clockwise seen from outside
    face_surface: np.ndarray  # (m,) int32 index into ``surfaces``
    smooth: np.ndarray        # (m,) bool: smooth-shaded (normals only; geometry unchanged)
    surfaces: tuple[Surface, ...]

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def triangle_normals(self) -> np.ndarray:
        a, b, c = (self.vertices[self.faces[:, i]] for i in range(3))
        n = np.cross(b - a, c - a)
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)

    def areas(self) -> np.ndarray:
        a, b, c = (self.vertices[self.faces[:, i]] for i in range(3))
        return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def edge_report(faces: np.ndarray) -> dict:
    """Edge statistics of a triangle list: ``boundary`` (edges used once), ``nonmanifold``
    (used more than twice), ``flipped`` (a directed edge used twice: neighbours wound the
    same way). A closed, consistently oriented surface has all three zero."""
    f = np.asarray(faces, dtype=np.int64)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    n = int(directed.max()) + 1 if len(directed) else 1
    d_key = directed[:, 0] * n + directed[:, 1]
    _, d_counts = np.unique(d_key, return_counts=True)
    und = np.sort(directed, axis=1)
    _, u_counts = np.unique(und[:, 0] * n + und[:, 1], return_counts=True)
    return {"boundary": int(np.sum(u_counts == 1)), "nonmanifold": int(np.sum(u_counts > 2)),
            "flipped": int(np.sum(d_counts > 1))}


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Volume enclosed by a closed triangle surface (positive when normals point out)."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    return float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c))) / 6.0)


# --- transforms -------------------------------------------------------------------------

def rot_y(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def rot_x(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def rot_z(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def pose(R: Optional[np.ndarray] = None, t: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    T[:3, 3] = t
    return T


def cross3(a, b) -> np.ndarray:
    """``np.cross`` of two 3-vectors without its any-shape set-up (which costs ~20x the
    arithmetic): the same products and differences in the same order, so the same bits."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


# --- polygon helpers --------------------------------------------------------------------

def polygon_area2(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return float(0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def triangulate_polygon(poly: np.ndarray) -> np.ndarray:
    """Ear-clipping triangulation of a simple 2-D polygon given counter-clockwise:
    (k-2, 3) indices into ``poly``, each triangle counter-clockwise."""
    poly = np.asarray(poly, dtype=float)
    idx = list(range(len(poly)))
    tris = []

    def inside(p, a, b, c):
        def cross(o, u, v):
            return (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0])
        return cross(a, b, p) >= -1e-12 and cross(b, c, p) >= -1e-12 and cross(c, a, p) >= -1e-12

    guard = 0
    while len(idx) > 3 and guard < 10000:
        guard += 1
        for k in range(len(idx)):
            i0, i1, i2 = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            a, b, c = poly[i0], poly[i1], poly[i2]
            if (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) <= 1e-14:
                continue  # reflex or degenerate corner
            if any(inside(poly[j], a, b, c) for j in idx if j not in (i0, i1, i2)):
                continue
            tris.append((i0, i1, i2))
            idx.pop(k)
            break
        else:
            raise ValueError("polygon is not simple or not counter-clockwise")
    tris.append(tuple(idx))
    return np.array(tris, dtype=np.int64)


@functools.lru_cache(maxsize=None)
def _box_triangles(skip: tuple) -> np.ndarray:
    """A box's triangles (vertex 4ix + 2iy + iz), two per face in -x, +x, -y, +y, -z, +z
    order, without the faces named in ``skip``."""
    quads = {"-x": (0, 1, 3, 2), "+x": (4, 6, 7, 5), "-y": (0, 4, 5, 1),
             "+y": (2, 3, 7, 6), "-z": (0, 2, 6, 4), "+z": (1, 5, 7, 3)}
    tris = [t for name, (a, b, c, d) in quads.items() if name not in skip for t in ((a, b, c), (a, c, d))]
    out = np.array(tris, dtype=np.int64).reshape(-1, 3)
    out.setflags(write=False)
    return out


def _per_triangle(value, dtype, n: int) -> np.ndarray:
    """``value`` (one for all or one per triangle) as an array of n (what broadcasting gives)."""
    a = np.asarray(value, dtype=dtype)
    return np.full(n, a, dtype=dtype) if a.ndim == 0 else np.broadcast_to(a, (n,)).copy()


# --- the builder ------------------------------------------------------------------------

class MeshBuilder:
    """Collects triangle parts; ``build()`` returns the :class:`MeshData`."""

    def __init__(self):
        self._V: list[np.ndarray] = []
        self._F: list[np.ndarray] = []
        self._S: list[np.ndarray] = []
        self._smooth: list[np.ndarray] = []
        self._surfaces: dict[Surface, int] = {}
        self._count = 0

    def surface(self, material: str, colour: Optional[Sequence[float]] = None, part: str = "") -> int:
        s = Surface(material, None if colour is None else tuple(round(float(c), 4) for c in colour), part)
        if s not in self._surfaces:
            self._surfaces[s] = len(self._surfaces)
        return self._surfaces[s]

    def add(self, verts, tris, surf, smooth=False, T: Optional[np.ndarray] = None,
            closed: bool = False, facing=None) -> None:
        """Add vertices and triangles (indices local to ``verts``); ``surf`` an index (one
        for all) or an array (one per triangle); ``smooth`` likewise; ``T`` a 4x4 placing
        them. ``closed``: the part is a closed surface, wound consistently; it is turned
        inside out if its normals point in. ``facing``: an open part whose normals should
        point (on average) along this vector is flipped if they do not."""
        V = np.asarray(verts, dtype=float).reshape(-1, 3)
        F = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
        if len(F) == 0:
            return
        if T is not None:
            V = V @ np.asarray(T)[:3, :3].T + np.asarray(T)[:3, 3]
        if closed and signed_volume(V - V.mean(axis=0), F) < 0:
            F = F[:, [0, 2, 1]]
        if facing is not None:
            a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
            if np.sum(np.cross(b - a, c - a) @ np.asarray(facing, float)) < 0:
                F = F[:, [0, 2, 1]]
        self._V.append(V)
        self._F.append(F + self._count)
        self._S.append(_per_triangle(surf, np.int64, len(F)))
        self._smooth.append(_per_triangle(smooth, bool, len(F)))
        self._count += len(V)

    def merge(self, other: "MeshBuilder", T: Optional[np.ndarray] = None) -> None:
        data = other.build()
        remap = np.array([self.surface(s.material, s.colour, s.part) for s in data.surfaces], dtype=np.int64)
        if len(data.faces):
            self._V.append(data.vertices if T is None else
                           data.vertices @ np.asarray(T)[:3, :3].T + np.asarray(T)[:3, 3])
            self._F.append(data.faces.astype(np.int64) + self._count)
            self._S.append(remap[data.face_surface])
            self._smooth.append(data.smooth.copy())
            self._count += len(data.vertices)

    def build(self) -> MeshData:
        surfaces = tuple(sorted(self._surfaces, key=self._surfaces.get))
        if not self._F:
            return MeshData(np.zeros((0, 3)), np.zeros((0, 3), np.int32), np.zeros(0, np.int32),
                            np.zeros(0, bool), surfaces)
        return MeshData(np.concatenate(self._V), np.concatenate(self._F).astype(np.int32),
                        np.concatenate(self._S).astype(np.int32), np.concatenate(self._smooth), surfaces)

    # --- primitives (each closed one is watertight and oriented outwards) ---------------

    def quad(self, p0, p1, p2, p3, surf, T=None) -> None:
        """A planar quad p0..p3, counter-clockwise seen from its front."""
        self.add([p0, p1, p2, p3], [(0, 1, 2), (0, 2, 3)], surf, T=T)

    def box(self, lo, hi, surf, T=None, skip=()) -> None:
        """Axis-aligned box [lo, hi] (then placed by T); ``skip`` names faces to leave out
        ('-x', '+x', '-y', '+y', '-z', '+z'): the box is then open there."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        V = [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]  # 4ix + 2iy + iz
        self.add(V, _box_triangles(tuple(skip)), surf, T=T)

    def oriented_box(self, origin, a1, a2, a3, surf) -> None:
        """The parallelepiped origin + [0,1]a1 + [0,1]a2 + [0,1]a3 (any handedness)."""
        o, A = np.asarray(origin, float), np.array([a1, a2, a3], dtype=float)
        V = [o + i * A[0] + j * A[1] + k * A[2] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
        quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
        self.add(V, tris, surf, closed=True)

    def extrude(self, polygon, offset, surf, cap_surf=None) -> None:
        """A prism: the planar convex polygon (k, 3) swept by the vector ``offset``."""
        P = np.asarray(polygon, dtype=float)
        k = len(P)
        V = np.concatenate([P, P + np.asarray(offset, float)])
        tris = []
        for i in range(k):
            j = (i + 1) % k
            tris += [(i, j, k + j), (i, k + j, k + i)]
        cs = surf if cap_surf is None else cap_surf
        caps = [(0, i + 1, i) for i in range(1, k - 1)] + [(k, k + i, k + i + 1) for i in range(1, k - 1)]
        self.add(V, tris + caps, [surf] * len(tris) + [cs] * len(caps), closed=True)

    def prism(self, poly_xz, y0: float, y1: float, surf, T=None, cap_surf=None) -> None:
        """A vertical prism: the simple polygon ``poly_xz`` (k, 2) of (x, z) points, either
        winding, extruded from y0 to y1; sides flat-shaded, caps ear-clipped."""
        P = np.asarray(poly_xz, dtype=float)
        if polygon_area2(P) < 0:
            P = P[::-1]                       # counter-clockwise in (x, z)
        k = len(P)
        V = np.concatenate([np.column_stack([P[:, 0], np.full(k, y0), P[:, 1]]),
                            np.column_stack([P[:, 0], np.full(k, y1), P[:, 1]])])
        tris = []
        for i in range(k):
            j = (i + 1) % k
            tris += [(i, k + j, j), (i, k + i, k + j)]
        ear = triangulate_polygon(P)          # counter-clockwise in (x, z): normals -Y
        caps = [(a, b, c) for a, b, c in ear] + [(k + a, k + c, k + b) for a, b, c in ear]
        surfs = [surf] * len(tris) + [surf if cap_surf is None else cap_surf] * len(caps)
        self.add(V, tris + caps, surfs, T=T, closed=True)

    def loft(self, loops, face_surf, cap_surf, T=None, smooth=False, caps: bool = True) -> None:
        """A tube through ``loops`` (s, k, 3): loop i joined to loop i+1, point j to j+1
        (closed loops); the end loops are capped by fans from their centroid (which must
        see the whole loop, e.g. a convex loop). ``face_surf`` (s-1, k): the surface of each
        band quad (between points j and j+1 of loops i and i+1)."""
        L = np.asarray(loops, dtype=float)
        s, k = L.shape[:2]
        V = [L.reshape(-1, 3)]
        band, cap = _loft_triangles(s, k)
        tris = [band]
        surfs = [np.repeat(np.asarray(face_surf, dtype=np.int64).reshape(-1), 2)]
        smooth_flags = [np.full(len(tris[0]), bool(smooth))]
        if caps:
            V += [L[0].mean(axis=0, keepdims=True), L[-1].mean(axis=0, keepdims=True)]
            tris.append(cap)
            surfs.append(np.full(2 * k, cap_surf, dtype=np.int64))
            smooth_flags.append(np.zeros(2 * k, bool))
        self.add(np.concatenate(V), np.concatenate(tris), np.concatenate(surfs), smooth=np.concatenate(smooth_flags),
                 T=T, closed=caps)

    def revolve(self, profile, n: int, surf, T=None, smooth=True) -> None:
        """Surface of revolution about local +Y: ``profile`` (p, 2) of (radius, y) from an
        axis point (radius 0) round the outline to another axis point (radius 0): closed."""
        prof = np.asarray(profile, dtype=float)
        if prof[0, 0] != 0 or prof[-1, 0] != 0:
            raise ValueError("a revolved profile starts and ends on the axis")
        inner = prof[1:-1]
        ang = 2 * np.pi * np.arange(n) / n
        rings = np.stack([np.stack([r * np.cos(ang), np.full(n, y), -r * np.sin(ang)], axis=1)
                          for r, y in inner])
        V = np.concatenate([[[0.0, prof[0, 1], 0.0]], rings.reshape(-1, 3), [[0.0, prof[-1, 1], 0.0]]])
        m, top = len(inner), len(V) - 1
        tris = [(0, 1 + (j + 1) % n, 1 + j) for j in range(n)]
        for i in range(m - 1):
            for j in range(n):
                a, b = 1 + i * n + j, 1 + i * n + (j + 1) % n
                c, d = 1 + (i + 1) * n + (j + 1) % n, 1 + (i + 1) * n + j
                tris += [(a, b, c), (a, c, d)]
        tris += [(top, 1 + (m - 1) * n + j, 1 + (m - 1) * n + (j + 1) % n) for j in range(n)]
        self.add(V, tris, surf, smooth=smooth, T=T, closed=True)

    def cylinder(self, radius: float, y0: float, y1: float, n: int, surf, T=None, smooth=True,
                 cap_surf=None) -> None:
        """A closed cylinder about local Y from y0 to y1 (sides smooth, caps flat)."""
        self.frustum(radius, radius, y0, y1, n, surf, T=T, smooth=smooth, cap_surf=cap_surf)

    def frustum(self, r0: float, r1: float, y0: float, y1: float, n: int, surf, T=None, smooth=True,
                cap_surf=None) -> None:
        """A closed truncated cone about local Y: radius r0 at y0, r1 at y1 (r1 may be 0)."""
        ang = 2 * np.pi * np.arange(n) / n
        ring = np.stack([np.cos(ang), np.zeros(n), -np.sin(ang)], axis=1)
        V = np.concatenate([ring * (r0, 1, r0) + (0, y0, 0), ring * (r1, 1, r1) + (0, y1, 0),
                            [[0.0, y0, 0.0], [0.0, y1, 0.0]]])
        tris, surfs, flags = [], [], []
        cs = surf if cap_surf is None else cap_surf
        for j in range(n):
            jn = (j + 1) % n
            tris += [(j, jn, n + jn), (j, n + jn, n + j)]
            tris += [(2 * n, jn, j), (2 * n + 1, n + j, n + jn)]
            surfs += [surf, surf, cs, cs]
            flags += [smooth, smooth, False, False]
        self.add(V, tris, surfs, smooth=flags, T=T, closed=True)

    def tube(self, points, radii, n: int, surf, smooth=True) -> None:
        """A closed generalised cylinder along the polyline ``points`` (p, 3) with ``radii``
        (p,) and ``n`` sides (see :meth:`tubes`)."""
        self.tubes([(points, radii, n)], surf, smooth)

    def tubes(self, paths, surf, smooth=True) -> None:
        """Closed generalised cylinders, one per (points (p, 3), radii (p,), sides) of
        ``paths``, added in that order: rings perpendicular to the path's (central-difference)
        tangent, the frame carried along without twist, both ends capped (a :meth:`loft`
        each), turned outwards. Tubes of equal points and sides are made in one vectorised
        pass (a tree's hundreds of branches cost a few passes, not hundreds): every value is
        the one a tube made alone gets, bit for bit (dot products and norms through stacked
        ``matmul``, which rounds as the 1-D ``@``/``norm`` of a lone tube do)."""
        groups: dict = {}
        where = []                                   # (group, index in it) of each path
        for points, radii, n in paths:
            P = np.asarray(points, dtype=float)
            key = (len(P), int(n))
            g = groups.setdefault(key, ([], []))
            where.append((key, len(g[0])))
            g[0].append(P)
            g[1].append(np.broadcast_to(np.asarray(radii, dtype=float), (len(P),)))
        made = {key: _tube_vertices(np.stack(Ps), np.stack(Rs), key[1]) for key, (Ps, Rs) in groups.items()}
        tris = {}
        for (p, n), V in made.items():
            band, cap = _loft_triangles(p, n)
            F = np.concatenate([band, cap])
            a, b, c = (V - V.mean(axis=1, keepdims=True))[:, F].transpose(2, 0, 1, 3)
            inward = np.einsum("mij,mij->m", a, np.cross(b, c)) < 0      # add(closed=True)'s test
            tris[p, n] = (F, F[:, [0, 2, 1]], inward, len(band))
        Vs, Fs, Ss, smooths = [], [], [], []
        for key, i in where:
            F, flipped, inward, n_band = tris[key]
            Vs.append(made[key][i])
            Fs.append((flipped if inward[i] else F) + self._count)
            Ss.append(np.full(len(F), surf, dtype=np.int64))
            smooths.append(np.arange(len(F)) < n_band if smooth else np.zeros(len(F), bool))
            self._count += len(Vs[-1])
        if Vs:
            self._V.append(np.concatenate(Vs))
            self._F.append(np.concatenate(Fs))
            self._S.append(np.concatenate(Ss))
            self._smooth.append(np.concatenate(smooths))

    def sheet(self, grid, surf, facing=(0.0, 1.0, 0.0), smooth=False, cell_surf=None) -> None:
        """An open surface through the vertex grid (r, c, 3), each cell two triangles
        (split along the (i, j)-(i+1, j+1) diagonal), normals turned towards ``facing``;
        ``cell_surf`` (r-1, c-1) gives each cell's surface (else ``surf`` for all)."""
        G = np.asarray(grid, dtype=float)
        r, c = G.shape[:2]
        i, j = np.meshgrid(np.arange(r - 1), np.arange(c - 1), indexing="ij")
        a = (i * c + j).ravel()
        b, cc, d = a + 1, a + c + 1, a + c
        tris = np.concatenate([np.stack([a, b, cc], 1), np.stack([a, cc, d], 1)])
        if cell_surf is None:
            s = surf
        else:
            fs = np.asarray(cell_surf).ravel()
            s = np.concatenate([fs, fs])
        self.add(G.reshape(-1, 3), tris, s, smooth=smooth, facing=facing)


def _loft_triangles(s: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of a loft of ``s`` loops of ``k`` points: the band quads in loop order,
    each as (a, b, c), (a, c, d), and the two end caps' fans from the centroids that follow
    the loops' points (vertices s*k and s*k + 1)."""
    i, j = np.meshgrid(np.arange(s - 1), np.arange(k), indexing="ij")
    a, b = i * k + j, i * k + (j + 1) % k
    c, d = (i + 1) * k + (j + 1) % k, (i + 1) * k + j
    band = np.stack([np.stack([a, b, c], -1), np.stack([a, c, d], -1)], axis=2).reshape(-1, 3)
    n0, j = s * k, np.arange(k)
    jn = (j + 1) % k
    cap = np.stack([np.stack([np.full(k, n0), jn, j], -1),
                    np.stack([np.full(k, n0 + 1), (s - 1) * k + j, (s - 1) * k + jn], -1)], axis=1).reshape(-1, 3)
    return band, cap


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products of the 3-vectors along the last axis, each rounded as numpy's 1-D
    ``a @ b`` rounds it (BLAS, fused multiply-adds: not the rounding of ``(a * b).sum()``)."""
    return np.matmul(a[..., None, :], b[..., :, None])[..., 0, 0]


def _tube_vertices(P: np.ndarray, R: np.ndarray, n: int) -> np.ndarray:
    """The vertices of m tubes of n sides along the paths ``P`` (m, p, 3) with radii ``R``
    (m, p): each tube's p rings of n points, then its two end centroids (m, p*n + 2, 3)."""
    m, p = P.shape[:2]
    tang = np.gradient(P, axis=1)
    tang /= np.linalg.norm(tang, axis=-1, keepdims=True)
    # frame_from_z of each first tangent, row by row
    y = tang[:, 0] / np.sqrt(_dot(tang[:, 0], tang[:, 0]))[:, None]
    helper = np.where((np.abs(y[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    x = np.cross(y, helper)
    x /= np.sqrt(_dot(x, x))[:, None]
    X, Z = np.empty((m, p, 3)), np.empty((m, p, 3))
    for i in range(p):      # the frame carried along the paths (sequential along each)
        t = tang[:, i]
        x = x - _dot(x, t)[:, None] * t
        x /= np.sqrt(_dot(x, x))[:, None]
        X[:, i], Z[:, i] = x, np.cross(x, t)
    ang = 2 * np.pi * np.arange(n) / n
    cos, sin = np.cos(ang)[None, None, :, None], np.sin(ang)[None, None, :, None]
    loops = P[:, :, None, :] + R[:, :, None, None] * (cos * X[:, :, None, :] + sin * Z[:, :, None, :])
    return np.concatenate([loops.reshape(m, p * n, 3), loops[:, 0].mean(axis=1, keepdims=True),
                           loops[:, -1].mean(axis=1, keepdims=True)], axis=1)


def start(size, seed: int) -> tuple[np.random.Generator, float, float, float, MeshBuilder]:
    """What an asset generator begins with: its seeded random stream, the three numbers of its
    size (floats) and an empty builder."""
    a, b, c = (float(x) for x in size)
    return np.random.default_rng(seed), a, b, c, MeshBuilder()
