"""Which objects a range of frames can see (pure numpy): conservative culling, so that each
chunk of a long sequence builds only its part of the world (``render --cull``).

An object is kept when its bounding box (:func:`object_box`, in the object's own frame,
carried by its pose) meets the **view volume** of one of the chunk's camera poses, for every
view: the pyramid of the image's pixel rays, widened by ``EDGE_MARGIN_PX`` beyond the image's
edge (anti-aliasing samples reach past the pixel centres), from the camera centre to the far
plane (z <= far holds for every point Cycles can show, whether it clips along the ray or
along the optical axis). With a distorting lens the pyramid bounds the lens's rays through
the widened image border. On the sensor path (motion blur, rolling shutter) the poses are
sampled every 1/``SUBFRAME_STEPS`` frame over the frame's +-1 frame (every shutter lies
within that), the camera's and the moving objects', and the test widens by the motion
between two samples. The test itself: a box is outside a pyramid when its 8 corners lie
outside one of its 5 planes; otherwise it is kept (conservative: never drops a box that meets
the pyramid).

So a primary ray through any pixel meets only kept objects: **depth, object ids, normals and
positions of a culled render are exactly those of the full render** (and so is the ``gt``
preset's flat RGB, a function of the surface seen). A shaded render (any other preset) also
keeps what lights what it sees: every object whose **sun shadow** (its box swept along the
sunlight to the ground) can reach a view volume, for each sun (``LIGHT sun``, the sky's sun),
and everything within ``RGB_RADIUS_M`` of the camera (reflections, light bounced near the
camera). Its RGB then differs from the full render's only by light reflected or bounced off
objects farther away outside the view volumes (and, with an HDRI, by the shadows of its sun,
whose direction the script does not give): measured in docs/rendering.md.

Objects whose extent the script does not give are always kept: BLEND files' objects, and
MESH files other than OBJ and STL (whose vertices are read here).
"""
from __future__ import annotations

import dataclasses
import math
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Optional

import numpy as np

from . import assets, dynamics, lighting_data
from .contract.frames import object_pose
from .contract.rig import T_world_view
from .contract.se3 import invert
from .errors import SesgenError
from .model import Asset, Cuboid, Cylinder, Mesh, Quad, Scene, SceneObject, Sphere

EDGE_MARGIN_PX = 2.0        # beyond the outermost pixel centres: the pixel filter's reach, and more
SUBFRAME_STEPS = 8          # samples per frame of the camera's and objects' motion on the sensor path
RGB_RADIUS_M = 40.0         # a shaded render keeps everything this close to the camera
STRIP_MARGIN_M = 0.05       # a strip's chords and slab beyond its centreline's samples
ASSET_GROWTH = 0.15         # an asset's box: its size, the kind's overhang and this share of its footprint


@dataclass(frozen=True)
class Box:
    """A box ``lo``..``hi`` in the frame that ``T_world`` places in the SES world."""
    T_world: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    def corners(self) -> np.ndarray:
        """(8, 3) world corners."""
        c = np.array([(x, y, z) for x in (self.lo[0], self.hi[0]) for y in (self.lo[1], self.hi[1])
                      for z in (self.lo[2], self.hi[2])])
        return c @ self.T_world[:3, :3].T + self.T_world[:3, 3]


def asset_local_box(kind: str, size, bend=(0.0,), offset: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) in the asset's frame containing every vertex of any asset of this kind and
    size (tests/test_culling.py checks it on every kind): the footprint (``size`` x and z)
    and height plus the kind's documented overhang and ``ASSET_GROWTH`` of the footprint on
    every side (below the ground too: ceiling lights hang down, roots reach in); a strip's box from its
    centreline (``street.arc_frame``) and lateral extent, its slab below the road."""
    k = assets.KINDS[kind]
    w, h, d = (float(x) for x in size)
    o = float(k.overhang)
    if not k.strip:    # the documented overhang holds at the default sizes; parts scale with the asset
        m = o + ASSET_GROWTH * max(w, d)
        return np.array([-w / 2 - m, -h - m, -d / 2 - m]), np.array([w / 2 + m, h + 2 * m, d / 2 + m])
    from .assets.street import arc_frame
    bend = np.atleast_1d(np.asarray(bend, float))
    s = np.linspace(0.0, d, max(8 * len(bend) + 1, int(d / 2.0) + 2))
    c, n, _ = arc_frame(s, d, bend)
    pts = np.concatenate([c + (offset - w / 2) * n, c + (offset + w / 2) * n])
    m = STRIP_MARGIN_M + o + d / len(bend) * np.radians(np.abs(bend).max()) ** 2 / 8   # chord sagitta
    lo = pts.min(axis=0) - m
    hi = pts.max(axis=0) + m
    lo[1], hi[1] = -max(h, 0.3) - 0.3, h + 0.3
    return lo, hi


def _mesh_file_extent(path: str) -> Optional[tuple[np.ndarray, np.ndarray]]:
    """(lo, hi) of the vertices of an OBJ or STL file; None for other formats or unreadable files."""
    p = Path(path)
    ext = p.suffix.lower()
    try:
        if ext == ".obj":
            V = []
            with open(p, "r", encoding="utf-8", errors="replace") as f:
                for line in f:
                    if line.startswith("v "):
                        V.append([float(x) for x in line.split()[1:4]])
            V = np.array(V)
        elif ext == ".stl":
            data = p.read_bytes()
            n = struct.unpack_from("<I", data, 80)[0] if len(data) >= 84 else -1
            if len(data) == 84 + 50 * n:                    # binary
                rec = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                                    count=n, offset=84)
                V = rec["v"].reshape(-1, 3).astype(float)
            else:
                V = np.array([[float(x) for x in ln.split()[1:4]] for ln in data.decode("ascii", "replace").splitlines()
                              if ln.strip().startswith("vertex")])
        else:
            return None
    except (OSError, ValueError, struct.error):
        return None
    if V.ndim != 2 or len(V) == 0 or not np.all(np.isfinite(V)):
        return None
    return V.min(axis=0), V.max(axis=0)


def object_box(o: SceneObject) -> Optional[Box]:
    """The object's bounding box at its rest pose (None: extent unknown, never culled)."""
    if isinstance(o, Quad):
        V = np.asarray(o.vertices, float)
        c = V.mean(axis=0)
        return Box(object_pose(c), V.min(axis=0) - c, V.max(axis=0) - c)
    T = object_pose(o.position, o.rotation_deg)
    if isinstance(o, Cuboid):
        h = np.asarray(o.size, float) / 2
        return Box(T, -h, h)
    if isinstance(o, Sphere):
        r = np.full(3, float(o.radius))
        return Box(T, -r, r)
    if isinstance(o, Cylinder):
        h = np.array([o.radius, o.height / 2, o.radius], float)
        return Box(T, -h, h)
    if isinstance(o, Asset):
        lo, hi = asset_local_box(o.kind, o.size, o.bend, o.offset)
        return Box(T, lo, hi)
    if isinstance(o, Mesh):
        ext = _mesh_file_extent(o.path)
        if ext is None:
            return None
        s = np.asarray(o.scale, float)
        a, b = ext[0] * s, ext[1] * s
        return Box(T, np.minimum(a, b), np.maximum(a, b))
    return None


@dataclass(frozen=True)
class ViewPyramid:
    """The view volume of a camera: x/z in [a0, a1], y/z in [b0, b1], 0 <= z <= far (OpenCV
    camera frame); ``widen`` (rad) turns each side plane outwards."""
    a0: float
    a1: float
    b0: float
    b1: float
    far: float

    def planes(self, widen: float = 0.0) -> np.ndarray:
        """(5, 4) inward half-spaces n . X + c >= 0 in the camera frame."""
        def side(t, sign):   # the plane through the origin and the ray x/z = t (or y/z), opened by widen
            ang = math.atan(t) + sign * widen
            return math.tan(max(min(ang, math.pi / 2 - 1e-6), -math.pi / 2 + 1e-6))
        a0, a1, b0, b1 = side(self.a0, -1), side(self.a1, 1), side(self.b0, -1), side(self.b1, 1)
        return np.array([[1.0, 0.0, -a0, 0.0], [-1.0, 0.0, a1, 0.0], [0.0, 1.0, -b0, 0.0], [0.0, -1.0, b1, 0.0],
                         [0.0, 0.0, -1.0, self.far]])


def view_pyramid(K, width: int, height: int, far: float, lens=None) -> ViewPyramid:
    """The pyramid of a camera's pixel rays through the image border widened by
    ``EDGE_MARGIN_PX``; with ``lens`` (contract.lens.Lens) the lens's rays there."""
    m = EDGE_MARGIN_PX
    u = np.linspace(-0.5 - m, width - 0.5 + m, 64)
    v = np.linspace(-0.5 - m, height - 0.5 + m, 64)
    border = np.concatenate([np.stack([u, np.full_like(u, v[0])], 1), np.stack([u, np.full_like(u, v[-1])], 1),
                             np.stack([np.full_like(v, u[0]), v], 1), np.stack([np.full_like(v, u[-1]), v], 1)])
    if lens is None:
        K = np.asarray(K, float)
        xy = (border - K[:2, 2]) @ np.linalg.inv(K[:2, :2]).T
    else:
        rays = lens.unproject(border)
        xy = rays[:, :2] / rays[:, 2:3]
    return ViewPyramid(float(xy[:, 0].min()), float(xy[:, 0].max()), float(xy[:, 1].min()), float(xy[:, 1].max()),
                       float(far))


def _outside(planes: np.ndarray, T_cam_world: np.ndarray, pts: np.ndarray, margin=0.0) -> np.ndarray:
    """bool (n,): each point set pts (n, m, 3) lies entirely outside one of the ``planes``
    (unit normals: (5, 4) n . X + c >= 0 inside) by more than ``margin`` (scalar or (n,)),
    seen from a camera at inv(T_cam_world)."""
    X = pts @ T_cam_world[:3, :3].T + T_cam_world[:3, 3]             # (n, m, 3)
    s = np.einsum("nmj,pj->npm", X, planes[:, :3]) + planes[:, 3][None, :, None]   # (n, 5, m)
    return np.any(np.all(s < -np.reshape(margin, (-1, 1, 1)), axis=2), axis=1)


@dataclass
class CullResult:
    """What a range of frames keeps: ``keep`` ids, and why (``in_view``, ``shadow``, ``near``,
    ``unknown``: no extent), of ``total`` objects."""
    keep: set
    total: int
    in_view: int = 0
    shadow: int = 0
    near: int = 0
    unknown: int = 0

    def summary(self) -> str:
        return (f"{len(self.keep)} of {self.total} objects ({self.in_view} in view"
                + (f", {self.shadow} casting shadows into it" if self.shadow else "")
                + (f", {self.near} within {RGB_RADIUS_M:g} m" if self.near else "")
                + (f", {self.unknown} of unknown extent" if self.unknown else "") + ")")


def _suns(scene: Scene) -> list[np.ndarray]:
    """Unit directions the sunlight travels: LIGHT sun statements and the sky's sun."""
    out = [np.asarray(li.direction, float) for li in scene.lights if li.kind == "sun" and li.direction is not None]
    if scene.world is not None and scene.world.kind == "sky":
        sun = lighting_data.sky_sun_light(scene.world)
        if sun is not None:
            out.append(np.asarray(sun.direction, float))
    return [d / np.linalg.norm(d) for d in out if np.linalg.norm(d) > 0]


def camera_poses(plan, frames: Iterable[int]) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(T_world_cam (n, 4, 4) of every view at every instant the frames' images can show,
    those instants in frames, the largest translation (m) and rotation (rad) between two
    consecutive samples: the widening the test needs)."""
    frames = sorted(set(int(k) for k in frames))
    sensor = plan.sensor
    views = plan.views
    if not sensor.shutter_effects:
        times = np.array(frames, float)
        poses = [plan.view_poses[v][frames] for v in views]
        return np.concatenate(poses), times, 0.0, 0.0
    t = np.unique(np.concatenate([k + np.arange(-SUBFRAME_STEPS, SUBFRAME_STEPS + 1) / SUBFRAME_STEPS
                                  for k in frames]))
    start = sensor.timing.start_s if sensor.timing else 0.0
    T = sensor.motion.T_world_cam(start + t / sensor.rate_hz)
    poses, dp, dr = [], 0.0, 0.0
    for v in views:
        Tv = T_world_view(T, v, sensor.baseline)
        poses.append(Tv)
        if len(Tv) > 1:
            dp = max(dp, float(np.linalg.norm(np.diff(Tv[:, :3, 3], axis=0), axis=1).max()))
            R = np.einsum("nji,njk->nik", Tv[:-1, :3, :3], Tv[1:, :3, :3])
            dr = max(dr, float(np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1)).max()))
    return np.concatenate(poses), t, dp, dr


def visible_objects(plan, frames: Iterable[int], shaded: Optional[bool] = None) -> CullResult:
    """The objects the frames ``frames`` of ``plan`` (a ``RenderPlan``) can show (see the
    module docstring); ``shaded`` (default: the plan's preset is not the flat ``gt``) adds
    shadow casters and what lies near the camera."""
    scene: Scene = plan.scene
    settings = plan.settings
    if shaded is None:
        shaded = settings.preset.shading != "flat"
    poses, times, dp, dr = camera_poses(plan, frames)
    pyramid = view_pyramid(settings.K, settings.width, settings.height, scene.rig.far, plan.sensor.lens)
    planes = pyramid.planes(widen=dr)
    planes /= np.linalg.norm(planes[:, :3], axis=1, keepdims=True)
    T_cam_world = invert(poses)
    cam_centres = poses[:, :3, 3]
    sub = plan.sensor.shutter_effects
    ids, sets, margins, unknown = [], [], [], set()
    for o in scene.objects:
        b = object_box(o)
        if b is None:
            unknown.add(o.id)
            continue
        motion = scene.motion_of(o.id)
        if motion is None:
            pts, step = b.corners(), 0.0
        else:   # the box at every sampled instant of its motion
            T_obj = dynamics.poses_at(motion.poses(), times, motion.kind) if sub \
                else motion.poses()[np.asarray(times, int)]
            M = T_obj @ invert(dynamics.rest_pose(o)) @ b.T_world
            corners = np.einsum("nij,mj->nmi", M[:, :3, :3], Box(np.eye(4), b.lo, b.hi).corners()) + M[:, None, :3, 3]
            step = float(np.linalg.norm(np.diff(corners, axis=0), axis=2).max()) if sub and len(corners) > 1 else 0.0
            pts = corners.reshape(-1, 3)
        ids.append(o.id)
        sets.append(pts)
        margins.append(dp + step)
    total = len(scene.objects)
    if not ids:
        return CullResult(keep=set(unknown), total=total, unknown=len(unknown))
    ids, margins = np.array(ids), np.array(margins)
    n_inst = len(times)
    static = np.array([len(p) == 8 for p in sets])
    S = np.flatnonzero(static)
    movers = np.flatnonzero(~static)                    # their boxes: (n_inst, 8, 3), one per instant
    P_static = np.stack([sets[i] for i in S]) if len(S) else np.zeros((0, 8, 3))
    T_cam_inst = T_cam_world.reshape(len(plan.views), n_inst, 4, 4)

    def meets(P_s: np.ndarray, mover_sets: dict, already: np.ndarray) -> np.ndarray:
        """bool per object: its points (static: P_s rows, for every camera pose; a mover: its
        points at each instant, for that instant's cameras) are not all outside one plane."""
        hit = already.copy()
        for Tcw in T_cam_world:
            todo = ~hit[S]
            if not todo.any():
                break
            hit[S[todo]] = ~_outside(planes, Tcw, P_s[todo], margins[S[todo]])
        for i, pts in mover_sets.items():
            if hit[i]:
                continue
            for Tv in T_cam_inst:
                X = np.einsum("nij,nmj->nmi", Tv[:, :3, :3], pts.reshape(n_inst, -1, 3)) + Tv[:, None, :3, 3]
                sd = np.einsum("nmj,pj->npm", X, planes[:, :3]) + planes[:, 3][None, :, None]
                if not np.all(np.any(np.all(sd < -margins[i], axis=2), axis=1)):
                    hit[i] = True
                    break
        return hit

    none = np.zeros(len(ids), bool)
    in_view = meets(P_static, {i: sets[i] for i in movers}, none)
    keep = set(ids[in_view].tolist()) | unknown
    res = CullResult(keep=keep, total=total, in_view=int(in_view.sum()), unknown=len(unknown))
    if shaded:
        lo = np.array([p.min(axis=0) for p in sets]) - margins[:, None]
        hi = np.array([p.max(axis=0) for p in sets]) + margins[:, None]
        y_floor = float(lo[:, 1].min())
        shadow = none.copy()
        for d in _suns(scene):
            if d[1] >= -1e-6:
                continue

            def swept(P):             # each point set and its shadow down to the scene's lowest point
                reach = (P[..., 1].max(axis=-1) - y_floor) / -d[1]
                return np.concatenate([P, P + reach[..., None, None] * d], axis=-2)
            sweeps = {i: swept(sets[i].reshape(n_inst, -1, 3)).reshape(-1, 3) for i in movers}
            shadow = meets(swept(P_static), sweeps, shadow | in_view) & ~in_view
        gap = np.maximum(np.maximum(lo[None] - cam_centres[:, None], cam_centres[:, None] - hi[None]), 0.0)
        near = (np.linalg.norm(gap, axis=2) <= RGB_RADIUS_M).any(axis=0) & ~in_view & ~shadow
        res.shadow, res.near = int(shadow.sum()), int(near.sum())
        keep |= set(ids[shadow | near].tolist())
    return res


def culled_scene(scene: Scene, keep: set) -> Scene:
    """``scene`` with only the objects whose ids are in ``keep`` (everything else as it was:
    the timeline, motions, lights, world, materials)."""
    return dataclasses.replace(scene, objects=tuple(o for o in scene.objects if o.id in keep))


def check_cullable(scene: Scene) -> None:
    """SesgenError when culling cannot keep the render exact: the default lighting (no LIGHT,
    no WORLD) decides on a ceiling light by casting rays at every object."""
    if not scene.lights and scene.world is None:
        raise SesgenError("--cull needs the scene's own lighting (a LIGHT or a WORLD statement): the default "
                          "lighting looks at every object of the scene to place its lamp")
