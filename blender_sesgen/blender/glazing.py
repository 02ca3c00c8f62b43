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

The build's cost (issue 29): the rays from a pane's points are tested only against the
triangles whose footprint along each direction can hold them (``scene/occlusion.py``, the
same answers as every ray against every triangle), each normal's open sky once, and each map
is kept in the asset cache (kind ``glow``) under everything it depends on (``map_key``: the
code, the world and its sky table's or HDRI's values, the sun, the pane, the triangles that can
shade it), so a warm build reads it; what the outer side is (rays through the whole scene)
is found again each build.
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import logging
from pathlib import Path

import bpy
import numpy as np

from ..contract.frames import R_BLENDER_SES
from ..scene import lighting as pure
from ..scene import occlusion
from ..scene.assets import cache
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
        self.items, self.meshes, self.placed = [], {}, {}
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
            if k not in self.placed:             # a pane's two point sets reach the same ones
                if mesh.name not in self.meshes:
                    mesh.calc_loop_triangles()
                    co = np.empty(3 * len(mesh.vertices))
                    mesh.vertices.foreach_get("co", co)
                    idx = np.empty(3 * len(mesh.loop_triangles), dtype=np.int64)
                    mesh.loop_triangles.foreach_get("vertices", idx)
                    self.meshes[mesh.name] = co.reshape(-1, 3)[idx.reshape(-1, 3)]
                self.placed[k] = self.meshes[mesh.name] @ M[:3, :3].T + M[:3, 3]
            tris.append(self.placed[k])
        return np.concatenate(tris) if tris else np.zeros((0, 3, 3))


def _occluders(triangles: _Triangles, points, normal, skip) -> np.ndarray:
    """(T, 3, 3): what can shade ``points`` (on a face with outward ``normal``) from within
    ``NEAR_M`` of them (beyond the face's own extent): the reveal, the frame's bars, an
    overhang (what lies farther outside is not traced)."""
    centre = points.mean(axis=0)
    radius = NEAR_M + float(np.max(np.linalg.norm(points - centre, axis=1)))
    # the bounding boxes let through whole walls and columns: only triangles before the face
    tris = occlusion.shading_triangles(triangles.near(centre, radius, skip), centre, normal, radius)
    log.debug("glow: %d triangles shade a pane", len(tris))
    return tris


def _visibility(points, normal, tris, stats: dict | None = None):
    """A function of SES directions (K, 3) giving (K, P): whether each of ``points`` (just off
    the face along ``normal``) sees past ``tris`` along each."""
    origins = points + 1e-3 * normal

    def visible(dirs_ses):
        d = np.asarray(dirs_ses, dtype=float) @ R_BLENDER_SES.T
        return 1.0 - occlusion.blocked_grid(origins, d, tris, stats)
    return visible


def _map_size(corners) -> tuple[int, int]:
    """(MU, MV): a QUAD's map texels along u and v (at most ``MAP_TEXEL_M``, ``MAP_MAX``)."""
    size = [max(np.linalg.norm(corners[1] - corners[0]), np.linalg.norm(corners[2] - corners[3])),
            max(np.linalg.norm(corners[3] - corners[0]), np.linalg.norm(corners[2] - corners[1]))]
    MU, MV = (int(np.clip(np.ceil(x / MAP_TEXEL_M), 1, MAP_MAX)) for x in size)
    return MU, MV


def _at(corners, fu, fv) -> np.ndarray:
    """The points at (fu x fv) of the corners' bilinear map, rows along v."""
    u, v = np.meshgrid(fu, fv)                     # rows: v
    u, v = u.ravel()[:, None], v.ravel()[:, None]
    return ((1 - u) * (1 - v) * corners[0] + u * (1 - v) * corners[1] + u * v * corners[2]
            + (1 - u) * v * corners[3])


_COARSE = (np.arange(SKY_POINTS) + 0.5) / SKY_POINTS


def pane_points(corners) -> tuple[np.ndarray, np.ndarray]:
    """(the 3 x 3 points whose view of the sky is traced, the map's texel centres) of a
    QUAD's ``corners`` (Blender's world)."""
    corners = np.asarray(corners, dtype=float)
    MU, MV = _map_size(corners)
    return _at(corners, _COARSE, _COARSE), _at(corners, (np.arange(MU) + 0.5) / MU, (np.arange(MV) + 0.5) / MV)


class Daylight:
    """The world's daylight on faces (``world``, its sky ``table`` or HDRI ``image``, whether
    the ``sun`` is a lamp): each normal's open sky and hemisphere computed once (a hall's
    panes face four ways)."""

    def __init__(self, world: World, table=None, image=None, sun: bool = True):
        self.world, self.sun = world, sun
        # read as float64 once (world_radiance reads them so each time: the same values)
        self.table = None if table is None else np.asarray(table, dtype=float)
        self.image = None if image is None else np.asarray(image, dtype=float)
        self.lamp = pure.sky_sun_light(world) if world.kind == "sky" and sun else None
        self._open, self._hemisphere = {}, {}

    def open_sky(self, normal_ses) -> np.ndarray:
        """The open sky's irradiance on a face (no sun): ``daylight_irradiance``'s."""
        key = tuple(np.ravel(normal_ses).tolist())
        if key not in self._open:
            self._open[key] = pure.daylight_irradiance(self.world, normal_ses, self.table, self.image, sun=False)
        return self._open[key]

    def seen_share(self, normal_ses, visible) -> np.ndarray:
        """``lighting.seen_share`` of the face, its directions and their radiance read once."""
        key = tuple(np.ravel(normal_ses).tolist())
        if key not in self._hemisphere:
            self._hemisphere[key] = pure.sky_hemisphere(self.world, normal_ses, self.table, self.image)
        return pure.seen_share(self.world, normal_ses, visible, hemisphere=self._hemisphere[key])


def irradiance_map(daylight: Daylight, normal_ses, corners, visible_at) -> np.ndarray:
    """(MV, MU, 3) irradiance over a pane's outer face, row j / column i at v = (j + 1/2) / MV,
    u = (i + 1/2) / MU of its corners' bilinear map (Blender's world, corners 0-1-2-3 at uv
    (0, 0), (1, 0), (1, 1), (0, 1): a QUAD's UVs; texels of at most ``MAP_TEXEL_M``): the sky
    over the face's hemisphere seen from 3 x 3 points, read between them (it changes slowly),
    plus the sun lamp at every texel (its shadow edges are sharp). ``visible_at(points)``:
    the visibility function of those points (``pane_points``)."""
    corners = np.asarray(corners, dtype=float)
    MU, MV = _map_size(corners)
    coarse_points, texels = pane_points(corners)
    fu, fv = (np.arange(MU) + 0.5) / MU, (np.arange(MV) + 0.5) / MV
    sky = daylight.open_sky(normal_ses) * daylight.seen_share(normal_ses, visible_at(coarse_points))   # (9, 3)
    sky = sky.reshape(SKY_POINTS, SKY_POINTS, 3)
    # bilinear between the 3 x 3 points (held beyond them), along u then along v
    rows = pure.interp_rows(fu, _COARSE, sky.transpose(0, 2, 1))              # (3, 3 colours, MU)
    E = pure.interp_rows(fv, _COARSE, rows.transpose(2, 1, 0)).transpose(2, 0, 1)   # (MV, MU, 3)
    lamp = daylight.lamp
    if lamp is not None:
        towards = -np.asarray(lamp.direction, dtype=float)
        n = np.asarray(normal_ses, dtype=float) / np.linalg.norm(normal_ses)
        incidence = float(towards @ n)
        if incidence > 0:
            lit = visible_at(texels)(towards[None])[0].reshape(MV, MU)
            E = E + np.asarray(lamp.colour) * lamp.strength * incidence * lit[..., None]
    return E


def _escapes(bscene, depsgraph, centre, normal, n: int = OPEN_RAYS):
    """(how many, an iterator of whether each leaves the scene) of ``n`` rays over the
    hemisphere of ``normal`` from ``centre`` (just off the face): none leave into a room, most
    of them out of a window (its reveal and bars stop a few)."""
    dirs = R_BLENDER_SES @ pure.fibonacci_directions(2 * n).T
    dirs = dirs.T[dirs.T @ normal > 0.05]
    origin = tuple(centre + 1e-3 * normal)
    return len(dirs), (not bscene.ray_cast(depsgraph, origin, tuple(d), distance=ESCAPE_M)[0] for d in dirs)


def _outer_side(bscene, depsgraph, centre, normal) -> float | None:
    """+1 or -1: the side of a face (along ``normal``) whose rays leave the scene more often
    (``_escapes``' share), None for a tie; the second side's rays stop once the answer is
    known."""
    n, rays = _escapes(bscene, depsgraph, centre, normal)
    front = sum(rays) / n if n else float("nan")
    n, rays = _escapes(bscene, depsgraph, centre, -normal)
    left, count = n, 0
    for ray in rays:
        count, left = count + ray, left - 1
        if count / n > front:              # the back's share can only grow
            return -1.0
        if (count + left) / n < front:     # ... or stay below this
            return 1.0
    back = count / n if n else float("nan")
    return None if back == front else (1.0 if not back > front else -1.0)


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


# what a pane's irradiance map is computed by (a change to any of them misses the cache)
_SOURCES = ("blender/glazing.py", "scene/lighting.py", "scene/occlusion.py", "contract/frames.py")
MAPS_KEPT = 1024     # irradiance maps kept in the cache (~30 KB each: the hall has 26)


@functools.lru_cache(maxsize=1)
def _code_version() -> str | None:
    """A hash of ``_SOURCES`` and numpy's version; None where the sources cannot be read (a
    package without its .py files): then the maps are not cached."""
    root = Path(__file__).resolve().parents[1]
    return cache.sources_digest(np.__version__, ((name, root / name) for name in _SOURCES))


def _digest(a) -> str | None:
    return None if a is None else hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()


def world_key(world: World, table, image, sun: bool) -> list:
    """What every pane's irradiance map depends on: the code, the world (its fields, the sky
    table's and the HDRI's values) and whether the sun is a lamp."""
    return [_code_version(), dataclasses.asdict(world), _digest(table), _digest(image), bool(sun)]


def map_key(world_part: list, normal_ses, shape, occluders) -> list:
    """What a pane's irradiance map depends on, exactly: ``world_key``'s ``world_part``, the
    outer normal, the pane (a QUAD's corners or another face's points) and the triangles that
    can shade each of its point sets."""
    return world_part + [[float(x) for x in np.ravel(normal_ses)], [float(x) for x in np.ravel(shape)],
                         [[len(t), _digest(np.asarray(t, dtype=float))] for t in occluders]]


def _cached_map(key, make, shape) -> np.ndarray:
    """``make()`` (an irradiance map of ``shape``), kept in the asset cache under ``key``."""
    def valid(a: np.ndarray) -> bool:
        return a.shape == shape and a.dtype == np.float64 and bool(np.isfinite(a).all())
    if cache.folder() is None or _code_version() is None:
        return make()
    return cache.cached_array("glow", key(), make, valid, keep=MAPS_KEPT)


def apply(built, scene: Scene, world: World, sun: bool, threads: int = 0, stats: dict | None = None) -> dict:
    """Set the emission of every object whose material glows; returns {object id: RGB radiance
    of the pane's own colour} (for tests and the log). Each pane's irradiance map comes from
    the asset cache where an earlier build made it from the same inputs (``map_key``).
    ``stats``: gets the ray-triangle tests made (``tests``; ``all``: every ray against every
    occluder's)."""
    glowing = [o for o in scene.objects if o.material and scene.material(o.material).glow]
    if not glowing:
        return {}
    bscene = built.scene
    table, image = world_arrays(bscene.world, world, threads)
    daylight = Daylight(world, table, image, sun)
    table64, image64 = daylight.table, daylight.image
    with bpy.context.temp_override(scene=bscene, view_layer=bscene.view_layers[0]):
        depsgraph = bpy.context.evaluated_depsgraph_get()
    triangles = _Triangles(depsgraph)
    world_part = functools.cache(lambda: world_key(world, table, image, sun))
    copies: dict = {}
    radiance = {}
    for o in glowing:
        m = scene.material(o.material)
        passed = np.asarray(transmitted_colour(tuple(np.multiply(o.colour, m.colour)), entry(m.library.name)))
        for b in built.objects[o.id]:
            centre, normal, points = face_frame(b)
            outer = _outer_side(bscene, depsgraph, centre, normal)
            if outer is None:        # a tie: the side the open sky lights more
                E = {side: pure.daylight_irradiance(world, R_BLENDER_SES.T @ (side * normal), table64, image64, sun)
                     for side in (1.0, -1.0)}
                outer = max(E, key=lambda s: _luminance(tuple(E[s])))
            n_ses = R_BLENDER_SES.T @ (outer * normal)
            skip = set(built.objects[o.id])
            if isinstance(o, Quad):
                corners = np.asarray(o.vertices, dtype=float) @ R_BLENDER_SES.T
                sets, shape = pane_points(corners), corners
                size = _map_size(corners)[::-1] + (3,)
            else:
                sets, shape, size = (points,), points, (1, 1, 3)
            occ = {p.tobytes(): _occluders(triangles, p, outer * normal, skip) for p in sets}

            def visible_at(pts, n=outer * normal, skip=skip, occ=occ):
                tris = occ.get(pts.tobytes())
                return _visibility(pts, n, _occluders(triangles, pts, n, skip) if tris is None else tris, stats)

            def make(o=o, corners=shape, points=points, n_ses=n_ses, visible_at=visible_at):
                if isinstance(o, Quad):
                    return irradiance_map(daylight, n_ses, corners, visible_at)
                seen_at = visible_at(points)                # one value: the mean over its points
                return pure.daylight_irradiance(world, n_ses, table64, image64, sun, n=pure.GLOW_SEEN_DIRECTIONS,
                                                visible=lambda d: seen_at(d).mean(axis=1))[None, None]
            E_map = _cached_map(lambda: map_key(world_part(), n_ses, shape, occ.values()), make, size)
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
