"""The glowing panes' build made cheap at the same maps (issue 29): the ray tests culled to the
pairs that can meet, the interpolation vectorised, the maps kept in the asset cache.

Oracles: every ray against every triangle (``occlusion.blocked``, Moller-Trumbore as glazing
had it) for the culled test, bit for bit, on a window's frame bars seen from points on grids
aligned with their edges and along grazing directions; ``np.interp`` for the vectorised rows;
in Blender, a build that computes the maps against one that reads them (equal pixels) and
builds whose inputs changed (the sun, one occluder moved: computed again).
"""
from __future__ import annotations

import numpy as np
import pytest

from markers import needs
from blender_sesgen.scene import lighting as L
from blender_sesgen.scene import occlusion as O


def _box(lo, hi) -> np.ndarray:
    """The 12 triangles (12, 3, 3) of an axis-aligned box."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    c = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return c[np.array(faces)]


def _frame() -> np.ndarray:
    """A 2 x 1 m pane's frame in z = 0: bars around it and across it, 0-0.2 m before it."""
    bars = [_box((-1.05, -0.55, 0), (1.05, -0.5, 0.2)), _box((-1.05, 0.5, 0), (1.05, 0.55, 0.2)),
            _box((-1.05, -0.5, 0), (-1.0, 0.5, 0.2)), _box((1.0, -0.5, 0), (1.05, 0.5, 0.2)),
            _box((-0.025, -0.5, 0.05), (0.025, 0.5, 0.15)), _box((-1, -0.02, 0), (1, 0.02, 0.1))]
    return np.concatenate(bars)


def _every_pair(points, dirs, tris) -> np.ndarray:
    o = np.repeat(points[None], len(dirs), axis=0).reshape(-1, 3)
    d = np.repeat(dirs[:, None], len(points), axis=1).reshape(-1, 3)
    return O.blocked(o, d, tris).reshape(len(dirs), len(points))


def test_the_culled_ray_test_equals_every_ray_against_every_triangle():
    """Points on a grid whose lines run along the bars' edges (rays through edges and corners),
    the 256 cosine directions of a pane's sky, the axes and directions grazing the bars' faces
    (1e-9 off their planes): the same answer for every ray, from a tenth of the tests."""
    tris = _frame()
    u = np.arange(-1.1, 1.1001, 0.05)
    g = np.stack(np.meshgrid(u, u / 2), -1).reshape(-1, 2)
    points = np.c_[g, np.full(len(g), 1e-3)]
    dirs = np.concatenate([L.cosine_directions((0, 0, 1), 256),
                           [[0, 0, 1], [1, 0, 1e-9], [0, 1, 1e-9], [0.6, 0, 0.8], [0, 0.6, 0.8], [1, 1, 1e-12]]])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    stats = {}
    got = O.blocked_grid(points, dirs, tris, stats)
    want = _every_pair(points, dirs, tris)
    assert 0.05 < want.mean() < 0.95
    assert np.array_equal(got, want), int((got != want).sum())
    assert stats["all"] == len(points) * len(dirs) * len(tris)
    assert stats["tests"] < 0.1 * stats["all"], stats


def test_the_culled_ray_test_on_random_triangles():
    rng = np.random.default_rng(0)
    for _ in range(10):
        tris = rng.uniform(-1, 1, (150, 3, 3)) + [0, 0, 1.0]
        points = np.c_[rng.uniform(-1, 1, (9, 2)), np.zeros(9)]
        dirs = L.cosine_directions((0, 0, 1), 256)
        assert np.array_equal(O.blocked_grid(points, dirs, tris), _every_pair(points, dirs, tris))


def test_a_pane_sees_its_frame_at_a_fraction_of_the_tests():
    """The hall's case: 3 x 3 points on a pane, 256 directions, its frame: blocked rays as
    every-pair's, under 15 % of its tests (measured on the hall's 26 panes: 8.6 %)."""
    tris = _frame()
    f = (np.arange(3) + 0.5) / 3
    points = np.stack(np.meshgrid(2 * f - 1, f - 0.5), -1).reshape(-1, 2)
    points = np.c_[points, np.full(9, 1e-3)]
    dirs = L.cosine_directions((0, 0, 1), L.GLOW_SEEN_DIRECTIONS)
    stats = {}
    assert np.array_equal(O.blocked_grid(points, dirs, tris, stats), _every_pair(points, dirs, tris))
    assert stats["tests"] < 0.15 * stats["all"], stats


def test_the_shading_triangles_keep_every_one_that_can_block():
    """Triangles all within reach of a face in z = 0 (outer side +z), some wholly behind it:
    the rays from its points over its hemisphere are blocked by the kept ones exactly as by
    all of them, and the ones behind it are dropped."""
    rng = np.random.default_rng(1)
    front = rng.uniform(-0.5, 0.5, (80, 3, 3)) + [0, 0, 0.4]
    behind = rng.uniform(-0.5, 0.5, (40, 3, 3)) - [0, 0, 0.6]
    tris = np.concatenate([front, behind])
    points = np.c_[rng.uniform(-0.5, 0.5, (9, 2)), np.zeros(9)]
    kept = O.shading_triangles(tris, np.zeros(3), np.array([0.0, 0.0, 1.0]), radius=3.0)
    assert len(kept) == len(front) + int(((behind[..., 2]).max(axis=1) > 0).sum()) < len(tris)
    dirs = L.cosine_directions((0, 0, 1), 256)
    origins = points + [0, 0, 1e-3]
    assert np.array_equal(O.blocked_grid(origins, dirs, kept), _every_pair(origins, dirs, tris))


def test_interp_rows_is_np_interp_bit_for_bit():
    rng = np.random.default_rng(2)
    xp = (np.arange(3) + 0.5) / 3
    for m in (1, 2, 7, 22, 52, 64):
        x = (np.arange(m) + 0.5) / m
        fp = rng.uniform(0, 5, (12, 3)) * 10.0 ** rng.uniform(-3, 3, (12, 1))
        assert np.array_equal(L.interp_rows(x, xp, fp), np.stack([np.interp(x, xp, f) for f in fp]))
    xp = np.sort(rng.uniform(0, 1, 5))
    x = np.concatenate([rng.uniform(-0.2, 1.2, 40), xp])          # outside, inside and on the knots
    fp = rng.normal(size=(6, 5))
    assert np.array_equal(L.interp_rows(x, xp, fp), np.stack([np.interp(x, xp, f) for f in fp]))


# --- in Blender: the maps' cache ----------------------------------------------------------
SCENE = """CAMERA resolution 32 32 focal 24 baseline 0
START position 0 1.5 0 90 0 0
WORLD sky strength 1 elevation {el} azimuth 90
MATERIAL name wall colour 0.5 0.5 0.5
MATERIAL name pane library frosted_glass glow
CUBOID id 1 material wall position 0 -0.1 0 dim 4.4 0.2 4.4
CUBOID id 3 material wall position -2.1 1.5 0 dim 0.2 3 4.4
CUBOID id 4 material wall position 2.1 1.5 0 dim 0.2 3 4.4
CUBOID id 5 material wall position 0 1.5 2.1 dim 4 3 0.2
CUBOID id 6 material wall position 0 1.5 -2.1 dim 4 3 0.2
QUAD id 7 material pane vertices -2 3 -2 2 3 -2 2 3 2 -2 3 2
CUBOID id 8 material wall position {beam} 3.3 0 dim 0.6 0.1 4.4
"""


def _glow_maps(text: str) -> dict:
    """Build ``text`` (no render): {pane id: (strength, map pixels)}."""
    from blender_sesgen.blender import builder, library
    from blender_sesgen.render.plan import RenderOptions, RenderPlan
    from blender_sesgen.ses import parse_string
    plan = RenderPlan.from_scene(parse_string(text), RenderOptions(samples=1), scene_text=text)
    s = plan.settings
    built = builder.build_scene(plan.scene, width=s.width, height=s.height, K=s.K, view_poses=plan.view_poses)
    out = {}
    for oid in built.glow:
        mat = built.objects[oid][0].material_slots[0].material
        nodes = mat.node_tree.nodes
        img = nodes[library.GLOW_MAP_NODE].image
        px = np.empty(img.size[0] * img.size[1] * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
        out[oid] = (nodes[library.GLOW_NODE].inputs["Strength"].default_value, px)
    return out


@pytest.mark.render
@needs("bpy")
def test_a_warm_build_reads_the_maps_a_changed_input_computes_them(tmp_path, monkeypatch):
    """The black-room pane under its beam, sun 70 deg up: built with the cache off (the maps
    computed), then twice with a cache: the first computes and keeps them, the second reads
    them (no map computed) with the same pixels and strength as the uncached build; the sun
    at another elevation, or the beam (an occluder) moved by 5 cm, each compute the map again
    (and the beam's shadow moves in it)."""
    from blender_sesgen.blender import glazing
    from blender_sesgen.scene.assets import cache
    made = []
    real = glazing.irradiance_map
    monkeypatch.setattr(glazing, "irradiance_map", lambda *a, **k: made.append(1) or real(*a, **k))
    base = SCENE.format(el=70, beam=0.4)
    monkeypatch.setenv(cache.ENV, "off")
    cold = _glow_maps(base)
    assert len(made) == 1
    monkeypatch.setenv(cache.ENV, str(tmp_path / "cache"))
    first = _glow_maps(base)
    assert len(made) == 2
    warm = _glow_maps(base)
    assert len(made) == 2                               # read, not computed
    assert len(list((tmp_path / "cache" / "glow").glob("*.npy"))) == 1
    for maps in (first, warm):
        assert maps.keys() == cold.keys() == {7}
        assert maps[7][0] == cold[7][0] and np.array_equal(maps[7][1], cold[7][1])
    sun = _glow_maps(SCENE.format(el=60, beam=0.4))
    assert len(made) == 3 and sun[7][0] != cold[7][0]
    moved = _glow_maps(SCENE.format(el=70, beam=0.45))
    assert len(made) == 4 and not np.array_equal(moved[7][1], cold[7][1])
    assert len(list((tmp_path / "cache" / "glow").glob("*.npy"))) == 3
