"""The text ``sesgen check`` prints about a parsed scene (and ``api.summary`` returns): its
objects, rig, motion, lighting, render settings and sensor statements."""
from __future__ import annotations

from collections import Counter

import numpy as np

from ..contract.camera import field_of_view_deg
from ..contract.frames import start_rotation_deg
from .model import Scene


def _pose_text(T: np.ndarray) -> str:
    """Position and the START-statement Euler angles of a camera pose."""
    rx, ry, rz = start_rotation_deg(T)
    x, y, z = T[:3, 3] + 0.0  # + 0.0: no "-0" in the output
    return f"position {x:.4g} {y:.4g} {z:.4g}  rotation {rx + 0.0:.4g} {ry + 0.0:.4g} {rz + 0.0:.4g} deg"


def _travel(T: np.ndarray) -> float:
    """Distance a frame's origin travels over the sequence (the camera's: the path length)."""
    return float(np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1).sum()) if len(T) > 1 else 0.0


def summary(scene: Scene) -> str:
    """A human-readable summary of a parsed scene (what `check` prints)."""
    rig = scene.rig
    kinds = Counter(o.shape for o in scene.objects)
    fov_h, fov_v = field_of_view_deg(rig.width, rig.height, rig.focal_px)
    T = scene.timeline.left()
    path_length = _travel(T)
    textures = Counter(o.texture.name for o in scene.objects if o.texture)
    lines = [
        f"scene     {scene.source}",
        f"objects   {len(scene.objects)}: " + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())),
        f"ids       {min(o.id for o in scene.objects)}..{max(o.id for o in scene.objects)}",
        "textures  " + (", ".join(f"{name} x{n}" for name, n in sorted(textures.items())) or "none"),
        f"rig       {rig.width}x{rig.height} px, focal {rig.focal_px:g} px, principal ({rig.cx:g}, {rig.cy:g}), "
        + (f"stereo baseline {rig.baseline:g}" if rig.stereo else "monocular"),
        f"K         {np.array2string(rig.K(), precision=4, suppress_small=True).replace(chr(10), '')}",
        f"fov       {fov_h:.2f} x {fov_v:.2f} deg (horizontal x vertical), clip {rig.near:g}..{rig.far:g}",
        f"motion    {scene.motion.kind}, {scene.frames} frames, path length {path_length:.4g}",
        f"start     {_pose_text(T[0])}",
        f"end       {_pose_text(T[-1])}",
        "moving    " + (", ".join(f"{m.id} ({m.kind}, {_travel(m.poses()):.4g})" for m in scene.object_motions)
                         or "none (static scene)"),
        *_lighting_lines(scene),
    ]
    extras = []
    if scene.materials:
        extras.append(f"{len(scene.materials)} materials ({', '.join(m.name for m in scene.materials)})")
    if scene.fog:
        extras.append(f"fog {scene.fog.start:g}..{scene.fog.end:g}")
    if scene.noise:
        extras.append(f"noise sigma {scene.noise.sigma:g} seed {scene.noise.seed}")
    r = scene.render
    from .presets import effective
    p = effective(None, None, None, r.quality, r.samples, r.denoise)
    sampling = f"adaptive <= {p.samples} samples" if p.adaptive else f"{p.samples} samples"
    extras.append(f"render quality {p.quality}{'' if r.quality else ' (default)'}: {sampling}, "
                  f"denoise {'on' if p.denoise else 'off'}, seed {r.seed}")
    lines.append("extras    " + "; ".join(extras))
    sensors = _sensor_text(scene)
    if sensors:
        lines.append("sensors   " + sensors)
    return "\n".join(lines)


def _world_text(w) -> str:
    if w.kind == "sky":
        haze = f", aerosol {w.aerosol:g}" if w.aerosol != 1.0 else ""
        return f"sky, strength {w.strength:g}, sun at elevation {w.sun_elevation_deg:g} azimuth {w.sun_azimuth_deg:g} deg{haze}"
    if w.kind == "hdri":
        return f"hdri {w.hdri or w.hdri_source}, strength {w.strength:g}, rotation {w.rotation_deg:g} deg"
    return f"colour {' '.join(f'{c:g}' for c in w.colour)}, strength {w.strength:g}"


def _lighting_lines(scene: Scene) -> list[str]:
    """The ``lights`` and ``world`` lines: what the renderer lights the scene with
    (``lighting_data.effective_world``; docs/ses-language.md, LIGHT and WORLD)."""
    from .lighting import effective_world
    blend_lamps = any(imp.lights for imp in scene.imports)
    world = effective_world(scene.world, bool(scene.lights))
    sky_sun = " + the sky's sun" if world.kind == "sky" else ""
    kinds = Counter(light.kind for light in scene.lights)
    lamps = ", ".join(f"{n} {k}" if n > 1 else k for k, n in kinds.items())
    if blend_lamps:
        lamps = f"{lamps}, " * bool(lamps) + "the BLEND file's lamps (if it has any)"
    if scene.lights or scene.world is not None:
        lights = (lamps + sky_sun) if lamps else f"none: the WORLD lights the scene{sky_sun}"
    else:
        lights = (f"{lamps}; without lamps: " if lamps else "") + (
            "default lighting: a clear-sky day (the sky and its sun), plus a ceiling light when START is "
            "inside a closed space")
    if scene.world is not None:
        world_line = _world_text(scene.world)
    elif scene.lights:
        world_line = f"none: a uniform {_world_text(world)} (the LIGHTs light the scene)"
    else:
        world_line = f"none: the default lighting's {_world_text(world)}"
    return ["lights    " + lights, "world     " + world_line]


def _sensor_text(scene: Scene) -> str:
    """One line on the sensor statements (empty when there are none)."""
    parts = []
    t = scene.timing
    if t is not None:
        parts.append(f"{t.rate_hz:g} Hz" + (f", exposure {t.exposure_s * 1e3:g} ms" if t.exposure_s else "")
                     + (" (blur off)" if t.exposure_s and not t.blur else "")
                     + (f", rolling shutter {t.readout_s * 1e3:g} ms" if t.readout_s else ""))
    if scene.lens is not None:
        ln = scene.lens
        parts.append(f"lens {ln.model}" + (f" {' '.join(f'{c:g}' for c in ln.coeffs)}" if ln.coeffs else "")
                     + (f" f/{ln.f_number:g}" if ln.f_number else ""))
    if scene.sensor is not None:
        s = scene.sensor
        parts.append("sensor" + (f" profile {s.profile} (per pixel of {s.native_width_px} px, binned to the render)"
                                 if s.profile else "")
                     + f" {s.bits}-bit" + (f" {s.cfa.upper()}" if s.cfa else " mono" if s.mono else "")
                     + (f" (near infrared {s.nir_share:g} of its signal)" if s.nir_share else "") + f" seed {s.seed}"
                     + (f" jpeg {s.jpeg_quality}" if s.jpeg_quality else ""))
    if scene.autoexposure is not None:
        parts.append(f"auto-exposure speed {scene.autoexposure.speed:g}/s")
    if scene.imu is not None:
        parts.append(f"IMU {scene.imu.rate_hz:g} Hz")
    return "; ".join(parts)
