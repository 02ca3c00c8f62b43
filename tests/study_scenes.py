"""Scripts and study files for the study tests (tests/test_study_*.py)."""
from __future__ import annotations

from pathlib import Path

ROOM = """\
// a small textured room: a stereo rig walks forward and turns right
CAMERA resolution 96 64 focal 60 baseline 0.12 near 0.1 far 100
START position 0 1.2 2.5
QUAD id 1 texture 4 vertices -3 0 -4  3 0 -4  3 0 3  -3 0 3           // floor
QUAD id 2 texture 3 vertices -3 0 -4  -3 3 -4  3 3 -4  3 0 -4         // back wall
QUAD id 3 texture 7 vertices -3 0 3  -3 3 3  -3 3 -4  -3 0 -4         // left wall
QUAD id 4 texture 9 vertices 3 0 -4  3 3 -4  3 3 3  3 0 3             // right wall
CUBOID id 5 texture 1 position -0.8 0.4 -1.5 dim 0.8 0.8 0.8
SPHERE id 6 texture 2 position 0.9 0.5 -2 dim 0.5
MATERIAL name shiny colour 0.7 0.2 0.2 roughness 0.3
CYLINDER id 7 material shiny position 1.8 0.5 -3 dim 0.2 1
LIGHT sun direction -0.3 -1 -0.4 strength 3
WORLD colour 0.6 0.65 0.7 strength 1
EGO 0.02 0 0.12 0 1.5 0
EGO 0.02 0 0.12 0 1.5 0
EGO 0.02 0.01 0.12 0.3 1.5 0
EGO 0.02 0 0.12 0 1.5 0
EGO 0.02 0 0.12 0 1.5 0
EGO 0.02 0 0.12 0 1.5 0
EGO 0.02 0 0.12 0 1.5 0
"""

# a white wall 2 m ahead with dark vertical bars; the rig slides sideways at 5 m/s (0.2 m per
# frame at 25 Hz): the image moves uniformly at f v / Z = 100 * 5 / 2 = 250 px/s
WALL_Z = 2.0
WALL_FOCAL = 100.0
WALL_SPEED = 5.0
WALL = f"""\
CAMERA resolution 96 48 focal {WALL_FOCAL:g} baseline 0.1 near 0.1 far 100
START position 0 1 {WALL_Z:g}
QUAD id 1 colour 0.8 0.8 0.8 vertices -20 -5 0  20 -5 0  20 5 0  -20 5 0
CUBOID id 2 colour 0.02 0.02 0.02 position 0.3 1 0.01 dim 0.06 3 0.01
CUBOID id 3 colour 0.02 0.02 0.02 position 0.9 1 0.01 dim 0.06 3 0.01
WORLD colour 1 1 1 strength 0.3
LIGHT sun direction 0 0 -1 strength 0.5
SENSOR bits 12 fullwell 4000 saturation 1.2
EGO {WALL_SPEED / 25:g} 0 0 0 0 0
EGO {WALL_SPEED / 25:g} 0 0 0 0 0
"""

# writes the ground truth it finds in a KITTI folder: a perfect system (compare, harness tests)
PERFECT = "import shutil, sys; shutil.copy(sys.argv[1] + '/poses.txt', sys.argv[2])"
# the ground truth plus noise of a given size (a worse version of the perfect system)
NOISY = """
import sys, numpy as np
P = np.loadtxt(sys.argv[1] + '/poses.txt').reshape(-1, 3, 4)
rng = np.random.default_rng(int(sys.argv[4]))
P[:, :, 3] += float(sys.argv[3]) * rng.standard_normal(P[:, :, 3].shape)
np.savetxt(sys.argv[2], P.reshape(-1, 12))
"""


def world(script: str = "scene.ses", **keys) -> str:
    """A study file's [world] table: the script and ``keys`` (TOML values from Python's)."""
    import json
    return "[world]\n" + f"script = {json.dumps(script)}\n" + "".join(f"{k} = {json.dumps(v)}\n"
                                                                     for k, v in keys.items())


def write(folder: Path, name: str, text: str) -> Path:
    path = Path(folder) / name
    path.write_text(text, encoding="utf-8")
    return path


def study_file(folder: Path, body: str, script: str = ROOM, name: str = "study.toml") -> Path:
    write(folder, "scene.ses", script)
    return write(folder, name, body)
