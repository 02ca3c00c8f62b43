"""Glowing panes (``MATERIAL ... library frosted_glass glow``): each pane's emission set from
the world's daylight on its outer face (bpy).

A diffusing pane passes t E / pi of the irradiance E on its outer face as radiance from its
inner face (Lambertian transmission, t its passed colour). Traced, that light reaches a room
only by bounces: Cycles' shadow rays stop at the pane, so every pixel the daylight lights is
found by chance (the hall's noise, bench/quality_noise_source.py). A ``glow`` pane emits it
instead (the library's ``_glow``: no Translucent BSDF, the light does not arrive twice) and is
light-sampled. E is the world's (scene/lighting.py ``daylight_irradiance``: the sky's table or
the HDRI's pixels over the outer hemisphere, unoccluded, and the sky's sun lamp by its
incidence); the outer face is the side from which more rays over its hemisphere (from the
pane's centre) escape the scene (a tie: the brighter side). A copy of the material per distinct
irradiance: its Emission's strength is the pane's mean emitted luminance, so Cycles' light
tree, which estimates a textured emission by its strength, weighs the pane by its real light.
"""
from __future__ import annotations

import bpy
import numpy as np

from ..contract.frames import R_BLENDER_SES
from ..scene import lighting as pure
from ..scene.materials import _luminance, entry, transmitted_colour
from ..scene.model import Scene, World
from . import compat, library
from . import sky as sky_table
from .datablocks import tag

ESCAPE_M = 1e6
OPEN_RAYS = 64      # rays a side that find the outer face (the side that sees the sky)


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


def face_frame(obj) -> tuple[np.ndarray, np.ndarray]:
    """(centre, unit normal) in Blender's world of a flat object's faces: area-weighted."""
    mesh = obj.data
    n = len(mesh.polygons)
    normals, centres, areas = (np.empty(3 * n), np.empty(3 * n), np.empty(n))
    mesh.polygons.foreach_get("normal", normals)
    mesh.polygons.foreach_get("center", centres)
    mesh.polygons.foreach_get("area", areas)
    M = np.array(obj.matrix_world)
    normal = np.linalg.inv(M[:3, :3]).T @ (areas @ normals.reshape(n, 3))
    centre = M[:3, :3] @ (areas @ centres.reshape(n, 3) / areas.sum()) + M[:3, 3]
    return centre, normal / np.linalg.norm(normal)


def _open_share(bscene, depsgraph, centre, normal, n: int = OPEN_RAYS) -> float:
    """The share of ``n`` rays over the hemisphere of ``normal`` from ``centre`` (just off the
    face) that leave the scene: 0 into a room, most of them out of a window (its reveal and
    bars stop a few)."""
    dirs = R_BLENDER_SES @ pure.fibonacci_directions(2 * n).T
    dirs = dirs.T[dirs.T @ normal > 0.05]
    origin = tuple(centre + 1e-3 * normal)
    return float(np.mean([not bscene.ray_cast(depsgraph, origin, tuple(d), distance=ESCAPE_M)[0] for d in dirs]))


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
    copies: dict = {}
    radiance = {}
    for o in glowing:
        m = scene.material(o.material)
        passed = np.asarray(transmitted_colour(tuple(np.multiply(o.colour, m.colour)), entry(m.library.name)))
        for b in built.objects[o.id]:
            centre, normal = face_frame(b)
            E = {side: pure.daylight_irradiance(world, R_BLENDER_SES.T @ (side * normal), table, image, sun)
                 for side in (1.0, -1.0)}
            seen = {side: _open_share(bscene, depsgraph, centre, side * normal) for side in (1.0, -1.0)}
            if seen[1.0] != seen[-1.0]:
                outer = max(seen, key=seen.get)
            else:
                outer = max(E, key=lambda s: _luminance(tuple(E[s])))
            L = pure.glow_radiance(E[outer], passed)
            strength = float(_luminance(tuple(L)))
            gain = np.asarray(E[outer]) / np.pi / strength if strength > 0 else np.zeros(3)
            for slot in b.material_slots:
                mat = slot.material
                if mat is None or library.GLOW_NODE not in compat.node_tree(mat).nodes:
                    continue
                key = (mat.name, tuple(np.round(E[outer], 6)))
                if key not in copies:
                    copy = tag(mat.copy())
                    copy.name = f"{mat.name}_glow{len(copies)}"
                    nodes = compat.node_tree(copy).nodes
                    nodes[library.GLOW_NODE].inputs["Strength"].default_value = strength
                    nodes[library.GLOW_COLOUR_NODE].outputs[0].default_value = (*(float(x) for x in gain), 1.0)
                    copies[key] = copy
                slot.link = "OBJECT"
                slot.material = copies[key]
            radiance[o.id] = L
    return radiance
