"""Glowing panes (``MATERIAL ... library frosted_glass glow``): each pane's emission set from
the world's daylight on its outer face (bpy).

A diffusing pane passes t E / pi of the irradiance E on its outer face as radiance from its
inner face (Lambertian transmission, t its passed colour). Traced, that light reaches a room
only by bounces: Cycles' shadow rays stop at the pane, so every pixel the daylight lights is
found by chance (the hall's noise, bench/quality_noise_source.py). A ``glow`` pane emits it
instead (the library's ``_glow``: no Translucent BSDF, the light does not arrive twice) and is
light-sampled. E is the world's over the pane (``irradiance_map``): the open sky's irradiance
on the outer face (scene/lighting.py ``daylight_irradiance``: the sky's table, the HDRI's pixels
or the uniform colour, 20 000 directions) times the share of it that each of 3 x 3 points on
the pane sees past what stands within ``NEAR_M`` before it (reveal, frame bars; 256 cosine
directions, read between the points), plus the sky's sun lamp by its incidence at every texel of
at most 10 cm (its shadows there as sharp as the traced pane's). Occluders count as black: the
light a sunlit reveal reflects onto the pane is left out. The outer face is the side from which
more rays over its hemisphere (from the pane's centre) escape the scene (a tie: the brighter
side). Each pane gets its own copy of the material and its map (a float image read by the
QUAD's UVs; one value for other shapes) at the strength of its mean emitted luminance, so
Cycles' light tree, which estimates a textured emission by its strength, weighs the pane by its
real light.
"""
from __future__ import annotations

import logging

import bpy
import numpy as np

from ..contract.frames import R_BLENDER_SES
from ..scene import lighting as pure
from ..scene.materials import _luminance, entry, transmitted_colour
from ..scene.model import Quad, Scene, World
from . import compat, library
from . import sky as sky_table
from .datablocks import tag

log = logging.getLogger(__name__)
ESCAPE_M = 1e6
OPEN_RAYS = 16      # rays a side that find the outer face (the side that sees the sky)
POINTS = 3          # points across and up a face (not a QUAD) whose view of the sky is traced
SKY_POINTS = 3      # a QUAD's points whose view of the sky is traced (3 x 3)
MAP_TEXEL_M = 0.1   # a QUAD's irradiance map: texels of at most 10 cm (the sun's shadows on it)...
MAP_MAX = 64        # ...and at most 64 a side
NEAR_M = 1.0        # what shades a pane: geometry this close to it (beyond its own extent)


def world_arrays(bworld, world: World, threads: int = 0):
    """(sky table, HDRI pixels) of the built world (None where it has none)."""
    table = image = None
    nt = compat.node_tree(bworld)
    for node in nt.nodes:
        if node.bl_idname == "ShaderNodeTexSky" and world.kind == "sky":
            if not sky_table.available():
                raise RuntimeError("MATERIAL glow under WORLD sky needs Blender 5.0's physical sky")
            table = sky_table.table_of(node, threads)
        elif node.bl_idname == "ShaderNodeTexEnvironment" and world.kind == "hdri" and node.image is not None:
            w, h = node.image.size
            px = np.empty(w * h * 4, dtype=np.float32)
            node.image.pixels.foreach_get(px)
            image = px.reshape(h, w, 4)
    return table, image


def face_frame(obj) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre, unit normal, sample points) in Blender's world of a flat object's faces: the
    area-weighted centre and normal, and ``POINTS`` x ``POINTS`` points spread over the
    faces' bounding rectangle in their plane (at the centres of its cells)."""
    mesh = obj.data
    n = len(mesh.polygons)
    normals, centres, areas = (np.empty(3 * n), np.empty(3 * n), np.empty(n))
    mesh.polygons.foreach_get("normal", normals)
    mesh.polygons.foreach_get("center", centres)
    mesh.polygons.foreach_get("area", areas)
    co = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", co)
    M = np.array(obj.matrix_world)
    normal = np.linalg.inv(M[:3, :3]).T @ (areas @ normals.reshape(n, 3))
    normal /= np.linalg.norm(normal)
    centre = M[:3, :3] @ (areas @ centres.reshape(n, 3) / areas.sum()) + M[:3, 3]
    verts = co.reshape(-1, 3) @ M[:3, :3].T + M[:3, 3]
    t1, t2 = pure.tangent_frame(normal)
    u, v = (verts - centre) @ t1, (verts - centre) @ t2
    f = (np.arange(POINTS) + 0.5) / POINTS
    uu, vv = np.meshgrid(u.min() + f * (u.max() - u.min()), v.min() + f * (v.max() - v.min()))
    points = centre + np.outer(uu.ravel(), t1) + np.outer(vv.ravel(), t2)
    return centre, normal, points


class _Triangles:
    """The evaluated scene's mesh instances (bounding boxes, one pass) and their triangles in
    the world, read from a mesh once however many instances share it."""

    def __init__(self, depsgraph):
        self.items, self.meshes = [], {}
        for inst in depsgraph.object_instances:
            ob = inst.object
            if ob.type != "MESH":
                continue
            M = np.array(inst.matrix_world)
            box = np.array(ob.bound_box) @ M[:3, :3].T + M[:3, 3]
            self.items.append((ob.original, ob.data, M, box.min(axis=0), box.max(axis=0)))
        self.lo = np.array([i[3] for i in self.items]).reshape(-1, 3)
        self.hi = np.array([i[4] for i in self.items]).reshape(-1, 3)

    def near(self, centre, radius: float, skip) -> np.ndarray:
        """(T, 3, 3) triangles of the instances whose boxes come within ``radius`` of
        ``centre``, ``skip`` (the pane's own objects) left out."""
        gap = np.linalg.norm(np.maximum(np.maximum(self.lo - centre, centre - self.hi), 0.0), axis=1)
        tris = []
        for k in np.flatnonzero(gap <= radius):
            original, mesh, M = self.items[k][:3]
            if original in skip:
                continue
            if mesh.name not in self.meshes:
                mesh.calc_loop_triangles()
                co = np.empty(3 * len(mesh.vertices))
                mesh.vertices.foreach_get("co", co)
                idx = np.empty(3 * len(mesh.loop_triangles), dtype=np.int64)
                mesh.loop_triangles.foreach_get("vertices", idx)
                self.meshes[mesh.name] = co.reshape(-1, 3)[idx.reshape(-1, 3)]
            tris.append(self.meshes[mesh.name] @ M[:3, :3].T + M[:3, 3])
        return np.concatenate(tris) if tris else np.zeros((0, 3, 3))


def _blocked(origins: np.ndarray, dirs: np.ndarray, tris: np.ndarray, chunk: int = 1 << 18) -> np.ndarray:
    """Whether each ray (origins (R, 3), unit dirs (R, 3)) hits one of ``tris`` ahead of it
    (Moller-Trumbore, vectorised over rays x triangles, component by component)."""
    out = np.zeros(len(origins), dtype=bool)
    if not len(tris):
        return out
    a = tris[:, 0].T[:, None, :]                            # (3, 1, T)
    e1, e2 = (tris[:, 1] - tris[:, 0]).T[:, None, :], (tris[:, 2] - tris[:, 0]).T[:, None, :]

    def cross(x, y):
        return (x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0])

    def dot(x, y):
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]
    step = max(1, chunk // len(tris))
    for i in range(0, len(origins), step):
        o, d = origins[i:i + step].T[:, :, None], dirs[i:i + step].T[:, :, None]   # (3, R, 1)
        p = cross(d, e2)
        det = dot(p, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tv = (o[0] - a[0], o[1] - a[1], o[2] - a[2])
            u = dot(tv, p) * inv
            q = cross(tv, e1)
            v = dot(d, q) * inv
            t = dot(q, e2) * inv
        hit = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)
        out[i:i + step] = hit.any(axis=1)
    return out


def _visibility(triangles: _Triangles, points, normal, skip):
    """A function of SES directions (K, 3) giving (K, P): whether each of ``points`` (just off
    the face along ``normal``) sees past what stands within ``NEAR_M`` of the pane along each
    (the reveal, the frame's bars, an overhang; what lies farther outside is not traced)."""
    origins = points + 1e-3 * normal
    centre = points.mean(axis=0)
    radius = NEAR_M + float(np.max(np.linalg.norm(points - centre, axis=1)))
    tris = triangles.near(centre, radius, skip)
    # only what stands before the face can shade it: triangles with a corner on its outer side,
    # within reach of its rays (the bounding boxes let through whole walls and columns)
    ahead = ((tris - centre) @ normal).max(axis=1) > 0
    near = np.linalg.norm(tris.mean(axis=1) - centre, axis=1) - np.linalg.norm(
        tris - tris.mean(axis=1, keepdims=True), axis=2).max(axis=1) < radius
    tris = tris[ahead & near]
    log.debug("glow: %d triangles shade a pane", len(tris))

    def visible(dirs_ses):
        d = np.asarray(dirs_ses, dtype=float) @ R_BLENDER_SES.T
        o = np.repeat(origins[None], len(d), axis=0).reshape(-1, 3)
        dd = np.repeat(d[:, None], len(origins), axis=1).reshape(-1, 3)
        return 1.0 - _blocked(o, dd, tris).reshape(len(d), len(origins))
    return visible


def irradiance_map(world: World, normal_ses, corners, visible_at, table=None, image=None, sun: bool = True):
    """(MV, MU, 3) irradiance over a pane's outer face, row j / column i at v = (j + 1/2) / MV,
    u = (i + 1/2) / MU of its corners' bilinear map (Blender's world, corners 0-1-2-3 at uv
    (0, 0), (1, 0), (1, 1), (0, 1): a QUAD's UVs; texels of at most ``MAP_TEXEL_M``): the sky
    over the face's hemisphere seen from 3 x 3 points, read between them (it changes slowly),
    plus the sun lamp at every texel (its shadow edges are sharp). ``visible_at(points)``:
    the visibility function of those points."""
    corners = np.asarray(corners, dtype=float)
    size = [max(np.linalg.norm(corners[1] - corners[0]), np.linalg.norm(corners[2] - corners[3])),
            max(np.linalg.norm(corners[3] - corners[0]), np.linalg.norm(corners[2] - corners[1]))]
    MU, MV = (int(np.clip(np.ceil(x / MAP_TEXEL_M), 1, MAP_MAX)) for x in size)

    def at(fu, fv):
        u, v = np.meshgrid(fu, fv)                     # rows: v
        u, v = u.ravel()[:, None], v.ravel()[:, None]
        return ((1 - u) * (1 - v) * corners[0] + u * (1 - v) * corners[1] + u * v * corners[2]
                + (1 - u) * v * corners[3])
    coarse = (np.arange(SKY_POINTS) + 0.5) / SKY_POINTS
    fu, fv = (np.arange(MU) + 0.5) / MU, (np.arange(MV) + 0.5) / MV
    open_sky = pure.daylight_irradiance(world, normal_ses, table, image, sun=False)
    sky = open_sky * pure.seen_share(world, normal_ses, visible_at(at(coarse, coarse)), table, image)   # (9, 3)
    sky = sky.reshape(SKY_POINTS, SKY_POINTS, 3)
    # bilinear between the 3 x 3 points (held beyond them), along u then along v
    rows = np.stack([np.stack([np.interp(fu, coarse, sky[j, :, c]) for c in range(3)], -1)
                     for j in range(SKY_POINTS)])                                # (3, MU, 3)
    E = np.stack([np.stack([np.interp(fv, coarse, rows[:, i, c]) for c in range(3)], -1)
                  for i in range(MU)], 1)                                        # (MV, MU, 3)
    lamp = pure.sky_sun_light(world) if world.kind == "sky" and sun else None
    if lamp is not None:
        towards = -np.asarray(lamp.direction, dtype=float)
        n = np.asarray(normal_ses, dtype=float) / np.linalg.norm(normal_ses)
        incidence = float(towards @ n)
        if incidence > 0:
            lit = visible_at(at(fu, fv))(towards[None])[0].reshape(MV, MU)
            E = E + np.asarray(lamp.colour) * lamp.strength * incidence * lit[..., None]
    return E


def _open_share(bscene, depsgraph, centre, normal, n: int = OPEN_RAYS) -> float:
    """The share of ``n`` rays over the hemisphere of ``normal`` from ``centre`` (just off the
    face) that leave the scene: 0 into a room, most of them out of a window (its reveal and
    bars stop a few)."""
    dirs = R_BLENDER_SES @ pure.fibonacci_directions(2 * n).T
    dirs = dirs.T[dirs.T @ normal > 0.05]
    origin = tuple(centre + 1e-3 * normal)
    return float(np.mean([not bscene.ray_cast(depsgraph, origin, tuple(d), distance=ESCAPE_M)[0] for d in dirs]))


def _map_image(name: str, gain: np.ndarray):
    """A float image (non-colour data) of ``gain`` (H, W, 3; row 0 at v = 0)."""
    h, w = gain.shape[:2]
    img = tag(bpy.data.images.new(name, w, h, alpha=False, float_buffer=True))
    img.colorspace_settings.name = "Non-Color"
    rgba = np.ones((h, w, 4), dtype=np.float32)
    rgba[..., :3] = gain
    img.pixels.foreach_set(rgba.ravel())
    img.pack()
    return img


def apply(built, scene: Scene, world: World, sun: bool, threads: int = 0) -> dict:
    """Set the emission of every object whose material glows; returns {object id: RGB radiance
    of the pane's own colour} (for tests and the log)."""
    glowing = [o for o in scene.objects if o.material and scene.material(o.material).glow]
    if not glowing:
        return {}
    bscene = built.scene
    table, image = world_arrays(bscene.world, world, threads)
    with bpy.context.temp_override(scene=bscene, view_layer=bscene.view_layers[0]):
        depsgraph = bpy.context.evaluated_depsgraph_get()
    triangles = _Triangles(depsgraph)
    copies: dict = {}
    radiance = {}
    for o in glowing:
        m = scene.material(o.material)
        passed = np.asarray(transmitted_colour(tuple(np.multiply(o.colour, m.colour)), entry(m.library.name)))
        for b in built.objects[o.id]:
            centre, normal, points = face_frame(b)
            seen = {side: _open_share(bscene, depsgraph, centre, side * normal) for side in (1.0, -1.0)}
            if seen[1.0] == seen[-1.0]:        # a tie: the side the open sky lights more
                E = {side: pure.daylight_irradiance(world, R_BLENDER_SES.T @ (side * normal), table, image, sun)
                     for side in (1.0, -1.0)}
                outer = max(E, key=lambda s: _luminance(tuple(E[s])))
            else:
                outer = max(seen, key=seen.get)
            n_ses = R_BLENDER_SES.T @ (outer * normal)
            skip = set(built.objects[o.id])

            def visible_at(pts, n=outer * normal, skip=skip):
                return _visibility(triangles, pts, n, skip)
            if isinstance(o, Quad):
                corners = np.asarray(o.vertices, dtype=float) @ R_BLENDER_SES.T
                E_map = irradiance_map(world, n_ses, corners, visible_at, table, image, sun)
            else:                                       # one value: the mean over its points
                E_map = pure.daylight_irradiance(world, n_ses, table, image, sun, n=pure.GLOW_SEEN_DIRECTIONS,
                                                 visible=lambda d: visible_at(points)(d).mean(axis=1))[None, None]
            E_mean = E_map.reshape(-1, 3).mean(axis=0)
            L = pure.glow_radiance(E_mean, passed)
            strength = float(_luminance(tuple(L)))
            gain = E_map / np.pi / strength if strength > 0 else np.zeros_like(E_map)
            for slot in b.material_slots:
                mat = slot.material
                if mat is None or library.GLOW_NODE not in compat.node_tree(mat).nodes:
                    continue
                copy = tag(mat.copy())
                copy.name = f"{mat.name}_glow{len(copies)}"
                nodes = compat.node_tree(copy).nodes
                nodes[library.GLOW_NODE].inputs["Strength"].default_value = strength
                nodes[library.GLOW_MAP_NODE].image = _map_image(f"{copy.name}_map", gain)
                copies[copy.name] = copy
                slot.link = "OBJECT"
                slot.material = copy
            radiance[o.id] = L
    return radiance
