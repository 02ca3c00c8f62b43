"""ASSET objects -> Blender: the pure generator's triangles become one mesh object with one
material slot per surface (blender_sesgen.scene.assets does all the geometry; nothing here
computes any). Importing this module registers the ASSET builder with ``shapes.build_shape``."""
from __future__ import annotations

import dataclasses

import bpy
import numpy as np
from mathutils import Matrix

from ..scene import assets, materials
from ..scene.assets import cache
from ..ses.materials import library_material
from ..contract.frames import object_pose, ses_to_blender_world
from ..errors import SesgenError
from ..scene.model import Asset, Material
from . import compat
from .datablocks import tag
from .shapes import ShapeContext, build_shape

def library_or_stand_in(name: str) -> Material:
    """The library material ``name`` with its defaults, or the asset-only material of that
    name (``assets.ASSET_MATERIALS``)."""
    if name in assets.ASSET_MATERIALS:
        return assets.ASSET_MATERIALS[name]
    if not materials.is_library_name(name):
        raise SesgenError(f"asset surface material '{name}' is neither a library material nor an asset material")
    return library_material(name)


def mesh_from_triangles(name: str, vertices: np.ndarray, faces: np.ndarray, tag=tag, face_surface=None,
                        smooth=None):
    """A Blender mesh holding exactly these triangles, in this order (no clean-up that
    could drop or reorder faces), with each triangle's material slot and smooth flag if given."""
    V = np.ascontiguousarray(vertices, dtype=np.float32)
    F = np.ascontiguousarray(faces, dtype=np.int32)
    me = tag(bpy.data.meshes.new(name))
    me.vertices.add(len(V))
    compat.set_mesh_array(me, "vertices", "co", V.ravel())
    me.loops.add(3 * len(F))
    compat.set_mesh_array(me, "loops", "vertex_index", F.ravel())
    me.polygons.add(len(F))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    if face_surface is not None:
        compat.set_mesh_array(me, "polygons", "material_index", np.ascontiguousarray(face_surface, dtype=np.int32))
    if smooth is not None:
        compat.set_mesh_array(me, "polygons", "use_smooth", np.ascontiguousarray(smooth, dtype=bool))
    me.update(calc_edges=True)
    if len(me.polygons) != len(F):
        raise SesgenError(f"{name}: Blender kept {len(me.polygons)} of {len(F)} triangles")
    return me


def surface_material(factory, obj: Asset, surface, index: int):
    """The Blender material of an asset's surface ``index``: the script's MATERIAL of that
    name, else the library material (the surface's colour, if it has one, replacing the
    library's); the main surface (0) takes the object's material, texture and colour, and so
    does a building's ground floor (part ``ground``) unless the object names a
    ``ground_material``, which it then takes alone."""
    name, tex, tint = surface.material, None, (1.0, 1.0, 1.0)
    main = index == 0 or surface.part == "ground"
    own = getattr(obj, "ground_material", None) if surface.part == "ground" else None
    if own:
        name, main = own, False
    elif main:
        name = obj.material or name
        tint, tex = obj.colour, obj.texture
    try:
        m = factory.scene.material(name)
    except KeyError:
        m = library_or_stand_in(name)
        if surface.colour is not None and not own and not (main and obj.material):
            m = dataclasses.replace(m, colour=tuple(surface.colour))
    if tex is not None and m.library is not None:
        m = dataclasses.replace(m, library=None)      # a texture tag: the plain textured material
    tex = tex if tex is not None else m.texture
    colour = tuple(float(c) for c in np.multiply(tint, m.colour))
    key = (tex, colour, m, False)
    if key not in factory.cache:
        factory.cache[key] = factory._make(f"sesgen_{name}", colour, tex, m)
    return factory.cache[key]


def build_asset(o: Asset, collection, surface_material_of, meshes: dict) -> object:
    """One Blender object for the ASSET ``o``; ``surface_material_of(surface, index)`` gives the
    Blender material of each surface (index 0 is the main one). Assets with the same kind,
    size, seed, bend, offset and material tags share one mesh (``meshes`` caches them per
    build): a forest of a dozen tree variants costs a dozen meshes, and Cycles instances them."""
    key = assets.mesh_key(o)
    me = meshes.get(key)
    if me is None:
        data = cache.generate(o.kind, o.size, o.seed, o.bend, o.offset)   # what an earlier process made
        me = mesh_from_triangles(f"{o.kind}_{o.seed}", data.vertices, data.faces, tag, data.face_surface, data.smooth)
        for i, s in enumerate(data.surfaces):
            me.materials.append(surface_material_of(s, i))
        me.update()
        meshes[key] = me
    obj = tag(bpy.data.objects.new(o.name, me))
    collection.objects.link(obj)
    obj.matrix_world = Matrix(ses_to_blender_world(object_pose(o.position, o.rotation_deg)).tolist())
    return obj


def keep_instanced(built, scene_objects, full_users: dict, tag=tag) -> int:
    """Give every asset mesh that the full scene shares between several objects but a culled
    build uses once a second user that no ray ever meets (visible to volume-scattering rays
    only, which these scenes never cast): Cycles then keeps it instanced, as in the full
    build, instead of baking its one object's transform into the vertices -- which would move
    the surface by float rounding and change depth in the last bits. Returns how many."""
    users: dict = {}
    for o in scene_objects:
        if isinstance(o, Asset) and o.id in built.objects:
            users.setdefault(assets.mesh_key(o), []).append(o.id)
    added = 0
    for key, ids in users.items():
        if len(ids) == 1 and full_users.get(key, 0) > 1:
            src = built.objects[ids[0]][0]
            twin = tag(bpy.data.objects.new(f"sesgen_instance_keeper_{ids[0]}", src.data))
            built.collection.objects.link(twin)
            twin.matrix_world = src.matrix_world.copy()
            for ray in ("camera", "diffuse", "glossy", "transmission", "shadow"):
                setattr(twin, f"visible_{ray}", False)
            twin.visible_volume_scatter = True            # not all off: Cycles would not export it at all
            added += 1
    return added


@build_shape.register
def _(o: Asset, ctx: ShapeContext) -> list:
    meshes = ctx.__dict__.setdefault("_asset_meshes", {})
    return [build_asset(o, ctx.collection, lambda s, i: surface_material(ctx.materials, o, s, i), meshes)]
