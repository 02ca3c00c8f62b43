"""Glowing panes (``MATERIAL ... library frosted_glass glow``): a diffusing pane emits the daylight
it passes, t E / pi of the irradiance E on its outer face, instead of passing it.

Oracles: the irradiance of analytic worlds (a uniform background: pi L on any face; a sky table
constant above the horizon: pi L up, pi L / 2 on a wall; the sun lamp's cosine) and of a
structured sky table integrated cell by cell in closed form (another method than the code's
Fibonacci directions and bilinear reads); in Cycles, the pane's own transmission: a closed
black room under a pane, the pane seen from inside is as bright glowing as passing the light
(the light arrives once), and a room lit through a small pane is less noisy with it glowing.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from markers import needs
from blender_sesgen.contract.frames import R_BLENDER_SES
from blender_sesgen.scene import lighting as L
from blender_sesgen.scene.model import World
from blender_sesgen.errors import ScriptError
from blender_sesgen.ses import parse_string


def test_uniform_world_gives_pi_l_on_any_face():
    w = World(kind="colour", colour=(0.2, 0.5, 1.0), strength=2.0)
    for normal in ((0, 1, 0), (1, 0, 0), (0.3, -0.8, 0.5)):
        assert L.daylight_irradiance(w, normal) == pytest.approx(np.pi * 2.0 * np.array([0.2, 0.5, 1.0]), rel=2e-3)


def _half_sky(value: float) -> np.ndarray:
    table = np.zeros((256, 512, 3))
    table[128:] = value              # rows 128-255: above the horizon (row 0 at the nadir)
    return table


def test_sky_above_the_horizon_and_the_sun_lamp():
    w = World(kind="sky", strength=1.0, sun_elevation_deg=30.0, sun_azimuth_deg=90.0, aerosol=1.0)
    sky = L.daylight_irradiance(w, (0, 1, 0), table=_half_sky(5.0), sun=False)
    assert sky == pytest.approx([np.pi * 5.0 / L.SKY_EXPOSURE] * 3, rel=3e-3)
    wall = L.daylight_irradiance(w, (0, 0, 1), table=_half_sky(5.0), sun=False)
    assert wall == pytest.approx([np.pi * 5.0 / L.SKY_EXPOSURE / 2] * 3, rel=3e-3)
    # the sun (azimuth 90: towards SES +X, 30 deg up) on a wall facing +X: E_sun cos 30
    sun = L.sky_sun_irradiance(30.0, 1.0) / L.SKY_EXPOSURE
    facing = L.daylight_irradiance(w, (1, 0, 0), table=_half_sky(0.0))
    assert facing == pytest.approx(sun * math.cos(math.radians(30)), rel=1e-6)
    assert L.daylight_irradiance(w, (-1, 0, 0), table=_half_sky(0.0)) == pytest.approx([0, 0, 0], abs=1e-12)
    up = L.daylight_irradiance(w, (0, 1, 0), table=_half_sky(0.0))
    assert up == pytest.approx(sun * 0.5, rel=1e-6)


def _cell_integral(table, normal_blender, rotation):
    """The irradiance of a table constant in each cell, integrated exactly cell by cell: cell
    (i, j) spans the elevations of y = i/H..(i+1)/H (e = sign(s) (2|s|)^2 pi/2, s = y - 1/2)
    and the azimuths of x = j/W..(j+1)/W (Blender's atan2(y, x) = 2 pi x + 3/2 pi - rotation);
    the cosine to the normal integrated over each cell on a fine grid."""
    H, W = table.shape[:2]
    E = np.zeros(3)
    sub = 16
    for i in range(H):
        y = (i + (np.arange(sub) + 0.5) / sub) / H
        s = y - 0.5
        e = np.sign(s) * (2 * np.abs(s)) ** 2 * np.pi / 2
        de = 4 * np.pi * np.abs(s) / (H * sub)      # d(elevation) = 4 pi |s| dy
        x = (np.arange(W * 4) + 0.5) / (W * 4)
        phi = 2 * np.pi * x + 1.5 * np.pi - rotation
        d = np.stack([np.cos(e)[:, None] * np.cos(phi)[None], np.cos(e)[:, None] * np.sin(phi)[None],
                      np.broadcast_to(np.sin(e)[:, None], (sub, len(x)))], -1)
        cos = np.maximum(d @ normal_blender, 0.0) * np.cos(e)[:, None] * de[:, None] * (2 * np.pi / len(x))
        per_col = cos.sum(axis=0).reshape(W, 4).sum(axis=1)
        E += per_col @ table[i]
    return E


@pytest.mark.parametrize("normal", [(0.0, 1.0, 0.0), (0.0, 0.0, -1.0), (0.8, 0.0, 0.6)])
def test_a_structured_sky_table_against_its_cell_integral(normal):
    H, W = 256, 512
    rows, cols = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
    table = np.stack([1 + 0.5 * np.cos(2 * np.pi * cols / W) * rows / H,        # brighter at the sun's side
                      1 + 0.8 * (rows / H) ** 2,
                      np.where(rows < H // 2, 0.1, 1.0 + 0.3 * np.sin(2 * np.pi * cols / W))], -1)
    w = World(kind="sky", strength=L.SKY_EXPOSURE, sun_elevation_deg=40.0, sun_azimuth_deg=70.0)
    got = L.daylight_irradiance(w, normal, table=table, sun=False, n=60000)
    want = _cell_integral(table, R_BLENDER_SES @ np.asarray(normal), math.radians(70.0))
    assert got == pytest.approx(want, rel=6e-3)


def test_glow_radiance_is_t_e_over_pi():
    assert L.glow_radiance((2.0, 1.0, 4.0), (0.45, 0.45, 0.44)) == pytest.approx(
        [0.9 / np.pi, 0.45 / np.pi, 1.76 / np.pi])


QUAD = "QUAD id 1 material {} vertices 0 0 -5 1 0 -5 1 1 -5 0 1 -5\n"


def test_glow_needs_diffusing_glazing():
    assert parse_string("MATERIAL name pane library frosted_glass glow\n" + QUAD.format("pane")).material("pane").glow
    assert not parse_string("MATERIAL name pane library frosted_glass\n" + QUAD.format("pane")).material("pane").glow
    for bad in ("MATERIAL name x library concrete glow\n", "MATERIAL name x colour 1 1 1 glow\n",
                "MATERIAL name x library leaves glow\n"):
        with pytest.raises(ScriptError, match="'glow' needs a diffusing glazing"):
            parse_string(bad + QUAD.format("x"))


# --- in Cycles -------------------------------------------------------------------------------
ROOM = """CAMERA resolution {res} focal 24 baseline 0
START position {start}
WORLD sky strength 1 elevation {el} azimuth {az}
LOOK exposure 0
MATERIAL name wall colour {wall} {wall} {wall} roughness 1 specular 0
MATERIAL name pane library frosted_glass{glow}
CUBOID id 1 material wall position 0 -0.1 0 dim 4.4 0.2 4.4
CUBOID id 3 material wall position -2.1 1.5 0 dim 0.2 3 4.4
CUBOID id 4 material wall position 2.1 1.5 0 dim 0.2 3 4.4
CUBOID id 5 material wall position 0 1.5 2.1 dim 4 3 0.2
"""
# a pane as the whole ceiling, the room black: the pane seen from inside is its passed light alone
CEILING = ("CUBOID id 6 material wall position 0 1.5 -2.1 dim 4 3 0.2\n"
           "QUAD id 7 material pane vertices -2 3 -2 2 3 -2 2 3 2 -2 3 2\n")
# a closed grey room with a 1 x 1 m pane in its north wall, lit through it only
WINDOW = ("CUBOID id 2 material wall position 0 3.1 0 dim 4.4 0.2 4.4\n"
          "CUBOID id 6 material wall position -1.25 1.5 -2.1 dim 1.5 3 0.2\n"
          "CUBOID id 8 material wall position 1.25 1.5 -2.1 dim 1.5 3 0.2\n"
          "CUBOID id 9 material wall position 0 0.5 -2.1 dim 1 1 0.2\n"
          "CUBOID id 10 material wall position 0 2.5 -2.1 dim 1 1 0.2\n"
          "QUAD id 7 material pane vertices -0.5 1 -2.1 0.5 1 -2.1 0.5 2 -2.1 -0.5 2 -2.1\n")


def _luminance(tmp_path, name, text, samples, seed=0):
    from render_support import load_manifest, read_exr, render_text
    folder = tmp_path / name
    folder.mkdir()
    out = render_text(folder, text, "--samples", str(samples), "--seed", str(seed), here=True)
    m = load_manifest(out)
    ch = read_exr(out / m["files"]["left"][0])
    return np.stack([ch[c] for c in m["channels"]["rgb"][:3]], -1) @ np.array([0.2126, 0.7152, 0.0722])


@pytest.mark.render
@needs("bpy")
@pytest.mark.parametrize("world", ["WORLD sky strength 1 elevation 80 azimuth 30",
                                   "WORLD hdri courtyard strength 1 rotation 40"])
def test_a_glowing_pane_is_as_bright_as_the_light_it_passes(tmp_path, world):
    """A black room under a ceiling pane, the camera looking up at it (the sky with its sun
    80 deg up, or an HDRI with its sun in a few texels): what the pane sends into the room is
    its transmission alone (nothing inside to reflect), so the glowing pane must equal the
    traced one (Cycles' Translucent BSDF: t E / pi by its own light paths): E from the right
    face, from the sky's table and the sun lamp or the HDRI's pixels, and pi."""
    pytest.importorskip("OpenEXR")
    text = ROOM.format(res="40 40", start="0 1.5 0 90 0 0", el=80, az=30, wall=0, glow="{glow}") + CEILING
    text = text.replace("WORLD sky strength 1 elevation 80 azimuth 30", world)
    traced = _luminance(tmp_path, "traced", text.replace("{glow}", ""), 64)
    glow = _luminance(tmp_path, "glow", text.replace("{glow}", " glow"), 64)
    assert traced.mean() > 0.05
    assert glow.mean() == pytest.approx(traced.mean(), rel=0.01)


@pytest.mark.render
@needs("bpy")
def test_a_room_lit_through_a_glowing_pane_is_less_noisy(tmp_path):
    """A closed grey room lit by the sky only through a 1 m pane, the floor and far wall seen
    at 16 samples under two seeds: the glowing pane is light-sampled, so the seeds differ by
    under 0.4 of the traced pane's variance (measured 0.20), at the traced mean (within 15 %:
    glowing, the daylight needs one diffuse bounce fewer; measured +6 %)."""
    pytest.importorskip("OpenEXR")
    text = ROOM.format(res="48 32", start="0 1.2 1.5 -30 0 0", el=35, az=150, wall=0.5, glow="{glow}") + WINDOW
    var, mean = {}, {}
    for glow in ("", " glow"):
        a, b = (_luminance(tmp_path, f"w{glow.strip()}{s}", text.replace("{glow}", glow), 16, seed=s) for s in (0, 1))
        var[glow], mean[glow] = float(((a - b) ** 2).mean() / 2), float((a.mean() + b.mean()) / 2)
    assert var[" glow"] < 0.4 * var[""], var
    assert mean[" glow"] == pytest.approx(mean[""], rel=0.15), mean


@pytest.mark.render
@needs("bpy")
def test_a_glowing_pane_shows_the_shadows_cast_on_its_outer_face(tmp_path):
    """The black room's ceiling pane under a beam 0.3 m above it (outside), the sun 70 deg up:
    the traced pane shows the beam's sun shadow on its outer face (what it passes there is the
    sky's light only); the glowing pane must show it in the same place (its irradiance map,
    10 cm texels): per image column, as deep (under 0.2 of the sunlit level), as wide (the
    shadow's area within 10 %), centred within a column, and elsewhere within 5 %."""
    pytest.importorskip("OpenEXR")
    beam = "CUBOID id 8 material wall position 0.4 3.3 0 dim 0.6 0.1 4.4\n"
    text = ROOM.format(res="48 48", start="0 1.5 0 90 0 0", el=70, az=90, wall=0, glow="{glow}") + CEILING + beam
    traced = _luminance(tmp_path, "traced", text.replace("{glow}", ""), 64)
    glow = _luminance(tmp_path, "glow", text.replace("{glow}", " glow"), 64)
    lit = float(np.percentile(traced[12:36], 90))
    t, g = traced[12:36].mean(axis=0) / lit, glow[12:36].mean(axis=0) / lit   # the pane's middle rows
    assert t.min() < 0.2 and g.min() < 0.2, np.round(np.c_[t, g], 2).T
    assert (1 - g).sum() == pytest.approx((1 - t).sum(), rel=0.1)
    centre = lambda p: float(((1 - p) * np.arange(len(p))).sum() / (1 - p).sum())  # noqa: E731
    assert abs(centre(g) - centre(t)) < 1.0
    away = np.abs(np.arange(len(t)) - centre(t)) > 10
    assert np.abs(g - t)[away].max() < 0.05
