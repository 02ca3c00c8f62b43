"""Render one swatch PNG per built-in texture into docs/img/ (bpy; ~1 minute on 2 cores).

    .venv/bin/python tools/make_texture_swatches.py

Each swatch: a 1.2 m x 1.2 m quad seen square-on from 1.5 m, plus a sphere of radius
0.25 m, default lighting, 32 samples, 192 x 192 px (a pixel is ~5 mm on the quad).
"""
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]

from blender_sesgen.contract.frames import start_pose
from blender_sesgen.contact_sheet import write_png
from blender_sesgen.contract.colour import linear_to_srgb8
from blender_sesgen.exr import read_exr
from blender_sesgen.model import Quad, Rig, Scene, Sphere, TextureRef, Timeline, mat4
from blender_sesgen.job import RenderJob
from blender_sesgen.plan import RenderOptions
from blender_sesgen.textures import BUILTIN_TEXTURES

SIZE = 192


def swatch(number: int, name: str, tmp: Path) -> np.ndarray:
    tex = TextureRef(kind="builtin", name=name, number=number)
    scene = Scene(
        source=f"<swatch {name}>",
        objects=(Quad(id=1, name="quad", texture=tex, vertices=((-0.6, 0.4, 0), (0.6, 0.4, 0), (0.6, 1.6, 0), (-0.6, 1.6, 0))),
                 Sphere(id=2, name="ball", texture=tex, position=(0.3, 0.7, 0.3), radius=0.25)),
        rig=Rig(width=SIZE, height=SIZE, focal_px=SIZE * 1.5 / 1.2, cx=(SIZE - 1) / 2, cy=(SIZE - 1) / 2, baseline=0.0),
        timeline=Timeline(T_world_left=(mat4(start_pose((0, 1.0, 1.5))),)),
    )
    out = tmp / name
    job = RenderJob.from_scene(scene, out, RenderOptions(samples=32, denoise=False))
    job.build()
    job.render_frame(0)
    ch = read_exr(out / "exr/left/000000.exr")
    return linear_to_srgb8(np.stack([ch[f"ViewLayer.Combined.{c}"] for c in "RGB"], -1))


def main():
    img_dir = REPO / "docs" / "img"
    img_dir.mkdir(parents=True, exist_ok=True)
    tiles = []
    with tempfile.TemporaryDirectory() as tmp:
        for number, (name, _) in BUILTIN_TEXTURES.items():
            im = swatch(number, name, Path(tmp))
            write_png(img_dir / f"texture_{number:02d}_{name}.png", im)
            tiles.append(im)
            print(number, name, flush=True)
    gap = 4
    rows = []
    for r in range(0, len(tiles), 6):
        row = []
        for t in tiles[r:r + 6]:
            row += [t, np.full((SIZE, gap, 3), 255, np.uint8)]
        rows += [np.concatenate(row[:-1], 1), np.full((gap, 6 * SIZE + 5 * gap, 3), 255, np.uint8)]
    write_png(img_dir / "textures.png", np.concatenate(rows[:-1], 0))


if __name__ == "__main__":
    main()
