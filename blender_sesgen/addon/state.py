"""What the panel shows about a script, without bpy: parse status and scene summary.

The panel redraws often, so ``script_info(path)`` parses a file once per change (cached on
path, modification time and size) and returns a :class:`ScriptInfo` to draw from.
"""
from __future__ import annotations

import os
import re
from collections import Counter
from dataclasses import dataclass, field
from typing import Optional

from ..errors import ScriptError, SesgenError
from ..scene.model import Scene


@dataclass(frozen=True)
class ScriptInfo:
    """``state``: 'none' (no path), 'missing', 'error' or 'ok'."""
    state: str
    path: str = ""
    scene: Optional[Scene] = None
    errors: tuple = ()              # ((line, col, message), ...) in source order
    message: str = ""               # the first error as one line ("line L:C: message")
    summary: tuple = field(default=())  # lines for the panel

    @property
    def ok(self) -> bool:
        return self.state == "ok"


_cache: dict = {}


def error_line(e: Exception) -> str:
    """One line for the panel: ``line 12:30: CUBOID 'dim' needs 3 numbers, got 2``."""
    if isinstance(e, ScriptError):
        return f"line {e.line}:{e.col}: {e.message}"
    return str(e)


def summary_lines(scene: Scene) -> tuple[str, ...]:
    rig = scene.rig
    kinds = Counter(o.shape for o in scene.objects)
    objects = ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())) or "none"
    r = scene.render
    return (
        f"Objects: {len(scene.objects)} ({objects})",
        f"Frames: {scene.frames} ({scene.motion.kind} motion)",
        f"Rig: {rig.width}x{rig.height} px, f {rig.focal_px:g} px, "
        + (f"baseline {rig.baseline:g}" if rig.stereo else "monocular"),
        f"Script render: quality {r.quality or 'final (default)'}"
        + (f", {r.samples} samples" if r.samples is not None else "")
        + ("" if r.denoise is None else f", denoise {'on' if r.denoise else 'off'}") + f", seed {r.seed}",
    ) + sensor_lines(scene)


def sensor_lines(scene: Scene) -> tuple[str, ...]:
    """What the script says about moving objects, camera timing, lens, sensor and IMU (one
    line each, only for what it sets; the panel's Timing override replaces the timing)."""
    lines = []
    if scene.object_motions:
        names = {o.id: o.name or str(o.id) for o in scene.objects}
        shown = [f"{names.get(m.id, m.id)}: {m.kind}" for m in scene.object_motions[:3]]
        more = len(scene.object_motions) - len(shown)
        lines.append(f"Moving: {len(scene.object_motions)} object(s) (" + ", ".join(shown)
                     + (f", {more} more" if more else "") + ")")
    t = scene.timing
    if t is not None:
        lines.append(f"Timing: {t.rate_hz:g} Hz, exposure {t.exposure_s * 1e3:g} ms, readout {t.readout_s * 1e3:g} ms"
                     + (", motion blur" if t.motion_blur else "")
                     + (", still camera" if t.still and t.motion_blur and not t.rolling_shutter else ""))
    if scene.lens is not None:
        lens = scene.lens
        optics = [f"f/{lens.f_number:g}" if lens.f_number else "", f"vignetting {lens.vignetting:g}"
                  if lens.vignetting else "", f"chromatic {lens.chromatic_px:g} px" if lens.chromatic_px else ""]
        lines.append(f"Lens: {lens.model}" + "".join(f", {o}" for o in optics if o))
    if scene.sensor is not None:
        sn = scene.sensor
        lines.append("Sensor: " + (f"profile {sn.profile} (per pixel of {sn.native_width_px} px), " if sn.profile else "")
                     + f"full well {sn.full_well_e:g} e-, read noise {sn.read_noise_e:g} e-, "
                     f"{sn.bits} bit" + (f", CFA {sn.cfa}" if sn.cfa else ", mono" if sn.mono else ""))
    if scene.imu is not None:
        lines.append(f"IMU: {scene.imu.rate_hz:g} Hz, seed {scene.imu.seed}")
    return tuple(lines)


def parse_script(path: str) -> Scene:
    """Parse ``path`` (SesgenError/ScriptError on failure)."""
    from ..ses import parse_file
    return parse_file(path)


def script_info(path: str) -> ScriptInfo:
    """Parse status and summary of the script at ``path`` (an absolute path or '')."""
    if not path:
        return ScriptInfo("none")
    try:
        st = os.stat(path)
    except OSError:
        return ScriptInfo("missing", path, message=f"no such file: {path}")
    key = (path, st.st_mtime_ns, st.st_size)
    hit = _cache.get(path)
    if hit is not None and hit[0] == key:
        return hit[1]
    try:
        scene = parse_script(path)
        info = ScriptInfo("ok", path, scene=scene, summary=summary_lines(scene))
    except ScriptError as e:
        errs = tuple((x.line, x.col, x.message) for x in getattr(e, "errors", (e,)))
        info = ScriptInfo("error", path, errors=errs, message=error_line(e))
    except SesgenError as e:
        info = ScriptInfo("error", path, message=str(e))
    _cache[path] = (key, info)
    return info


def forget(path: Optional[str] = None) -> None:
    """Drop the cached parse of ``path`` (all when None)."""
    if path is None:
        _cache.clear()
    else:
        _cache.pop(path, None)


# --- the panel's world override ----------------------------------------------------------

_WORLD_LINE = re.compile(r"^[ \t]*world(?=[ \t]|$)", re.IGNORECASE)
WORLD_OVERRIDE_NOTE = "// the add-on's World override:"


def script_with_world(text: str, hdri: str, strength: float = 1.0, rotation_deg: float = 0.0) -> str:
    """``text`` lit by the bundled HDRI ``hdri`` instead of its own WORLD: the script's WORLD
    line is commented out in place (so every other line keeps its number, and errors their
    position) and ``WORLD hdri ...`` is appended. What is rendered is then exactly the
    script that the output folder's ``scene.ses`` holds."""
    lines = text.splitlines()
    lines = [f"// {ln}" if _WORLD_LINE.match(ln) else ln for ln in lines]
    lines += [WORLD_OVERRIDE_NOTE, f"WORLD hdri {hdri} strength {strength:g} rotation {rotation_deg:g}"]
    return "\n".join(lines) + "\n"


# --- the panel's camera profile -------------------------------------------------------------

_SENSOR_LINE = re.compile(r"^[ \t]*sensor(?=[ \t]|$)", re.IGNORECASE)
PROFILE_OVERRIDE_NOTE = "// the add-on's Camera override:"


def script_with_profile(text: str, profile: str) -> str:
    """``text`` seen through the camera ``profile`` (``sensor/profiles.py``) instead of its
    own SENSOR: the script's SENSOR line is commented out in place (line numbers kept) and
    ``SENSOR profile NAME`` is appended, as :func:`script_with_world` does for the WORLD."""
    lines = [f"// {ln}" if _SENSOR_LINE.match(ln) else ln for ln in text.splitlines()]
    lines += [PROFILE_OVERRIDE_NOTE, f"SENSOR profile {profile}"]
    return "\n".join(lines) + "\n"
