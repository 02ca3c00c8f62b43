"""The ``gt`` preset's flat shading: every object drawn in its own colour under a head-light.

One override material for the whole view layer (``view_layer.material_override``): an
emission of the object's colour (``Object.color``, read by the Object Info node) times
``0.4 + 0.6 |cos θ|``, θ the angle between the surface normal and the camera ray. Lights are
hidden and the world is not importance-sampled, so a camera ray costs one intersection and a
few shader nodes: ground truth at primary-ray cost. Depth, object index, normal and position
are geometry and do not change (tests/test_quality_presets.py). The RGB is a picture of the
ground truth, not a photograph of the scene: textures are not drawn.
"""
from __future__ import annotations

import bpy
import numpy as np

from ..model import Mesh, Scene
from . import compat

AMBIENT = 0.4        # brightness of a surface seen edge-on; face-on it is 1
OVERRIDE_NAME = "sesgen_flat"


def model_colour(obj, scene: Scene) -> tuple[float, float, float]:
    """An object's flat colour: its ``colour`` times its material's (textures left out)."""
    c = np.asarray(obj.colour, dtype=float)
    if obj.material:
        try:
            c = c * np.asarray(scene.material(obj.material).colour, dtype=float)
        except KeyError:
            pass
    return tuple(float(x) for x in np.clip(c, 0.0, 1.0))


def _file_colour(bobj) -> tuple[float, float, float]:
    """The base colour of an imported mesh's first material (grey without one)."""
    for slot in bobj.material_slots:
        m = slot.material
        if m is None:
            continue
        nt = getattr(m, "node_tree", None)
        for node in (nt.nodes if nt is not None else ()):
            if node.type == "BSDF_PRINCIPLED":
                return tuple(float(x) for x in node.inputs["Base Color"].default_value[:3])
        return tuple(float(x) for x in m.diffuse_color[:3])
    return (0.8, 0.8, 0.8)


def _override_material(tag):
    mat = tag(bpy.data.materials.new(OVERRIDE_NAME))
    nt = compat.node_tree(mat)
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    info = nt.nodes.new("ShaderNodeObjectInfo")
    facing = nt.nodes.new("ShaderNodeLayerWeight")        # Facing = 1 - |cos θ| at blend 0.5
    facing.inputs["Blend"].default_value = 0.5
    light = nt.nodes.new("ShaderNodeMath")
    light.operation = "MULTIPLY_ADD"                      # 1 - (1 - AMBIENT) * Facing
    light.inputs[1].default_value = -(1.0 - AMBIENT)
    light.inputs[2].default_value = 1.0
    emit = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(facing.outputs["Facing"], light.inputs[0])
    nt.links.new(info.outputs["Color"], emit.inputs["Color"])
    nt.links.new(light.outputs[0], emit.inputs["Strength"])
    nt.links.new(emit.outputs[0], out.inputs["Surface"])
    if hasattr(mat, "cycles") and hasattr(mat.cycles, "emission_sampling"):
        mat.cycles.emission_sampling = "NONE"             # not a light
    return mat


def apply_flat_shading(built, scene: Scene, tag) -> None:
    """Switch the built scene to flat shading (see the module docstring)."""
    by_id = {o.id: o for o in scene.objects}
    for oid, bobjs in built.objects.items():
        model = by_id.get(oid)          # None: an object of a BLEND file, coloured as its file says
        custom = model is not None and (not isinstance(model, Mesh) or model.texture is not None
                                        or model.material is not None or tuple(model.colour) != (1.0, 1.0, 1.0))
        for b in bobjs:
            rgb = model_colour(model, scene) if custom else _file_colour(b)
            b.color = (*rgb, 1.0)
    bscene = built.scene
    for o in built.collection.objects:
        if o.type == "LIGHT":
            o.hide_render = True
    world = bscene.world
    if world is not None and hasattr(world, "cycles") and hasattr(world.cycles, "sampling_method"):
        world.cycles.sampling_method = "NONE"
    bscene.view_layers[0].material_override = _override_material(tag)
