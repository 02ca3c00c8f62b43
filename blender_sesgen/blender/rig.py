"""The stereo rig: one Blender camera per view, keyed at every frame (CONSTANT interpolation).

Each camera gets the exact intrinsics of ``CAMERA`` (``contract.camera.blender_camera_settings``)
and, at frame k, ``matrix_world = contract.frames.camera_matrix_world(T_world_cam[k])`` with
T_world_cam the manifest pose of its view (OpenCV camera, SES world). Blender frame k+FRAME0
is sequence frame k (FRAME0 = 0: Blender frames start at 0 here, like the file names).
"""
from __future__ import annotations

import numpy as np
from mathutils import Matrix

from ..contract.camera import blender_camera_settings
from ..contract.frames import camera_matrix_world
from . import compat

FRAME0 = 0  # Blender frame number of sequence frame 0


def blender_frame(k: int) -> int:
    return FRAME0 + int(k)


def apply_intrinsics(cam_data, width: int, height: int, K, near: float, far: float) -> None:
    s = blender_camera_settings(width, height, float(K[0][0]), float(K[0][2]), float(K[1][2]), near, far)
    cam_data.type = "PERSP"
    cam_data.sensor_fit = s.sensor_fit
    cam_data.sensor_width = s.sensor_width_mm
    cam_data.lens_unit = "MILLIMETERS"
    cam_data.lens = s.lens_mm
    cam_data.shift_x = s.shift_x
    cam_data.shift_y = s.shift_y
    cam_data.clip_start = s.clip_start
    cam_data.clip_end = s.clip_end


def add_camera(collection, name: str, width: int, height: int, K, near: float, far: float,
               T_world_cam: np.ndarray, tag) -> object:
    """A camera keyed at every frame with the OpenCV poses ``T_world_cam`` (N, 4, 4)."""
    import bpy
    data = bpy.data.cameras.new(name)
    tag(data)
    apply_intrinsics(data, width, height, K, near, far)
    obj = bpy.data.objects.new(name, data)
    tag(obj)
    collection.objects.link(obj)
    obj.rotation_mode = "QUATERNION"
    key_poses(obj, T_world_cam)
    tag(obj.animation_data.action)
    return obj


def key_poses(obj, T_world_cam: np.ndarray) -> None:
    """Key location + rotation at every frame (constant interpolation): at frame k the
    object's matrix_world is camera_matrix_world(T_world_cam[k])."""
    T_world_cam = np.asarray(T_world_cam, dtype=float)
    key_matrices(obj, [blender_frame(k) for k in range(len(T_world_cam))],
                 [camera_matrix_world(T) for T in T_world_cam], "CONSTANT")


def key_matrices(obj, times, matrices, interpolation: str = "CONSTANT") -> None:
    """Key ``obj``'s location + rotation_quaternion at Blender frames ``times`` (increasing;
    fractional for sub-frame keys) so that its matrix_basis there is ``matrices[i]`` (rigid,
    4x4); ``interpolation`` of every key: 'CONSTANT' or 'LINEAR'."""
    N = len(times)
    locs, quats = [], []
    for M4 in matrices:
        loc, rot, _ = Matrix(np.asarray(M4, dtype=float).tolist()).decompose()
        locs.append(tuple(loc))
        quats.append(tuple(rot))
    if quats:  # keep quaternions in one hemisphere (so LINEAR keys take the short way)
        for i in range(1, N):
            if np.dot(quats[i], quats[i - 1]) < 0:
                quats[i] = tuple(-q for q in quats[i])
    obj.rotation_mode = "QUATERNION"
    obj.location = locs[0]
    obj.rotation_quaternion = quats[0]
    obj.keyframe_insert("location", frame=float(times[0]))
    obj.keyframe_insert("rotation_quaternion", frame=float(times[0]))
    values = {("location", i): [l[i] for l in locs] for i in range(3)}
    values.update({("rotation_quaternion", i): [q[i] for q in quats] for i in range(4)})
    for fc in compat.object_fcurves(obj):
        vals = values[(fc.data_path, fc.array_index)]
        kp = fc.keyframe_points
        if len(kp) < N:
            kp.add(N - len(kp))
        co = np.empty(2 * N, dtype=np.float32)
        co[0::2] = times
        co[1::2] = vals
        kp.foreach_set("co", co)
        for p in kp:
            p.interpolation = interpolation
        fc.update()
    obj.location = locs[0]
    obj.rotation_quaternion = quats[0]
