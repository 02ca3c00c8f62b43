"""Diffusing glazing (library ``frosted_glass``) in Cycles: it lets daylight through, scattered.

A closed 4 x 3 x 4 m room whose whole ceiling is one pane, a 0.3 m beam just under it, the
sun nearly overhead; a camera in the room looks down at the floor. Oracles: an opaque pane
(the same room, ``plaster`` instead: no light source inside, so the floor stays black) and
the open ceiling (the same room without the pane: the sun throws the beam's sharp shadow).
Through diffusing glazing the floor is lit and the beam's shadow is gone: the pane is a wide
even source, each floor point under the beam still sees nearly all of it.
"""
from __future__ import annotations

import numpy as np
import pytest

from markers import needs
from render_support import load_manifest, read_exr, render_text
from blender_sesgen.scene.materials import entry, transmitted_colour

pytestmark = [pytest.mark.render, needs("bpy")]
pytest.importorskip("OpenEXR")

ROOM = """CAMERA resolution 40 40 focal 20 baseline 0
START position 0 1.5 0 -90 0 0
WORLD sky strength 1 elevation 80 azimuth 30
LOOK exposure 0
CUBOID id 1 position 0 -0.1 0 dim 4.4 0.2 4.4
CUBOID id 2 position -2.1 1.5 0 dim 0.2 3 4.4
CUBOID id 3 position 2.1 1.5 0 dim 0.2 3 4.4
CUBOID id 4 position 0 1.5 -2.1 dim 4 3 0.2
CUBOID id 5 position 0 1.5 2.1 dim 4 3 0.2
CUBOID id 6 position 0 2.85 0 dim 4 0.1 0.3
"""
PANE = "QUAD id 7 material {m} vertices -2 3 -2 2 3 -2 2 3 2 -2 3 2\n"


def _floor_luminance(tmp_path, name: str, ceiling: str) -> np.ndarray:
    folder = tmp_path / name
    folder.mkdir()
    out = render_text(folder, ROOM + ceiling, "--samples", "32", "--seed", "0", here=True)
    m = load_manifest(out)
    ch = read_exr(out / m["files"]["left"][0])
    return np.stack([ch[c] for c in m["channels"]["rgb"][:3]], -1) @ np.array([0.2126, 0.7152, 0.0722])


def test_transmitted_colour_conserves_energy():
    e = entry("frosted_glass")
    assert transmitted_colour(e.colour, e) == pytest.approx((e.transmittance,) * 3, rel=0.03)
    for c in ((0.9, 0.9, 0.9), (0.05, 0.5, 0.85)):               # reflected + passed never exceed 1
        assert all(r + t <= 1.0 + 1e-12 for r, t in zip(c, transmitted_colour(c, e)))
    assert transmitted_colour((0.2, 0.2, 0.195), e)[0] == pytest.approx(e.transmittance / 2, rel=0.02)
    assert transmitted_colour(e.colour, entry("plaster")) == (0.0, 0.0, 0.0)


def test_frosted_glass_lets_daylight_in_without_sun_patches(tmp_path):
    frosted = _floor_luminance(tmp_path, "frosted", PANE.format(m="frosted_glass"))
    opaque = _floor_luminance(tmp_path, "opaque", PANE.format(m="plaster"))
    open_ = _floor_luminance(tmp_path, "open", "")
    assert opaque.max() < 1e-3 * frosted.mean()                  # no light in a closed room
    assert frosted.mean() > 0.01 * open_.mean()                  # the pane passes daylight...
    shadow = lambda L: float(np.percentile(L, 2) / np.median(L))  # noqa: E731  the darkest floor over the typical
    assert shadow(open_) < 0.5, shadow(open_)                    # the sun: the beam's sharp shadow
    assert shadow(frosted) > 0.7, shadow(frosted)                # ...scattered: no shadow of the beam
