"""ASSET objects -> Blender: the pure generator's triangles become one mesh object with one
material slot per surface (blender_sesgen.assets does all the geometry; nothing here
computes any)."""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

from .. import assets, poses
from .. import textures as builtin_textures
from ..errors import SesgenError
from ..model import Asset, Material, TextureRef

# A plain stand-in per library material name, used only where the material library has no
# material of that name in this build (the library resolves names first).
_STAND_IN = {
    "asphalt": ((0.16, 0.16, 0.16), 0.9, "concrete"), "lane_marking": ((0.85, 0.85, 0.82), 0.7, None),
    "concrete": ((0.6, 0.59, 0.56), 0.85, "concrete"), "brick": ((0.6, 0.35, 0.27), 0.85, "bricks"),
    "plaster": ((0.85, 0.83, 0.78), 0.85, "concrete"), "roof_tiles": ((0.45, 0.22, 0.15), 0.7, None),
    "wood_planks": ((0.5, 0.35, 0.2), 0.6, "wood"), "metal_painted": ((0.6, 0.6, 0.6), 0.4, None),
    "metal_brushed": ((0.7, 0.7, 0.7), 0.3, None), "metal_rusty": ((0.45, 0.3, 0.2), 0.8, None),
    "glass_window": ((0.05, 0.06, 0.07), 0.05, None), "grass": ((0.25, 0.4, 0.12), 0.9, "blotches"),
    "leaves": ((0.22, 0.38, 0.1), 0.7, None), "bark": ((0.3, 0.24, 0.18), 0.9, "granite"),
    "soil": ((0.32, 0.25, 0.18), 0.95, "blotches"), "gravel": ((0.5, 0.48, 0.45), 0.9, "gravel"),
    "ceramic_tiles": ((0.8, 0.8, 0.78), 0.3, "tiles"), "fabric": ((0.5, 0.5, 0.5), 0.95, None),
    "plastic": ((0.5, 0.5, 0.5), 0.4, None), "rubber": ((0.05, 0.05, 0.05), 0.8, None),
    "chrome": ((0.9, 0.9, 0.9), 0.05, None), "car_paint": ((0.6, 0.6, 0.6), 0.2, None),
}


def stand_in(name: str) -> Material:
    colour, rough, tex = _STAND_IN.get(name, ((0.6, 0.6, 0.6), 0.6, None))
    ref = None
    if tex is not None:
        ref = TextureRef(kind="builtin", name=tex, number=builtin_textures.NAME_TO_NUMBER[tex], scale=0.5)
    return Material(name=name, colour=colour, roughness=rough, texture=ref,
                    metallic=1.0 if name in ("chrome", "metal_brushed") else 0.0)


def mesh_from_triangles(name: str, vertices: np.ndarray, faces: np.ndarray, tag):
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


def build_asset(o: Asset, collection, surface_material, tag) -> object:
    """One Blender object for the ASSET ``o``; ``surface_material(surface, index)`` gives the
    Blender material of each surface (index 0 is the main one)."""
    data = assets.generate(o.kind, o.size, o.seed, o.bend)
    me = mesh_from_triangles(o.name, data.vertices, data.faces, tag)
    for i, s in enumerate(data.surfaces):
        me.materials.append(surface_material(s, i))
    me.polygons.foreach_set("material_index", data.face_surface.astype(np.int32))
    me.polygons.foreach_set("use_smooth", data.smooth.astype(bool))
    me.update()
    obj = tag(bpy.data.objects.new(o.name, me))
    collection.objects.link(obj)
    obj.matrix_world = Matrix(poses.ses_to_blender_world(poses.object_pose(o.position, o.rotation_deg)).tolist())
    return obj
