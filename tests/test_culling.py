"""Culling (blender_sesgen/render/culling.py): the bounds contain every object's real geometry, and
the objects a chunk keeps contain everything a pixel ray of its frames can hit -- checked by
casting rays through the pixels of sampled frames of a generated city against the full set of
objects (their exact triangles, tests/mesh_raycast.py). Shaded presets keep the sun's shadow
casters, the sensor path the objects its shutter sees moving; the default lighting refuses."""
from __future__ import annotations

import zlib
import numpy as np
import pytest

from blender_sesgen.scene import assets
from blender_sesgen.render import culling
from blender_sesgen.contract.frames import object_pose
from blender_sesgen.errors import SesgenError
from blender_sesgen.generators.builtin.city_grid import generate as city_grid
from blender_sesgen.scene.model import Asset, Cuboid, Cylinder, Quad, Sphere
from blender_sesgen.render.plan import RenderOptions, RenderPlan
from blender_sesgen.ses import parse_string

import mesh_raycast


def _inside(box: culling.Box, V_world: np.ndarray, tol=1e-9) -> bool:
    local = (V_world - box.T_world[:3, 3]) @ box.T_world[:3, :3]
    return bool(np.all(local >= box.lo - tol) and np.all(local <= box.hi + tol))


@pytest.mark.parametrize("kind", sorted(assets.KINDS))
def test_an_assets_box_holds_every_vertex_at_any_size(kind):
    k = assets.KINDS[kind]
    rng = np.random.default_rng(zlib.crc32(kind.encode()))   # not hash(): it changes with every process
    tall_and_thin = tuple(0.6 * lo if i != 1 else 1.6 * hi for i, (lo, hi) in enumerate(k.size_ranges))
    for i in range(4):
        seed = int(rng.integers(1, 10 ** 6))
        size = assets.default_size(kind, seed) if i == 0 else tall_and_thin if i == 3 else \
            tuple(float(rng.uniform(0.6 * lo, 1.6 * hi)) for lo, hi in k.size_ranges)
        bend = tuple(rng.uniform(-25, 25, int(rng.integers(1, 5)))) if k.strip else (0.0,)
        offset = float(rng.uniform(-6, 6)) if k.strip else 0.0
        d = assets.generate(kind, size, seed, bend, offset)
        lo, hi = culling.asset_local_box(kind, size, bend, offset)
        assert np.all(d.vertices >= lo - 1e-9) and np.all(d.vertices <= hi + 1e-9), (kind, size, seed, d.bounds, lo, hi)


def test_primitive_boxes_hold_their_shapes(tmp_path):
    rng = np.random.default_rng(0)
    for _ in range(20):
        pos, rot = tuple(rng.uniform(-5, 5, 3)), tuple(rng.uniform(-180, 180, 3))
        T = object_pose(pos, rot)
        size = tuple(rng.uniform(0.1, 4, 3))
        c = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * np.array(size) / 2
        assert _inside(culling.object_box(Cuboid(id=1, name="c", position=pos, rotation_deg=rot, size=size)),
                       c @ T[:3, :3].T + T[:3, 3], 1e-9)
        r, h = float(rng.uniform(0.1, 2)), float(rng.uniform(0.1, 3))
        a = rng.uniform(0, 2 * np.pi, 50)
        cyl = np.column_stack([r * np.cos(a), rng.uniform(-h / 2, h / 2, 50), r * np.sin(a)])
        assert _inside(culling.object_box(Cylinder(id=2, name="y", position=pos, rotation_deg=rot, radius=r, height=h)),
                       cyl @ T[:3, :3].T + T[:3, 3], 1e-9)
        u = rng.normal(size=(50, 3))
        sph = r * u / np.linalg.norm(u, axis=1, keepdims=True) + pos
        assert _inside(culling.object_box(Sphere(id=3, name="s", position=pos, rotation_deg=rot, radius=r)), sph, 1e-9)
    V = rng.uniform(-3, 3, (4, 3))
    assert _inside(culling.object_box(Quad(id=4, name="q", vertices=tuple(map(tuple, V)))), V)
    obj = tmp_path / "m.obj"
    obj.write_text("v 0 0 0\nv 2 1 0\nv 0 3 -1\nf 1 2 3\n")
    s = parse_string(f"MESH id 5 file {obj.name} position 1 0 0 0 30 0 scale 2\n", source=str(tmp_path / "a.ses"),
                     base_dir=str(tmp_path))
    b = culling.object_box(s.objects[0])
    T = object_pose((1, 0, 0), (0, 30, 0))
    Vm = np.array([(0, 0, 0), (2, 1, 0), (0, 3, -1)], float) * 2
    assert _inside(b, Vm @ T[:3, :3].T + T[:3, 3], 1e-9)


@pytest.fixture(scope="module")
def city():
    """A small generated city (one loop closure, two moving cars) and its plan at KITTI's size."""
    gen = city_grid
    text = gen(3, route_m=220.0, closures=1, traffic=2, blocks=2)
    scene = parse_string(text, source="city.ses")
    return scene, text


def _triangles(scene, ids=None):
    """Every object's exact triangles in the world (assets through their generator)."""
    ts = mesh_raycast.TriangleScene(leaf=4096)
    cache = {}
    for o in scene.objects:
        if ids is not None and o.id not in ids:
            continue
        if isinstance(o, Asset):
            key = (o.kind, o.size, o.seed, o.bend, o.offset)
            if key not in cache:
                cache[key] = assets.generate(o.kind, o.size, o.seed, o.bend, o.offset)
            d = cache[key]
            ts.add(o.id, d.vertices, d.faces, object_pose(o.position, o.rotation_deg))
        elif isinstance(o, Cuboid):
            h = np.asarray(o.size) / 2
            V = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h
            ts.add(o.id, V, mesh_raycast_box_faces(), object_pose(o.position, o.rotation_deg))
        elif isinstance(o, Quad):
            ts.add(o.id, np.array(o.vertices), np.array([(0, 1, 2), (0, 2, 3)]))
    return ts


def mesh_raycast_box_faces():
    return np.array([(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
                     (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)])


@pytest.mark.slow
def test_a_chunk_keeps_every_object_its_pixels_see(city):
    """Rays through pixel centres (a grid and the whole border) of sampled frames, cast
    against the full set of objects, only hit objects of the chunk's culled set; and the
    set is much smaller than the world (the test can fail both ways)."""
    scene, text = city
    plan = RenderPlan.from_scene(scene, RenderOptions(quality="gt", cull=True), scene_text=text)
    T_all = plan.view_poses
    K = np.array(plan.settings.K)
    W, H = plan.settings.width, plan.settings.height
    us, vs = np.linspace(0, W - 1, 40), np.linspace(0, H - 1, 12)
    grid = np.array([(u, v) for v in vs for u in us])
    border = np.concatenate([np.column_stack([us, np.zeros_like(us)]), np.column_stack([us, np.full_like(us, H - 1)]),
                             np.column_stack([np.zeros_like(vs), vs]), np.column_stack([np.full_like(vs, W - 1), vs])])
    pix = np.concatenate([grid, border])
    moving = {m.id: m.poses() for m in scene.object_motions}
    ts = _triangles(scene, ids={o.id for o in scene.objects} - set(moving))    # movers checked below
    far = scene.rig.far
    n = scene.frames
    chunk = 20
    kept_share, hits = [], 0
    for a in (0, n // 3, (2 * n) // 3, n - chunk):
        res = culling.visible_objects(plan, range(a, a + chunk))
        kept_share.append(len(res.keep) / res.total)
        for k in (a, a + chunk // 2, a + chunk - 1):
            for view in plan.views:
                o, d, cos = mesh_raycast.pinhole_rays(K, T_all[view][k], pix)
                t, ids = ts.cast(o, d)
                seen = set(ids[np.isfinite(t) & (t * cos <= far)].tolist())     # Cycles clips at far
                hits += len(seen)
                missing = seen - res.keep
                assert not missing, (a, k, view, sorted(missing)[:10])
    assert hits > 50
    assert max(kept_share) < 0.8, kept_share            # culling does cull
    # moving cars: in the set whenever their box is in view at one of the chunk's frames
    for mid, P in moving.items():
        for a in (0, n - chunk):
            res = culling.visible_objects(plan, range(a, a + chunk))
            pts = P[a:a + chunk, :3, 3]
            cam = T_all["left"][a:a + chunk]
            local = np.einsum("nji,nj->ni", cam[:, :3, :3], pts - cam[:, :3, 3])
            ahead = (local[:, 2] > 2) & (local[:, 2] < 100) & (np.abs(local[:, 0]) < 0.5 * local[:, 2])
            if ahead.any():
                assert mid in res.keep


def test_shaded_presets_keep_the_suns_shadow_casters():
    """A tall tower behind the camera whose shadow (low sun ahead) falls into view: kept
    for a shaded preset, left out for gt (flat shading has no shadows)."""
    text = ("CAMERA resolution 64 48 focal 50 far 200\nWORLD sky elevation 12 azimuth 180\n"
            "START position 0 1.5 0\nQUAD id 1 vertices -100 0 50  100 0 50  100 0 -150  -100 0 -150\n"
            "CUBOID id 2 position 0 15 90 dim 4 30 4\n"        # 90 m behind, 30 m tall: shadow ~140 m long
            "CUBOID id 3 position 0 15 -400 dim 4 30 4\n")     # beyond the far plane, no shadow into view
    s = parse_string(text, source="t.ses")
    gt = culling.visible_objects(RenderPlan.from_scene(s, RenderOptions(quality="gt", cull=True)), [0])
    shaded = culling.visible_objects(RenderPlan.from_scene(s, RenderOptions(quality="draft", cull=True)), [0])
    assert gt.keep == {1} and 2 in shaded.keep and 3 not in shaded.keep and shaded.shadow == 1


def test_the_sensor_path_keeps_what_its_shutter_sees_move():
    """A ball passing the camera's view only between frames 0 and 1 (a fast twist): the
    plain path (sharp frames) leaves it out, motion blur (the shutter open around each
    frame) keeps it."""
    base = ("CAMERA resolution 64 48 focal 50 far 100\nWORLD colour 0.5 0.5 0.5\nSTART position 0 1 0\n"
            "FRAMES 2\nQUAD id 1 vertices -50 0 50  50 0 50  50 0 -50  -50 0 -50\n"
            "SPHERE id 2 position -40 1 -10 dim 0.5\nMOVE id 2 twist 80 0 0 0 0 0\n")
    plain = culling.visible_objects(RenderPlan.from_scene(parse_string(base, source="a.ses"),
                                                          RenderOptions(quality="gt", cull=True)), [0, 1])
    blur = parse_string(base + "TIMING rate 25 exposure 0.04\n", source="b.ses")
    shutter = culling.visible_objects(RenderPlan.from_scene(blur, RenderOptions(quality="gt", cull=True)), [0, 1])
    assert 2 not in plain.keep and 2 in shutter.keep


def test_default_lighting_cannot_be_culled():
    s = parse_string("CUBOID id 1 position 0 0 -5 dim 1 1 1\n", source="t.ses")
    with pytest.raises(SesgenError, match="--cull needs"):
        RenderPlan.from_scene(s, RenderOptions(cull=True))
    assert RenderPlan.from_scene(s, RenderOptions()).settings.cull is False


def test_the_manifest_says_a_render_was_culled_and_resume_keeps_to_it():
    from blender_sesgen.render.folder import OutputFolder
    s = parse_string("CAMERA resolution 64 48 focal 50\nWORLD colour 0.5 0.5 0.5\nCUBOID id 1 position 0 0 -5 "
                     "dim 1 1 1\n", source="t.ses")
    culled = RenderPlan.from_scene(s, RenderOptions(quality="gt", cull=True)).settings
    plain = RenderPlan.from_scene(s, RenderOptions(quality="gt")).settings
    assert "culling" in culled.manifest_block() and "culling" not in plain.manifest_block()
    assert "exact" in culled.manifest_block()["culling"]
    manifest = {"render": plain.manifest_block(), "resolution": [plain.width, plain.height]}
    assert OutputFolder.same_settings(manifest, plain) and not OutputFolder.same_settings(manifest, culled)
