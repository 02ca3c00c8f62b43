"""How the rig moves: START, EGO, POSE, TRAJECTORY and FRAMES statements -> the start pose,
the :class:`blender_sesgen.scene.model.Motion` as written and the per-frame Timeline.

The poses come from the contract's frames and motion modules. The motion is described one way only (EGO, POSE
or TRAJECTORY, not mixed); START sets frame 0 for EGO and TRAJECTORY and is refused with
POSE, whose first line is frame 0. A TRAJECTORY file is read here and replayed relative
to START. ``FRAMES N`` holds a still rig at START for N frames (for scenes where only
objects move); it cannot be combined with the other three.
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from ..scene import model
from ..contract.frames import start_pose
from ..contract.motion import integrate_ego
from ..contract.se3 import invert
from .checks import Checks, vec
from .statements import ParsedStatement
from .trajectory_files import TrajectoryFileError, read_trajectory

MOTION_KEYWORDS = ("EGO", "POSE", "TRAJECTORY", "FRAMES")
MAX_FRAMES = 1_000_000
ORIGIN = (0.0, 0.0, 0.0)


class RigMotion(NamedTuple):
    """The Scene fields this module owns (``**rig_motion._asdict()`` fills them in)."""
    start_position: model.Vec3
    start_rotation_deg: model.Vec3
    motion: model.Motion
    timeline: model.Timeline


def rig_motion(statements: list[ParsedStatement], start: Optional[ParsedStatement], check: Checks) -> RigMotion:
    """The start pose, Motion and Timeline of the script (``start``: its START statement)."""
    start_position = vec(start, "position", ORIGIN)[:3] if start else ORIGIN
    start_rotation = (vec(start, "position")[3:] or ORIGIN) if start else ORIGIN
    motion, T_world_left = _motion(statements, start, start_position, start_rotation, check)
    if motion.kind == "pose" and motion.keyframes:
        start_position, start_rotation = motion.keyframes[0][:3], motion.keyframes[0][3:]
    return RigMotion(start_position=tuple(start_position), start_rotation_deg=tuple(start_rotation),
                     motion=motion, timeline=model.Timeline(T_world_left=tuple(model.mat4(T) for T in T_world_left)))


def _motion(statements, start, start_position, start_rotation, check: Checks) -> tuple[model.Motion, list[np.ndarray]]:
    """(Motion, list of T_world_left) from EGO / POSE / TRAJECTORY (or START alone)."""
    first: dict[str, ParsedStatement] = {}
    for stmt in statements:
        if stmt.keyword not in MOTION_KEYWORDS:
            continue
        for other, other_stmt in first.items():
            if other != stmt.keyword and stmt.keyword not in first:
                check.err(stmt.token, f"{stmt.keyword} cannot be mixed with {other} (first {other} on line "
                                      f"{other_stmt.token.line}): describe the motion one way only")
                break
        first.setdefault(stmt.keyword, stmt)
    T_start = start_pose(start_position, start_rotation)
    if not first:
        return model.Motion(), [T_start]
    keyword = min(first, key=lambda k: first[k].token.line)
    if keyword == "FRAMES":
        stmt = first["FRAMES"]
        n, tok = stmt.numbers[0], stmt.number_tokens[0]
        if not float(n).is_integer() or not 1 <= n <= MAX_FRAMES:
            check.err(tok, f"FRAMES must be a whole number in 1..{MAX_FRAMES}, got {tok.text}")
            return model.Motion(), [T_start]
        return model.Motion(), [T_start] * int(n)
    if keyword == "EGO":
        ego = tuple(s.numbers for s in statements if s.keyword == "EGO")
        return model.Motion(kind="ego", ego=ego), list(integrate_ego(T_start, ego))
    if keyword == "POSE":
        if start is not None:
            check.err(start.token, "START cannot be used with POSE: the first POSE line is frame 0")
        keyframes = tuple(s.numbers for s in statements if s.keyword == "POSE")
        return (model.Motion(kind="pose", keyframes=keyframes),
                [start_pose(k[:3], k[3:]) for k in keyframes])
    return _trajectory(first["TRAJECTORY"], T_start, check)


def _trajectory(stmt: ParsedStatement, T_start: np.ndarray, check: Checks) -> tuple[model.Motion, list[np.ndarray]]:
    """The TRAJECTORY file's poses, replayed so that its first pose lands on START."""
    tok = stmt.tags["file"].tokens[0]
    fmt = stmt.get("format")
    path = check.existing_file(stmt, "file")
    motion = model.Motion(kind="trajectory", trajectory_path=str(path), trajectory_format=fmt)
    if path is None:
        return motion, [T_start]
    try:
        T_file = read_trajectory(str(path), fmt)
    except TrajectoryFileError as e:
        check.err(tok, f"TRAJECTORY file '{tok.text}' {e}")
        return motion, [T_start]
    # replayed relative to START: T_world_cam(k) = T_start . inv(T_file(0)) . T_file(k)
    T_start_file0 = T_start @ invert(T_file[0])
    return motion, [T_start_file0 @ T for T in T_file]
