"""The built-in texture palette renders detail with contrast, stuck to the surface.

Each texture on a fronto-parallel quad seen by a stereo rig whose disparity on the quad is
exactly 4 px: the right image must be the left one shifted by 4 px (the pattern lives on
the surface, not on the screen), and it must have contrast at a trackable scale.
"""
from __future__ import annotations


import numpy as np
import pytest

from render_support import read_exr
from markers import needs

pytestmark = [pytest.mark.render, needs("bpy")]
pytest.importorskip("OpenEXR")

SIZE, F, Z, SHIFT = 64, 64.0, 1.5, 4


@pytest.fixture(scope="module")
def swatches(tmp_path_factory):
    return render_swatches(tmp_path_factory.mktemp("tex"))


def render_swatches(base) -> dict:
    """{texture: {view: luminance}}: every built-in texture on its own quad, the quads 20 m apart
    in one plane (none shadows or lights another), the camera facing quad k at frame k (nothing
    else in its view): one render job for all of them."""
    from blender_sesgen.contract.frames import start_pose
    from blender_sesgen.render.plan import RenderOptions
    from blender_sesgen.scene.model import Quad, Rig, Scene, TextureRef, Timeline, mat4
    from blender_sesgen.render.job import RenderJob
    from blender_sesgen.scene.textures import BUILTIN_TEXTURES
    B = SHIFT * Z / F  # disparity f B / Z = SHIFT px
    textures = list(BUILTIN_TEXTURES.items())
    xs = [20.0 * k for k in range(len(textures))]
    scene = Scene(
        source="<textures>",
        objects=tuple(Quad(id=k + 1, name=f"q{k}", texture=TextureRef(kind="builtin", name=name, number=number),
                           vertices=((x - 2, -1, -Z), (x + 2, -1, -Z), (x + 2, 3, -Z), (x - 2, 3, -Z)))
                      for k, ((number, (name, _)), x) in enumerate(zip(textures, xs))),
        rig=Rig(width=SIZE, height=SIZE, focal_px=F, cx=(SIZE - 1) / 2, cy=(SIZE - 1) / 2, baseline=B),
        timeline=Timeline(T_world_left=tuple(mat4(start_pose((x, 1.0, 0.0))) for x in xs)),
    )
    job = RenderJob.from_scene(scene, base / "swatches", RenderOptions(samples=16))
    job.build()
    job.run()
    out = {}
    for k, (_, (name, _)) in enumerate(textures):
        lum = {}
        for view in ("left", "right"):
            ch = read_exr(base / "swatches" / f"exr/{view}/{k:06d}.exr")
            rgb = np.stack([ch[f"ViewLayer.Combined.{c}"] for c in "RGB"], -1)
            lum[view] = rgb @ np.array([0.2126, 0.7152, 0.0722])
        out[name] = lum
    return out


def test_every_texture_has_contrast(swatches):
    assert len(swatches) == 12
    for name, lum in swatches.items():
        L = lum["left"]
        rms = L.std() / L.mean()
        assert rms > 0.05, f"{name}: RMS contrast {rms:.3f}"
        # detail at the pixel scale: mean absolute gradient relative to the mean
        g = (np.abs(np.diff(L, axis=0)).mean() + np.abs(np.diff(L, axis=1)).mean()) / L.mean()
        assert g > 0.03, f"{name}: gradient {g:.3f}"


def test_textures_stick_to_the_surface(swatches):
    for name, lum in swatches.items():
        a = lum["left"][:, SHIFT:]       # x_right = x_left - d
        b = lum["right"][:, :-SHIFT]
        r = np.corrcoef(a.ravel(), b.ravel())[0, 1]
        assert r > 0.9, f"{name}: left/right correlation after the 4 px shift {r:.3f}"
        r0 = np.corrcoef(lum["left"].ravel(), lum["right"].ravel())[0, 1]
        assert r > r0, f"{name}: unshifted views correlate better ({r0:.3f} >= {r:.3f}): pattern swims"
