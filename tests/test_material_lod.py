"""The library materials' level of detail (blender/library/lod.py).

Oracles: the footprints and the Toksvig roughness in closed form on synthetic patches; the
measured means of recipes without a pattern equal their material's constants; the switch,
rendered: a plane nearer than the distances is pixel for pixel the full material (built without
the level of detail), one beyond the relief's distance is the material built without its relief
(the squared slope set to 0), one beyond the recipe's distance shows the cheap branch's colour.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_sesgen.blender import library  # noqa: E402
from blender_sesgen.blender.library import lod  # noqa: E402
from blender_sesgen.ses.materials import library_material  # noqa: E402

P = lod.PATCH_PX
PX_M = lod.PATCH_M / P


def test_footprint_is_the_box_that_averages_the_pattern_out():
    y, x = np.mgrid[:P, :P]
    checker = np.where((x // 2 + y // 2) % 2 == 0, 0.4, 0.6)[..., None] * np.ones(3)   # period 4 px
    assert lod.footprint([checker, checker]) == pytest.approx(4 * PX_M)
    stripes = np.where((x // 8) % 2 == 0, 0.45, 0.55)[..., None] * np.ones(3)        # period 16 px
    assert lod.footprint([stripes, checker]) == pytest.approx(16 * PX_M)
    ramp = (0.3 + 0.4 * x / P)[..., None] * np.ones(3)        # metre-scale contrast: never averaged out
    assert lod.footprint([ramp, ramp]) == math.inf
    assert lod.footprint([checker, checker * 1.05]) == math.inf   # the orientations disagree
    assert lod.footprint([np.full((P, P, 3), 0.5)] * 2) == pytest.approx(PX_M)


def test_relief_footprint_and_toksvig_in_closed_form():
    y, x = np.mgrid[:P, :P]
    tilt = np.zeros((P, P, 2))
    tilt[..., 0] = np.where((x // 4) % 2 == 0, 0.3, -0.3)     # grooves 8 px apart
    assert lod.relief_footprint(tilt) == pytest.approx(8 * PX_M)
    leaning = np.full((P, P, 2), [0.1, 0.0])                  # a tilt no box averages out
    assert lod.relief_footprint(leaning) == math.inf
    assert lod.toksvig(0.5, 0.0) == pytest.approx(0.5)
    assert lod.toksvig(0.0, 0.0016) == pytest.approx(0.2)      # alpha^2 = 0.04 = slope^2
    assert lod.toksvig(0.6, 0.01) == pytest.approx((0.6 ** 4 + 0.01) ** 0.25)
    assert lod.toksvig(0.9, 2.0) == 1.0


@pytest.mark.render
def test_measured_means_equal_the_recipes_means_in_closed_form():
    """chrome: its colour and metallic are the material's constants; plastic: its colour is the
    colour times a tone remapped symmetrically about the noise's centre (0.97 ... 1.03 over
    0.3 ... 0.7): mean 1 by symmetry; both roughnesses within the recipes' ranges."""
    colour = (0.55, 0.35, 0.2)
    chrome, plastic = library.measure_lod([(library_material(n), colour) for n in ("chrome", "plastic")], threads=2)
    assert chrome.colour == pytest.approx(colour, rel=1e-4)          # (Cycles' float32 film)
    assert chrome.metallic == pytest.approx(library_material("chrome").metallic, abs=1e-4)
    assert chrome.footprint_m == pytest.approx(PX_M)                   # no pattern: the finest box
    r = library_material("chrome").roughness
    assert r - 1e-4 <= chrome.roughness <= lod.toksvig(r + 0.15, chrome.slope2) + 1e-4
    assert plastic.colour == pytest.approx(colour, rel=0.005)
    assert plastic.metallic == pytest.approx(0.0, abs=1e-6)
    r = library_material("plastic").roughness
    assert r - 0.05 <= plastic.roughness <= lod.toksvig(r + 0.05, plastic.slope2) + 1e-4
    brick = library.measure_lod([(library_material("brick"), colour)], threads=2)[0]
    assert brick.slope2 > 1e-3 and math.isfinite(brick.relief_footprint_m)   # the mortar's relief


def _render_planes(tmp_path, key: str, build, near_m: float = 4.0, far_m: float = 40.0) -> np.ndarray:
    """Two square planes facing the camera, the left one ``near_m`` away, the right one ``far_m``
    away (each filling its half of the view), both of the material ``build(nt)`` returns the shader
    of; sun and sky, 4 samples at 64 x 32, seed 3: the linear RGB."""
    from blender_sesgen.files.exr import read_exr
    scene = bpy.data.scenes.new(f"lod_test_{key}")
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device, c.samples, c.use_denoising, c.seed = "CPU", 4, False, 3
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 32, 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    world = bpy.data.worlds.new(f"lod_test_{key}")
    world.color = (0.3, 0.35, 0.4)
    scene.world = world
    sun = bpy.data.objects.new(f"lod_sun_{key}", bpy.data.lights.new(f"lod_sun_{key}", "SUN"))
    sun.rotation_euler = (0.6, 0.3, 0.2)
    sun.data.energy = 3.0
    scene.collection.objects.link(sun)
    mat = bpy.data.materials.new(f"lod_test_{key}")
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(build(nt), out.inputs["Surface"])
    cam = bpy.data.objects.new(f"lod_cam_{key}", bpy.data.cameras.new(f"lod_cam_{key}"))
    cam.data.angle = math.radians(40.0)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)          # looks along +y
    scene.collection.objects.link(cam)
    scene.camera = cam
    for side, d in ((-1, near_m), (1, far_m)):            # half the view's width at distance d
        half = d * math.tan(math.radians(20.0))
        me = bpy.data.meshes.new(f"lod_plane_{key}_{side}")
        x0, x1 = (-half, 0.0) if side < 0 else (0.0, half)
        me.from_pydata([(x0, 0, -half), (x1, 0, -half), (x1, 0, half), (x0, 0, half)], [], [(0, 1, 2, 3)])
        me.materials.append(mat)
        obj = bpy.data.objects.new(f"lod_plane_{key}_{side}", me)
        obj.location = (0.0, d, 0.0)
        scene.collection.objects.link(obj)
        library.object_properties(obj, seed=3, object_id=2 + side)
    scene.render.filepath = str(tmp_path / f"lod_{key}.exr")
    with bpy.context.temp_override(scene=scene):
        bpy.ops.render.render(write_still=True, scene=scene.name)
    ch = read_exr(scene.render.filepath)
    bpy.data.scenes.remove(scene)
    return np.stack([ch[k] for k in "RGB"], -1)


@pytest.mark.render
def test_the_switch_draws_the_full_graph_near_and_the_cheap_branches_far(tmp_path):
    m = library_material("brick")
    colour = (0.6, 0.5, 0.4)
    means = lod.Means(colour=(1.0, 0.0, 0.0), roughness=0.9, metallic=0.0, footprint_m=math.inf, slope2=0.0,
                      relief_footprint_m=1.0)
    focal = 10.0        # the relief's distance 10 m: between the planes (4 m, 40 m)

    def lod_material(means):
        def build(nt):
            shader = library.build_shader(nt, m, colour, lod=True)
            lod.write(nt, means, focal)
            return shader
        return build

    full = _render_planes(tmp_path, "full", lambda nt: library.build_shader(nt, m, colour))
    flat = dataclasses.replace(m, library=dataclasses.replace(m.library, bump=0.0))
    no_relief = _render_planes(tmp_path, "no_relief", lambda nt: library.build_shader(nt, flat, colour))
    mid = _render_planes(tmp_path, "mid", lod_material(means))
    left, right = np.s_[:, :30], np.s_[:, 34:]
    assert float(np.abs(full[right] - no_relief[right]).mean()) > 1e-3    # the relief is seen far
    np.testing.assert_allclose(mid[left], full[left], rtol=1e-5, atol=1e-6)         # near: the full graph
    np.testing.assert_allclose(mid[right], no_relief[right], rtol=1e-5, atol=1e-6)  # far: no relief
    far = _render_planes(tmp_path, "far", lod_material(dataclasses.replace(means, footprint_m=2.0)))
    np.testing.assert_allclose(far[left], full[left], rtol=1e-5, atol=1e-6)
    r, g = far[right][..., 0].mean(), far[right][..., 1].mean()
    assert r > 5 * g      # beyond 20 m: the cheap branch's (red) mean colour
    off = _render_planes(tmp_path, "off", lambda nt: library.build_shader(nt, m, colour, lod=True))
    np.testing.assert_allclose(off, full, rtol=1e-5, atol=1e-6)    # unmeasured: the full graph everywhere
