"""Rendered procedural assets keep exact ground truth: depth and ids at pixel centres equal
an independent ray cast against the asset's own triangles (blender_sesgen.scene.assets, placed
by the contract's object pose), on a small street scene with a curved road, a kerb, a
building, a car, a sign on its pole, a street light and a bush of thousands of leaves."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.scene import assets
from blender_sesgen.contract.frames import object_pose
from blender_sesgen.ses import parse_file

import mesh_raycast
from render_support import cli_in_process, depth_and_ids, load_manifest, read_exr
from markers import needs

pytestmark = [pytest.mark.render, needs("bpy")]
pytest.importorskip("OpenEXR")

SCRIPT = """CAMERA resolution 112 84 focal 84 baseline 0.3
START position 1.2 1.6 7 -6 8 0
ASSET road id 1 seed 1 position 0 0 12 size 7 0.3 30 bend 4 8
ASSET kerb id 2 seed 2 position 0 0 12 size 0.2 0.13 30 bend 4 8 offset 3.55
ASSET building id 3 seed 5 position -8 0 -6 0 80 0 size 12 10 8
ASSET car id 4 seed 9 position 1.2 0 1 0 170 0
ASSET pole id 5 position -2.9 0.13 2.5 size 0.076 2.7 0.076
ASSET sign id 6 seed 3 position -2.9 0.13 2.57 size 0.7 2.4 0.025
ASSET streetlight id 7 seed 4 position 4.4 0.13 -2 0 180 0
ASSET bush id 8 seed 6 position 3.6 0.13 0.5 size 1.4 1.2 1.2
EGO 0.05 0 -0.4 0 1.5 0
"""


def _truth(scene, K, T_world_cam, W, H):
    ts = mesh_raycast.TriangleScene()
    for o in scene.objects:
        d = assets.generate(o.kind, o.size, o.seed, o.bend, o.offset)
        ts.add(o.id, d.vertices, d.faces, object_pose(o.position, o.rotation_deg))
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    pix = np.column_stack([u.ravel(), v.ravel()])
    o, d, cos = mesh_raycast.pinhole_rays(K, T_world_cam, pix)
    t, ids = ts.cast(o, d)
    # an edge within 2e-3 px of a pixel centre (a silhouette, or a step between two faces of
    # one asset): the id or the depth jumps when the ray moves that much. Only pixels whose
    # 8 neighbours differ in id or in depth by > 0.3 % can be such pixels.
    img, z = ids.reshape(H, W), (t * cos).reshape(H, W)
    pad_i, pad_z = np.pad(img, 1, mode="edge"), np.pad(z, 1, mode="edge")
    cand = np.zeros((H, W), bool)
    with np.errstate(invalid="ignore"):
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                zi = pad_z[1 + dy:1 + dy + H, 1 + dx:1 + dx + W]
                cand |= (pad_i[1 + dy:1 + dy + H, 1 + dx:1 + dx + W] != img) | (np.abs(zi - z) > 3e-3 * z)
    cand = cand.ravel()
    near = np.zeros(len(pix), bool)
    for du, dv in ((2e-3, 0), (-2e-3, 0), (0, 2e-3), (0, -2e-3)):
        o2, d2, cos2 = mesh_raycast.pinhole_rays(K, T_world_cam, pix[cand] + (du, dv))
        t2, ids2 = ts.cast(o2, d2)
        with np.errstate(invalid="ignore"):
            jump = (ids2 != ids[cand]) | ~(np.abs(t2 * cos2 - (t * cos)[cand]) <= 5e-4 * (t * cos)[cand])
        near[np.flatnonzero(cand)[jump & (ids[cand] > 0) | (ids2 != ids[cand])]] = True
    return z, img, near.reshape(H, W)


def test_asset_depth_and_ids_match_ray_casting_their_meshes(tmp_path):
    script = tmp_path / "assets.ses"
    script.write_text(SCRIPT)
    out = tmp_path / "out"
    r = cli_in_process("blender_sesgen", "render", script, "--out", out, "--samples", "1", "--quiet")
    assert r.returncode == 0, r.stderr
    m = load_manifest(out)
    W, H = m["resolution"]
    scene = parse_file(script)
    K = np.array(m["K"])
    seen = set()
    for view in m["views"]:
        for k in range(m["frames"]):
            depth, ids = depth_and_ids(read_exr(out / m["files"][view][k]), m)
            z_true, id_true, near = _truth(scene, K, np.array(m["poses"][view][k]), W, H)
            bad = (ids != id_true) & ~near
            assert bad.sum() == 0, f"{view} {k}: {bad.sum()} id mismatches at {np.argwhere(bad)[:5].tolist()}"
            hit = (id_true > 0) & ~near
            rel = np.abs(depth - z_true) / np.where(hit, z_true, 1.0)
            assert rel[hit].max() <= 2e-4, f"{view} {k}: max rel depth error {rel[hit].max():.2e}"
            assert np.all(depth[(id_true == 0) & ~near] == m["depth"]["background"])
            seen |= set(np.unique(id_true[hit]).tolist())
    assert seen == {1, 2, 3, 4, 5, 6, 7, 8}, seen


def test_asset_meshes_hold_the_generators_triangles_surfaces_and_smooth_flags():
    """Asset meshes are written through the mesh's attribute arrays: read back through the
    element properties (Blender's other path to them), they hold the generator's vertices,
    triangles, each triangle's surface and smooth flag, and the edges of those triangles."""
    import bpy
    from blender_sesgen.blender.assets import mesh_from_triangles
    d = assets.generate("bush", (1.2, 1.0, 1.1), 4)       # smooth stems, flat leaves, 5 surfaces
    assert d.smooth.any() and not d.smooth.all() and len(d.surfaces) > 2
    me = mesh_from_triangles("sesgen_test_bush", d.vertices, d.faces, lambda x: x, d.face_surface, d.smooth)
    try:
        nv, nf = len(d.vertices), len(d.faces)
        assert len(me.vertices) == nv and len(me.polygons) == nf

        def read(elements, prop, n, dtype):
            out = np.empty(n, dtype)
            getattr(me, elements).foreach_get(prop, out)
            return out
        assert np.array_equal(read("vertices", "co", 3 * nv, np.float32), d.vertices.astype(np.float32).ravel())
        assert np.array_equal(read("loops", "vertex_index", 3 * nf, np.int32), d.faces.ravel())
        assert np.array_equal(read("polygons", "loop_total", nf, np.int32), np.full(nf, 3))
        assert np.array_equal(read("polygons", "material_index", nf, np.int32), d.face_surface)
        assert np.array_equal(read("polygons", "use_smooth", nf, bool), d.smooth)
        edges = {tuple(sorted(e)) for f in d.faces.tolist() for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
        assert {tuple(sorted(e)) for e in read("edges", "vertices", 2 * len(me.edges), np.int32).reshape(-1, 2).tolist()} \
            == edges and len(me.edges) == len(edges)
        assert not me.validate()                            # nothing for Blender to repair
    finally:
        bpy.data.meshes.remove(me)
