"""Exposure of the lighting a script gets: never black, never blown out.

Oracle: a white Lambertian ground of albedo 1 has radiance E/pi; what matters here is the
band a user expects from the docs (docs/rendering.md, Lighting), so the bounds are wide but
fail for the two real failure modes: an unlit (black) scene and a physical sky in absolute
units (a white ground reads ~39, measured before the normalisation).
"""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.pipeline import RenderOptions
from render_support import load_manifest, read_exr, rendered

pytestmark = pytest.mark.render

GROUND = "QUAD id 1 colour 1 1 1 vertices -50 0 50  50 0 50  50 0 -50  -50 0 -50\n"
LOOK_DOWN = "CAMERA resolution 32 24 focal 20 baseline 0\nSTART position 0 2 0 -60 0 0\n"


def _mean_linear_rgb(tmp_path, script: str) -> np.ndarray:
    (tmp_path / "s.ses").write_text(script)
    rendered(str(tmp_path / "s.ses"), str(tmp_path / "out"), "--samples", "4", here=True)
    m = load_manifest(tmp_path / "out")
    exr = read_exr(tmp_path / "out" / m["files"]["left"][0])
    rgb = np.stack([exr[c] for c in m["channels"]["rgb"][:3]], -1)
    return rgb.reshape(-1, 3).mean(axis=0)


@pytest.mark.parametrize("elevation, low, high", [(45, 0.45, 1.1), (20, 0.2, 0.6)])
def test_sky_strength_1_is_well_exposed(tmp_path, elevation, low, high):
    # the only light is the sky (a negligible point light keeps the default lights away)
    script = (LOOK_DOWN + f"WORLD sky strength 1 elevation {elevation} azimuth 0\n"
              "LIGHT point position 0 100 0 strength 0.000001\n" + GROUND)
    rgb = _mean_linear_rgb(tmp_path, script)
    assert low < rgb.mean() < high, rgb


def test_a_script_without_lights_is_lit_not_black(tmp_path):
    rgb = _mean_linear_rgb(tmp_path, LOOK_DOWN + GROUND)
    assert 0.15 < rgb.mean() < 1.5, rgb


def test_sky_sun_lamp_delivers_the_sky_models_own_sun(tmp_path):
    """WORLD sky renders the sky without its sun disc plus a lamp (lighting_data's measured
    table): a white ground lit that way matches the same ground under the sky model's own
    disc (disc back on, lamp removed), per channel, at two elevations and azimuths, and in a
    hazy sky whose aerosol density lies between the table's measured rows."""
    import bpy
    from blender_sesgen.blender import render
    from blender_sesgen.pipeline import RenderJob
    for elevation, azimuth, aerosol in ((35, 20, 1), (12, -120, 1), (47, 70, 6)):
        script = tmp_path / f"sky{elevation}.ses"
        script.write_text(LOOK_DOWN + f"WORLD sky strength 1 elevation {elevation} azimuth {azimuth} aerosol {aerosol}\n"
                          "LOOK exposure 0\n" + GROUND +
                          "CUBOID id 2 position 0 0.5 -1.5 dim 0.6 1 0.6\n")   # casts a shadow
        job = RenderJob.prepare(script, tmp_path / f"out{elevation}", RenderOptions(samples=64))
        job.build()
        bscene = job.built.scene
        means = []
        for disc in (False, True):
            if disc:
                nt = bscene.world.node_tree
                sky = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeTexSky")
                sky.sun_disc = True   # linked: the world reads the disc-less sky's baked table (sky.py)
                nt.links.new(sky.outputs["Color"], next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBackground").inputs["Color"])
                for o in [o for o in bscene.objects if o.type == "LIGHT"]:
                    bpy.data.objects.remove(o)
            path = tmp_path / f"e{elevation}{disc}.exr"
            render.render_view(bscene, job.built.cameras["left"], 1, 0, str(path))
            ch = read_exr(path)
            means.append(np.stack([ch[f"ViewLayer.Combined.{c}"] for c in "RGB"], -1).reshape(-1, 3).mean(0))
        lamp, sky_disc = means
        np.testing.assert_allclose(lamp, sky_disc, rtol=0.04, err_msg=f"elevation {elevation}")


def test_closed_room_gets_a_ceiling_light(tmp_path):
    room = ("CAMERA resolution 32 24 focal 20 baseline 0\nSTART position 0 1.5 1\n"
            "CUBOID id 1 position 0 -0.05 0 dim 6 0.1 6\nCUBOID id 2 position 0 3.05 0 dim 6 0.1 6\n"
            "CUBOID id 3 position -3.05 1.5 0 dim 0.1 3 6\nCUBOID id 4 position 3.05 1.5 0 dim 0.1 3 6\n"
            "CUBOID id 5 position 0 1.5 -3.05 dim 6 3 0.1\nCUBOID id 6 position 0 1.5 3.05 dim 6 3 0.1\n")
    from blender_sesgen.pipeline import RenderJob
    (tmp_path / "room.ses").write_text(room)
    job = RenderJob.prepare(tmp_path / "room.ses", tmp_path / "o")
    job.build()
    lamps = [o for o in job.built.scene.objects if o.type == "LIGHT"]
    area = [o for o in lamps if o.data.type == "AREA"]
    assert len(area) == 1 and abs(area[0].location.z - 2.95) < 1e-6   # just under the ceiling
    rgb = _mean_linear_rgb(tmp_path, room)
    assert 0.15 < rgb.mean() < 1.5, rgb


def test_spot_area_and_portal_lamps_are_built_as_written(tmp_path):
    import math
    from blender_sesgen.pipeline import RenderJob
    (tmp_path / "l.ses").write_text(
        "CUBOID id 1 position 0 0 -3 dim 1 1 1\n"
        "LIGHT spot position 0 3 0 direction 0 -1 0 angle 60 blend 0.3 strength 800 size 0.1\n"
        "LIGHT area position 1 2.9 0 direction 0 -1 0 size 1 0.5 strength 200\n"
        "LIGHT portal position 0 1.5 -3 direction 0 0 1 size 1.2 1.5\n"
        "WORLD hdri courtyard strength 0.5 rotation 20\n")
    job = RenderJob.prepare(tmp_path / "l.ses", tmp_path / "o")
    job.build()
    lamps = {o.data.type + ("_portal" if o.data.type == "AREA" and o.data.cycles.is_portal else ""): o
             for o in job.built.scene.objects if o.type == "LIGHT"}
    assert set(lamps) == {"SPOT", "AREA", "AREA_portal"}   # no default lights: the script has its own
    spot = lamps["SPOT"]
    assert math.isclose(spot.data.spot_size, math.radians(60), rel_tol=1e-6)   # float32
    assert math.isclose(spot.data.spot_blend, 0.3, rel_tol=1e-6)
    # a lamp emits along its -Z: SES -Y (down) is Blender -Z
    down = spot.matrix_world.to_3x3() @ __import__("mathutils").Vector((0, 0, -1))
    assert down.z < -0.999
    area = lamps["AREA"].data
    assert area.shape == "RECTANGLE" and (area.size, area.size_y) == (1.0, 0.5)
    portal = lamps["AREA_portal"]
    into_room = portal.matrix_world.to_3x3() @ __import__("mathutils").Vector((0, 0, -1))
    assert into_room.y < -0.999          # SES +Z is Blender -Y
    env = next(n for n in job.built.scene.world.node_tree.nodes if n.bl_idname == "ShaderNodeTexEnvironment")
    assert env.image.filepath.endswith("courtyard.exr") and env.image.size[0] == 1024
    assert not (tmp_path / "o").exists()
