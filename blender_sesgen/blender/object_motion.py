"""Moving objects in Blender: each mover hangs from an empty keyed with its motion.

For an object with a ``MOVE`` motion (model.ObjectMotion) the builder makes an empty
``sesgen_motion_<name>`` whose matrix_world at Blender frame FRAME0 + t is
``ses_to_blender_world(T_world_obj(t))`` — the object frame's pose (blender_sesgen.dynamics:
exact at every frame, by the motion's own rule in between) — and parents the object's
Blender objects to it with their placement *relative to the object frame* (a MESH's
scale and file axes, a QUAD's vertices about their centroid) as their local matrix.

Keys: location + quaternion at every frame and at ``dynamics.KEYS_PER_FRAME - 1`` instants
between frames, half a frame beyond both ends, LINEAR. At whole frames (where every image
and all ground truth are rendered) the pose is the keyed one; between them Cycles' motion
blur (``render.use_motion_blur``) evaluates sub-frame times and sees the object move, so a
moving object is blurred along its own motion, not only by the camera's.
"""
from __future__ import annotations

import numpy as np
from mathutils import Matrix

from .. import dynamics
from ..contract.frames import ses_to_blender_world
from ..model import ObjectMotion, SceneObject
from . import rig


def attach_motion(obj: SceneObject, motion: ObjectMotion, blender_objects: list, collection, tag) -> object:
    """Parent ``blender_objects`` (built at the object's rest pose) to a new keyed empty."""
    import bpy
    T_rest_blender = ses_to_blender_world(dynamics.rest_pose(obj))
    empty = tag(bpy.data.objects.new(f"sesgen_motion_{obj.name}", None))
    empty.empty_display_type = "ARROWS"
    collection.objects.link(empty)
    T = motion.poses()
    times = dynamics.key_times(len(T))
    mats = [ses_to_blender_world(P) for P in dynamics.poses_at(T, times, motion.kind)]
    rig.key_matrices(empty, [rig.blender_frame(0) + t for t in times], mats, "LINEAR")
    tag(empty.animation_data.action)
    inv_rest = np.linalg.inv(T_rest_blender)
    for b in blender_objects:
        local = inv_rest @ np.array(b.matrix_world)
        b.parent = empty
        b.matrix_parent_inverse = Matrix.Identity(4)
        b.matrix_basis = Matrix(local.tolist())
    return empty
