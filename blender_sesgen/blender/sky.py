"""Blender 5.0's physical sky (``MULTIPLE_SCATTERING``) read from a table baked once.

Cycles draws that sky from a 512 x 256 table (XYZ; columns: azimuth from the sun, rows:
elevation through a square root, nadir to zenith) that it computes in every render session
that uses the sky node: ~0.55 CPU s each, and a render process has two (the exposure preview,
the frames). The table depends only on the sun's elevation and the atmosphere, so it is
baked once: a render of a plane whose emission is the sky node evaluated at each table
cell's centre (a Cycles render, so it holds Cycles' own values, RGB), kept in the asset
cache (``scene/assets/cache.py: cached_array``; baked per process when the cache is off).
The world then reads it with the sky kernel's own mapping (``lookup``): the same bilinear
interpolation of the same cells, so the background is the sky node's to float rounding
(tests/test_sky_table.py), and so is its importance map.
"""
from __future__ import annotations

import json
import math

import bpy
import numpy as np

from ..scene.assets.cache import cached_array
from . import compat
from .library.graph import G

WIDTH, HEIGHT = 512, 256          # Cycles' table (intern/cycles/scene/image_sky.cpp)
TYPE = "MULTIPLE_SCATTERING"      # the one sky whose kernel mapping ``lookup`` repeats
# what the table depends on (the sun's azimuth only turns the lookup)
PARAMETERS = ("sun_elevation", "altitude", "air_density", "aerosol_density", "ozone_density")
TABLE_FORMAT = 1                  # bump when the bake or the lookup changes


def available() -> bool:
    return compat.sky_type_for() == TYPE


def _kernel_uv(g: G, direction, sun_rotation: float):
    """(x, y) of the sky kernel's table lookup for a unit ``direction`` socket (Cycles'
    ``sky_radiance_nishita``): x = fract((azimuth + rotation - 3/2 pi) / 2 pi), y =
    0.5 + 0.5 sign(e) sqrt(|e| / (pi/2)) for the elevation e (measured: 1e-5 of the node)."""
    dx, dy, dz = g.sep(direction)
    elevation = g.sub(math.pi / 2, g.math("ARCCOSINE", dz))
    root = g.math("SQRT", g.math("DIVIDE", g.math("ABSOLUTE", elevation), math.pi / 2))
    y = g.madd(g.mul(root, g.math("SIGN", elevation)), 0.5, 0.5)
    x = g.math("FRACT", g.math("DIVIDE", g.add(g.math("ARCTAN2", dy, dx), sun_rotation - 1.5 * math.pi),
                                 2 * math.pi))
    return g.comb(x, y, 0.0)


def lookup(nt, sky_node, tag=lambda x: x, threads: int = 0):
    """The colour socket of the world's sky, read from the baked table of ``sky_node``'s
    sky (the node stays in the tree, unlinked: Cycles computes nothing for it); ``threads``:
    the bake's CPU threads (0: Cycles' automatic count), as the render's ``--threads``."""
    table = table_of(sky_node, threads)
    image = bpy.data.images.new("sesgen_sky_table", WIDTH, HEIGHT, alpha=False, float_buffer=True)
    tag(image)
    image.colorspace_settings.name = "Non-Color"
    rgba = np.ones((HEIGHT, WIDTH, 4), dtype=np.float32)
    rgba[..., :3] = table
    image.pixels.foreach_set(rgba.ravel())
    image.pack()   # a saved .blend keeps it
    g = G(nt)
    uv = _kernel_uv(g, g.node("ShaderNodeTexCoord").outputs["Generated"], float(sky_node.sun_rotation))
    # linear and clamped at the edges, as Cycles reads its table
    colour = g.node("ShaderNodeTexImage", {"Vector": uv}, image=image, interpolation="Linear",
                    extension="EXTEND").outputs["Color"]
    g.layout()
    return colour


# the tables this process has baked or read, by key: the world's build and the glowing panes
# (blender/glazing.py) read one bake, also with the cache off (a bake is ~0.5 CPU s)
_TABLES: dict[str, np.ndarray] = {}


def table_of(sky_node, threads: int = 0) -> np.ndarray:
    """(HEIGHT, WIDTH, 3) float32 RGB of ``sky_node``'s table, row 0 at the nadir (baked with
    ``threads`` CPU threads when not in the cache: the values do not depend on them); a copy
    of this process's one bake or read of it."""
    params = {p: float(getattr(sky_node, p)) for p in PARAMETERS}
    key = [TABLE_FORMAT, compat.version_string(), TYPE, params]

    def valid(a: np.ndarray) -> bool:
        return a.shape == (HEIGHT, WIDTH, 3) and a.dtype == np.float32 and bool(np.isfinite(a).all())
    memo = json.dumps(key, sort_keys=True)
    if memo not in _TABLES:
        _TABLES[memo] = cached_array("sky", key, lambda: bake(params, threads), valid)
    return _TABLES[memo].copy()


def bake(params: dict, threads: int = 0) -> np.ndarray:
    """The table of the sky of ``params`` (``PARAMETERS``), rendered: an orthographic camera
    looks at a plane whose emission is the sky node at the direction of each cell's centre
    (snapped to it, whatever the pixel filter), one sample, no denoiser; ``threads`` CPU threads
    (0: automatic) for the render and Cycles' precompute of the table inside it."""
    from .render import Bake
    baking = Bake("sesgen_sky_bake", WIDTH, HEIGHT, samples=1, threads=threads, ortho_scale=1.0,
                camera_location=(0.5, 0.5, 1.0))     # x in [0, 1], y in [0.25, 0.75]
    baking.scene.cycles.filter_width = 0.01
    new = baking.new
    mesh = new("meshes", "sesgen_sky_bake_plane")
    mesh.from_pydata([(-1, -1, 0), (2, -1, 0), (2, 2, 0), (-1, 2, 0)], [], [(0, 1, 2, 3)])
    plane = new("objects", "sesgen_sky_bake_plane", mesh)
    baking.scene.collection.objects.link(plane)
    mat = new("materials", "sesgen_sky_bake")
    mesh.materials.append(mat)
    nt = compat.node_tree(mat)
    nt.nodes.clear()
    g = G(nt)
    emit = g.node("ShaderNodeEmission")
    g.set(g.node("ShaderNodeOutputMaterial").inputs["Surface"], emit.outputs[0])
    px, py, _ = g.sep(g.node("ShaderNodeTexCoord").outputs["Object"])

    def centre(value, scale, offset=0.0, count=1):   # the centre of the cell holding the pixel
        cell = g.math("FLOOR", g.mul(g.sub(value, offset), scale * count))
        return g.math("DIVIDE", g.add(cell, 0.5), count)
    x = centre(px, 1.0, count=WIDTH)
    y = centre(py, 2.0, offset=0.25, count=HEIGHT)
    # the inverse of ``_kernel_uv`` with rotation 0
    s = g.sub(y, 0.5)
    a = g.mul(g.math("ABSOLUTE", s), 2.0)
    elevation = g.mul(g.mul(g.mul(a, a), math.pi / 2), g.math("SIGN", s))
    azimuth = g.madd(x, 2 * math.pi, -math.pi / 2)
    ce = g.math("COSINE", elevation)
    direction = g.comb(g.mul(ce, g.math("COSINE", azimuth)), g.mul(ce, g.math("SINE", azimuth)),
                       g.math("SINE", elevation))
    sky = g.node("ShaderNodeTexSky", {"Vector": direction}, sky_type=TYPE, sun_disc=False, sun_rotation=0.0,
                 **params)
    g.set(emit.inputs["Color"], sky.outputs["Color"])
    try:
        rgb = baking.render_rgb("sky")
    finally:
        baking.close()
    return np.ascontiguousarray(rgb[::-1], dtype=np.float32)
