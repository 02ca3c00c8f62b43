"""The factor registry (pure): what a study may change, in physical units, and how each
change is written into a script.

A factor turns a script into its variant at one level (:class:`Factor.apply` edits a
:class:`~.script.Script`); ``stage`` says what it may change, which is what the study
proves and exploits:

- ``sensor``: only the post-render camera chain (gain, noise, CFA, response, vignetting):
  the variant's EXRs are the base render's, reused (``render --reuse-exr``);
- ``image``: only the rendered image (exposure, light, fog, textures): the ground truth
  (depth, ids, poses) is byte-identical to the base's (checked on every run of a study);
- ``camera``: the camera's geometry (resolution, baseline, lens, rolling shutter);
- ``path``: the rig's motion (``paths``: the same path, resampled or re-oriented);
- ``geometry``: the objects (moving cars, their speed);
- ``world``: a user factor (a statement's tag, a generator option): anything.

Factors are applied in registry order (paths first, the sensor last), each to the script
the previous one wrote. ``base_level(scene)`` is the level the base world itself has (the
point every one-factor-at-a-time sweep goes through). docs/studies.md lists the registry;
a test keeps the two equal.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Optional

import numpy as np

from ..scene import materials
from ..contract.camera import scaled_K, scaled_size
from ..contract.timing import DEFAULT_FPS
from ..errors import SesgenError
from ..scene.lighting import BUILTIN_HDRIS
from . import paths
from .script import Script, statement_line

STAGES = ("world", "path", "geometry", "camera", "image", "sensor")
CONTROLLED_STAGES = ("image", "sensor")   # the ground truth of their variants equals the base's


@dataclass
class Edit:
    """What a factor's ``apply`` may use besides the script and its level."""
    levels: dict                               # every factor's level in this variant
    options: dict                              # this factor's options (defaults merged)
    seed: int                                  # the world seed of this variant
    parse: Callable[[Script], Any]             # the script as a model.Scene (checked)


@dataclass(frozen=True)
class Factor:
    name: str
    unit: str
    doc: str
    stage: str
    apply: Callable[[Script, Any, Edit], None]
    base_level: Callable[[Any], Any]
    kind: str = "number"                       # number | text
    options: dict = field(default_factory=dict)
    needs_sensor: bool = False                 # the study's base gets a SENSOR statement
    choices: tuple = ()

    def check_level(self, level) -> None:
        if self.kind == "number":
            if isinstance(level, bool) or not isinstance(level, (int, float)) or not np.isfinite(level):
                raise SesgenError(f"expected a number ({self.unit}), got {level!r}")
        elif not isinstance(level, str):
            raise SesgenError(f"expected a text level, got {level!r}")
        if self.choices and level not in self.choices:
            raise SesgenError(f"{level!r} is not one of {', '.join(map(str, self.choices))}")


# --- helpers ------------------------------------------------------------------------------

def _positive(level, what: str, allow_zero: bool = True) -> float:
    x = float(level)
    if x < 0 or (x == 0 and not allow_zero):
        raise SesgenError(f"{what} must be {'>= 0' if allow_zero else '> 0'}, got {level}")
    return x


def _rate(scene) -> float:
    return scene.timing.rate_hz if scene.timing else DEFAULT_FPS


# --- path factors ---------------------------------------------------------------------------

def _frame_rate(s: Script, level, e: Edit) -> None:
    scene = e.parse(s)
    rate = _positive(level, "frame rate", allow_zero=False)
    t = paths.frame_rate_times(scene, rate)
    m = paths.rig_motion(scene)
    if scene.timing is not None and max(scene.timing.exposure_s, scene.timing.readout_s) > 1.0 / rate + 1e-12:
        raise SesgenError(f"the base's exposure/readout is longer than the frame period at {rate:g} Hz")
    paths.write_path(s, scene, m.T_world_cam(t), (t - m.start_s) * m.rate_hz)
    s.set_tag("TIMING", "rate", rate)


def _rig_speed(s: Script, level, e: Edit) -> None:
    scene = e.parse(s)
    t = paths.speed_times(scene, _positive(level, "rig speed", allow_zero=False))
    m = paths.rig_motion(scene)
    n = len(t)
    paths.write_path(s, scene, m.T_world_cam(t), np.arange(n, dtype=float))


def _rotation_rate(s: Script, level, e: Edit) -> None:
    if float(level) == 0:
        return
    scene = e.parse(s)
    t = paths.base_times(scene)
    T = paths.pan(scene.timeline.left(), t, float(level))
    paths.write_path(s, scene, T, np.arange(scene.frames, dtype=float))


def _hand_shake(s: Script, level, e: Edit) -> None:
    if _positive(level, "hand shake") == 0:
        return
    scene = e.parse(s)
    t = paths.base_times(scene)
    T = paths.shake(scene.timeline.left(), t, float(level), seed=int(e.options["seed"]) * 1_000_003 + int(e.seed))
    paths.write_path(s, scene, T, np.arange(scene.frames, dtype=float))


# --- geometry ---------------------------------------------------------------------------------

def _free_ids(scene, n: int, first: int = 30000) -> list[int]:
    used = {o.id for o in scene.objects}
    out, k = [], first
    while len(out) < n:
        if k > 32767:
            raise SesgenError("no free object ids left for the moving cars")
        if k not in used:
            out.append(k)
        k += 1
    return out


def _path_polyline(scene) -> tuple[np.ndarray, np.ndarray]:
    """The camera's positions and their cumulative path length (m)."""
    P = scene.timeline.left()[:, :3, 3]
    d = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))]
    return P, d


def _along(P: np.ndarray, d: np.ndarray, s: float) -> tuple[np.ndarray, np.ndarray]:
    """(point, horizontal unit forward) at path length ``s``, extrapolated straight beyond the ends."""
    def fwd(i):
        v = P[i + 1] - P[i]
        v = np.array([v[0], 0.0, v[2]])
        n = np.linalg.norm(v)
        return v / n if n > 1e-9 else np.array([0.0, 0.0, -1.0])
    if len(P) < 2 or d[-1] <= 1e-9:
        raise SesgenError("moving cars need a rig that travels (the cars drive along its path)")
    i = int(np.clip(np.searchsorted(d, s) - 1, 0, len(P) - 2))
    f = fwd(i)
    seg = d[i + 1] - d[i]
    if s < 0 or s > d[-1] or seg <= 1e-12:
        base, ds = (P[0], s) if s < 0 else (P[-1], s - d[-1])
        return base + ds * f, f
    u = (s - d[i]) / seg
    return P[i] + u * (P[i + 1] - P[i]), f


def _moving_cars(s: Script, level, e: Edit) -> None:
    n = int(round(_positive(level, "the number of moving cars")))
    if n != float(level):
        raise SesgenError(f"the number of moving cars must be a whole number, got {level}")
    if n == 0:
        return
    scene = e.parse(s)
    speed = float(e.levels.get("car_speed", e.options["speed_mps"]))
    lane = float(e.options["lane_offset_m"])
    P, d = _path_polyline(scene)
    rate = _rate(scene)
    t = np.arange(scene.frames) / rate
    rng = np.random.default_rng([int(e.seed), 0xCA25])
    first, spacing = float(e.options["first_m"]), float(e.options["spacing_m"])
    lines = ["", f"// {n} car(s) driving towards the camera, {speed:g} m/s, {lane:g} m to its left, the first "
                 f"{first:g} m ahead, then every {spacing:g} m (study)"]
    for car_id, i in zip(_free_ids(scene, n), range(n)):
        s0 = first + i * spacing                             # its path length at t = 0
        poses = []
        for tk in t:
            p, f = _along(P, d, s0 - speed * tk)
            left = -np.cross(f, [0.0, 1.0, 0.0])
            pos = p + lane * left
            heading = -f                                     # towards the camera
            yaw = float(np.degrees(np.arctan2(heading[0], heading[2])))
            poses.append((pos[0], float(e.options["ground_y"]), pos[2], yaw))
        x, y, z, yaw = poses[0]
        lines.append(statement_line("ASSET", [("car", ()), ("id", [car_id]), ("seed", [int(rng.integers(1, 10**6))]),
                                              ("position", [x, y, z, 0, yaw, 0])]))
        lines += [statement_line("MOVE", [("id", [car_id]), ("frame", [k]), ("position", [x, y, z, 0, yaw, 0])])
                  for k, (x, y, z, yaw) in enumerate(poses) if k > 0]
    s.append(*lines)


def _car_speed(s: Script, level, e: Edit) -> None:
    _positive(level, "car speed")        # read by moving_cars (applied after this factor)


def _object_speed(s: Script, level, e: Edit) -> None:
    k = _positive(level, "object speed", allow_zero=True)
    scene = e.parse(s)
    if not scene.object_motions or k == 1:
        return
    paths.rewrite_object_motions(s, scene, np.arange(scene.frames) * k)


# --- camera -----------------------------------------------------------------------------------

def _camera_tags(scene) -> dict:
    r = scene.rig
    return {"resolution": (r.width, r.height), "focal": (r.focal_px,), "principal": (r.cx, r.cy),
            "baseline": (r.baseline,), "near": (r.near,), "far": (r.far,)}


def _resolution(s: Script, level, e: Edit) -> None:
    scale = _positive(level, "resolution scale", allow_zero=False)
    scene = e.parse(s)
    r = scene.rig
    W, H = scaled_size(r.width, r.height, scale)
    K = scaled_K(r.K(), r.width, r.height, W, H)
    tags = _camera_tags(scene)
    tags.update(resolution=(W, H), focal=(K[0, 0],), principal=(K[0, 2], K[1, 2]))
    s.set_tags("CAMERA", tags)


def _baseline(s: Script, level, e: Edit) -> None:
    scene = e.parse(s)
    tags = _camera_tags(scene)
    tags["baseline"] = (_positive(level, "baseline"),)
    s.set_tags("CAMERA", tags)


def _lens_distortion(s: Script, level, e: Edit) -> None:
    k1 = float(level)
    if k1 == 0:
        st = s.first("LENS")
        if st is not None:
            s.edit(st, {}, drop=("brown", "fisheye"))
        return
    s.set_tag("LENS", "brown", k1, 0, 0, 0, drop=("fisheye",))


def _timing(tag: str, what: str):
    def apply(s: Script, level, e: Edit) -> None:
        x = _positive(level, what)
        scene = e.parse(s)
        if x > 1.0 / _rate(scene) + 1e-12:
            raise SesgenError(f"{what} {x:g} s is longer than the frame period 1/{_rate(scene):g} s")
        s.set_tag("TIMING", tag, x)
        if tag == "exposure":     # a fixed exposure: AUTOEXPOSURE would choose its own (and its blur)
            s.drop("AUTOEXPOSURE")
            if x > 0:
                s.set_tag("TIMING", "blur", "on")
    return apply


# --- image ------------------------------------------------------------------------------------

def _sun_elevation(s: Script, level, e: Edit) -> None:
    el = float(level)
    if not -90 <= el <= 90:
        raise SesgenError(f"sun elevation must be within -90..90 deg, got {level}")
    scene = e.parse(s)
    w = scene.world
    strength = w.strength if w is not None and w.kind == "sky" else 1.0
    azimuth = w.sun_azimuth_deg if w is not None and w.kind == "sky" else 0.0
    s.drop("LIGHT", where=lambda st: st.parsed.has("sun"))
    s.drop("WORLD")
    s.insert_head(statement_line("WORLD", [("sky", ()), ("strength", [strength]), ("elevation", [el]),
                                           ("azimuth", [azimuth])]))


def _hdri(s: Script, level, e: Edit) -> None:
    s.drop("LIGHT", where=lambda st: st.parsed.has("sun"))
    s.drop("WORLD")
    s.insert_head(statement_line("WORLD", [("hdri", [str(level)])]))


def _illuminance(s: Script, level, e: Edit) -> None:
    k = _positive(level, "illuminance")
    scene = e.parse(s)
    if not scene.lights and scene.world is None:     # the default daylight, made explicit
        s.insert_head(statement_line("WORLD", [("sky", ()), ("strength", [k]), ("elevation", [50])]))
        return
    for st in s.statements("LIGHT"):
        s.edit(st, {"strength": (k * float(st.get("strength", _default_strength(st))),)})
    w = s.first("WORLD")
    if w is not None:
        s.edit(w, {"strength": (k * float(w.get("strength", 1.0)),)})


def _default_strength(st) -> float:
    return 3.0 if st.parsed.has("sun") else 500.0


def _fog_density(s: Script, level, e: Edit) -> None:
    dens = _positive(level, "fog density")
    s.drop("FOG")
    if dens > 0:
        s.insert_head(statement_line("FOG", [("start", [0]), ("end", [1.0 / dens])]))


def _texture_richness(s: Script, level, e: Edit) -> None:
    """Keep a seeded share of the scene's textures and materials; the rest become plain
    colours (nested: a richer level keeps every source a poorer one keeps)."""
    f = float(level)
    if not 0 <= f <= 1:
        raise SesgenError(f"texture richness is a fraction in 0..1, got {level}")
    if f == 1:
        return
    scene = e.parse(s)
    script_materials = {m.name.lower(): m for m in scene.materials}
    textured = [("object", o.id) for o in scene.objects if o.texture is not None]
    sources = sorted([("material", n) for n in script_materials]
                     + [("library", n) for n in materials.LIBRARY if n not in script_materials]
                     + textured, key=str)
    rng = np.random.default_rng([int(e.options["seed"]), int(e.seed), 0x7E27])
    order = [sources[i] for i in rng.permutation(len(sources))]
    plain = set(order[int(round(f * len(order))):])
    for st in s.statements("MATERIAL"):
        if ("material", str(st.get("name")).lower()) in plain:
            s.edit(st, {}, drop=("texture", "texture_scale", "library", "wear", "bump", "variation", "seed",
                                 "albedo_map", "normal_map", "roughness_map", "map_size", "glow"))
    lines = []
    for kind, name in sorted(plain):
        if kind == "library":
            entry = materials.LIBRARY[name]
            lines.append(statement_line("MATERIAL", [("name", [name]), ("colour", entry.colour),
                                                     ("roughness", [entry.roughness]),
                                                     ("metallic", [entry.metallic])]))
    by_id = {o.id: o for o in scene.objects}
    for st in s.statements("QUAD", "CUBOID", "SPHERE", "CYLINDER", "MESH", "ASSET"):
        o = by_id.get(int(st.get("id")))
        if o is None:
            continue
        tags, drop = {}, []
        if ("object", o.id) in plain:
            drop += ["texture", "texture_scale"]
        mat = (o.material or "").lower()
        if mat and (("library", mat) in plain or ("material", mat) in plain) and not st.parsed.has("class"):
            tags["class"] = (o.semantic_class,)      # the class the library material gave it stays
        if tags or drop:
            s.edit(st, tags, drop=drop)
    if lines:
        s.append("", "// plain stand-ins for library materials (study: texture_richness)", *lines)


# --- sensor -----------------------------------------------------------------------------------

def _sensor(tag: str, what: str, lo: float = 0.0):
    def apply(s: Script, level, e: Edit) -> None:
        x = float(level)
        if x < lo:
            raise SesgenError(f"{what} must be >= {lo:g}, got {level}")
        s.set_tag("SENSOR", tag, x)
    return apply


def _cfa(s: Script, level, e: Edit) -> None:
    if level == "none":
        st = s.first("SENSOR")
        if st is not None:
            s.edit(st, {}, drop=("cfa",))
        else:
            s.set_tags("SENSOR", {})
        return
    s.set_tag("SENSOR", "cfa", str(level))


def _response(s: Script, level, e: Edit) -> None:
    s.set_tag("SENSOR", "response", str(level))


def _vignetting(s: Script, level, e: Edit) -> None:
    s.set_tag("LENS", "vignetting", _positive(level, "vignetting"))


# --- the registry -----------------------------------------------------------------------------

def _t(scene, attr, default):
    return getattr(scene.timing, attr) if scene.timing else default


def _sensor_attr(attr, default):
    return lambda scene: getattr(scene.sensor, attr) if scene.sensor else default


def _sky_elevation(scene):
    w = scene.world
    if w is not None and w.kind == "sky":
        return w.sun_elevation_deg
    return 50.0 if w is None and not scene.lights else None


def _fog_level(scene):
    f = scene.fog
    return 0.0 if f is None else 1.0 / max(f.end - f.start, 1e-9)


FACTORS: dict[str, Factor] = {f.name: f for f in (
    Factor("frame_rate", "Hz", "frames per second on the same path and duration (the base's path resampled)",
           "path", _frame_rate, lambda sc: _rate(sc)),
    Factor("rig_speed", "x base", "the rig's speed along the same path (times the base's; same frame rate)",
           "path", _rig_speed, lambda sc: 1.0),
    Factor("rotation_rate", "deg/s", "peak rate of a pan (2 s period) added about the camera's vertical axis, "
           "same positions", "path", _rotation_rate, lambda sc: 0.0),
    Factor("hand_shake", "deg", "RMS per axis of a smooth seeded hand-held shake (1.5-7 Hz) added to the "
           "orientation, same positions", "path", _hand_shake, lambda sc: 0.0, options={"seed": 0}),
    Factor("car_speed", "m/s", "speed of the cars moving_cars adds", "geometry", _car_speed, lambda sc: 10.0),
    Factor("moving_cars", "cars", "cars driving towards the camera along its path in the lane to its left, "
           "one every 12 m from 8 m ahead",
           "geometry", _moving_cars, lambda sc: 0,
           options={"speed_mps": 10.0, "lane_offset_m": 3.4, "first_m": 8.0, "spacing_m": 12.0, "ground_y": 0.0}),
    Factor("object_speed", "x base", "speed of every object the script moves (MOVE), on its own path",
           "geometry", _object_speed, lambda sc: 1.0),
    Factor("resolution", "x base", "image size and focal length in pixels (the same field of view)", "camera",
           _resolution, lambda sc: 1.0),
    Factor("baseline", "m", "stereo baseline", "camera", _baseline, lambda sc: sc.rig.baseline),
    Factor("lens_distortion", "k1", "radial distortion strength (Brown-Conrady k1; rendered distorted)", "camera",
           _lens_distortion, lambda sc: sc.lens.coeffs[0] if sc.lens and sc.lens.model == "brown" else 0.0),
    Factor("readout_time", "s", "rolling-shutter readout time, top to bottom (0: global shutter)", "camera",
           _timing("readout", "readout time"), lambda sc: _t(sc, "readout_s", 0.0)),
    Factor("exposure_time", "s", "fixed exposure time: the motion blur of the camera moving during it (a "
           "script's AUTOEXPOSURE is dropped)", "image",
           _timing("exposure", "exposure time"), lambda sc: _t(sc, "exposure_s", 0.0)),
    Factor("sun_elevation", "deg", "time of day: the physical sky's sun elevation (replaces the WORLD and sun "
           "lamps)", "image", _sun_elevation, _sky_elevation),
    Factor("hdri", "name", "image-based lighting: a bundled HDRI (night, sunset, ...) replaces the WORLD", "image",
           _hdri, lambda sc: sc.world.hdri if sc.world is not None and sc.world.kind == "hdri" else None,
           kind="text", choices=BUILTIN_HDRIS),
    Factor("illuminance", "x base", "every light's and the sky's strength (with a SENSOR: a darker, noisier "
           "image at the same exposure)", "image", _illuminance, lambda sc: 1.0, needs_sensor=True),
    Factor("fog_density", "1/m", "distance fog from the camera, opaque at 1/density metres (0: none)", "image",
           _fog_density, _fog_level),
    Factor("texture_richness", "fraction", "share of the textures and materials kept (seeded; the rest plain "
           "colours)", "image", _texture_richness, lambda sc: 1.0, options={"seed": 0}),
    Factor("gain", "x", "sensor analog gain at the same exposure", "sensor", _sensor("gain", "gain", 1e-9),
           _sensor_attr("gain", 1.0), needs_sensor=True),
    Factor("read_noise", "e-", "sensor read noise (std, electrons)", "sensor", _sensor("readnoise", "read noise"),
           _sensor_attr("read_noise_e", 0.0), needs_sensor=True),
    Factor("full_well", "e-", "sensor full-well capacity (shot noise grows as it shrinks)", "sensor",
           _sensor("fullwell", "full well", 1.0), _sensor_attr("full_well_e", 10000.0), needs_sensor=True),
    Factor("cfa", "pattern", "Bayer colour filter array, demosaiced (none: a colour sensor)", "sensor", _cfa,
           lambda sc: (sc.sensor.cfa or "none") if sc.sensor else "none", kind="text",
           choices=("none", "rggb", "bggr", "grbg", "gbrg"), needs_sensor=True),
    Factor("response", "curve", "the sensor's response curve to 8 bits", "sensor", _response,
           _sensor_attr("response", "srgb"), kind="text", choices=("srgb", "linear", "gamma"), needs_sensor=True),
    Factor("vignetting", "x cos^4", "lens vignetting (1 = the natural cos^4 law)", "sensor", _vignetting,
           lambda sc: sc.lens.vignetting if sc.lens else 0.0, needs_sensor=True),
)}


@dataclass(frozen=True)
class UserFactor:
    """A factor of the study file: a tag of a statement, or an option of the generator."""
    name: str
    unit: str
    doc: str
    statement: Optional[str] = None           # keyword (SENSOR, FOG, MATERIAL, ...)
    tag: Optional[str] = None
    match: tuple = ()                          # ((tag, value), ...) selecting the statements
    option: Optional[str] = None               # a generator option
    stage: str = "world"
    kind: str = "number"
    options: dict = field(default_factory=dict)
    needs_sensor: bool = False
    choices: tuple = ()

    def check_level(self, level) -> None:
        if isinstance(level, bool) or not isinstance(level, (int, float, str)):
            raise SesgenError(f"expected a number or a text, got {level!r}")

    def base_level(self, scene):
        return None

    def apply(self, s: Script, level, e: Edit) -> None:
        if self.option is not None:
            return                              # applied by the generator (variants.py)
        values = level if isinstance(level, (list, tuple)) else (level,)
        from ..ses.grammar import SINGLETON_KEYWORDS
        if self.statement in SINGLETON_KEYWORDS:
            s.set_tag(self.statement, self.tag, *values)
            return
        hits = [st for st in s.statements(self.statement)
                if all(str(st.get(k)).lower() == str(v).lower() for k, v in self.match)]
        if not hits:
            where = " ".join(f"{k} {v}" for k, v in self.match)
            raise SesgenError(f"the script has no {self.statement} {where}".rstrip())
        for st in hits:
            s.edit(st, {self.tag: values})


def lookup(name: str) -> Factor:
    if name not in FACTORS:
        import difflib
        close = difflib.get_close_matches(name, FACTORS, n=1)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        raise SesgenError(f"unknown factor '{name}'{hint} (factors: {', '.join(FACTORS)}; or a user factor with "
                          "statement/tag or option)")
    return FACTORS[name]


def ordered(names) -> list[str]:
    """Factor names in the order they are applied: the registry's, then user factors."""
    reg = list(FACTORS)
    return sorted(names, key=lambda n: (reg.index(n) if n in reg else len(reg), n))
