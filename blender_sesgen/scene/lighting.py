"""Daylight and image-based lighting as data (pure): the built-in HDRI names, the physical
sky's sun as a lamp, and the default lighting's parameters. The Blender side is
``blender/lighting.py``; docs/rendering.md (Lighting) explains the choices.
"""
from __future__ import annotations

import math

import numpy as np

from .model import Light, World

# Blender's bundled CC0 HDRIs (Poly Haven, 1024 x 512; bpy's datafiles/studiolights/world)
BUILTIN_HDRIS = ("city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset")
HDRI_SUFFIXES = (".exr", ".hdr")

# Blender's physical sky is in absolute units: at strength 1 a white ground under a 45 deg
# sun reads ~39 (linear), far past white. ``WORLD sky strength s`` means s / SKY_EXPOSURE,
# so that strength 1 is well exposed (white ground ~0.75 at 45 deg, ~0.35 at 20 deg).
SKY_EXPOSURE = 50.0
SUN_ANGLE_DEG = 0.545        # the sky model's (and the real) sun disc diameter

# Irradiance (W/m^2 per channel, linear RGB, sky strength 1) of the physical sky's sun
# disc on a surface facing the sun, per aerosol density (``WORLD sky aerosol``) and sun
# elevation (deg): measured on Blender 5.0's MULTIPLE_SCATTERING sky by
# bench/calibrate_sky_sun.py. ``WORLD sky`` renders the sky without its disc plus a sun lamp
# delivering this: a lamp is sampled directly, which halves the noise of sunlit surfaces at
# a given sample count.
AEROSOL_RANGE = (0.0, 10.0)  # Blender's aerosol_density
SKY_SUN_IRRADIANCE: tuple[tuple[float, tuple[tuple[float, tuple[float, float, float]], ...]], ...] = (
    (0, (
        (10, (115.8, 78.5, 36.39)),
        (20, (142.2, 111.6, 71.84)),
        (30, (152.8, 125.9, 90.44)),
        (40, (158.2, 133.6, 101.1)),
        (50, (161.4, 138.1, 107.7)),
        (70, (164.6, 142.7, 114.5)),
        (90, (165.5, 144, 116.5)),
    )),
    (1, (
        (1, (18.46, 4.264, 0.07569)),
        (2, (34.09, 10.74, 0.09561)),
        (3, (48.56, 19.01, 1.656)),
        (5, (72.24, 36.82, 8.399)),
        (7, (89.79, 52.98, 17.79)),
        (10, (108.2, 72.19, 32.48)),
        (15, (126.7, 93.65, 53.01)),
        (20, (137.5, 107.1, 68.04)),
        (25, (144.6, 116.2, 79.01)),
        (30, (149.4, 122.5, 87.18)),
        (40, (155.5, 130.7, 98.28)),
        (50, (159.1, 135.7, 105.2)),
        (60, (161.3, 138.7, 109.6)),
        (70, (162.7, 140.6, 112.3)),
        (80, (163.4, 141.6, 113.8)),
        (90, (163.9, 142.2, 114.5)),
    )),
    (4, (
        (10, (88.06, 56.19, 23.17)),
        (20, (124.4, 94.67, 57.69)),
        (30, (139.6, 112.7, 77.98)),
        (40, (147.6, 122.6, 90.18)),
        (50, (152.3, 128.5, 97.89)),
        (70, (157, 134.6, 106)),
        (90, (161.1, 138.6, 110.1)),
    )),
    (8, (
        (10, (66.8, 40.16, 14.67)),
        (20, (108.9, 80.33, 46.31)),
        (30, (127.5, 100.8, 67.21)),
        (40, (137.6, 112.4, 80.34)),
        (50, (143.6, 119.5, 88.91)),
        (70, (149.8, 126.9, 98.05)),
        (90, (150.7, 128.3, 100.1)),
    )),
)

# the default lighting of a script with neither LIGHT nor WORLD: a clear-sky day
DEFAULT_SKY = World(kind="sky", strength=1.0, sun_elevation_deg=50.0, sun_azimuth_deg=210.0)  # behind the camera
LIGHTS_ONLY_WORLD = World(kind="colour", colour=(0.55, 0.6, 0.7), strength=0.35)  # LIGHTs, no WORLD
DEFAULT_FILL_IRRADIANCE = 1.5    # W/m^2 at half the scene's extent (enclosed scenes' ceiling light)
ENCLOSED_HIT_FRACTION = 0.9      # a scene whose START sees geometry in >= 90 % of directions is enclosed


# LOOK view -> Blender's view transform of the display-referred PNGs
VIEW_TRANSFORMS = {"agx": "AgX", "filmic": "Filmic", "standard": "Standard"}
# LOOK look (AgX only) -> Blender's look; "base" is AgX itself
AGX_LOOKS = {"base": "None", "punchy": "AgX - Punchy", "very_low_contrast": "AgX - Very Low Contrast",
             "low_contrast": "AgX - Low Contrast", "medium_low_contrast": "AgX - Medium Low Contrast",
             "medium_high_contrast": "AgX - Medium High Contrast", "high_contrast": "AgX - High Contrast",
             "very_high_contrast": "AgX - Very High Contrast"}

# automatic exposure: the linear luminance the 90th-percentile pixel of a preview of frame 0
# is brought to (blender/exposure.py)
EXPOSURE_TARGET = 0.6


def direction_towards_sun(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """SES-world unit vector *towards* the sun: elevation above the XZ ground plane (Y up),
    azimuth from -Z (forward of an unrotated camera) towards +X."""
    el, az = math.radians(elevation_deg), math.radians(azimuth_deg)
    return np.array([math.cos(el) * math.sin(az), math.sin(el), -math.cos(el) * math.cos(az)])


def sky_sun_irradiance(elevation_deg: float, aerosol: float = 1.0) -> np.ndarray:
    """The sky model's sun irradiance (RGB, W/m^2 at sky strength 1) at this elevation and
    aerosol density: linear in elevation, log-linear in aerosol density (the aerosol's
    extinction is exponential in its density) between the measured rows; 0 below the horizon."""
    if elevation_deg <= 0:
        return np.zeros(3)
    densities = np.array([a for a, _ in SKY_SUN_IRRADIANCE], dtype=float)
    per_density = np.array([_irradiance_at(rows, elevation_deg) for _, rows in SKY_SUN_IRRADIANCE])
    if len(densities) == 1:
        return per_density[0]
    log_E = np.log(np.maximum(per_density, 1e-12))
    return np.exp([np.interp(aerosol, densities, log_E[:, c]) for c in range(3)])


def _irradiance_at(rows, elevation_deg: float) -> np.ndarray:
    el = np.array([e for e, _ in rows], dtype=float)
    E = np.array([rgb for _, rgb in rows], dtype=float)
    if elevation_deg < el[0]:
        return E[0] * elevation_deg / el[0]
    return np.array([np.interp(elevation_deg, el, E[:, c]) for c in range(3)])


def effective_world(world: World | None, has_lights: bool) -> World:
    """The script's WORLD; without one, the default sky (no LIGHT either: the default
    lighting) or, for a script with LIGHTs (or a BLEND file's lamps), ``LIGHTS_ONLY_WORLD``."""
    if world is not None:
        return world
    return LIGHTS_ONLY_WORLD if has_lights else DEFAULT_SKY


def sky_sun_light(world: World) -> Light | None:
    """The sun lamp that stands in for the sky's sun disc (None below the horizon)."""
    E = sky_sun_irradiance(world.sun_elevation_deg, world.aerosol) * world.strength / SKY_EXPOSURE
    peak = float(E.max())
    if peak <= 0:
        return None
    towards = direction_towards_sun(world.sun_elevation_deg, world.sun_azimuth_deg)
    return Light(kind="sun", colour=tuple(float(x) for x in E / peak), strength=peak,
                 direction=tuple(float(x) for x in -towards))


def fibonacci_directions(n: int) -> np.ndarray:
    """``n`` unit vectors spread evenly over the sphere (the enclosure test's rays)."""
    i = np.arange(n) + 0.5
    y = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - y * y)
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=1)
