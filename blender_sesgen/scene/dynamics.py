"""Moving objects: each object's frame, and its pose at every frame or instant (pure, no bpy).

An object's own frame (its *object frame*) is where its ``position x y z [rx ry rz]``
puts it: origin at ``position``, axes turned by the XYZ Euler rule (``contract.frames.object_pose``);
a QUAD's object frame is the centroid of its vertices with the world's axes, a MESH's is
its ``position``/rotation (its ``scale`` acts inside the object frame). A point fixed on
the object has constant coordinates X_obj in that frame, so at frame k it is at
X_world(k) = T_world_obj(k) @ X_obj, in the SES world (Y up).

Three ways to move (``MOVE`` in docs/ses-language.md), all from the object's rest pose
T_world_obj(0) (the pose its own statement gives):

- **keyframes** (frame f, pose): between two keyframes the position moves on the straight
  line and the orientation turns about one axis at a constant rate (``contract.se3.interpolate_pose``,
  as animation keyframes are interpolated); before the first it rests, after the last it holds;
- **twists** (first, last, U V W alpha beta gamma): from frame ``first`` to ``last`` every
  frame step is the constant body twist [omega, v] in the object's own frame,
  T(k+1) = T(k) @ exp([omega, v]) (as EGO moves the rig), holding elsewhere;
- **trajectory** (poses P(j) from a TUM/KITTI file, from frame ``first``): replayed relative
  to the rest pose, T(first + j) = T(0) @ inv(P(0)) @ P(j), holding after the file ends.

Between two frames (motion blur, sub-frame keys) an object moves by the same rule
(:func:`pose_at`): a twisting object along the constant body twist from its pose at k to
its pose at k+1 (``contract.se3.interpolate_twist``), a keyframed or trajectory-replaying object
by ``contract.se3.interpolate_pose`` between them — exact for twists and keyframes (both rules
subdivide into themselves), the definition for trajectories.
"""
from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np

from ..contract.frames import object_pose
from ..contract.motion import ego_step
from ..contract.se3 import interpolate_pose, interpolate_twist, invert, relative, rotation_angle_rad
from .model import Placed, Quad, SceneObject


def rest_pose(obj: SceneObject) -> np.ndarray:
    """T_world_obj of an object as its statement places it (frame 0 of a moving object)."""
    if isinstance(obj, Quad):
        return object_pose(np.mean(np.asarray(obj.vertices, dtype=float), axis=0))
    if isinstance(obj, Placed):
        return object_pose(obj.position, obj.rotation_deg)
    raise TypeError(f"no object frame for {type(obj).__name__}")


def keyed_poses(T_rest: np.ndarray, keys: Sequence[tuple[int, np.ndarray]], frames: int) -> np.ndarray:
    """(frames, 4, 4): rest pose at frame 0, ``keys`` = [(frame, T_world_obj)] in increasing
    frame order (all >= 1), straight line + slerp between consecutive keys
    (``contract.se3.interpolate_pose``, every frame at once), held after the last."""
    f = np.array([0] + [int(k) for k, _ in keys])
    T = np.stack([np.asarray(T_rest, dtype=float)] + [np.asarray(T, dtype=float) for _, T in keys])
    out = np.empty((frames, 4, 4))
    k = np.arange(min(f[-1], frames))
    j = np.searchsorted(f, k, side="right") - 1          # f[j] <= k < f[j + 1]
    if len(k):
        out[k] = interpolate_pose(T[j], T[j + 1], (k - f[j]) / (f[j + 1] - f[j]))
    out[f[-1]:] = T[-1]
    return out


def twist_poses(T_rest: np.ndarray, twists: Iterable[Sequence[float]], frames: int) -> np.ndarray:
    """(frames, 4, 4) from twist segments (first, last, U, V, W, alpha, beta, gamma): each
    step k -> k+1 with first <= k < last is T(k) @ exp([omega, v]) (angles in degrees per
    frame, about the object's own x, y, z); other steps hold. Segments must not overlap."""
    step = {}
    for seg in twists:
        first, last = int(seg[0]), int(seg[1])
        T_step = ego_step(*seg[2:8])
        for k in range(first, min(last, frames - 1)):
            step[k] = T_step
    out = np.empty((frames, 4, 4))
    out[0] = T_rest
    for k in range(frames - 1):
        out[k + 1] = out[k] @ step[k] if k in step else out[k]
    return out


def trajectory_poses(T_rest: np.ndarray, T_file: np.ndarray, first: int, frames: int) -> np.ndarray:
    """(frames, 4, 4): the file's poses replayed from frame ``first`` relative to the rest
    pose, T(first + j) = T_rest @ inv(P(0)) @ P(j); rest before ``first``, the last pose held
    after the file ends; poses beyond the sequence are not used."""
    T_file = np.asarray(T_file, dtype=float)
    T_rest_file0 = np.asarray(T_rest, dtype=float) @ invert(T_file[0])
    out = np.empty((frames, 4, 4))
    for k in range(frames):
        j = min(max(k - first, 0), len(T_file) - 1)
        out[k] = T_rest if k < first else T_rest_file0 @ T_file[j]
    return out


def largest_step_rotation_deg(T_frames: np.ndarray) -> tuple[float, int]:
    """(angle, k): the largest rotation between consecutive poses and the step k -> k+1 where it is."""
    T = np.asarray(T_frames, dtype=float)
    if len(T) < 2:
        return 0.0, 0
    angles = np.degrees(rotation_angle_rad(relative(T[:-1], T[1:])[..., :3, :3]))
    k = int(np.argmax(angles))
    return float(angles[k]), k


def pose_at(T_frames: np.ndarray, t: float, kind: str = "keys") -> np.ndarray:
    """The pose at time ``t`` in frames (fractional for sub-frame instants) of an object whose
    per-frame poses are ``T_frames`` and whose motion is of ``kind`` ('twist': the constant
    body twist from frame floor(t) to floor(t)+1; 'keys'/'trajectory': straight line + slerp).
    Before frame 0 / after the last frame the first / last step is extrapolated (a
    motion-blurred shutter may open before frame 0)."""
    T = np.asarray(T_frames, dtype=float)
    n = len(T)
    if n == 1:
        return T[0].copy()
    k = int(np.clip(np.floor(t), 0, n - 2))
    s = float(t) - k
    if s == 0.0:
        return T[k].copy()
    if s == 1.0:
        return T[k + 1].copy()
    interp = interpolate_twist if kind == "twist" else interpolate_pose
    return interp(T[k], T[k + 1], s)


KEYS_PER_FRAME = 8  # keys per frame interval of a moving object in Blender (for motion blur)
SHUTTER_MARGIN = 0.5  # frames keyed before frame 0 and after the last (a shutter open around them)


def key_times(frames: int, keys_per_frame: int = KEYS_PER_FRAME, margin: float = SHUTTER_MARGIN) -> np.ndarray:
    """Instants (in frames) at which a moving object is keyed in Blender: every frame, and
    ``keys_per_frame - 1`` evenly spaced instants between frames, from ``-margin`` to
    ``frames - 1 + margin`` — so that Cycles' motion blur, which evaluates the scene at
    sub-frame times around each frame, sees the object move (linear interpolation between
    keys 1/8 frame apart; exact at the keys)."""
    n = int(round((frames - 1 + 2 * margin) * keys_per_frame))
    t = -margin + np.arange(n + 1) / keys_per_frame
    t = np.round(t * keys_per_frame) / keys_per_frame  # integers exactly
    return t


def poses_at(T_frames: np.ndarray, times, kind: str = "keys") -> np.ndarray:
    """(len(times), 4, 4) :func:`pose_at` for each instant; exact frame poses at integers.
    Straight line + slerp for all instants at once: a mover is keyed 8 times a frame over
    the whole sequence (12 k instants on a 1 km route) by every chunk that builds it."""
    T = np.asarray(T_frames, dtype=float)
    t = np.asarray(times, dtype=float).reshape(-1)
    if kind == "twist" or len(T) == 1 or not len(t):
        return np.stack([pose_at(T, float(x), kind) for x in t]) if len(t) else np.zeros((0, 4, 4))
    k = np.clip(np.floor(t), 0, len(T) - 2).astype(int)
    s = t - k
    out = interpolate_pose(T[k], T[k + 1], s)
    out[s == 0.0] = T[k[s == 0.0]]
    out[s == 1.0] = T[k[s == 1.0] + 1]
    return out
