"""Procedural assets (blender_sesgen.scene.assets): deterministic, well-formed meshes of the size
asked for; strips that fit side by side exactly; the terrain's height function is its mesh."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from blender_sesgen.scene import assets
from blender_sesgen.scene.assets.mesh import MeshBuilder, edge_report, signed_volume, triangulate_polygon
from blender_sesgen.scene.assets.nature import terrain_height, trail_x
from blender_sesgen.scene.assets.street import arc_frame, end_pose

KINDS = sorted(assets.KINDS)
SEEDS = (0, 1, 7)
HEAVY = {"tree", "conifer", "bush", "hedge", "terrain"}   # tens of thousands of triangles: one seed


def _seeds(kind):
    return SEEDS[:1] if kind in HEAVY else SEEDS


def _mesh(kind, seed, bend=(0.0,), offset=0.0, size=None):
    return assets.generate(kind, size or assets.default_size(kind, seed), seed, bend, offset)


def _components(faces: np.ndarray) -> np.ndarray:
    """Connected-component label of each triangle (sharing a vertex connects)."""
    n = int(faces.max()) + 1
    rows = np.repeat(faces[:, 0], 2)
    cols = faces[:, 1:].ravel()
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return labels[faces[:, 0]]


@pytest.mark.parametrize("kind", KINDS)
def test_same_seed_same_mesh_other_seed_other_mesh(kind):
    a, b = _mesh(kind, 3), _mesh(kind, 3)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert np.array_equal(a.face_surface, b.face_surface) and a.surfaces == b.surfaces
    others = [_mesh(kind, seed, size=assets.default_size(kind, 3)) for seed in (4, 5, 6)[:1 if kind in HEAVY else 3]]
    assert any(len(c.faces) != len(a.faces) or not np.allclose(c.vertices, a.vertices) or c.surfaces != a.surfaces
               for c in others)


@pytest.mark.parametrize("kind", KINDS)
def test_meshes_are_well_formed(kind):
    for seed in _seeds(kind):
        d = _mesh(kind, seed, bend=(4.0, -6.0) if assets.KINDS[kind].strip else (0.0,))
        assert d.vertices.dtype == np.float64 and np.all(np.isfinite(d.vertices))
        assert d.faces.shape[1] == 3 and d.faces.min() >= 0 and d.faces.max() < len(d.vertices)
        assert len(d.face_surface) == len(d.faces) == len(d.smooth)
        assert d.face_surface.min() >= 0 and d.face_surface.max() < len(d.surfaces)
        assert np.all(d.areas() > 1e-12), "degenerate triangles"
        assert all(s.material for s in d.surfaces)


@pytest.mark.parametrize("kind", [k for k in KINDS if assets.KINDS[k].closed])
def test_closed_kinds_are_watertight_and_outward(kind):
    """Every part of a closed kind is a closed, consistently wound surface enclosing a
    positive volume (its normals point out), so it has an inside and an outside."""
    for seed in SEEDS:
        d = _mesh(kind, seed, bend=(5.0, -3.0) if assets.KINDS[kind].strip else (0.0,))
        labels = _components(d.faces)
        for lab in np.unique(labels):
            f = d.faces[labels == lab]
            assert edge_report(f) == {"boundary": 0, "nonmanifold": 0, "flipped": 0}, (kind, seed, lab)
            assert signed_volume(d.vertices, f) > 0, (kind, seed, lab)


@pytest.mark.parametrize("kind", [k for k in KINDS if not assets.KINDS[k].strip])
def test_size_governs_the_asset(kind):
    """The mesh spans its size (width, height, depth) up to the kind's documented overhang."""
    k = assets.KINDS[kind]
    for seed in _seeds(kind):
        size = np.array(assets.default_size(kind, seed))
        lo, hi = _mesh(kind, seed).bounds
        extent = np.array([2 * max(-lo[0], hi[0]), hi[1], 2 * max(-lo[2], hi[2])])
        assert np.all(extent <= size + 2 * k.overhang + 1e-9), (kind, seed, extent, size)
        assert hi[1] >= 0.5 * size[1] - 0.2 or kind in ("ceiling_light",), (kind, seed)


def test_default_sizes_lie_in_their_ranges():
    for kind, k in assets.KINDS.items():
        for seed in range(5):
            size = assets.default_size(kind, seed)
            assert all(lo <= s <= hi for s, (lo, hi) in zip(size, k.size_ranges)), (kind, size)


def test_triangulated_polygon_covers_its_area():
    poly = np.array([(0, 0), (4, 0), (4, 3), (2, 1), (0, 3)], float)   # concave
    tris = triangulate_polygon(poly)
    area = sum(0.5 * np.cross(poly[b] - poly[a], poly[c] - poly[a]) for a, b, c in tris)
    assert len(tris) == 3 and np.isclose(area, 4 * 3 - 0.5 * 4 * 2)


def test_builder_primitives_are_closed_with_exact_volumes():
    b = MeshBuilder()
    s = b.surface("concrete")
    b.box((0, 0, 0), (1, 2, 3), s)
    b.prism([(0, 0), (2, 0), (2, 1), (0, 1)], 0.0, 1.5, s)
    d = b.build()
    assert edge_report(d.faces) == {"boundary": 0, "nonmanifold": 0, "flipped": 0}
    assert np.isclose(signed_volume(d.vertices, d.faces), 6.0 + 3.0)


def test_tubes_made_in_one_pass_are_each_tube_made_alone_and_round_their_paths():
    """``tubes`` groups paths of equal shape into vectorised passes: every tube must come out
    as it does alone, bit for bit and in order, and be a closed outward tube whose rings lie
    at their radius, perpendicular to the path (checked from the geometry, not the code)."""
    rng = np.random.default_rng(3)
    paths = []
    for k in range(40):
        p, n = int(rng.integers(2, 8)), int(rng.choice([4, 5, 7, 10]))
        d = [0.0, 0.5, 0.0] if k % 3 else [0.5, 0.0, 0.0]      # the frame's two helper axes
        pts = rng.normal(size=3) + np.concatenate([np.zeros((1, 3)),
                                                   np.cumsum(rng.normal(size=(p - 1, 3)) * 0.2 + d, axis=0)])
        paths.append((pts, np.linspace(0.1, 0.02, p) * rng.uniform(0.5, 2), n))
    together, alone = MeshBuilder(), MeshBuilder()
    together.tubes(paths, together.surface("bark"))
    for pts, rad, n in paths:
        alone.tube(pts, rad, n, alone.surface("bark"))
    a, b = together.build(), alone.build()
    for x, y in ((a.vertices, b.vertices), (a.faces, b.faces), (a.face_surface, b.face_surface), (a.smooth, b.smooth)):
        assert x.dtype == y.dtype and x.tobytes() == y.tobytes()
    start = 0
    for pts, rad, n in paths:
        p = len(pts)
        V = a.vertices[start:start + p * n + 2]
        F = a.faces[(a.faces >= start).all(axis=1) & (a.faces < start + len(V)).all(axis=1)] - start
        start += len(V)
        assert len(F) == 2 * n * p and edge_report(F) == {"boundary": 0, "nonmanifold": 0, "flipped": 0}
        assert signed_volume(V - V.mean(axis=0), F) > 0
        rings = V[:p * n].reshape(p, n, 3) - pts[:, None, :]
        assert np.allclose(np.linalg.norm(rings, axis=-1), rad[:, None], rtol=1e-12, atol=0)
        tang = np.gradient(pts, axis=0)
        assert np.abs(np.einsum("pnj,pj->pn", rings, tang)).max() < 1e-12
        assert np.allclose(V[p * n:], [V[:n].mean(axis=0), V[(p - 1) * n:p * n].mean(axis=0)])


# --- strips -----------------------------------------------------------------------------

def test_arc_frame_is_an_arc_length_parametrised_chain_of_arcs():
    L, bends = 100.0, (0.0, 12.0, -7.0, 3.0)
    s = np.linspace(0, L, 4001)
    c, n, h = arc_frame(s, L, bends)
    steps = np.linalg.norm(np.diff(c, axis=0), axis=1)
    np.testing.assert_allclose(steps, L / 4000, rtol=1e-6)                  # unit speed
    tangent = np.diff(c, axis=0) / steps[:, None]
    heading = np.arctan2(-tangent[:, 0], -tangent[:, 2])
    np.testing.assert_allclose(heading, 0.5 * (h[1:] + h[:-1]), atol=1e-6)   # heading = direction
    np.testing.assert_allclose(np.degrees(h[-1]), sum(bends), atol=1e-9)
    np.testing.assert_allclose(np.einsum("ij,ij->i", n, np.column_stack([-np.sin(h), 0 * h, -np.cos(h)])), 0, atol=1e-12)
    p, turn = end_pose(L, bends)
    np.testing.assert_allclose(p, c[-1], atol=1e-9) and np.isclose(turn, sum(bends))


def test_strips_of_one_street_meet_exactly():
    """A road's right edge and the kerb's road side lie on the same offset curve, so the
    kerb (5 cm over the road edge) leaves no gap, on straights and bends alike."""
    L, bends, half = 60.0, (0.0, 9.0, -4.0), 4.0
    road = assets.generate("road", (2 * half, 0.3, L), 1, bends, 0.0)
    kerb = assets.generate("kerb", (0.2, 0.13, L), 2, bends, half + 0.05)
    lat_road, lat_kerb = _lateral(road.vertices, L, bends), _lateral(kerb.vertices, L, bends)
    assert np.sum(np.isclose(lat_road, half, atol=1e-5)) > 40          # the road's right edge ...
    assert np.sum(np.isclose(lat_kerb, half - 0.05, atol=1e-5)) > 40   # ... is under the kerb's road side
    assert np.abs(lat_road).max() <= half + 1e-5 and lat_kerb.min() >= half - 0.05 - 1e-5


def _lateral(V, L, bends):
    """Signed lateral offset of points from the strip's centreline (nearest of a dense
    sampling, 2.5 mm apart: the offset is then exact to ~1e-6 m)."""
    from scipy.spatial import cKDTree
    s = np.linspace(0, L, int(L / 0.0025) + 1)
    c, n, _ = arc_frame(s, L, bends)
    _, idx = cKDTree(c[:, [0, 2]]).query(V[:, [0, 2]])
    return np.einsum("ij,ij->i", V[:, [0, 2]] - c[idx][:, [0, 2]], n[idx][:, [0, 2]])


def test_kerbs_and_sidewalks_face_the_road_on_both_sides():
    """The road side (chamfer, at the lower edge) of a kerb is the side nearer the centreline."""
    L = 20.0
    for off in (5.0, -5.0):
        V = assets.generate("kerb", (0.2, 0.13, L), 1, (0.0,), off).vertices
        top = V[V[:, 1] > 0.12]
        lowest_top_x = V[(V[:, 1] > 0.05) & (V[:, 1] < 0.12)][:, 0]
        assert np.all(np.abs(lowest_top_x) < np.abs(top[:, 0]).max())   # chamfer towards x = 0
        assert np.isclose(np.abs(lowest_top_x).min(), abs(off) - 0.1)


def test_terrain_mesh_follows_its_height_function_and_the_trail_is_soil():
    size, seed = (40.0, 3.0, 60.0), 5
    d = assets.generate("terrain", size, seed)
    ground = [i for i, s in enumerate(d.surfaces) if s.material != "leaves"]
    gv = d.vertices[np.unique(d.faces[np.isin(d.face_surface, ground)])]
    top = gv[gv[:, 1] > d.vertices[:, 1].min() + 0.1]
    np.testing.assert_allclose(top[:, 1], terrain_height(size, seed, top[:, 0], top[:, 2]), atol=1e-9)
    # fallen leaves lie on the ground mesh: each leaf's base 4 +- 1 mm above it (cast straight down)
    import mesh_raycast
    bases = d.vertices[np.unique(d.faces[~np.isin(d.face_surface, ground)][:, 0])]
    assert len(bases) > 1000
    sample = bases[np.random.default_rng(0).choice(len(bases), 300, replace=False)]
    ts = mesh_raycast.TriangleScene()
    ts.add(1, d.vertices, d.faces[np.isin(d.face_surface, ground)])
    t, _ = ts.cast(sample + [0.0, 10.0, 0.0], np.tile([0.0, -1.0, 0.0], (len(sample), 1)))
    np.testing.assert_allclose(t - 10.0, 0.004, atol=0.001)
    z = np.linspace(-25, 25, 11)
    xt = trail_x(size, seed, z)
    h = terrain_height(size, seed, xt, z)
    h_side = terrain_height(size, seed, xt + 0.3, z)
    np.testing.assert_allclose(h, h_side, atol=1e-9)                 # the trail is levelled across
    trail = [i for i, s in enumerate(d.surfaces) if s.material == "soil" and s.colour == (0.16, 0.12, 0.08)]
    centres = d.vertices[d.faces].mean(axis=1)
    on = np.abs(centres[:, 0] - trail_x(size, seed, centres[:, 2])) < 0.5
    up = d.triangle_normals()[:, 1] > 0.5
    assert len(trail) == 1 and np.all(d.face_surface[on & up] == trail[0])


def test_every_kind_has_a_known_class_and_documented_sizes():
    for kind, k in assets.KINDS.items():
        assert k.semantic_class and k.summary and k.size_meaning and len(k.size_ranges) == 3, kind


def test_surfaces_name_library_or_asset_materials_and_kinds_known_classes():
    from blender_sesgen.contract.semantics import lookup
    from blender_sesgen.scene.materials import LIBRARY
    for kind, k in assets.KINDS.items():
        assert lookup(k.semantic_class) is not None, (kind, k.semantic_class)
        d = _mesh(kind, 0)
        for s in d.surfaces:
            assert s.material in LIBRARY or s.material in assets.ASSET_MATERIALS, (kind, s.material)
            assert s.colour is None or all(0.0 <= c <= 0.86 for c in s.colour), (kind, s)   # linear albedos


def test_a_sidewalk_strip_is_one_surface_so_an_object_material_covers_it():
    """An object's ``material`` replaces its asset's main surface (0) only: a sidewalk strip is one
    paving surface (the pavers' tones are the material's), so a bay given ``material setts`` is
    setts all over; kerbs are granite."""
    from blender_sesgen.scene.assets import street
    for offset in (3.25, -3.25):
        d = street.sidewalk((2.5, 0.01, 40.0), 9, [0.0, 5.0], offset)
        assert [s.material for s in d.surfaces] == ["paving"] and set(np.unique(d.face_surface)) == {0}
    assert {s.material for s in street.kerb((0.2, 0.13, 40.0), 2, [0.0], 4.55).surfaces} == {"granite"}


def _side_gap(md, px: float = 0.05) -> float:
    """Share of sky inside a mesh's outline seen from the side (along z, orthographic, ``px``
    metres a pixel): triangles filled, the outline their 75 cm closing, 25 cm in from its edge."""
    import cv2
    P = ((md.vertices[:, :2] - md.vertices[:, :2].min(axis=0)) / px).astype(np.float32)
    W, H = (P.max(axis=0) + 2).astype(int)
    img = np.zeros((H, W), np.uint8)
    for tri in P[md.faces].round().astype(np.int32):
        cv2.fillConvexPoly(img, tri, 1)
    outline = cv2.erode(cv2.morphologyEx(img, cv2.MORPH_CLOSE, np.ones((15, 15), np.uint8)), np.ones((5, 5), np.uint8))
    return 1.0 - float(img[outline > 0].mean())


def test_tree_crowns_show_sky_between_their_leaf_sprays():
    """A broadleaf crown's leaves grow in sprays with sky between them (KITTI sequence_1's
    street trees: 25-35 % sky inside a crown's outline at 3-8 cm a pixel); leaves spread evenly
    along every twig closed the crown to 18 % (seeds 0-3; 27 % in sprays; docs/sensors.md, Camera twins)."""
    gaps = [_side_gap(_mesh("tree", seed)) for seed in range(4)]
    assert np.mean(gaps) > 0.24, gaps


def test_garden_trees_are_young_trees_with_small_leaves_in_open_crowns():
    """KITTI sequence_1's front-garden trees (full-size frames 0 and 14; SGBM: 4.5-6 m high, crowns
    from ~1.5-2.5 m up) are young trees: a clear stem to a third of the height or more, small
    leaves in loose sprays with the white wall between them. ``garden_tree`` (seeds 0-3, 2.6 x
    5.2 x 1.5 m): no leaf below a quarter of the height, leaves 5-8 cm long (a street tree's
    9-15 cm: 12-18 px at KITTI's size from 10 m would be blobs, not sprays), 22-40 % of the
    crown's outline open seen from the side (KITTI's crowns 25-35 %), inside its size."""
    from blender_sesgen.scene.assets import generate
    gaps = []
    for seed in range(4):
        md = generate("garden_tree", (2.6, 5.2, 1.5), seed)
        leaf = np.isin(md.face_surface, [i for i, s in enumerate(md.surfaces) if s.material == "leaves"])
        F = md.faces[leaf][: leaf.sum() // 2]          # a leaf's kite: (base, right, tip), then (base, tip, left)
        length = np.linalg.norm(md.vertices[F[:, 2]] - md.vertices[F[:, 0]], axis=1)
        assert 0.04 <= length.min() and length.max() <= 0.0961, (seed, length.min(), length.max())
        assert 0.05 <= np.median(length) <= 0.08, (seed, np.median(length))
        assert md.vertices[md.faces[leaf].ravel(), 1].min() > 0.25 * 5.2, seed
        lo, hi = md.vertices.min(axis=0), md.vertices.max(axis=0)
        assert np.all(np.abs([lo[0], hi[0]]) < 1.3 + 0.3) and np.all(np.abs([lo[2], hi[2]]) < 0.75 + 0.3), (lo, hi)
        gaps.append(_side_gap(md))
    assert 0.22 < np.mean(gaps) < 0.40, gaps
