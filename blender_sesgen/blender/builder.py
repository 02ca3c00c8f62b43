"""The scene model -> a Blender scene: objects, lights, world and the stereo rig (bpy).

The one place that puts a whole :class:`~blender_sesgen.model.Scene` into Blender: shapes
(``shapes.build_shape``) with their materials (``materials``), lights and world
(``lighting``), the keyed cameras (``rig``), all tagged (``datablocks``) in the dedicated
scene ``SCENE_NAME``. Object ``pass_index`` = script ``id``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import bpy

from ..model import Scene
from . import assets as _assets  # noqa: F401  (registers the ASSET shape builder)
from . import lighting, rig
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


def build_scene(scene: Scene, *, width: int, height: int, K, view_poses: dict) -> BuiltScene:
    """Build ``scene`` into a fresh Blender scene named SCENE_NAME (replacing any previous).

    ``view_poses``: {view: (N, 4, 4) T_world_cam} (OpenCV camera, SES world); ``K`` the
    (possibly rescaled) intrinsics for ``width`` x ``height``.
    """
    clear_previous()
    bscene = bpy.data.scenes.new(SCENE_NAME)
    bscene[TAG] = 1
    coll = tag(bpy.data.collections.new("SESGen objects"))
    bscene.collection.children.link(coll)
    built = BuiltScene(scene=bscene, collection=coll)

    lights = list(scene.lights) or lighting.default_lights(scene)
    ambient = lighting.DEFAULT_AMBIENT if not scene.lights else 0.0
    ctx = ShapeContext(scene, coll, MaterialFactory(scene, ambient), max(float(K[0][0]), scene.rig.focal_px),
                       built.segments)
    for o in scene.objects:
        objs = build_shape(o, ctx)
        for b in objs:
            b.pass_index = int(o.id)
            b["sesgen_id"] = int(o.id)
        built.objects[o.id] = objs

    for i, light in enumerate(lights):
        lo = lighting.add_light(bscene, coll, light, f"sesgen_light_{i}")
        tag(lo)
        tag(lo.data)
    tag(lighting.build_world(bscene, scene.world, scene.fog, "sesgen_world"))

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
