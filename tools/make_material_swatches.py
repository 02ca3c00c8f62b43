"""Render the material library's swatch sheet into docs/img/ (bpy; ~3 minutes on 2 cores).

    .venv/bin/python tools/make_material_swatches.py [NAME ...] [--size 192] [--samples 32]

Each swatch: a 1.2 m x 1.2 m wall seen square-on from 1.5 m above a 1.2 m strip of floor,
and a sphere of radius 0.25 m, all in the same material, under a physical sky with its sun
(45 deg elevation, from behind the camera on the left), a fixed exposure (0 EV), AgX view transform, OpenImageDenoise. A pixel is
~5 mm on the wall at 192 px. Writes docs/img/material_NAME.png for each NAME (default:
all) and rebuilds docs/img/materials.png from every swatch on disk (the sheet, 6 per row,
in the library's order).
"""
import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]

from blender_sesgen.contact_sheet import write_png
from blender_sesgen.contract.frames import start_pose
from blender_sesgen.material_library import LIBRARY
from blender_sesgen.model import Look, Quad, Rig, Scene, Sphere, Timeline, World, mat4
from blender_sesgen.pipeline import RenderJob, RenderOptions
from blender_sesgen.ses.materials import library_material


def swatch(name: str, tmp: Path, size: int, samples: int) -> np.ndarray:
    mat = library_material(name)
    scene = Scene(
        source=f"<material {name}>",
        objects=(Quad(id=1, name="wall", material=name, vertices=((-0.6, 0.4, 0), (0.6, 0.4, 0), (0.6, 1.6, 0), (-0.6, 1.6, 0))),
                 Quad(id=2, name="floor", material=name, vertices=((-0.6, 0.4, 1.2), (0.6, 0.4, 1.2), (0.6, 0.4, 0), (-0.6, 0.4, 0))),
                 Sphere(id=3, name="ball", material=name, position=(0.3, 0.7, 0.3), radius=0.25)),
        materials=(mat,),
        world=World(kind="sky", strength=1.0, sun_elevation_deg=45.0, sun_azimuth_deg=-145.0),
        look=Look(auto_exposure=False, exposure_ev=0.0),
        rig=Rig(width=size, height=size, focal_px=size * 1.5 / 1.2, cx=(size - 1) / 2, cy=(size - 1) / 2, baseline=0.0),
        timeline=Timeline(T_world_left=(mat4(start_pose((0, 1.0, 1.5))),)),
    )
    out = tmp / name
    job = RenderJob.from_scene(scene, out, RenderOptions(samples=samples, denoise=True))
    job.build()
    job.render_frame(0)
    import cv2
    return cv2.imread(str(out / "rgb" / "left" / "000000.png"))[..., ::-1]  # the display-referred image


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("names", nargs="*", default=list(LIBRARY))
    ap.add_argument("--size", type=int, default=192)
    ap.add_argument("--samples", type=int, default=32)
    ap.add_argument("--out", default=str(REPO / "docs" / "img"))
    args = ap.parse_args()
    img_dir = Path(args.out)
    img_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.names:
            write_png(img_dir / f"material_{name}.png", swatch(name, Path(tmp), args.size, args.samples))
            print(name, flush=True)
    # the sheet: every swatch, the ones not rendered now as they are on disk
    import cv2
    tiles = [cv2.imread(str(img_dir / f"material_{name}.png"))[..., ::-1] for name in LIBRARY]
    if any(t.shape != tiles[0].shape for t in tiles):
        sys.exit("swatches of different sizes: render them all (no NAME) to rebuild the sheet")
    S, gap, per_row = tiles[0].shape[0], 4, 6
    rows = []
    for r in range(0, len(tiles), per_row):
        row = tiles[r:r + per_row] + [np.full((S, S, 3), 255, np.uint8)] * (per_row - len(tiles[r:r + per_row]))
        parts = []
        for t in row:
            parts += [t, np.full((S, gap, 3), 255, np.uint8)]
        rows += [np.concatenate(parts[:-1], 1), np.full((gap, per_row * S + (per_row - 1) * gap, 3), 255, np.uint8)]
    write_png(img_dir / "materials.png", np.concatenate(rows[:-1], 0))


if __name__ == "__main__":
    main()
