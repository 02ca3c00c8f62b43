"""Daylight and image-based lighting as data (pure): the built-in HDRI names, the physical
sky's sun as a lamp, and the default lighting's parameters. The Blender side is
``blender/lighting.py``; docs/rendering.md (Lighting) explains the choices.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ..contract.frames import R_BLENDER_SES
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
    return _fibonacci(n).copy()


@functools.lru_cache(maxsize=8)
def _fibonacci(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    y = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - y * y)
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=1)


# --- daylight on a pane: what a diffusing pane with ``MATERIAL ... glow`` emits -------------
# A diffusing (Lambertian) transmitter of transmittance t lit by irradiance E on one face
# sends t E / pi as radiance from its other face. Cycles traces that light only by bounces
# (its shadow rays stop at the pane), so ``glow`` puts it on the pane as emission instead:
# light-sampled, the same mean (docs/rendering.md, Lighting). The irradiance is the world's:
# the sky (or HDRI, or uniform colour) over the face's hemisphere, unoccluded, plus the
# sky's sun lamp (``sky_sun_light``) by its incidence.
GLOW_DIRECTIONS = 20000      # Fibonacci directions of the hemisphere integral (error ~1e-3)
GLOW_SEEN_DIRECTIONS = 256   # cosine-distributed directions when what the face sees is traced


def sky_table_uv(d_blender: np.ndarray, sun_rotation: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) in [0, 1] of Blender directions (N, 3) in the physical sky's table, the sky
    kernel's mapping (blender/sky.py ``_kernel_uv``): x from the azimuth turned by the sun's
    rotation, y = 0.5 + 0.5 sign(e) sqrt(|e| / (pi/2)) of the elevation e."""
    d = np.asarray(d_blender, dtype=float)
    elevation = np.pi / 2 - np.arccos(np.clip(d[:, 2], -1.0, 1.0))
    y = 0.5 + 0.5 * np.sign(elevation) * np.sqrt(np.abs(elevation) / (np.pi / 2))
    x = np.mod((np.arctan2(d[:, 1], d[:, 0]) + sun_rotation - 1.5 * np.pi) / (2 * np.pi), 1.0)
    return x, y


def bilinear(image: np.ndarray, x: np.ndarray, y: np.ndarray, wrap_x: bool = False) -> np.ndarray:
    """``image`` (H, W, C; row 0 at y = 0) read at (x, y) in [0, 1] between its pixel centres,
    as Blender's linear image lookup: clamped at the edges (``wrap_x``: periodic across x)."""
    H, W = image.shape[:2]
    fx, fy = x * W - 0.5, np.clip(y * H - 0.5, 0.0, H - 1.0)
    x0, y0 = np.floor(fx).astype(int), np.minimum(np.floor(fy).astype(int), H - 2)
    ax, ay = (fx - x0)[:, None], (fy - y0)[:, None]
    if wrap_x:
        x0, x1 = np.mod(x0, W), np.mod(x0 + 1, W)
    else:
        ax = np.where((fx < 0)[:, None], 0.0, np.where((fx > W - 1)[:, None], 1.0, ax))
        x0 = np.clip(x0, 0, W - 2)
        x1 = x0 + 1
    top = image[y0 + 1, x0] * (1 - ax) + image[y0 + 1, x1] * ax
    bottom = image[y0, x0] * (1 - ax) + image[y0, x1] * ax
    return bottom * (1 - ay) + top * ay


def interp_rows(x, xp, fp) -> np.ndarray:
    """``np.interp(x, xp, f)`` of every row ``f`` of ``fp`` (..., len(xp)) at once, (..., len(x)):
    the same values bit for bit (its slope, its ends held, its exact knots)."""
    x, xp, fp = np.asarray(x, dtype=float), np.asarray(xp, dtype=float), np.asarray(fp, dtype=float)
    j = np.clip(np.searchsorted(xp, x, side="right") - 1, 0, len(xp) - 2)
    slope = (fp[..., j + 1] - fp[..., j]) / (xp[j + 1] - xp[j])
    out = np.where(x == xp[j], fp[..., j], slope * (x - xp[j]) + fp[..., j])
    out = np.where(x < xp[0], fp[..., :1], out)
    return np.where(x >= xp[-1], fp[..., -1:], out)


def hdri_uv(d_blender: np.ndarray, rotation_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) of Blender directions in an equirectangular world image turned by ``rotation_deg``
    about the vertical (blender/lighting.py's Mapping node, then Cycles' equirectangular map)."""
    r = math.radians(rotation_deg)
    c, s = math.cos(r), math.sin(r)
    d = np.asarray(d_blender, dtype=float) @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T
    u = -np.arctan2(d[:, 1], d[:, 0]) / (2 * np.pi) + 0.5
    v = np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1])) / np.pi + 0.5
    return u, v


def world_radiance(world: World, d_ses: np.ndarray, table: np.ndarray | None = None,
                   image: np.ndarray | None = None) -> np.ndarray:
    """The background radiance (N, 3; Blender units, the world's strength applied) towards SES
    directions ``d_ses``: ``table`` is the physical sky's (blender/sky.py ``table_of``, row 0
    at the nadir), ``image`` an HDRI's pixels (row 0 at the bottom)."""
    d = np.asarray(d_ses, dtype=float) @ R_BLENDER_SES.T
    if world.kind == "sky":
        if table is None:
            raise ValueError("a sky world's radiance needs its table")
        x, y = sky_table_uv(d, math.radians(world.sun_azimuth_deg))
        return bilinear(np.asarray(table, dtype=float), x, y) * world.strength / SKY_EXPOSURE
    if world.kind == "hdri":
        if image is None:
            raise ValueError("an HDRI world's radiance needs its image")
        u, v = hdri_uv(d, world.rotation_deg)
        return bilinear(np.asarray(image, dtype=float)[..., :3], u, v, wrap_x=True) * world.strength
    return np.tile(np.asarray(world.colour, dtype=float) * world.strength, (len(d), 1))


def tangent_frame(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (t1, t2) that make (t1, t2, normal) right-handed and orthonormal, for a
    unit ``normal`` (any frame: t1 from the axis least along it)."""
    t1 = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(normal, t1)


def cosine_directions(normal_ses, n: int) -> np.ndarray:
    """``n`` unit vectors spread over the hemisphere of ``normal_ses`` with density cos/pi
    (a Fibonacci spiral on the unit disc lifted onto the hemisphere): the mean of a radiance
    over them times pi is its irradiance."""
    normal = np.asarray(normal_ses, dtype=float)
    normal = normal / np.linalg.norm(normal)
    t1, t2 = tangent_frame(normal)
    i = np.arange(n) + 0.5
    r = np.sqrt(i / n)
    phi = np.pi * (3.0 - math.sqrt(5.0)) * i
    return (np.outer(r * np.cos(phi), t1) + np.outer(r * np.sin(phi), t2)
            + np.outer(np.sqrt(np.maximum(1.0 - r * r, 0.0)), normal))


def daylight_irradiance(world: World, normal_ses, table: np.ndarray | None = None,
                        image: np.ndarray | None = None, sun: bool = True,
                        n: int = GLOW_DIRECTIONS, visible=None) -> np.ndarray:
    """RGB irradiance (Blender units) on a face whose outward normal is ``normal_ses`` under
    ``world``: the background over the face's hemisphere plus, for a sky (``sun``: its disc is
    a lamp), the sun lamp's irradiance times the cosine of its incidence. ``visible``: None
    (nothing in the way; ``n`` Fibonacci directions over the sphere) or a function of SES
    directions (K, 3) giving the share of the face that sees the sky along each (the window's
    reveal and bars): then the open sky's irradiance times ``seen_share`` over ``n``
    cosine-distributed directions, and the sun times its own share."""
    normal = np.asarray(normal_ses, dtype=float)
    normal = normal / np.linalg.norm(normal)
    if visible is None:
        dirs = fibonacci_directions(n)
        cos = dirs @ normal
        keep = cos > 0
        E = (world_radiance(world, dirs[keep], table, image) * cos[keep, None]).sum(axis=0) * 4 * np.pi / n
    else:
        E = daylight_irradiance(world, normal, table, image, sun=False) * seen_share(
            world, normal, lambda d: np.asarray(visible(d), dtype=float)[:, None], table, image, n)[0]
    if world.kind == "sky" and sun:
        lamp = sky_sun_light(world)
        if lamp is not None:
            towards = -np.asarray(lamp.direction, dtype=float)
            incidence = max(0.0, float(towards @ normal))
            if incidence > 0 and visible is not None:
                incidence *= float(np.asarray(visible(towards[None]), dtype=float)[0])
            E = E + np.asarray(lamp.colour) * lamp.strength * incidence
    return E


def sky_hemisphere(world: World, normal_ses, table=None, image=None,
                   n: int = GLOW_SEEN_DIRECTIONS) -> tuple[np.ndarray, np.ndarray]:
    """(dirs (n, 3), L (n, 3)): ``n`` cosine-distributed SES directions over the hemisphere of
    ``normal_ses`` and the world's radiance along each (``seen_share``'s)."""
    dirs = cosine_directions(normal_ses, n)
    return dirs, world_radiance(world, dirs, table, image)


def seen_share(world: World, normal_ses, visible, table=None, image=None,
               n: int = GLOW_SEEN_DIRECTIONS, hemisphere=None) -> np.ndarray:
    """(P, 3): the share of the open sky's irradiance on a face that each of P points on it
    receives, ``visible(dirs)`` (K, P) saying whether a point sees the sky along each of ``n``
    cosine-distributed directions: sum L V / sum L per channel (the open sky's own integral
    comes from many more directions: an HDRI's sun is a few texels). ``hemisphere``: this
    face's ``sky_hemisphere`` where it is known."""
    dirs, L = sky_hemisphere(world, normal_ses, table, image, n) if hemisphere is None else hemisphere
    V = np.asarray(visible(dirs), dtype=float)                        # (K, P)
    return (V.T @ L) / np.maximum(L.sum(axis=0), 1e-30)


def glow_radiance(irradiance, transmitted) -> np.ndarray:
    """The radiance a Lambertian diffuser passing ``transmitted`` (RGB) sends from its
    unlit face when ``irradiance`` (RGB) falls on its other one: t E / pi."""
    return np.asarray(transmitted, dtype=float) * np.asarray(irradiance, dtype=float) / np.pi
