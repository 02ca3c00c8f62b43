"""Shared helpers of the scene generators: number formatting, SES lines for assets and
poses, a street's centreline (the same function the street strips are built from).

Imported by the generators of this package; pure numpy.
"""
from __future__ import annotations

import inspect
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

REPO = Path(__file__).resolve().parents[3]   # the source tree (its ../shared/data: real sensor files)

from ...contract.se3 import R_to_euler_xyz_deg, euler_xyz_deg_to_R


KITTI_CAMERA_HEIGHT = 1.65     # KITTI's left camera above the road (m)


def kitti_rig(far: float = 600.0) -> str:
    """KITTI odometry's stereo rig: 1226 x 370 px, f = 707 px, baseline 0.54 m."""
    return f"CAMERA resolution 1226 370 focal 707 baseline 0.54 near 0.1 far {num(far)}"


def num(v: float, nd: int = 3) -> str:
    """A number with at most ``nd`` decimals, no trailing zeros, never '-0'."""
    s = f"{float(v):.{nd}f}"
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def nums(values, nd: int = 3) -> str:
    return " ".join(num(v, nd) for v in values)


class Ids:
    """Object ids handed out in ranges per category (so ids say what an object is)."""

    def __init__(self, starts: dict[str, int]):
        self.next = dict(starts)

    def __call__(self, category: str) -> int:
        i = self.next[category]
        self.next[category] += 1
        return i


def asset(kind: str, id_: int, position, yaw_deg: float = 0.0, size=None, seed=None, extra: str = "") -> str:
    parts = [f"ASSET {kind} id {id_}"]
    if seed is not None:
        parts.append(f"seed {int(seed)}")
    rot = f" 0 {num(yaw_deg, 3)} 0" if abs(yaw_deg) > 1e-9 else ""
    parts.append(f"position {nums(position)}{rot}")
    if size is not None:
        parts.append(f"size {nums(size)}")
    if extra:
        parts.append(extra)
    return " ".join(parts)


def camera_pose_line(position, yaw_deg: float, pitch_deg: float = 0.0, roll_deg: float = 0.0) -> str:
    """``POSE x y z rx ry rz`` of a camera at ``position`` heading ``yaw_deg`` (left
    positive, 0 = looking along -z), pitched up by ``pitch_deg`` about its own x axis and
    rolled by ``roll_deg`` about its own optical axis."""
    rx, ry, rz = R_to_euler_xyz_deg(camera_body_R(yaw_deg, pitch_deg, roll_deg))
    return f"POSE {nums(position, 4)} {nums((rx, ry, rz), 4)}"


def camera_body_R(yaw_deg: float, pitch_deg: float = 0.0, roll_deg: float = 0.0) -> np.ndarray:
    """The camera's rotation (Blender's camera axes: x right, y up, z back) that
    :func:`camera_pose_line` writes: R = Ry(yaw) Rx(pitch) Rz(-roll)."""
    return (euler_xyz_deg_to_R(0, yaw_deg, 0) @ euler_xyz_deg_to_R(pitch_deg, 0, 0)
            @ euler_xyz_deg_to_R(0, 0, -roll_deg))


def camera_yaw_pitch_roll(R: np.ndarray) -> tuple[float, float, float]:
    """(yaw, pitch, roll) in degrees of a camera rotation: the inverse of :func:`camera_body_R`."""
    pitch = np.arcsin(np.clip(-R[1, 2], -1.0, 1.0))
    return (float(np.degrees(np.arctan2(R[0, 2], R[2, 2]))), float(np.degrees(pitch)),
            float(-np.degrees(np.arctan2(R[1, 0], R[1, 1]))))


def smooth_noise(rng, n: int, scale: float, cycles=(1.3, 2.9, 6.1)) -> np.ndarray:
    """A smooth random signal of n samples: a few sines of random phase, RMS ~ scale."""
    t = np.linspace(0.0, 1.0, n)
    out = np.zeros(n)
    for c in cycles:
        out += np.sin(2 * np.pi * c * rng.uniform(0.7, 1.3) * t + rng.uniform(0, 2 * np.pi)) / np.sqrt(len(cycles))
    return scale * out * np.sqrt(2)


def sun_travel(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """The way sunlight travels (``LIGHT sun direction``) for a sun at this elevation and
    azimuth (azimuth from -z towards +x, as ``WORLD sky``'s)."""
    el, az = np.radians(elevation_deg), np.radians(azimuth_deg)
    return -np.array([np.cos(el) * np.sin(az), np.sin(el), -np.cos(el) * np.cos(az)])


def sky_and_sun(elevation_deg: float, azimuth_deg: float, sky_strength: float = 1.0, aerosol: float = 1.0) -> list[str]:
    """A physical sky with its sun (the renderer adds the sun as a calibrated lamp); ``aerosol``
    above 1 is a hazier sky than the sky model's default."""
    haze = f" aerosol {num(aerosol)}" if aerosol != 1.0 else ""
    return [f"WORLD sky strength {num(sky_strength)} elevation {num(elevation_deg)} azimuth {num(azimuth_deg)}{haze}"]


# --- what a seed varies besides the layout: light, time of day, fog -------------------------

OUTDOOR_HDRIS = ("city", "courtyard", "forest", "sunrise", "sunset")   # bundled, daylight (not night/studio)
HAZE = ((0.72, 0.75, 0.8), (0.78, 0.78, 0.78), (0.66, 0.68, 0.7))    # fog colours (linear): blue-grey haze, mist
ASPHALT = (0.085, 0.085, 0.082)                                      # the city streets' asphalt (linear albedo)
PAVING = ((0.30, 0.29, 0.27), (0.34, 0.33, 0.31), (0.26, 0.25, 0.24), (0.31, 0.22, 0.18))   # sidewalk tones


def variation_rng(seed: int, salt: int) -> np.random.Generator:
    """The random stream of a seed's variation (light, materials, trajectory), apart from its
    layout stream ``default_rng(seed)``: drawing variations never shifts the layout."""
    return np.random.default_rng([int(seed), int(salt)])


class SeededVariation:
    """Base of a generator's ``Variation`` (a frozen dataclass of what a seed changes besides the
    layout), declared ``class Variation(SeededVariation, salt=0xC1D)``: ``Variation.of(0)`` is
    the defaults (the checked-in script), any other seed is what the class's ``draw(rng)`` draws
    from the seed's own stream ``variation_rng(seed, salt)``."""
    salt: int

    def __init_subclass__(cls, salt: int, **kwargs):
        super().__init_subclass__(**kwargs)
        cls.salt = salt

    @classmethod
    def of(cls, seed: int):
        return cls() if seed == 0 else cls.draw(variation_rng(seed, cls.salt))

    @classmethod
    def draw(cls, rng: np.random.Generator):
        raise NotImplementedError


def draw_street_surfaces(rng: np.random.Generator, tone: float) -> dict:
    """A city variation's road (asphalt at ``tone``, wear) and sidewalk paving (tone, wear),
    as ``Variation`` fields: the asphalt's wear, then the paving's tone and wear, drawn in
    that order."""
    road = (tuple(round(c * tone, 3) for c in ASPHALT), round(float(rng.uniform(0.1, 0.8)), 2))
    return {"road": road, "paving": (PAVING[int(rng.integers(len(PAVING)))], round(float(rng.uniform(0.0, 0.6)), 2))}


@dataclass(frozen=True)
class Lighting:
    """A scene's natural light: a physical sky with its sun at ``sun`` = (elevation, azimuth)
    in degrees (the time of day), or a bundled HDRI ``hdri`` = (name, strength, rotation deg;
    the sun is then unused);
    optional distance fog ``fog`` = (start m, end m, colour); ``aerosol``: the sky's haze
    (``WORLD sky aerosol``)."""
    sun: tuple = (45.0, 0.0)
    sky_strength: float = 1.0
    aerosol: float = 1.0
    hdri: Optional[tuple] = None
    fog: Optional[tuple] = None

    def lines(self) -> list[str]:
        if self.hdri is not None:
            name, strength, rotation = self.hdri
            out = [f"WORLD hdri {name} strength {num(strength)} rotation {num(rotation)}"]
        else:
            out = sky_and_sun(self.sun[0], self.sun[1], self.sky_strength, self.aerosol)
        if self.fog is not None:
            start, end, colour = self.fog
            out.append(f"FOG start {num(start, 1)} end {num(end, 1)} colour {nums(colour)}")
        return out


def draw_lighting(rng: np.random.Generator, elevation=(12.0, 65.0), azimuth=(0.0, 360.0), hdris=OUTDOOR_HDRIS,
                  p_hdri: float = 0.3, p_fog: float = 0.0, fog_start=(15.0, 60.0), fog_depth=(80.0, 300.0)) -> Lighting:
    """A random :class:`Lighting`: a sun anywhere in ``elevation`` x ``azimuth`` (sky
    strength 0.8-1.2), or with probability ``p_hdri`` one of ``hdris`` (strength 0.7-1.4,
    any rotation); fog with probability ``p_fog``, starting in ``fog_start`` and fully
    fogged ``fog_depth`` metres further."""
    sun = (round(float(rng.uniform(*elevation)), 1), round(float(rng.uniform(*azimuth)) % 360.0, 1))
    strength = round(float(rng.uniform(0.8, 1.2)), 2)
    hdri = None
    if hdris and rng.uniform() < p_hdri:
        hdri = (str(rng.choice(hdris)), round(float(rng.uniform(0.7, 1.4)), 2), round(float(rng.uniform(0, 360)), 1))
    fog = None
    if rng.uniform() < p_fog:
        start = round(float(rng.uniform(*fog_start)), 1)
        fog = (start, round(start + float(rng.uniform(*fog_depth)), 1), HAZE[int(rng.integers(len(HAZE)))])
    return Lighting(sun=sun, sky_strength=strength, hdri=hdri, fog=fog)


def derived_material(name: str, library: str, colour=None, wear=None, seed=None, texture_scale=None) -> str:
    """``MATERIAL name N library L ...``: a library material with this scene's colour, wear
    and per-object variation seed."""
    parts = [f"MATERIAL name {name} library {library}"]
    if colour is not None:
        parts.append(f"colour {nums(colour)}")
    if texture_scale is not None:
        parts.append(f"texture_scale {num(texture_scale)}")
    if wear is not None:
        parts.append(f"wear {num(wear, 2)}")
    if seed is not None:
        parts.append(f"seed {int(seed)}")
    return " ".join(parts)


# --- lining a street: buildings with front yards, green stretches, parked cars, lights ------
# ``place(s, offset)`` gives (the ground point, the street's yaw in degrees (0 = along -z, left
# positive)) at arc length s along a street line and ``offset`` metres to its right; the
# helpers below fill one side of such a line (side +1: right, -1: left), city_kitti's street
# and the sides of city_grid's blocks alike.

@dataclass(frozen=True)
class Frontage:
    """How a street side is lined: green stretches (trees, bushes in a lawn) with probability
    ``p_green``, else buildings of ``width`` x ``depth`` and a height drawn from ``height_low``
    or (probability ``p_high``) ``height_high``, set back ``setback`` from the edge, with front
    yards (a hedge or fence along the edge with probability ``p_yard_edge``, bushes), bins and
    (``p_second_row``) a taller building behind. The defaults are city_kitti's ``block``."""
    start: tuple = (2.0, 10.0)
    p_green: float = 0.4
    green_length: tuple = (25.0, 45.0)
    green_depth: tuple = (3.0, 18.0)
    width: tuple = (11.0, 24.0)
    depth: tuple = (9.0, 15.0)
    height_low: tuple = (8.0, 12.0)
    height_high: tuple = (12.0, 19.0)
    p_high: float = 0.45
    setback: tuple = (4.0, 12.0)
    gap: tuple = (1.5, 7.0)
    p_second_row: float = 0.7
    p_yard_edge: float = 0.75     # yards closed along the edge: a hedge (probability 0.45), else a fence


def random_seed(rng: np.random.Generator):
    """The default asset seeds of the lining helpers: a fresh seed per asset."""
    return lambda kind: int(rng.integers(1e6))


class VariantPool:
    """A few variants (seed, and a size where ``sizes`` draws one) per pool, drawn once; every
    asset of a pooled kind picks one of them. Assets with equal kind, size and seed share one
    mesh in Blender (``scene.assets.mesh_key``) and Cycles instances it, so a street of
    trees costs a pool's few meshes to generate, build and hold, not one per tree. Object
    ids stay per object. A pool name not in ``counts``: a fresh seed (and no size) per asset.
    Called as ``pool(kind)`` it is the lining helpers' ``seed_of``. Picks draw from ``rng``
    (one draw each, as a fresh seed would); the variants from ``variants_rng`` (default
    ``rng``): a stream of their own leaves the layout drawn after them as it was."""

    def __init__(self, rng: np.random.Generator, counts: dict, sizes: Optional[dict] = None,
                 variants_rng: Optional[np.random.Generator] = None):
        self.rng = rng
        v = rng if variants_rng is None else variants_rng
        self.seeds = {k: [int(x) for x in v.integers(1, 10 ** 6, n)] for k, n in counts.items()}
        self.sizes = {k: [size_of(v) for _ in range(counts[k])] for k, size_of in (sizes or {}).items()}

    def __call__(self, kind: str) -> int:
        return self.pick(kind)[0]

    def pick(self, name: str) -> tuple:
        """(seed, size or None) of one variant of pool ``name``."""
        seeds = self.seeds.get(name)
        if seeds is None:
            return int(self.rng.integers(10 ** 6)), None
        i = int(self.rng.integers(len(seeds)))
        return seeds[i], (self.sizes[name][i] if name in self.sizes else None)


def line_street_side(rng: np.random.Generator, place, s_end: float, side: int, edge: float, ids: Ids,
                     style: Frontage = Frontage(), seed_of=None, limit: Optional[float] = None) -> list[str]:
    """Buildings (front facades towards the street) and green stretches along one side of a
    street line, from a start drawn in ``style.start`` while the arc length is below
    ``s_end``; ``edge``: the distance from the line to where the lots begin. ``limit``: no
    building reaches beyond this arc length (the last one is narrowed, or left out).
    ``seed_of(kind)`` gives each asset's seed."""
    seed_of = seed_of or random_seed(rng)
    out = []
    s = float(rng.uniform(*style.start))
    while s < s_end:
        if rng.random() < style.p_green:        # a green stretch: trees and bushes in a lawn
            length = float(rng.uniform(*style.green_length))
            for t in np.arange(s + 3, s + length - 3, rng.uniform(4, 8)):
                depth = edge + rng.uniform(*style.green_depth)
                p, _ = place(t + rng.uniform(-2, 2), side * depth)
                kind = "conifer" if rng.random() < 0.25 else "tree"
                out.append(asset(kind, ids("tree"), p, rng.uniform(0, 360), seed=seed_of(kind)))
                if rng.random() < 0.5:
                    bp, _ = place(t + rng.uniform(-3, 3), side * (edge + rng.uniform(2, 12)))
                    out.append(asset("bush", ids("veg"), bp, rng.uniform(0, 360), seed=seed_of("bush")))
            s += length
            continue
        W = float(rng.uniform(*style.width))
        D = float(rng.uniform(*style.depth))
        H = float(rng.choice([rng.uniform(*style.height_low), rng.uniform(*style.height_high)],
                             p=[1 - style.p_high, style.p_high]))
        setback = float(rng.uniform(*style.setback))
        if limit is not None and s + W > limit:
            W = limit - s
            if W < 0.7 * style.width[0]:
                break
        centre_s = s + W / 2
        p, h = place(centre_s, side * (edge + setback + D / 2))
        yaw = h - 90 if side > 0 else h + 90
        out.append(asset("building", ids("building"), p, yaw, (round(W, 2), round(H, 2), round(D, 2)),
                         seed=seed_of("building")))
        # front yard: a hedge or a fence along the sidewalk (length along the street), bushes
        r = rng.random()
        if setback > 2.6 and r < style.p_yard_edge:
            kind = "hedge" if r < 0.45 else "fence"
            hp, hh = place(centre_s, side * (edge + (0.6 if kind == "hedge" else 0.25)))
            size = ((round(W * rng.uniform(0.6, 0.95), 2), round(float(rng.uniform(0.8, 1.5)), 2), 0.7)
                    if kind == "hedge" else (round(W * rng.uniform(0.7, 1.0), 2), round(float(rng.uniform(0.8, 1.2)), 2), 0.2))
            out.append(asset(kind, ids("veg"), hp, hh + 90, size, seed=seed_of(kind)))
        for _ in range(int(rng.integers(0, 4)) if setback > 2.5 else 0):
            bp, _ = place(centre_s + rng.uniform(-W / 2, W / 2), side * (edge + rng.uniform(1.2, setback - 0.8)))
            out.append(asset("bush", ids("veg"), bp, rng.uniform(0, 360), seed=seed_of("bush")))
        if rng.random() < 0.35:     # a bin facing the street
            bp, bh = place(centre_s + rng.uniform(-W / 3, W / 3), side * (edge + 0.9))
            out.append(asset("bin", ids("furniture"), bp, bh - 90 if side > 0 else bh + 90, seed=seed_of("bin")))
        # a second row behind (seen through the gaps), simpler and taller
        if rng.random() < style.p_second_row:
            p2, h2 = place(centre_s + rng.uniform(-5, 5), side * (edge + setback + D + rng.uniform(8, 20) + 6))
            out.append(asset("building", ids("building"), p2, (h2 - 90 if side > 0 else h2 + 90) + rng.uniform(-8, 8),
                             (round(float(rng.uniform(12, 26)), 2), round(float(rng.uniform(10, 22)), 2),
                              round(float(rng.uniform(10, 14)), 2)), seed=seed_of("building")))
        s += W + float(rng.uniform(*style.gap))
    return out


def kerb_cars(rng: np.random.Generator, place, s: float, s_end: float, side: int, offset: float, p_park: float,
              ids: Ids, seed_of=None) -> list[str]:
    """Cars parked along the kerb on one side of a street line, ``offset`` from it (facing the
    way traffic on that side drives), one in a slot with probability ``p_park``."""
    seed_of = seed_of or random_seed(rng)
    out = []
    while s < s_end:
        if rng.random() < p_park:
            p, h = place(s, side * (offset + rng.uniform(-0.05, 0.05)))
            out.append(asset("car", ids("car"), p, (h + 180 if side > 0 else h) + rng.uniform(-2, 2),
                             seed=seed_of("car")))
            s += float(rng.uniform(5.2, 6.5))
        else:
            s += float(rng.uniform(4, 14))
    return out


def street_lights(rng: np.random.Generator, place, s: float, s_end: float, side: int, offset: float, ids: Ids,
                  spacing=(28.0, 36.0), seed_of=None) -> list[str]:
    """Street lights on one side of a street line, ``offset`` from it, their arms reaching
    over the street."""
    seed_of = seed_of or random_seed(rng)
    out = []
    while s < s_end:
        p, h = place(s, side * offset)
        out.append(asset("streetlight", ids("furniture"), p, h if side > 0 else h + 180, seed=seed_of("streetlight")))
        s += float(rng.uniform(*spacing))
    return out


def script_with_poses(lines: list[str], comment: str, P, yaw, pitch, roll) -> str:
    """The script: ``lines``, a blank line, ``// comment`` and one POSE line per camera
    position (angles in degrees)."""
    poses = [camera_pose_line(P[i], yaw[i], pitch[i], roll[i]) for i in range(len(P))]
    return "\n".join(lines + ["", f"// {comment}"] + poses) + "\n"


def _option_type(hint, default):
    """The command-line type of an option: its annotation's (``Optional[X]``: X) when that is a
    number, text or a truth value, else its default's; None when it has no such type."""
    args = [a for a in typing.get_args(hint) if a is not type(None)] if typing.get_origin(hint) is typing.Union else [hint]
    t = args[0] if len(args) == 1 and args[0] in (int, float, str, bool) else type(default)
    if t is bool:
        return lambda v: {"true": True, "false": False}[v.lower()]
    return t if t in (int, float, str) else None


def command_line(generate, doc: str, frames: Optional[int], argv=None) -> None:
    """A generator's command line: ``--seed S``, ``--frames N`` (default ``frames``) when it
    takes frames, and ``--NAME VALUE`` for each other option that is a number, text or a truth
    value (``true``/``false``); the script on stdout."""
    import argparse
    import sys
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    hints = typing.get_type_hints(generate)
    for p in list(inspect.signature(generate).parameters.values())[1:]:
        kind = int if p.name == "frames" else _option_type(hints.get(p.name), p.default)
        if kind is not None:
            ap.add_argument("--" + p.name.replace("_", "-"), type=kind, default=frames if p.name == "frames" else p.default)
    a = vars(ap.parse_args(argv))
    sys.stdout.write(generate(a.pop("seed"), **a))
