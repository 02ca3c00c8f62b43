"""SES objects -> Blender geometry, one builder per shape (``build_shape`` dispatches on the
model's type; a new shape registers its builder).

Geometry, all in scene units, placed with ``contract.frames.object_pose`` and re-expressed in
Blender's Z-up world with ``contract.frames.ses_to_blender_world``:
- QUAD: one planar face through its 4 vertices (UVs (0,0) (1,0) (1,1) (0,1));
- CUBOID: a box of the exact edge lengths; with ``bevel``, the rounded box of
  ``blender_sesgen.scene.geometry.rounded_box`` (arcs as fine as a cylinder's, real geometry);
- SPHERE: a one-point point cloud (Cycles intersects it as an exact sphere: silhouette
  and depth are those of the ideal sphere, no tessellation at all) — but Cycles never hits
  a point from inside, so a sphere that a camera enters (a dome, a spherical room) is a
  smooth UV-sphere mesh with the cylinder's silhouette and depth tolerances instead;
- CYLINDER: a closed prism whose segment count keeps the silhouette within
  ``SILHOUETTE_TOLERANCE_PX`` of the ideal cylinder from the closest camera position and
  the depth of its side within ``DEPTH_TOLERANCE_REL`` (relative) of the ideal surface;
- MESH: imported OBJ/PLY/STL/glTF, file coordinates taken as SES-local (Y up).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from functools import singledispatch

import bpy
import numpy as np
from mathutils import Matrix

from ..scene import dynamics
from ..contract.frames import R_BLENDER_SES, object_pose, ses_to_blender_world
from ..contract.se3 import invert
from ..errors import SesgenError
from ..scene.model import Cuboid, Cylinder, Mesh, Quad, Scene, SceneObject, Sphere
from ..scene.geometry.rounded_box import rounded_box
from .datablocks import tag
from .materials import MaterialFactory
from .runtime import quiet_stdout

SILHOUETTE_TOLERANCE_PX = 0.25
DEPTH_TOLERANCE_REL = 2e-5  # the prism's radial error r(1 - cos(pi/n)) / closest distance
MAX_SEGMENTS = 4096
MAX_SPHERE_SEGMENTS = 1024  # a UV sphere of 1024 x 512 faces


@dataclass
class ShapeContext:
    """What every shape builder may need: the scene, where to link objects, the materials,
    the largest focal length in use (for tessellation tolerances), and what it records."""
    scene: Scene
    collection: object
    materials: MaterialFactory
    focal_px: float
    segments: dict = field(default_factory=dict)  # id -> segment count of tessellated shapes


def segments_for(radius: float, min_distance: float, focal_px: float,
                 tolerance_px: float = SILHOUETTE_TOLERANCE_PX,
                 depth_tolerance_rel: float = DEPTH_TOLERANCE_REL) -> int:
    """Sides of a regular polygon inscribed in a circle of ``radius`` whose radial error
    r(1 - cos(pi/n)), seen from ``min_distance`` with ``focal_px``, is at most ``tolerance_px``
    and at most ``depth_tolerance_rel`` of ``min_distance`` (so ground-truth depth on the
    curved side is that of the ideal cylinder to that relative error)."""
    d = max(min_distance, 1e-9)
    max_err = min(tolerance_px * d / focal_px, depth_tolerance_rel * d)
    if max_err >= radius:
        return 8
    n = math.ceil(math.pi / math.acos(1.0 - max_err / radius))
    return int(min(max(n, 8), MAX_SEGMENTS))


def _camera_centre_distances(scene: Scene, obj: SceneObject, centre) -> np.ndarray:
    """Distances from every camera of every frame to the object's centre at that frame
    (a moving object's centre moves with its object frame)."""
    cams = [scene.timeline.left()[:, :3, 3]]
    if scene.rig.stereo:
        cams.append(scene.timeline.right(scene.rig.baseline)[:, :3, 3])
    motion = scene.motion_of(obj.id)
    if motion is None:
        C = np.asarray(centre, dtype=float)[None]
    else:  # the centre in the object frame, carried by T_world_obj(k)
        c_obj = invert(dynamics.rest_pose(obj)) @ np.append(np.asarray(centre, dtype=float), 1.0)
        C = (motion.poses() @ c_obj)[:, :3]
    return np.concatenate([np.linalg.norm(P - C, axis=1) for P in cams])


def _min_camera_distance(scene: Scene, obj: SceneObject, centre, bounding_radius: float) -> float:
    d = float(np.min(_camera_centre_distances(scene, obj, centre))) - bounding_radius
    return max(d, scene.rig.near)


def _mesh_object(name: str, verts, faces, uvs, collection, smooth_faces=()):
    me = tag(bpy.data.meshes.new(name))
    me.from_pydata([tuple(map(float, v)) for v in verts], [], [tuple(f) for f in faces])
    if uvs is not None:
        layer = me.uv_layers.new(name="UVMap")
        layer.data.foreach_set("uv", np.asarray(uvs, dtype=np.float32).reshape(-1))
    if smooth_faces:
        flags = np.zeros(len(me.polygons), dtype=bool)
        flags[list(smooth_faces)] = True
        me.polygons.foreach_set("use_smooth", flags)
    me.validate()
    me.update()
    obj = tag(bpy.data.objects.new(name, me))
    collection.objects.link(obj)
    return obj


def _set_world_matrix(obj, T_world_obj_ses: np.ndarray) -> None:
    obj.matrix_world = Matrix(ses_to_blender_world(T_world_obj_ses).tolist())


def build_quad(q: Quad, collection):
    V = np.asarray(q.vertices, dtype=float)
    c = V.mean(axis=0)
    obj = _mesh_object(q.name, V - c, [(0, 1, 2, 3)], [(0, 0), (1, 0), (1, 1), (0, 1)], collection)
    _set_world_matrix(obj, object_pose(c))
    return obj


def build_cuboid(b: Cuboid, collection):
    sx, sy, sz = (s / 2.0 for s in b.size)
    verts = [(x, y, z) for x in (-sx, sx) for y in (-sy, sy) for z in (-sz, sz)]
    # vertex index = 4*ix + 2*iy + iz; faces with outward normals
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    uvs = [(0, 0), (1, 0), (1, 1), (0, 1)] * 6
    obj = _mesh_object(b.name, verts, faces, uvs, collection)
    _set_world_matrix(obj, object_pose(b.position, b.rotation_deg))
    return obj


def build_rounded_cuboid(b: Cuboid, collection, quarter_segments: int):
    """A CUBOID with ``bevel``: the rounded box of ``rounded_box`` (real geometry), smooth
    shaded with its exact surface normals."""
    V, faces, N = rounded_box(b.size, b.bevel, quarter_segments)
    obj = _mesh_object(b.name, V, faces, None, collection, smooth_faces=range(len(faces)))
    obj.data.normals_split_custom_set_from_vertices([tuple(map(float, n)) for n in N])
    _set_world_matrix(obj, object_pose(b.position, b.rotation_deg))
    return obj


def _sphere_node_group(radius: float, material):
    ng = tag(bpy.data.node_groups.new("sesgen_sphere", "GeometryNodeTree"))
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    out = ng.nodes.new("NodeGroupOutput")
    pts = ng.nodes.new("GeometryNodePoints")
    pts.inputs["Count"].default_value = 1
    pts.inputs["Radius"].default_value = float(radius)
    sm = ng.nodes.new("GeometryNodeSetMaterial")
    sm.inputs["Material"].default_value = material
    ng.links.new(pts.outputs["Geometry"], sm.inputs["Geometry"])
    ng.links.new(sm.outputs["Geometry"], out.inputs[0])
    return ng


def build_sphere(s: Sphere, collection, material):
    me = tag(bpy.data.meshes.new(s.name))
    obj = tag(bpy.data.objects.new(s.name, me))
    collection.objects.link(obj)
    mod = obj.modifiers.new("sesgen_sphere", "NODES")
    mod.node_group = _sphere_node_group(s.radius, material)
    _set_world_matrix(obj, object_pose(s.position, s.rotation_deg))
    return obj


def _cameras_inside(scene: Scene, obj: SceneObject, centre, radius: float) -> tuple[bool, float]:
    """Whether any camera of the sequence is inside the sphere, and the closest any camera
    gets to its surface (from either side; a moving sphere's centre moves)."""
    dist = _camera_centre_distances(scene, obj, centre)
    return bool(np.any(dist < radius)), max(float(np.min(np.abs(dist - radius))), scene.rig.near)


def build_sphere_mesh(s: Sphere, collection, n: int):
    """A smooth UV sphere with ``n`` segments around and n/2 from pole to pole (vertices on
    the ideal sphere); its texture coordinates come from the shader, as for point spheres."""
    n_lat = max(n // 2, 4)
    lat = np.pi * np.arange(1, n_lat) / n_lat                  # rings between the poles
    lon = 2 * np.pi * np.arange(n) / n
    ring = np.stack([np.outer(np.sin(lat), np.cos(lon)), np.repeat(np.cos(lat)[:, None], n, 1),
                     -np.outer(np.sin(lat), np.sin(lon))], axis=-1).reshape(-1, 3)
    verts = np.concatenate([[(0, 1, 0)], ring, [(0, -1, 0)]]) * s.radius
    south = len(verts) - 1
    idx = lambda i, j: 1 + i * n + j % n  # noqa: E731 - ring i, meridian j
    faces = [(0, idx(0, j), idx(0, j + 1)) for j in range(n)]
    faces += [(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)) for i in range(n_lat - 2) for j in range(n)]
    faces += [(south, idx(n_lat - 2, j + 1), idx(n_lat - 2, j)) for j in range(n)]
    obj = _mesh_object(s.name, verts, faces, None, collection, smooth_faces=range(len(faces)))
    _set_world_matrix(obj, object_pose(s.position, s.rotation_deg))
    return obj


def build_cylinder(c: Cylinder, collection, n: int):
    r, h2 = c.radius, c.height / 2.0
    ang = 2 * np.pi * np.arange(n) / n
    ring = np.stack([r * np.cos(ang), np.zeros(n), -r * np.sin(ang)], axis=1)  # CCW seen from +Y
    bottom, top = ring + (0, -h2, 0), ring + (0, h2, 0)
    verts = np.concatenate([bottom, top])
    sides = [(i, (i + 1) % n, n + (i + 1) % n, n + i) for i in range(n)]
    cap_top = tuple(range(n, 2 * n))
    cap_bottom = tuple(reversed(range(n)))
    faces = sides + [cap_top, cap_bottom]
    uvs = []
    for i in range(n):
        u0, u1 = i / n, (i + 1) / n
        uvs += [(u0, 0), (u1, 0), (u1, 1), (u0, 1)]
    uvs += [(0.5 + 0.5 * np.cos(a), 0.5 + 0.5 * np.sin(a)) for a in ang]
    uvs += [(0.5 + 0.5 * np.cos(a), 0.5 - 0.5 * np.sin(a)) for a in ang[::-1]]
    obj = _mesh_object(c.name, verts, faces, uvs, collection, smooth_faces=range(n))
    _set_world_matrix(obj, object_pose(c.position, c.rotation_deg))
    return obj


_IMPORTERS = {
    ".obj": lambda p: bpy.ops.wm.obj_import(filepath=p, forward_axis="Y", up_axis="Z"),
    ".ply": lambda p: bpy.ops.wm.ply_import(filepath=p, forward_axis="Y", up_axis="Z"),
    ".stl": lambda p: bpy.ops.wm.stl_import(filepath=p, forward_axis="Y", up_axis="Z"),
    ".gltf": lambda p: bpy.ops.import_scene.gltf(filepath=p),
    ".glb": lambda p: bpy.ops.import_scene.gltf(filepath=p),
}


def build_mesh(m: Mesh, collection, material) -> list:
    """Import a mesh file; its coordinates are SES-local (Y up), scaled then placed."""
    ext = os.path.splitext(m.path)[1].lower()
    if ext not in _IMPORTERS:
        raise SesgenError(f"MESH {m.name}: unsupported file type '{ext}' (OBJ, PLY, STL, glTF)")
    if not os.path.isfile(m.path):
        raise SesgenError(f"MESH {m.name}: file not found: {m.path}")
    before = set(bpy.data.objects)
    owned_before = {name: set(getattr(bpy.data, name)) for name in ("materials", "images", "node_groups")}
    try:
        with quiet_stdout():
            result = _IMPORTERS[ext](m.path)
    except Exception as e:  # importer errors are bad input
        raise SesgenError(f"MESH {m.name}: cannot import {m.source}: {e}") from None
    if "FINISHED" not in result:
        raise SesgenError(f"MESH {m.name}: cannot import {m.source}")
    new = [o for o in bpy.data.objects if o not in before]
    for name, old in owned_before.items():   # the file's own materials and textures: ours to remove on rebuild
        for idb in set(getattr(bpy.data, name)) - old:
            tag(idb)
    # glTF is Y up by definition and its importer turns it Z up: undo that (back to file axes)
    C = np.eye(4)
    if ext in (".gltf", ".glb"):
        C[:3, :3] = R_BLENDER_SES.T
    S = np.diag([*m.scale, 1.0])
    place = ses_to_blender_world(object_pose(m.position, m.rotation_deg)) @ S @ C
    kept = []
    for o in new:
        for coll in list(o.users_collection):
            coll.objects.unlink(o)
        if o.type != "MESH":
            bpy.data.objects.remove(o)
            continue
        tag(o)
        if o.data is not None:
            tag(o.data)
        kept.append((o, np.array(o.matrix_world)))
    for i, (o, W) in enumerate(kept):  # named after the script, not the file
        o.name = m.name if len(kept) == 1 else f"{m.name}_{i}"
        o.data.name = o.name
        o.parent = None
        collection.objects.link(o)
        o.matrix_world = Matrix((place @ W).tolist())
        if material is not None:
            o.data.materials.clear()
            o.data.materials.append(material)
    if not kept:
        raise SesgenError(f"MESH {m.name}: {m.source} holds no mesh")
    return [o for o, _ in kept]


# --- one builder per shape ----------------------------------------------------------------

@singledispatch
def build_shape(o: SceneObject, ctx: ShapeContext) -> list:
    """Blender objects (with their materials) of one SES object."""
    raise SesgenError(f"unsupported object shape '{o.shape}'")


def _with_material(obj, o: SceneObject, ctx: ShapeContext) -> list:
    obj.data.materials.append(ctx.materials.get(o))
    return [obj]


@build_shape.register
def _(o: Quad, ctx: ShapeContext) -> list:
    return _with_material(build_quad(o, ctx.collection), o, ctx)


@build_shape.register
def _(o: Cuboid, ctx: ShapeContext) -> list:
    if o.bevel <= 0:
        return _with_material(build_cuboid(o, ctx.collection), o, ctx)
    bound = float(np.linalg.norm(o.size)) / 2.0
    n = segments_for(o.bevel, _min_camera_distance(ctx.scene, o, o.position, bound), ctx.focal_px)
    # per quarter arc, even; sqrt 2 finer than a cylinder's step, so that a corner cell's
    # diagonal deviates no more than a cylinder's side
    ctx.segments[o.id] = 2 * math.ceil(math.sqrt(2) * n / 8)
    return _with_material(build_rounded_cuboid(o, ctx.collection, ctx.segments[o.id]), o, ctx)


@build_shape.register
def _(o: Sphere, ctx: ShapeContext) -> list:
    inside, d_surface = _cameras_inside(ctx.scene, o, o.position, o.radius)
    if not inside:
        return [build_sphere(o, ctx.collection, ctx.materials.get(o))]
    n = min(segments_for(o.radius, d_surface, ctx.focal_px), MAX_SPHERE_SEGMENTS)
    ctx.segments[o.id] = n
    return _with_material(build_sphere_mesh(o, ctx.collection, n), o, ctx)


@build_shape.register
def _(o: Cylinder, ctx: ShapeContext) -> list:
    bound = math.hypot(o.radius, o.height / 2.0)
    n = segments_for(o.radius, _min_camera_distance(ctx.scene, o, o.position, bound), ctx.focal_px)
    ctx.segments[o.id] = n
    return _with_material(build_cylinder(o, ctx.collection, n), o, ctx)


@build_shape.register
def _(o: Mesh, ctx: ShapeContext) -> list:
    custom = o.texture is not None or o.material is not None or tuple(o.colour) != (1.0, 1.0, 1.0)
    return build_mesh(o, ctx.collection, ctx.materials.get(o) if custom else None)
