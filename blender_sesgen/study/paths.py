""""Same path" variants (pure): the base's one continuous path, resampled or re-oriented.

The base script's rig motion is a continuous function of time, ``T(t)``
(``contract.rig_motion.RigMotion``: the constant body twist of each EGO step, or the C2
spline through POSE/TRAJECTORY keyframes), from ``t0`` (frame 0) to ``t_end`` (the last
frame). A path variant samples it again and writes the samples as ``POSE`` lines:

- **frame rate** r: frames at ``t0 + k / r`` for every such time up to ``t_end`` (the
  duration is kept, so the frame count changes); ``TIMING rate r``;
- **rig speed** s (times the base's): frame k shows ``T(t0 + k s / r0)`` at the base rate r0
  (the same poses, reached s times sooner: fewer frames for s > 1);
- **rotation rate** w (deg/s): the base's frames, each turned about its own camera y axis
  (a pan) by ``theta(t) = A sin(2 pi t / P)`` with P = 2 s and A = w P / (2 pi), so the peak
  added turn rate is w and the positions are the base's;
- **hand shake** a (deg): the base's frames, each turned by a seeded, smooth rotation
  (per camera axis a sum of sinusoids of 1.5-7 Hz, random phases) of RMS a per axis; the
  positions are the base's.

Every variant pose of frame rate and rig speed lies on the base path (``T`` at some time);
tests/test_study_pure.py checks it. Objects that move (MOVE) keep the world's clock: each
is written as a keyframe per variant frame (``MOVE id N frame k position ...``) at its pose
at that frame's time on the base's object motion (``dynamics.pose_at``), so the world is
the same and only the camera changes. Between two frames a keyframed object moves on the
straight line + slerp (the base's twisting objects on their twist): a difference only
motion blur can see, of second order in the frame step.
"""
from __future__ import annotations

import numpy as np

from ..contract.frames import start_rotation_deg
from ..contract.rig_motion import RigMotion
from ..contract.se3 import R_to_euler_xyz_deg, so3_exp
from ..contract.timing import DEFAULT_FPS
from ..dynamics import pose_at
from ..errors import SesgenError
from .script import Script, statement_line

MOTION_KEYWORDS = ("START", "EGO", "POSE", "TRAJECTORY", "FRAMES")
PAN_PERIOD_S = 2.0
SHAKE_HZ = (1.5, 2.3, 3.7, 5.1, 7.0)


def rig_motion(scene) -> RigMotion:
    """The base scene's continuous rig motion (its own interpolation, its own clock)."""
    t = scene.timing
    rate = t.rate_hz if t else DEFAULT_FPS
    start = t.start_s if t else 0.0
    return RigMotion.for_motion_kind(scene.timeline.left(), rate, start, scene.motion.kind)


def base_times(scene) -> np.ndarray:
    m = rig_motion(scene)
    return m.start_s + np.arange(scene.frames) / m.rate_hz


def frame_rate_times(scene, rate_hz: float) -> np.ndarray:
    """Times of a variant at ``rate_hz`` over the base's duration."""
    m = rig_motion(scene)
    if not rate_hz > 0:
        raise SesgenError(f"frame rate must be > 0 Hz, got {rate_hz}")
    duration = (scene.frames - 1) / m.rate_hz
    n = int(np.floor(duration * rate_hz + 1e-9)) + 1
    if n < 2:
        raise SesgenError(f"{rate_hz:g} Hz leaves fewer than 2 frames in the base's {duration:g} s")
    return m.start_s + np.arange(n) / rate_hz


def speed_times(scene, speed: float) -> np.ndarray:
    """Base-path times of the frames of a variant ``speed`` times as fast (same frame rate)."""
    m = rig_motion(scene)
    if not speed > 0:
        raise SesgenError(f"rig speed must be > 0 (times the base's), got {speed}")
    n = int(np.floor((scene.frames - 1) / speed + 1e-9)) + 1
    if n < 2:
        raise SesgenError(f"rig speed x{speed:g} leaves fewer than 2 frames of the base's {scene.frames}")
    return m.start_s + np.arange(n) * speed / m.rate_hz


def pan(T: np.ndarray, times_s: np.ndarray, rate_deg_s: float) -> np.ndarray:
    """Each pose turned about its camera y axis by theta(t) (module docstring)."""
    amp = np.radians(rate_deg_s) * PAN_PERIOD_S / (2 * np.pi)
    out = np.array(T, dtype=float)
    for k, t in enumerate(times_s):
        out[k, :3, :3] = T[k, :3, :3] @ so3_exp(np.array([0.0, amp * np.sin(2 * np.pi * t / PAN_PERIOD_S), 0.0]))
    return out


def shake(T: np.ndarray, times_s: np.ndarray, rms_deg: float, seed: int = 0) -> np.ndarray:
    """Each pose turned by a smooth seeded rotation of ``rms_deg`` RMS per axis."""
    rng = np.random.default_rng([int(seed), 0x5A4E])
    phase = rng.uniform(0, 2 * np.pi, (3, len(SHAKE_HZ)))
    weight = rng.uniform(0.5, 1.0, (3, len(SHAKE_HZ)))
    t = np.asarray(times_s, dtype=float)[:, None, None]
    waves = (weight * np.sin(2 * np.pi * np.asarray(SHAKE_HZ) * t + phase)).sum(axis=2)   # (n, 3)
    rms = np.sqrt((weight ** 2).sum(axis=1) / 2)                                         # of each axis
    angles = np.radians(rms_deg) * waves / rms
    out = np.array(T, dtype=float)
    for k in range(len(out)):
        out[k, :3, :3] = T[k, :3, :3] @ so3_exp(angles[k])
    return out


def pose_line(T_world_cam: np.ndarray) -> str:
    """``POSE x y z rx ry rz`` of a camera pose (START's convention)."""
    return statement_line("POSE", numbers=(*T_world_cam[:3, 3], *start_rotation_deg(T_world_cam)))


def object_key_line(obj_id: int, frame: int, T_world_obj: np.ndarray) -> str:
    return statement_line("MOVE", [("id", [int(obj_id)]), ("frame", [int(frame)]),
                                   ("position", [*T_world_obj[:3, 3], *R_to_euler_xyz_deg(T_world_obj[:3, :3])])])


def write_path(script: Script, scene, T_world_cam: np.ndarray, object_frames: np.ndarray) -> None:
    """Replace the script's rig motion by POSE lines of ``T_world_cam`` and every moving
    object's motion by keyframes at the base-frame instants ``object_frames`` (one per
    variant frame, fractional: the object's own clock)."""
    script.drop(*MOTION_KEYWORDS)
    script.append("", "// the rig's path, resampled by the study (blender_sesgen/study/paths.py)")
    script.append(*(pose_line(T) for T in T_world_cam))
    rewrite_object_motions(script, scene, object_frames)


def rewrite_object_motions(script: Script, scene, object_frames: np.ndarray) -> None:
    """Every MOVE replaced by keyframes at the instants ``object_frames`` (base frames)."""
    if not scene.object_motions:
        return
    script.drop("MOVE")
    lines = []
    for om in scene.object_motions:
        T = om.poses()
        kind = "twist" if om.kind == "twist" else "keys"
        lines += [object_key_line(om.id, k, pose_at(T, float(tau), kind)) for k, tau in enumerate(object_frames)
                  if k > 0]
    script.append("", "// moving objects, keyed at every frame of the resampled clock", *lines)
