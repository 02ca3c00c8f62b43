"""Moving objects in Blender: each mover hangs from an empty keyed with its motion.

For an object with a ``MOVE`` motion (model.ObjectMotion) the builder makes an empty
``sesgen_motion_<name>`` whose matrix_world at Blender frame FRAME0 + t is
``ses_to_blender_world(T_world_obj(t))`` — the object frame's pose (blender_sesgen.scene.dynamics:
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

from ..scene import dynamics
from ..contract.frames import ses_to_blender_world
from ..scene.model import ObjectMotion, SceneObject
from . import compat, rig


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


def key_instants(built, scene, frame_times, shift_frames: float = 0.0, motion_steps: int | None = None) -> None:
    """Re-key every moving object's empty exactly at Blender frame times ``frame_times``
    (the instants Cycles samples for one frame's shutter) with its poses at
    ``frame_times + shift_frames`` (a rolling shutter's half line), LINEAR; and let Cycles
    sample the movers' objects at as many instants as the camera (``motion_steps``)."""
    times = np.unique(np.asarray(frame_times, dtype=float))
    for obj_id, empty in built.movers.items():
        motion = scene.motion_of(obj_id)
        T = motion.poses()
        seq_t = times + float(shift_frames) - rig.blender_frame(0)
        mats = [ses_to_blender_world(P) for P in dynamics.poses_at(T, seq_t, motion.kind)]
        for fc in compat.object_fcurves(empty):
            fc.keyframe_points.clear()
        rig.key_matrices(empty, list(times), mats, "LINEAR")
        if motion_steps is not None:
            for b in built.objects[obj_id]:
                b.cycles.use_motion_blur = True
                b.cycles.motion_steps = int(motion_steps)
