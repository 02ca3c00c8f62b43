"""The cars' fine detail as KITTI's camera sees it (issue 28): a car's rear seen from KITTI
sequence_1 frame 0's viewpoint (the parked car 13.8 m ahead, 3.3 m right of the camera, 1.65 m
below it; the distance from the car's plate, 27 px = 0.52 m at f 707 px) by an independent ray
cast against the asset's own triangles. Oracles: the EU plate standard (520 x 110 mm, black
characters 75 mm tall on white) and KITTI's own frames (its lamps are 0.3-0.45 m across and
carry 14-30 % of a car's finest contrast through glints: reflector facets turned many ways)."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.scene import assets
from blender_sesgen.scene.assets import vehicle

import mesh_raycast

SEEDS = (635105, 83216, 3)                      # two of the city's cars, and one more
PITCH_M = 0.012                                  # ray spacing on the car's rear: ~0.6 px of KITTI's at 13.8 m


def _view(seed):
    """(mesh, hit triangle per ray or -1, ray grid shape, the rays' targets (n, 3)) of the car's
    rear seen from KITTI frame 0's camera."""
    size = assets.default_size("car", seed)
    m = assets.generate("car", size, seed)
    W, H, L = size
    cam = np.array([3.3, 1.65, -L / 2 - 13.8])   # the car's nose is +z: the camera behind it, to its left
    xs = np.arange(-W / 2 - 0.1, W / 2 + 0.1, PITCH_M)
    ys = np.arange(0.05, H, PITCH_M)
    X, Y = np.meshgrid(xs, ys)
    target = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, -L / 2 + 0.1)])
    d = target - cam
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    tris = m.vertices[m.faces]
    t, i = mesh_raycast.rays_hit_triangles(np.broadcast_to(cam, d.shape), d, tris)
    hit = np.where(np.isfinite(t), i, -1)
    return m, hit, X.shape, cam + d * np.where(np.isfinite(t), t, 0.0)[:, None]


def _surface_of(m, hit, material, colour=None):
    idx = [k for k, s in enumerate(m.surfaces) if s.material == material and
           (colour is None or s.colour == tuple(round(float(c), 4) for c in colour))]
    return (hit >= 0) & np.isin(m.face_surface[np.maximum(hit, 0)], idx)


@pytest.fixture(scope="module", params=SEEDS)
def view(request):
    return _view(request.param)


def test_the_plate_is_an_eu_plate_with_dark_characters_a_camera_sees(view):
    m, hit, shape, P = view
    white = _surface_of(m, hit, "plastic", vehicle.PLATE_WHITE)
    blue = _surface_of(m, hit, "plastic", vehicle.PLATE_BLUE)
    assert white.any() and blue.any()
    lo, hi = P[white | blue].min(0), P[white | blue].max(0)
    # the EU band at the viewer's left (looking at the rear along +z, the viewer's left is +x)
    assert np.median(P[blue, 0]) > hi[0] - 0.05
    # 520 x 110 mm (seen from the side the visible width loses little: the plate faces back)
    assert 0.49 <= hi[0] - lo[0] <= 0.53 and 0.095 <= hi[1] - lo[1] <= 0.115
    inside = (P[:, 0] > lo[0]) & (P[:, 0] < hi[0]) & (P[:, 1] > lo[1]) & (P[:, 1] < hi[1]) & (hit >= 0)
    ink = inside & _surface_of(m, hit, "plastic", vehicle.PLATE_INK)
    share = ink.sum() / max(inside.sum(), 1)
    assert 0.12 <= share <= 0.45, share                      # strokes of 6-8 characters
    y_ink = P[ink, 1]
    # characters 75 mm tall (the rays' rows are 12 mm apart)
    assert 0.075 - 2 * PITCH_M <= y_ink.max() - y_ink.min() <= 0.075 + PITCH_M
    # in front of the plate's face (embossed): the rays hit them before the white
    z_white, z_ink = np.median(P[white, 2]), np.median(P[ink, 2])
    assert z_ink < z_white


def test_the_tail_lamps_are_facets_turned_many_ways_round_the_corner(view):
    m, hit, shape, P = view
    lamp = _surface_of(m, hit, "vehicle_lamp") & (P[:, 1] > 0.4)      # above the bumper's reflectors
    assert lamp.sum() > 50
    n = m.triangle_normals()[hit[lamp]]
    # facets: the normals the camera sees spread (a flat lens would show one); some turned
    # 20 deg or more from the lamp's mean, so that some catch the sun or the sky
    mean = n.mean(0) / np.linalg.norm(n.mean(0))
    ang = np.degrees(np.arccos(np.clip(n @ mean, -1, 1)))
    assert np.percentile(ang, 90) >= 20.0
    assert np.std(n[:, 0]) >= 0.15
    # and up and down: the body's rounded corner alone would turn them sideways only
    assert np.percentile(np.abs(n[:, 1]), 75) >= 0.15
    # each lamp 0.3-0.6 m across and 0.12-0.3 m high in the view (KITTI frame 0: 0.44 x 0.19 m,
    # frame 20: its corner 0.22 x 0.28 m), both within the car's width
    for side in (P[:, 0] < 0, P[:, 0] > 0):
        q = P[lamp & side]
        assert len(q)
        assert 0.3 <= q[:, 0].max() - q[:, 0].min() <= 0.6
        assert 0.12 <= q[:, 1].max() - q[:, 1].min() <= 0.3


def test_lamps_plates_and_glass_take_their_colours_from_the_physical_parts():
    # a red lens over a mirror; the plate's retro-reflective white well below paint white; a
    # dark cabin under the glass (KITTI frame 20: the rear window 0.26 x a grey body's median)
    r, g, b = vehicle.LAMP_RED
    assert r > 0.5 and g < 0.1 and b < 0.1
    assert 0.35 <= vehicle.PLATE_WHITE[0] <= 0.6 and max(vehicle.PLATE_INK) < 0.05
    assert max(vehicle.CABIN) < 0.26 * 0.35                    # the grey paints are 0.35-0.5
    assert vehicle.PLATE_M == (0.52, 0.11)
    m = assets.generate("car", assets.default_size("car", 0), 0)
    names = {s.material for s in m.surfaces}
    assert {"vehicle_lamp", "glass_window", "car_paint", "rubber", "chrome"} <= names
