"""The JSON types of a manifest's keys (``contract.manifest``'s reader calls :func:`check_types`).

Python's ``float()`` and ``np.array(dtype=float)`` quietly turn ``"3"``, ``true`` or ``null``
into numbers, and a reader deep in ``vo_reference`` would otherwise meet a list where it
expects a number: every key a reader relies on is checked here first, and a defect names
the key. Ranges (K, poses, timestamps) are the reader's own checks after this.

The optional sections of the sensor statements (``rig_motion``, ``timing``, ``lens``,
``sensor``, ``imu``) are typed records read and checked by ``manifest_sections``.
"""
from __future__ import annotations

import json
import math

from .errors import ContractError
from .manifest_sections import inside


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _numbers_only(v) -> bool:
    """True when ``v`` is a number or (nested) lists of numbers: no strings, booleans or nulls
    that ``float()`` / ``np.array(dtype=float)`` would quietly convert."""
    if isinstance(v, list):
        return all(_numbers_only(x) for x in v)
    return _is_number(v)


def check_types(m: dict, source: str, limit: float) -> None:
    """The JSON types of every key a reader relies on, so that a malformed manifest fails here
    naming the key, never deep inside a reader (ranges of K, poses, ... are checked after)."""
    def bad(key: str, want: str):
        raise ContractError(f"'{key}' must be {want}, got {json.dumps(m.get(key))[:80]}", source)

    for key in ("resolution", "K", "baseline", "near", "far", "timestamps", "fps"):
        if m.get(key) is not None and not _numbers_only(m[key]):
            bad(key, "numbers")
    if not (isinstance(m["resolution"], list) and len(m["resolution"]) == 2
            and all(isinstance(v, int) and not isinstance(v, bool) for v in m["resolution"])):
        bad("resolution", "[W, H] in whole pixels")
    if not isinstance(m["frames"], int) or isinstance(m["frames"], bool):
        bad("frames", "a whole number")
    if m.get("fps") is not None and not (_is_number(m["fps"]) and 0 < m["fps"] <= limit):
        bad("fps", f"a number in (0, {limit:g}]")
    for key in ("generator", "render", "channels", "depth", "segmentation", "poses", "files", "noise", "checksums"):
        if m.get(key) is not None and not isinstance(m[key], dict):
            bad(key, "an object")
    if not isinstance(m["views"], list) or not all(isinstance(v, str) for v in m["views"]):
        bad("views", "a list of names")
    if not all(_numbers_only(p) for p in (m["poses"] or {}).values()):
        bad("poses", "numbers")
    if m.get("objects") is not None and not (isinstance(m["objects"], list)
                                             and all(isinstance(o, dict) for o in m["objects"])):
        bad("objects", "a list of objects")
    for o in m.get("objects") or []:
        if o.get("moving") and not (isinstance(o.get("id"), int) and _numbers_only(o.get("T_world_obj"))):
            bad("objects", "objects whose moving ones have an integer id and T_world_obj numbers")
        box, rest = o.get("box"), o.get("T_world_obj_rest")
        if box is not None and not (_numbers_only(box) and len(box) == 2 and all(len(r) == 3 for r in box)
                                    and all(lo <= hi for lo, hi in zip(*box))):
            bad("objects", "objects whose box is [[x, y, z] min, [x, y, z] max]")
        if rest is not None and not (_numbers_only(rest) and len(rest) == 4 and all(len(r) == 4 for r in rest)):
            bad("objects", "objects whose T_world_obj_rest is a 4x4 matrix")
    complete = m.get("frames_complete")
    if complete is not None and not (isinstance(complete, list) and all(isinstance(c, bool) for c in complete)):
        bad("frames_complete", "a list of true/false")
    depth, seg, channels = m.get("depth") or {}, m.get("segmentation") or {}, m.get("channels") or {}
    if "background" in depth and not (_is_number(depth["background"]) and depth["background"] > 0):
        bad("depth", "an object whose background is a positive number")
    for key, d in (("depth", depth), ("segmentation", seg)):
        if d.get("channel") is not None and not isinstance(d["channel"], str):
            bad(key, "an object whose channel is a name")
    if not all(isinstance(c, str) or (isinstance(c, list) and all(isinstance(x, str) for x in c))
               for c in channels.values()):
        bad("channels", "channel names")
    if m.get("seal") is not None and not isinstance(m["seal"], str):
        bad("seal", "a SHA-256 string")
    if not all(isinstance(v, str) for v in (m.get("checksums") or {}).values()):
        bad("checksums", "an object of SHA-256 strings")
    noise = m.get("noise")
    if noise is not None and not (_is_number(noise.get("sigma")) and noise["sigma"] >= 0
                                  and isinstance(noise.get("seed", 0), int)):
        bad("noise", "{\"sigma\": >= 0, \"seed\": integer}")
    _check_listed_files(m, source)


def _check_listed_files(m: dict, source: str) -> None:
    """The trajectories and display PNGs the manifest lists stay inside the render folder
    (``verify`` checks each of them; the optional sections check their own files)."""
    def bad(key: str, want: str):
        raise ContractError(f"'{key}' must be {want}", source)

    views = m["views"]
    n = m["frames"]
    traj = m.get("trajectories")
    if traj is not None and not (isinstance(traj, dict) and all(
            isinstance(traj.get(k) or {}, dict) and all(inside(p) for p in (traj.get(k) or {}).values())
            for k in ("tum", "kitti")) and (traj.get("ego") is None or inside(traj["ego"]))):
        bad("trajectories", "paths inside the render folder")
    display = m.get("display")
    files = display.get("files") if isinstance(display, dict) else None
    if display is not None and not (isinstance(files, dict) and all(
            v in files and isinstance(files[v], list) and len(files[v]) == n and all(inside(p) for p in files[v])
            for v in views)):
        bad("display.files", f"for each view, {n} paths inside the render folder")
