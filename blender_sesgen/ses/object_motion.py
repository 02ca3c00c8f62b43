"""MOVE statements -> one :class:`blender_sesgen.scene.model.ObjectMotion` per moving object.

``MOVE id N frame F position x y z [rx ry rz]`` (a keyframe), ``MOVE id N twist U V W alpha
beta gamma [from A] [to B]`` (a constant per-frame twist in the object's own frame) or
``MOVE id N file PATH format tum|kitti [from A]`` (a recorded trajectory). The poses are
computed by ``blender_sesgen.scene.dynamics`` (with the contract's pose maths); this module checks the
statements: the id names an object, an object moves one way only, frame numbers lie in
the sequence, keyframes and twist segments come in increasing frame order without
overlaps, and no step turns by 180 degrees or more (the twist between two poses would be
ambiguous). The frame count is the rig's (EGO/POSE/TRAJECTORY/FRAMES).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..scene import dynamics, model
from ..contract.frames import object_pose
from ..contract.se3 import relative, rotation_angle_rad
from .checks import Checks, vec
from .statements import ParsedStatement
from .trajectory_files import TrajectoryFileError, read_trajectory

KINDS = {"position": "keys", "twist": "twist", "file": "trajectory"}
KIND_WORDS = {"keys": "keyframes", "twist": "a twist", "trajectory": "a trajectory file"}
# tags each kind accepts besides id and its own
ALLOWED = {"keys": {"frame"}, "twist": {"from", "to"}, "trajectory": {"from", "format"}}
MAX_STEP_DEG = 179.0  # larger steps make the joining twist ambiguous (and look like teleports)


def object_motions(statements: list[ParsedStatement], objects: list[model.SceneObject], frames: int,
                   check: Checks, attempted_ids: frozenset = frozenset()) -> tuple[model.ObjectMotion, ...]:
    """The ObjectMotions of the script's MOVE statements (faulty statements left out).

    ``attempted_ids``: ids of object statements that had errors of their own (a MOVE of
    such an object is skipped without a second error)."""
    by_id = {o.id: o for o in objects}
    groups: dict[int, list[tuple[str, ParsedStatement]]] = {}
    for stmt in statements:
        kind = _kind(stmt, check)
        if kind is None:
            continue
        tv = stmt.tags["id"]
        obj_id = int(tv.values[0])
        if obj_id not in by_id:
            if obj_id not in attempted_ids:
                check.err(tv.tokens[0], f"MOVE 'id' {obj_id}: no object has this id")
            continue
        earlier = groups.setdefault(obj_id, [])
        if earlier and earlier[0][0] != kind:
            first_kind, first_stmt = earlier[0]
            check.err(stmt.token, f"object {obj_id} already moves by {KIND_WORDS[first_kind]} (line "
                                  f"{first_stmt.token.line}): an object moves one way only")
            continue
        earlier.append((kind, stmt))
    out = []
    for obj_id in sorted(groups):
        motion = _motion(by_id[obj_id], groups[obj_id], frames, check)
        if motion is not None:
            out.append(motion)
    return tuple(out)


def _kind(stmt: ParsedStatement, check: Checks) -> Optional[str]:
    given = [t for t in KINDS if t in stmt.tags]
    if len(given) != 1:
        if not given:
            check.err(stmt.token, "MOVE needs one of 'position' (with 'frame': a keyframe), 'twist' "
                                  "(U V W alpha beta gamma per frame) or 'file' (with 'format': a trajectory)")
        else:
            check.err(stmt.tags[given[1]].tag, f"MOVE takes one of 'position', 'twist' or 'file', "
                                               f"not both '{given[0]}' and '{given[1]}'")
        return None
    kind = KINDS[given[0]]
    ok = True
    for name, tv in stmt.tags.items():
        if name not in ("id", given[0]) and name not in ALLOWED[kind]:
            check.err(tv.tag, f"MOVE '{name}' does not go with '{given[0]}' "
                              f"(with '{given[0]}': {', '.join(sorted(ALLOWED[kind]))})")
            ok = False
    if kind == "keys" and "frame" not in stmt.tags:
        check.err(stmt.token, "MOVE with 'position' needs 'frame F' (the frame this pose is keyed at)")
        ok = False
    if kind == "trajectory" and "format" not in stmt.tags:
        check.err(stmt.token, "MOVE with 'file' needs 'format tum|kitti'")
        ok = False
    return kind if ok else None


def _frame_in(stmt: ParsedStatement, tag: str, lo: int, hi: int, frames: int, check: Checks,
              why: str = "") -> Optional[int]:
    tv = stmt.tags[tag]
    f = int(tv.values[0])
    if not lo <= f <= hi:
        length = f"the sequence has {frames} frame{'s' if frames != 1 else ''}"
        if hi < lo:
            check.err(tv.tokens[0], f"MOVE '{tag}' {f}: {length}, too few to move in (the rig's EGO/POSE/"
                                    f"TRAJECTORY lines or FRAMES N set the frame count)")
        else:
            check.err(tv.tokens[0], f"MOVE '{tag}' must lie in {lo}..{hi}{why}, got {f} ({length}; the rig's "
                                    f"EGO/POSE/TRAJECTORY lines or FRAMES N set the frame count)")
        return None
    return f


def _motion(obj: model.SceneObject, group: list[tuple[str, ParsedStatement]], frames: int,
            check: Checks) -> Optional[model.ObjectMotion]:
    kind = group[0][0]
    before = len(check.diags.items)
    T_rest = dynamics.rest_pose(obj)
    if kind == "keys":
        motion, T = _keys(obj, [s for _, s in group], T_rest, frames, check)
    elif kind == "twist":
        motion, T = _twists(obj, [s for _, s in group], T_rest, frames, check)
    else:
        motion, T = _trajectory(obj, [s for _, s in group], T_rest, frames, check)
    if T is None or len(check.diags.items) != before:
        return None
    angle, k = dynamics.largest_step_rotation_deg(T)
    if angle > MAX_STEP_DEG:
        stmt = group[0][1]
        check.err(stmt.token, f"object {obj.id} turns by {angle:.1f} degrees from frame {k} to {k + 1}: "
                              f"keep each frame step below {MAX_STEP_DEG:g} degrees")
        return None
    return model.ObjectMotion(**motion, id=obj.id, kind=kind, T_world_obj=tuple(model.mat4(t) for t in T))


def _keys(obj, stmts, T_rest, frames, check):
    poses = [object_pose(p[:3], p[3:] or (0.0, 0.0, 0.0)) for p in (vec(stmt, "position") for stmt in stmts)]
    # each key's turn from the key before it, all at once (the loop recomputes it after a key it left out)
    turns = np.degrees(rotation_angle_rad(relative(np.stack([T_rest] + poses[:-1]), np.stack(poses))[..., :3, :3]))
    keys, knots, seen = [], [], {}
    T_prev, f_prev, i_prev = T_rest, 0, -1
    for i, stmt in enumerate(stmts):
        f = _frame_in(stmt, "frame", 1, frames - 1, frames, check, " (frame 0 is the object's own position)")
        if f is None:
            continue
        tok = stmt.tags["frame"].tokens[0]
        if f in seen:
            check.err(tok, f"object {obj.id} has a second keyframe for frame {f} (the first is on line {seen[f]})")
            continue
        if f < f_prev:
            check.err(tok, f"keyframe for frame {f} comes after frame {f_prev} (line {seen[f_prev]}): "
                           f"list an object's keyframes in increasing frame order")
            continue
        seen[f] = stmt.token.line
        p, T = vec(stmt, "position"), poses[i]
        angle = float(turns[i]) if i_prev == i - 1 else float(np.degrees(rotation_angle_rad(relative(T_prev, T)[:3, :3])))
        if angle > MAX_STEP_DEG:
            check.err(stmt.tags["position"].tag, f"object {obj.id} turns by {angle:.1f} degrees between frames "
                                                 f"{f_prev} and {f}: add a keyframe in between (each below "
                                                 f"{MAX_STEP_DEG:g} degrees)")
            continue
        keys.append((float(f), *p[:3], *(p[3:] or (0.0, 0.0, 0.0))))
        knots.append((f, T))
        T_prev, f_prev, i_prev = T, f, i
    return dict(keys=tuple(keys)), dynamics.keyed_poses(T_rest, knots, frames)


def _twists(obj, stmts, T_rest, frames, check):
    segs, spans = [], []
    for stmt in stmts:
        first = _frame_in(stmt, "from", 0, frames - 2, frames, check) if "from" in stmt.tags else 0
        last = _frame_in(stmt, "to", 1, frames - 1, frames, check) if "to" in stmt.tags else frames - 1
        if first is None or last is None:
            continue
        if frames < 2:
            check.err(stmt.token, "MOVE 'twist' needs a sequence of 2 frames or more (add EGO/POSE lines or FRAMES N)")
            continue
        if last <= first:
            check.err(stmt.tags["to"].tokens[0], f"MOVE 'to' ({last}) must be greater than 'from' ({first})")
            continue
        tw = vec(stmt, "twist")
        if np.linalg.norm(tw[3:]) > MAX_STEP_DEG:
            check.err(stmt.tags["twist"].tag, f"MOVE 'twist' turns by {np.linalg.norm(tw[3:]):.1f} degrees per "
                                              f"frame: keep it below {MAX_STEP_DEG:g}")
            continue
        if spans and first < spans[-1][1]:
            a, b, line = spans[-1]
            where = stmt.tags["from"].tokens[0] if "from" in stmt.tags else stmt.token
            check.err(where, f"twist from frame {first} to {last} of object {obj.id} overlaps or precedes the one "
                             f"from {a} to {b} (line {line}): list its twists in frame order without overlaps")
            continue
        spans.append((first, last, stmt.token.line))
        segs.append((float(first), float(last), *tw))
    return dict(twists=tuple(segs)), dynamics.twist_poses(T_rest, segs, frames)


def _trajectory(obj, stmts, T_rest, frames, check):
    stmt = stmts[0]
    for extra in stmts[1:]:
        check.err(extra.token, f"object {obj.id} already replays a trajectory file (line {stmt.token.line}): "
                               f"one file per object")
    first = _frame_in(stmt, "from", 0, frames - 1, frames, check) if "from" in stmt.tags else 0
    path = check.existing_file(stmt, "file")
    fmt = stmt.get("format")
    if first is None or path is None:
        return {}, None
    tok = stmt.tags["file"].tokens[0]
    try:
        T_file = read_trajectory(str(path), fmt)
    except TrajectoryFileError as e:
        check.err(tok, f"MOVE 'file' '{tok.text}' {e}")
        return {}, None
    motion = dict(trajectory_path=str(path), trajectory_format=fmt, trajectory_first=first)
    return motion, dynamics.trajectory_poses(T_rest, T_file, first, frames)
