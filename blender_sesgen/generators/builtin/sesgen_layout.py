"""Shared helpers of the scene generators: number formatting, SES lines for assets and
poses, a street's centreline (the same function the street strips are built from).

Imported by the generators of this package; pure numpy.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

REPO = Path(__file__).resolve().parents[3]   # the source tree (its ../shared/data: real sensor files)

from ...contract.se3 import R_to_euler_xyz_deg, euler_xyz_deg_to_R


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
    R_body = (euler_xyz_deg_to_R(0, yaw_deg, 0) @ euler_xyz_deg_to_R(pitch_deg, 0, 0)
              @ euler_xyz_deg_to_R(0, 0, -roll_deg))
    rx, ry, rz = R_to_euler_xyz_deg(R_body)
    return f"POSE {nums(position, 4)} {nums((rx, ry, rz), 4)}"


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


def sky_and_sun(elevation_deg: float, azimuth_deg: float, sky_strength: float = 1.0) -> list[str]:
    """A physical sky with its sun (the renderer adds the sun as a calibrated lamp)."""
    return [f"WORLD sky strength {num(sky_strength)} elevation {num(elevation_deg)} azimuth {num(azimuth_deg)}"]


# --- what a seed varies besides the layout: light, time of day, fog -------------------------

OUTDOOR_HDRIS = ("city", "courtyard", "forest", "sunrise", "sunset")   # bundled, daylight (not night/studio)
HAZE = ((0.72, 0.75, 0.8), (0.78, 0.78, 0.78), (0.66, 0.68, 0.7))    # fog colours (linear): blue-grey haze, mist


def variation_rng(seed: int, salt: int) -> np.random.Generator:
    """The random stream of a seed's variation (light, materials, trajectory), apart from its
    layout stream ``default_rng(seed)``: drawing variations never shifts the layout."""
    return np.random.default_rng([int(seed), int(salt)])


@dataclass(frozen=True)
class Lighting:
    """A scene's natural light: a physical sky with its sun at ``sun`` = (elevation, azimuth)
    in degrees (the time of day), or a bundled HDRI ``hdri`` = (name, strength, rotation deg;
    the sun is then unused);
    optional distance fog ``fog`` = (start m, end m, colour)."""
    sun: tuple = (45.0, 0.0)
    sky_strength: float = 1.0
    hdri: Optional[tuple] = None
    fog: Optional[tuple] = None

    def lines(self) -> list[str]:
        if self.hdri is not None:
            name, strength, rotation = self.hdri
            out = [f"WORLD hdri {name} strength {num(strength)} rotation {num(rotation)}"]
        else:
            out = sky_and_sun(self.sun[0], self.sun[1], self.sky_strength)
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


def script_with_poses(lines: list[str], comment: str, P, yaw, pitch, roll) -> str:
    """The script: ``lines``, a blank line, ``// comment`` and one POSE line per camera
    position (angles in degrees)."""
    poses = [camera_pose_line(P[i], yaw[i], pitch[i], roll[i]) for i in range(len(P))]
    return "\n".join(lines + ["", f"// {comment}"] + poses) + "\n"


def command_line(generate, doc: str, frames: int, argv=None) -> None:
    """A generator's command line: ``--seed S --frames N``, the script on stdout."""
    import argparse
    import sys
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--frames", type=int, default=frames)
    a = ap.parse_args(argv)
    sys.stdout.write(generate(a.seed, frames=a.frames))
