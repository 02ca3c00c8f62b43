"""The scene model -> a Blender scene: objects, lights, world and the stereo rig (bpy).

The one place that puts a whole :class:`~blender_sesgen.scene.model.Scene` into Blender: shapes
(``shapes.build_shape``) with their materials (``materials``, ``library``), the objects of
BLEND files (``blend_import``), lights and world (``lighting``), the keyed cameras (``rig``),
the moving objects' keyed empties (``object_motion``), all tagged (``datablocks``) in the
dedicated scene ``SCENE_NAME``. Object ``pass_index`` = script ``id``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import bpy

from ..scene.model import Scene
from . import assets as _assets  # noqa: F401  (registers the ASSET shape builder)
from . import blend_import, glazing, library, lighting, object_motion, rig
from .datablocks import SCENE_NAME, TAG, clear_previous, tag
from .materials import MaterialFactory
from .runtime import activate
from .shapes import ShapeContext, build_shape


@dataclass
class BuiltScene:
    """What ``build_scene`` made: the Blender scene, its objects by id, its cameras by view."""
    scene: object
    collection: object
    objects: dict = field(default_factory=dict)   # id -> [bpy objects]
    cameras: dict = field(default_factory=dict)   # view -> camera object
    segments: dict = field(default_factory=dict)  # tessellated shape id -> segment count
    imported: list = field(default_factory=list)  # manifest rows of BLEND objects
    movers: dict = field(default_factory=dict)    # moving object id -> its keyed empty (object_motion)
    glow: dict = field(default_factory=dict)      # glowing pane id -> its emitted RGB radiance (glazing)
    lod: dict = field(default_factory=dict)       # library material name -> its level of detail's Means


def build_scene(scene: Scene, *, width: int, height: int, K, view_poses: dict, threads: int = 0,
                material_lod: bool = False) -> BuiltScene:
    """Build ``scene`` into a fresh Blender scene named SCENE_NAME (replacing any previous).

    ``view_poses``: {view: (N, 4, 4) T_world_cam} (OpenCV camera, SES world); ``K`` the
    (possibly rescaled) intrinsics for ``width`` x ``height``; ``threads``: the CPU threads of
    the renders the build makes (the sky table's bake; 0: automatic); ``material_lod``: the
    library materials' level of detail (library/lod.py), measured for this focal length.
    """
    clear_previous()
    bscene = bpy.data.scenes.new(SCENE_NAME)
    bscene[TAG] = 1
    coll = tag(bpy.data.collections.new("SESGen objects"))
    bscene.collection.children.link(coll)
    built = BuiltScene(scene=bscene, collection=coll)

    factory = MaterialFactory(scene, lod=material_lod)
    ctx = ShapeContext(scene, coll, factory, max(float(K[0][0]), scene.rig.focal_px),
                       built.segments)
    for o in scene.objects:
        objs = build_shape(o, ctx)
        material = scene.material(o.material) if o.material else None
        seed = material.library.seed if material is not None and material.library is not None else 0
        for b in objs:
            b.pass_index = int(o.id)
            b["sesgen_id"] = int(o.id)
            library.object_properties(b, seed, o.id)   # the library materials' per-object variation
        built.objects[o.id] = objs
        motion = scene.motion_of(o.id)
        if motion is not None:  # a moving object hangs from an empty keyed with its motion
            built.movers[o.id] = object_motion.attach_motion(o, motion, objs, coll, tag)

    if material_lod:
        built.lod = library.apply_lod(factory.library_made, float(K[0][0]), threads)

    used_ids = {o.id for o in scene.objects}
    file_lamps = False
    for imp in scene.imports:
        rows, lamps = blend_import.load_blend(imp, bscene, coll, used_ids, tag)
        file_lamps = file_lamps or bool(lamps)
        built.imported += rows
        for row in rows:
            b = next(o for o in coll.objects if o.get("sesgen_id") == row["id"] and o.type != "LIGHT")
            library.object_properties(b, 0, row["id"])
            built.objects[row["id"]] = [b]

    # lights after the objects: the default lighting's enclosure test casts rays at them
    for i, light in enumerate(lighting.scene_lights(scene, bscene, file_lamps)):
        lo = lighting.add_light(bscene, coll, light, f"sesgen_light_{i}")
        tag(lo)
        tag(lo.data)
    world = lighting.effective_world(scene, file_lamps)
    tag(lighting.build_world(bscene, world, scene.fog, "sesgen_world", tag, threads))
    # glowing panes: their emission is the world's daylight on them (glazing.py)
    built.glow = glazing.apply(built, scene, world, lighting.sky_sun_lamp(), threads)

    N = scene.frames
    for view, T in view_poses.items():
        built.cameras[view] = rig.add_camera(coll, f"SESGen_{view}", width, height, K,
                                             scene.rig.near, scene.rig.far, T, tag)
    bscene.camera = built.cameras["left"]
    bscene.frame_start = rig.blender_frame(0)
    bscene.frame_end = rig.blender_frame(max(N - 1, 0))
    bscene.render.resolution_x = int(width)
    bscene.render.resolution_y = int(height)
    bscene.render.resolution_percentage = 100
    bscene.render.pixel_aspect_x = bscene.render.pixel_aspect_y = 1.0
    activate(bscene)
    bscene.frame_set(rig.blender_frame(0))
    return built
