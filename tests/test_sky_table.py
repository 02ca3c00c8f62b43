"""The physical sky read from its baked table (blender/sky.py) against Blender's own sky node.

Oracle: the same world with the sky node linked, as Cycles computes it in each session; the
table's background must equal it to float rounding in every direction (above, at and below the
horizon, towards and away from the sun), for two suns and atmospheres. The cache
(``cached_array``) is checked with counting makers: made once, read back, made again when the
file is damaged or the cache is off.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from blender_sesgen.scene.assets import cache


def test_cached_array_is_made_once_read_back_and_remade_when_damaged(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV, str(tmp_path))
    made = []

    def make():
        made.append(1)
        return np.arange(12, dtype=np.float32).reshape(3, 4)
    key = ["format 1", {"sun": 0.5}]
    first = cache.cached_array("t", key, make)
    again = cache.cached_array("t", key, make)
    assert len(made) == 1 and np.array_equal(first, again) and again.dtype == np.float32
    other = cache.cached_array("t", ["format 1", {"sun": 0.6}], make)   # another key: made
    assert len(made) == 2 and np.array_equal(first, other)
    files = sorted((tmp_path / "t").glob("*.npy"))
    assert len(files) == 2
    for f in files:
        f.write_bytes(f.read_bytes()[:40])          # truncated: made again, file replaced
    cache.cached_array("t", key, make)
    assert len(made) == 3
    cache.cached_array("t", key, make, valid=lambda a: a.shape == (9,))   # not whole: made again
    assert len(made) == 4
    monkeypatch.setenv(cache.ENV, "off")
    cache.cached_array("t", key, make)
    assert len(made) == 5


def test_cached_array_keeps_the_ones_used_last(tmp_path, monkeypatch):
    import os
    monkeypatch.setenv(cache.ENV, str(tmp_path))
    monkeypatch.setattr(cache, "KEEP_ARRAYS", 3)
    made = []
    for i in range(3):
        cache.cached_array("t", [i], lambda: made.append(1) or np.zeros(2))
    for age, f in enumerate(sorted((tmp_path / "t").glob("*.npy"))):   # all written long ago
        os.utime(f, (1e9 + age, 1e9 + age))
    cache.cached_array("t", [0], lambda: made.append(1) or np.zeros(2))    # read: used now
    for i in (3, 4):
        cache.cached_array("t", [i], lambda: made.append(1) or np.zeros(2))
    assert len(list((tmp_path / "t").glob("*.npy"))) == 3 and len(made) == 5
    cache.cached_array("t", [0], lambda: made.append(1) or np.zeros(2))    # kept
    cache.cached_array("t", [1], lambda: made.append(1) or np.zeros(2))    # removed: made again
    assert len(made) == 6


def _render_sky(bpy, world, path):
    """The sky alone through a wide camera at 1 sample, a pixel filter of 0.01 px: the
    background at the pixel centres."""
    scene = bpy.data.scenes.new("sky_test")
    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples, scene.cycles.use_denoising = "CPU", 1, False
    scene.cycles.filter_width = 0.01
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    cam = bpy.data.objects.new("sky_test_cam", bpy.data.cameras.new("sky_test_cam"))
    cam.data.lens = 10
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.world = world
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    out = []
    # towards the horizon (both sides of it), up, down, and turned about the vertical
    for i, rot in enumerate([(1.57, 0, 0), (1.5, 0, 2.0), (0.9, 0, 4.0), (0.2, 0, 1.0), (2.0, 0, 3.0)]):
        cam.rotation_euler = rot
        scene.render.filepath = str(path / f"{world.name}_{i}.exr")
        with bpy.context.temp_override(scene=scene):
            bpy.ops.render.render(write_still=True, scene=scene.name)
        from blender_sesgen.files.exr import read_exr
        ch = read_exr(scene.render.filepath)
        out.append(np.stack([ch[c] for c in "RGB"], -1))
    bpy.data.scenes.remove(scene)
    return np.stack(out)


@pytest.mark.render
@pytest.mark.parametrize("elevation, azimuth, aerosol", [(35.0, 20.0, 1.0), (8.0, -120.0, 5.0)])
def test_the_baked_table_renders_blenders_own_sky(tmp_path, monkeypatch, elevation, azimuth, aerosol):
    import bpy
    from blender_sesgen.blender import lighting, sky
    from blender_sesgen.scene.model import World
    if not sky.available():
        pytest.skip("this Blender has no MULTIPLE_SCATTERING sky (4.x): the sky node is used as it is")
    monkeypatch.setenv(cache.ENV, str(tmp_path / "cache"))
    monkeypatch.setattr(sky, "_TABLES", {})
    baked = []
    real_bake = sky.bake
    monkeypatch.setattr(sky, "bake", lambda params, threads=0: baked.append(1) or real_bake(params, threads))
    w = World(kind="sky", strength=1.0, sun_elevation_deg=elevation, sun_azimuth_deg=azimuth, aerosol=aerosol)
    holder = bpy.data.scenes.new("holder")
    table_world = lighting.build_world(holder, w, None, "table")
    sky._TABLES.clear()                                          # as another process would
    node_world = lighting.build_world(holder, w, None, "node")   # the second build reads the cache
    assert len(baked) == 1
    nt = node_world.node_tree
    sky_node = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeTexSky")
    bg = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBackground")
    nt.links.new(sky_node.outputs["Color"], bg.inputs["Color"])   # Blender's own sky
    a = _render_sky(bpy, table_world, tmp_path)
    b = _render_sky(bpy, node_world, tmp_path)
    bpy.data.scenes.remove(holder)
    assert b.max() > 0.1 and np.isfinite(a).all()
    rel = np.abs(a - b) / max(float(b.max()), 1e-6)
    assert rel.max() < 1e-4, rel.max()


@pytest.mark.render
def test_a_process_bakes_a_sky_once_with_the_cache_off(monkeypatch):
    """The world's build and the glowing panes (blender/glazing.py) both read the table: with
    the cache off a process still bakes it once (a bake is a Cycles render, ~0.5 CPU s), and
    each reader gets its own copy."""
    import bpy
    from blender_sesgen.blender import sky
    if not sky.available():
        pytest.skip("this Blender has no MULTIPLE_SCATTERING sky (4.x): nothing is baked")
    monkeypatch.setenv(cache.ENV, "off")
    monkeypatch.setattr(sky, "_TABLES", {})
    baked = []
    real_bake = sky.bake
    monkeypatch.setattr(sky, "bake", lambda params, threads=0: baked.append(1) or real_bake(params, threads))
    from blender_sesgen.blender import compat
    world = bpy.data.worlds.new("sky_once")
    node = compat.node_tree(world).nodes.new("ShaderNodeTexSky")
    node.sky_type = sky.TYPE
    node.sun_elevation = math.radians(30.0)
    first = sky.table_of(node)
    first[:] = 0.0                                   # a reader's change stays its own
    second = sky.table_of(node)
    bpy.data.worlds.remove(world)
    assert len(baked) == 1
    assert second.max() > 0.0


@pytest.mark.render
def test_the_sky_bake_renders_with_the_renders_threads(monkeypatch):
    """``--threads`` reaches the sky table's bake (a farm task's render keeps to its cores
    there too); the table does not depend on the thread count."""
    import bpy  # noqa: F401
    from blender_sesgen.blender import render, sky
    if not sky.available():
        pytest.skip("this Blender has no MULTIPLE_SCATTERING sky (4.x): nothing is baked")
    seen = []
    real_render = render._render

    def spy(bscene, quiet):
        seen.append((bscene.render.threads_mode, bscene.render.threads))
        return real_render(bscene, quiet)
    monkeypatch.setattr(render, "_render", spy)
    params = {"sun_elevation": 0.6, "altitude": 0.0, "air_density": 1.0, "aerosol_density": 2.0, "ozone_density": 1.0}
    one = sky.bake(params, threads=1)
    automatic = sky.bake(params)
    assert seen[0] == ("FIXED", 1) and seen[1][0] == "AUTO"
    assert np.array_equal(one, automatic)
