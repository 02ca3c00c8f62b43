"""ASSET objects -> Blender: the pure generator's triangles become one mesh object with one
material slot per surface (blender_sesgen.assets does all the geometry; nothing here
computes any). Importing this module registers the ASSET builder with ``shapes.build_shape``."""
from __future__ import annotations

import dataclasses

import bpy
import numpy as np
from mathutils import Matrix

from .. import assets
from ..contract.frames import object_pose, ses_to_blender_world
from ..errors import SesgenError
from ..model import Asset, Material
from .datablocks import tag
from .shapes import ShapeContext, build_shape

# A plain stand-in per library material name (linear albedo, roughness, metallic), used
# only where this build's material library lacks the name.
_STAND_IN = {
    "asphalt": ((0.085, 0.085, 0.082), 0.88, 0.0), "lane_marking": ((0.72, 0.72, 0.7), 0.55, 0.0),
    "concrete": ((0.38, 0.37, 0.35), 0.85, 0.0), "brick": ((0.3, 0.11, 0.06), 0.85, 0.0),
    "plaster": ((0.62, 0.58, 0.52), 0.8, 0.0), "roof_tiles": ((0.28, 0.085, 0.045), 0.75, 0.0),
    "wood_planks": ((0.33, 0.19, 0.09), 0.45, 0.0), "ceramic_tiles": ((0.62, 0.62, 0.6), 0.12, 0.0),
    "fabric": ((0.18, 0.2, 0.26), 0.9, 0.0), "plastic": ((0.55, 0.55, 0.55), 0.35, 0.0),
    "rubber": ((0.035, 0.035, 0.035), 0.85, 0.0), "metal_painted": ((0.12, 0.22, 0.16), 0.4, 0.0),
    "metal_brushed": ((0.58, 0.58, 0.58), 0.3, 1.0), "metal_rusty": ((0.3, 0.3, 0.29), 0.5, 1.0),
    "chrome": ((0.55, 0.56, 0.55), 0.05, 1.0), "car_paint": ((0.05, 0.09, 0.2), 0.35, 0.5),
    "glass_window": ((0.035, 0.038, 0.04), 0.03, 0.0), "grass": ((0.06, 0.1, 0.03), 0.9, 0.0),
    "leaves": ((0.05, 0.09, 0.025), 0.6, 0.0), "bark": ((0.13, 0.1, 0.08), 0.9, 0.0),
    "soil": ((0.14, 0.1, 0.07), 0.95, 0.0), "gravel": ((0.3, 0.28, 0.25), 0.85, 0.0),
}


def library_or_stand_in(name: str) -> Material:
    """The library material ``name`` with its defaults (a plain stand-in where the library
    of this build has no such entry)."""
    colour, rough, metallic = _STAND_IN.get(name, ((0.5, 0.5, 0.5), 0.6, 0.0))
    return Material(name=name, colour=colour, roughness=rough, metallic=metallic)


def mesh_from_triangles(name: str, vertices: np.ndarray, faces: np.ndarray, tag=tag):
    """A Blender mesh holding exactly these triangles, in this order (no clean-up that
    could drop or reorder faces)."""
    V = np.ascontiguousarray(vertices, dtype=np.float32)
    F = np.ascontiguousarray(faces, dtype=np.int32)
    me = tag(bpy.data.meshes.new(name))
    me.vertices.add(len(V))
    me.vertices.foreach_set("co", V.ravel())
    me.loops.add(3 * len(F))
    me.loops.foreach_set("vertex_index", F.ravel())
    me.polygons.add(len(F))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    me.update(calc_edges=True)
    if len(me.polygons) != len(F):
        raise SesgenError(f"{name}: Blender kept {len(me.polygons)} of {len(F)} triangles")
    return me


def surface_material(factory, obj: Asset, surface, index: int):
    """The Blender material of an asset's surface ``index``: the script's MATERIAL of that
    name, else the library material (the surface's colour, if it has one, replacing the
    library's); the main surface (0) takes the object's material, texture and colour."""
    name, tex, tint = surface.material, None, (1.0, 1.0, 1.0)
    if index == 0:
        name = obj.material or name
        tint, tex = obj.colour, obj.texture
    try:
        m = factory.scene.material(name)
    except KeyError:
        m = library_or_stand_in(name)
        if surface.colour is not None and not (index == 0 and obj.material):
            m = dataclasses.replace(m, colour=tuple(surface.colour))
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
    key = (o.kind, tuple(o.size), o.seed, tuple(o.bend), o.offset, o.material, tuple(o.colour), o.texture)
    me = meshes.get(key)
    if me is None:
        data = assets.generate(o.kind, o.size, o.seed, o.bend, o.offset)
        me = mesh_from_triangles(f"{o.kind}_{o.seed}", data.vertices, data.faces, tag)
        for i, s in enumerate(data.surfaces):
            me.materials.append(surface_material_of(s, i))
        me.polygons.foreach_set("material_index", data.face_surface.astype(np.int32))
        me.polygons.foreach_set("use_smooth", data.smooth.astype(bool))
        me.update()
        meshes[key] = me
    obj = tag(bpy.data.objects.new(o.name, me))
    collection.objects.link(obj)
    obj.matrix_world = Matrix(ses_to_blender_world(object_pose(o.position, o.rotation_deg)).tolist())
    return obj


@build_shape.register
def _(o: Asset, ctx: ShapeContext) -> list:
    meshes = ctx.__dict__.setdefault("_asset_meshes", {})
    return [build_asset(o, ctx.collection, lambda s, i: surface_material(ctx.materials, o, s, i), meshes)]
