"""The scripts in scenes/ parse and have the properties their READMEs promise."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from blender_sesgen import model
from blender_sesgen.contract.frames import object_pose
from blender_sesgen.contract.rig import right_from_left
from blender_sesgen.ses import parse_file

SCENES_DIR = Path(__file__).resolve().parents[1] / "scenes"
ALL = sorted(SCENES_DIR.glob("*.ses"))


@pytest.mark.parametrize("path", ALL, ids=[p.name for p in ALL])
def test_every_scene_parses(path):
    scene = parse_file(path)
    assert scene.objects and scene.frames >= 1


def test_the_three_scenes_exist():
    assert {"paper_room.ses", "street.ses", "minimal.ses"} <= {p.name for p in ALL}


# --- a tiny independent ray caster (SES world, exact for the four primitives) ----------

def _hit_quad(o, d, obj):
    V = np.array(obj.vertices)
    n = np.cross(V[1] - V[0], V[2] - V[0])
    den = d @ n
    if abs(den) < 1e-12:
        return np.inf
    t = ((V[0] - o) @ n) / den
    p = o + t * d
    side = [np.cross(V[(i + 1) % 4] - V[i], p - V[i]) @ n for i in range(4)]
    return t if t > 0 and (min(side) >= 0 or max(side) <= 0) else np.inf


def _local(o, d, obj):
    T = object_pose(obj.position, obj.rotation_deg)
    return T[:3, :3].T @ (o - T[:3, 3]), T[:3, :3].T @ d


def _hit_sphere(o, d, obj):
    oc = o - np.array(obj.position)
    b, c = oc @ d, oc @ oc - obj.radius ** 2
    disc = b * b - c
    ts = [t for t in (-b - np.sqrt(max(disc, 0)), -b + np.sqrt(max(disc, 0))) if t > 0 and disc >= 0]
    return min(ts, default=np.inf)


def _hit_cuboid(o, d, obj):
    lo, ld = _local(o, d, obj)
    h = np.array(obj.size) / 2
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-h - lo) / ld, (h - lo) / ld
    tn, tf = np.nanmax(np.minimum(t1, t2)), np.nanmin(np.maximum(t1, t2))
    return np.inf if tn > tf or tf < 0 else (tn if tn > 0 else tf)


def _hit_cylinder(o, d, obj):
    lo, ld = _local(o, d, obj)
    r, hh = obj.radius, obj.height / 2
    ts = []
    a, b, c = ld[0] ** 2 + ld[2] ** 2, 2 * (lo[0] * ld[0] + lo[2] * ld[2]), lo[0] ** 2 + lo[2] ** 2 - r * r
    if a > 1e-15 and b * b - 4 * a * c >= 0:
        for t in ((-b - np.sqrt(b * b - 4 * a * c)) / (2 * a), (-b + np.sqrt(b * b - 4 * a * c)) / (2 * a)):
            if t > 0 and abs(lo[1] + t * ld[1]) <= hh:
                ts.append(t)
    if abs(ld[1]) > 1e-15:
        for y_cap in (-hh, hh):
            t = (y_cap - lo[1]) / ld[1]
            p = lo + t * ld
            if t > 0 and p[0] ** 2 + p[2] ** 2 <= r * r:
                ts.append(t)
    return min(ts, default=np.inf)


HIT = {"quad": _hit_quad, "sphere": _hit_sphere, "cuboid": _hit_cuboid, "cylinder": _hit_cylinder}


def first_hit(scene, o, d):
    """(distance along the unit ray d, the object hit or None)."""
    best, hit = np.inf, None
    for obj in scene.objects:
        t = HIT[obj.shape](o, d, obj)
        if t < best:
            best, hit = t, obj
    return best, hit


def test_ray_caster_sanity():
    scene = parse_file(SCENES_DIR / "minimal.ses")
    # straight down from (0, 1, 3): the floor quad (id 1) at distance 1
    t, obj = first_hit(scene, np.array([0.0, 1.0, 3.0]), np.array([0.0, -1.0, 0.0]))
    assert obj.id == 1 and np.isclose(t, 1.0)
    # towards the sphere (id 4, r 0.5 at (0.6, 0.5, -0.3)) from 2 m in front of it along +Z
    t, obj = first_hit(scene, np.array([0.6, 0.5, 1.7]), np.array([0.0, 0.0, -1.0]))
    assert obj.id == 4 and np.isclose(t, 1.5)


# --- paper_room.ses ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def paper():
    return parse_file(SCENES_DIR / "paper_room.ses")


def test_paper_room_rig_and_length(paper):
    assert paper.rig == model.Rig(width=640, height=480, focal_px=389.0, cx=319.5, cy=239.5, baseline=0.12,
                                  near=0.05, far=1000.0)
    assert paper.motion.kind == "ego" and len(paper.motion.ego) == 40 and paper.frames == 41


def test_paper_room_motion_has_table1_magnitudes(paper):
    ego = np.array(paper.motion.ego)
    # SESGen paper, Sec. 5: max |U| 0.030, |V| 0.039, |W| 0.044, |alpha| 0.8, |beta| 0.8, |gamma| 0.5
    np.testing.assert_allclose(np.abs(ego).max(axis=0), [0.030, 0.039, 0.044, 0.8, 0.8, 0.5], rtol=0.01)
    assert np.all(ego != 0.0)                             # every component of every step moves
    assert np.all((ego[:, 2] >= 0.02) & (ego[:, 2] <= 0.044))  # forward 0.02-0.044 per frame
    norms = np.linalg.norm(ego[:, :3], axis=1)
    assert norms.min() >= 0.02
    # smooth: a step changes by a small fraction of each component's range
    jumps = np.abs(np.diff(ego, axis=0)).max(axis=0) / np.ptp(ego, axis=0)
    assert np.all(jumps < 0.2), jumps


def test_paper_room_is_textured_with_numbers_1_to_12(paper):
    assert all(o.texture is not None and o.texture.kind == "builtin" and 1 <= o.texture.number <= 12
               for o in paper.objects)
    shapes = {o.shape for o in paper.objects}
    assert shapes == {"quad", "cuboid", "sphere", "cylinder"}
    assert sum(o.shape == "quad" for o in paper.objects) >= 6  # floor, ceiling, four walls


@pytest.mark.slow
def test_paper_room_camera_sees_textured_surfaces_at_1_to_5_m(paper):
    K_inv = np.linalg.inv(paper.rig.K())
    pixels = [(u, v) for u in np.linspace(0, 639, 7) for v in np.linspace(0, 479, 5)]
    room = [o for o in paper.objects if o.shape == "quad"]
    lo = np.min([np.min(q.vertices, axis=0) for q in room], axis=0)
    hi = np.max([np.max(q.vertices, axis=0) for q in room], axis=0)
    for k, T_left in enumerate(paper.timeline.left()):
        for T in (T_left, right_from_left(T_left, paper.rig.baseline)):
            o = T[:3, 3]
            assert np.all(o > lo + 0.5) and np.all(o < hi - 0.5), f"frame {k}: camera leaves the room"
            for u, v in pixels:
                ray_cam = K_inv @ [u, v, 1.0]
                d = T[:3, :3] @ ray_cam / np.linalg.norm(ray_cam)
                t, obj = first_hit(paper, o, d)
                depth = t * (ray_cam[2] / np.linalg.norm(ray_cam))  # planar depth (camera z)
                assert obj is not None and 1.0 <= depth <= 5.0, (k, u, v, depth)


# --- street.ses and minimal.ses ---------------------------------------------------------

def test_street_is_a_long_forward_drive():
    scene = parse_file(SCENES_DIR / "street.ses")
    assert 250 <= scene.frames <= 400
    T = scene.timeline.left()
    steps = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)
    assert steps.min() >= 0.1 and steps.max() <= 0.5
    ego = np.array(scene.motion.ego)
    assert np.all(ego[:, 2] > 0) and np.abs(ego[:, 3:]).max() < 1.0      # forward, gentle turns
    heading = np.degrees(np.arctan2(-T[:, 0, 2], -T[:, 2, 2]))          # yaw of the optical axis
    assert np.ptp(heading) > 10                                          # it does turn
    assert np.ptp(T[:, 1, 3]) < 0.3                                      # and stays at eye height
    assert all(o.texture is not None for o in scene.objects)


def test_street_kitti_is_every_fourth_frame_of_street_with_kittis_rig():
    street, kitti = parse_file(SCENES_DIR / "street.ses"), parse_file(SCENES_DIR / "street_kitti.ses")
    assert (kitti.rig.width, kitti.rig.height, kitti.rig.focal_px, kitti.rig.baseline) == (1226, 370, 707, 0.54)
    assert kitti.frames == 51 and [o.id for o in kitti.objects] == [o.id for o in street.objects]
    T_s, T_k = street.timeline.left(), kitti.timeline.left()
    # same drive: the street's EGO rows are rounded to 1 mm / 0.001 deg, so poses agree to ~1 cm over 200 steps
    assert np.abs(T_k[:, :3, 3] - T_s[0:201:4, :3, 3]).max() < 0.02
    steps = np.linalg.norm(np.diff(T_k[:, :3, 3], axis=0), axis=1)
    assert 55 < steps.sum() < 70 and steps.min() > 0.8


def test_generated_scenes_are_in_sync_with_their_generator():
    import subprocess
    import sys
    gen = ["-m", "blender_sesgen.generators.builtin.street"]    # the built-in generator's command line
    for args, name in (([], "street.ses"), (["--kitti"], "street_kitti.ses")):
        out = subprocess.run([sys.executable, *gen, *args], capture_output=True, text=True, check=True).stdout
        assert out == (SCENES_DIR / name).read_text(), f"{name} differs from `python -m blender_sesgen.generators.builtin.street {' '.join(args)}`"


def test_minimal_is_tiny():
    scene = parse_file(SCENES_DIR / "minimal.ses")
    assert scene.frames == 3 and len(scene.objects) <= 6
    assert scene.rig.width * scene.rig.height <= 64 * 48
