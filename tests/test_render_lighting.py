"""Exposure of the lighting a script gets: never black, never blown out.

Oracle: a white Lambertian ground of albedo 1 has radiance E/pi; what matters here is the
band a user expects from the docs (docs/rendering.md, Lighting), so the bounds are wide but
fail for the two real failure modes: an unlit (black) scene and a physical sky in absolute
units (a white ground reads ~39, measured before the normalisation).
"""
from __future__ import annotations

import numpy as np
import pytest

from render_support import load_manifest, read_exr, run_render

pytestmark = pytest.mark.render

GROUND = "QUAD id 1 colour 1 1 1 vertices -50 0 50  50 0 50  50 0 -50  -50 0 -50\n"
LOOK_DOWN = "CAMERA resolution 32 24 focal 20 baseline 0\nSTART position 0 2 0 -60 0 0\n"


def _mean_linear_rgb(tmp_path, script: str) -> np.ndarray:
    (tmp_path / "s.ses").write_text(script)
    r = run_render(str(tmp_path / "s.ses"), "--out", str(tmp_path / "out"), "--samples", "4", "--quiet")
    assert r.returncode == 0, r.stderr
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
