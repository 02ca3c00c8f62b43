"""A house (``ASSET house``, issue 28, session 18), as KITTI sequence_1's near right houses
(frames 0-24 at full size): the upper storeys run on over a ground floor set back ~1.5-2 m along
most of the front, the front door and the ground floor's windows in the recess. The finished building's
mesh is unchanged (tests/test_building_shell.py's hashes); KITTI's side of it is
tests/test_scene_library.py's test_city_kitti_garden_houses_recess_their_ground_floors_as_kitti_sequence_1s."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.scene import assets
from blender_sesgen.scene.assets import building
import mesh_raycast

HOUSES = [(150934, (15.03, 11.56, 11.92)), (115691, (11.76, 15.15, 11.02)), (950911, (10.25, 18.97, 11.55)),
          (3, (22.0, 14.0, 12.0)), (4242, (18.0, 12.0, 10.0)), (7, (13.0, 9.5, 9.0))]


def _front_depths(kind, size, seed, y, fittings=True):
    """Rays along -z into the front (+z) from 1 m before it at height ``y``, every 0.1 m across
    the front (0.4 m in from each corner): (x, depth behind the front wall or inf, surface hit);
    ``fittings=False``: without session 20's gutters, downpipes and attic and roof windows."""
    W, H, D = size
    d = assets.generate(kind, size, seed)
    ts = mesh_raycast.TriangleScene()
    for k in np.unique(d.face_surface):          # one part a surface: the hit's id is its surface + 1
        if not fittings and d.surfaces[k].part == "fittings":
            continue
        ts.add(int(k) + 1, d.vertices, d.faces[d.face_surface == k])
    x = np.arange(-W / 2 + 0.4, W / 2 - 0.4, 0.1)
    o = np.column_stack([x, np.full_like(x, y), np.full_like(x, D / 2 + 1.0)])
    t, hit = ts.cast(o, np.tile([0.0, 0.0, -1.0], (len(x), 1)))
    return x, t - 1.0, np.asarray(hit, int) - 1, d


@pytest.mark.parametrize("seed, size", HOUSES)
def test_a_house_recesses_most_of_its_ground_floor_under_the_storeys_above(seed, size):
    """At 2.2 m up at least 60 % of the house's front lies 1.4-2.0 m behind its front wall (its
    windows' frames 7 cm before it), where the building of the same seed and size is its wall or a
    window's or door's reveal (at most 0.3 m deep); 5 m up (the first floor) the house's front is
    its wall, as the building's."""
    x, t, _, _ = _front_depths("house", size, seed, 2.2)
    deep = (t > 1.3) & (t < 2.05)
    assert np.mean(deep) >= 0.6, np.mean(deep)
    _, tb, _, _ = _front_depths("building", size, seed, 2.2)
    assert np.all(tb[np.isfinite(tb)] < 0.35), tb.max()
    _, t5, _, _ = _front_depths("house", size, seed, 5.0, fittings=False)     # a low eave's gutter hangs
    _, tb5, _, _ = _front_depths("building", size, seed, 5.0, fittings=False)  # before it (seed 7)
    wall = np.isfinite(tb5) & (tb5 < 0.01)
    assert np.all(np.abs(t5[wall]) < 0.01)


@pytest.mark.parametrize("seed, size", HOUSES[:3])
def test_the_recess_holds_the_front_door_and_the_ground_floors_windows(seed, size):
    """The recess's back is the ground floor's own wall (the surface an ASSET's ``ground_material``
    replaces: white in seed 0's houses, in shade there as KITTI's), with the front door (a leaf of
    the building's door surface 5 cm before it, 1.0-1.2 m wide) and glazed windows (their glass
    2 cm before it) in it: the dark openings in a lit wall where KITTI's ORB keypoints lie."""
    x, t, surf, d = _front_depths("house", size, seed, 1.5)
    recess = (t > 1.3) & (t < 2.05)
    r = np.max(t[recess])
    back = recess & (t > r - 0.001)
    assert back.sum() > 10
    assert {(d.surfaces[k].material, d.surfaces[k].part) for k in surf[back]} == {("plaster", "ground")}
    leaf = recess & (np.abs(t - (r - 0.05)) < 0.001)
    assert {d.surfaces[k].material for k in surf[leaf]} == {"wood_planks"}
    assert all(tuple(d.surfaces[k].colour) in building.palette.DOOR for k in surf[leaf])
    assert 1.0 <= np.ptp(x[leaf]) + 0.1 <= 1.25, x[leaf]
    pane = recess & (np.abs(t - (r - 0.02)) < 0.001)
    assert {d.surfaces[k].material for k in surf[pane]} == {"glass_window"} and pane.sum() >= 5


def test_house_is_a_kind_of_building_with_a_ground_floor():
    """``house`` draws with the building's class and sizes and takes ``ground_material``."""
    from blender_sesgen.ses.parser import GROUND_FLOOR_KINDS
    k, b = assets.KINDS["house"], assets.KINDS["building"]
    assert (k.semantic_class, k.size_ranges, k.closed) == (b.semantic_class, b.size_ranges, True)
    assert "house" in GROUND_FLOOR_KINDS
    assert building.PORCH["depth"][0] >= 1.4
