"""Covisibility ground truth (vo_reference/groundtruth/covisibility.py) against a brute-force
ray-cast count: a small scene of boxes, a sphere, a moving box and a wall that hides part of
it, seen by a camera that drives along, turns round and comes back; every frame's depth and
ids are ray cast in closed form (tests/raycast.py) and written as a render folder. For every
pair of frames, both directions: the share of frame i's pixels whose ray-cast point projects
into frame j and has nothing between it and camera j (the independent caster's own test)
equals the product's value, up to the points that land next to a silhouette of frame j (where
the product interpolates j's depth); the files are read back; pruning by tiles changes nothing."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.contract.manifest import object_motion_fields
from vo_reference.errors import VoError
from vo_reference.io.render import RenderSequence
from vo_reference.groundtruth.covisibility import (CovisibilityParams, compute_covisibility, read_covisibility,
                                                write_covisibility)

import raycast as rc
from synthetic_render import write_render

W, H, F = 64, 48, 48.0
K = np.array([[F, 0.0, W / 2 - 0.5], [0.0, F, H / 2 - 0.5], [0.0, 0.0, 1.0]])


def _pose(x, z, yaw_deg, y=1.5):
    """T_world_cam of a level camera at (x, y, z) turned left by yaw (0: looking along -Z)."""
    a = np.radians(yaw_deg)
    Ry = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    T = np.eye(4)
    T[:3, :3] = Ry @ np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = (x, y, z)
    return T


# the drive: along -Z, turning round at the far end, back along +Z on the other side, and a
# last look down the street the way it first went (a loop closure, same direction)
POSES = [_pose(0, 0, 0), _pose(0, -2, 0), _pose(0.5, -4, 20), _pose(1.5, -6, 90), _pose(3, -5, 180),
         _pose(3, -1, 180), _pose(0.2, 0.5, 5)]
N = len(POSES)
MOVER_ID = 7


def _mover_poses():
    """The moving box's pose per frame (it slides along +x)."""
    out = []
    for k in range(N):
        T = np.eye(4)
        T[:3, 3] = (-2.0 + 0.6 * k, 0.6, -7.0)
        out.append(T)
    return np.array(out)


def _prims(k):
    M = _mover_poses()[k]
    return [rc.QuadP(1, np.array([(-20, 0, 10), (20, 0, 10), (20, 0, -30), (-20, 0, -30)], float)),
            rc.BoxP(2, np.array([-3.0, 1.5, -10.0]), (0, 0, 0), np.array([2.0, 3.0, 2.0])),
            rc.BoxP(3, np.array([2.0, 1.0, -9.0]), (0, 25, 0), np.array([1.5, 2.0, 1.5])),
            rc.SphereP(4, np.array([0.0, 1.0, -12.0]), 1.0),
            rc.BoxP(5, np.array([6.0, 2.0, -4.0]), (0, 0, 0), np.array([0.3, 4.0, 6.0])),     # a wall
            rc.BoxP(6, np.array([-1.0, 0.5, -5.0]), (0, 0, 0), np.array([0.6, 1.0, 0.6])),     # hides a little
            rc.Moved(rc.BoxP(MOVER_ID, np.zeros(3), (0, 0, 0), np.array([1.0, 1.2, 1.0])), M)]


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    frames = []
    for k, T in enumerate(POSES):
        depth, ids, _ = rc.render_truth(_prims(k), K, T, W, H)
        frames.append({"left": (np.zeros((H, W, 3), np.float32), depth.astype(np.float32), ids)})
    M = _mover_poses()
    objects = [{"id": i, "name": f"o{i}", "shape": "cuboid", **object_motion_fields()} for i in range(1, 7)]
    objects.append({"id": MOVER_ID, "name": "mover", "shape": "cuboid", **object_motion_fields("keys", M)})
    return write_render(tmp_path_factory.mktemp("covis") / "r", K=K, baseline_m=0.0, T_world_left=np.array(POSES),
                        frames=frames, objects=objects, extra={"fps": 0.5})


def _oracle(i: int, j: int):
    """Per pixel of frame i that sees a surface (row-major): whether its ray-cast point (moved
    with its object to frame j) projects into j (inside the pixel area, in front) and nothing
    of frame j's scene lies between it and camera j; and whether the 2x2 pixels of j around
    its projection are not one plane of one object (a silhouette or a crease: there j's depth,
    which the product interpolates, is not the surface's) or it lands on the image's edge."""
    vv, uu = np.mgrid[0:H, 0:W]
    X, ids = rc.hit_point(_prims(i), K, POSES[i], uu.ravel(), vv.ravel())
    ok = ids > 0
    X, ids = X[ok], ids[ok]
    M = _mover_poses()
    on = ids == MOVER_ID
    X[on] = (X[on] - M[i][:3, 3]) @ M[i][:3, :3] @ M[j][:3, :3].T + M[j][:3, 3]
    Tj = POSES[j]
    Xc = (X - Tj[:3, 3]) @ Tj[:3, :3]
    z = Xc[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = K[0, 0] * Xc[:, 0] / z + K[0, 2]
        v = K[1, 1] * Xc[:, 1] / z + K[1, 2]
    inside = (z > 1e-9) & (u >= -0.5) & (u < W - 0.5) & (v >= -0.5) & (v < H - 0.5)
    vis = inside.copy()
    vis[inside] = rc.visible(_prims(j), Tj, X[inside], eps=1e-6)
    depth_j, ids_j, _ = rc.render_truth(_prims(j), K, Tj, W, H)
    inv = np.where(np.isfinite(depth_j), 1.0 / depth_j, 0.0)
    x0 = np.clip(np.floor(np.nan_to_num(u)), 0, W - 2).astype(int)
    y0 = np.clip(np.floor(np.nan_to_num(v)), 0, H - 2).astype(int)
    a, b, c, d = inv[y0, x0], inv[y0, x0 + 1], inv[y0 + 1, x0], inv[y0 + 1, x0 + 1]
    one_object = np.all([ids_j[y0 + dy, x0 + dx] == ids_j[y0, x0] for dy in (0, 1) for dx in (0, 1)], axis=0)
    flat = one_object & (np.abs(a + d - b - c) <= 1e-6 * np.maximum(np.abs(a) + np.abs(d), 1e-12)) \
        & (np.minimum.reduce([a, b, c, d]) > 0)
    on_border = np.minimum.reduce([np.abs(u + 0.5), np.abs(u - W + 0.5), np.abs(v + 0.5), np.abs(v - H + 0.5)]) < 1e-6
    return vis, (inside & ~flat) | on_border          # on the image's edge: inside or not is a rounding


def _warp_visible(seq, i: int, j: int):
    """The optical flow's own visibility test (groundtruth/flow.py) from frame i to j, per pixel
    of frame i that sees a surface (row-major), its movers moving with the manifest's poses."""
    from vo_reference.groundtruth.flow import object_transforms, sequence_object_poses, warp_depth
    T = seq.T_world_cam()
    Ti, Tj = T[i], T[j]
    w = warp_depth(seq.depth(i), K, np.linalg.inv(Tj) @ Ti, seq.depth(j), ids_src=seq.ids(i),
                   T_tgt_src_by_id=object_transforms(Ti, Tj, sequence_object_poses(seq, i, j)))
    return w.visible[w.valid]


def test_covisibility_equals_a_brute_force_ray_cast_count(render):
    """Every pixel (stride 1), every pair, both directions: the product's share equals the
    ray-cast oracle's but for pixels whose point lands where j's depth is not one plane (a
    silhouette, a crease), which are few; and it is exactly the share the optical flow's
    occlusion test gives (the same rule, another implementation)."""
    seq = RenderSequence(render)
    cov = compute_covisibility(seq, CovisibilityParams(stride=1, threshold=0.01, loop_threshold=0.01,
                                                       min_gap_s=5.0))
    oracle = np.zeros((N, N))
    checked = 0
    for i in range(N):
        for j in range(N):
            if i == j:
                continue
            vis, unsure = _oracle(i, j)
            flow_vis = _warp_visible(seq, i, j)
            n = len(vis)
            assert n == cov.points[i]
            oracle[i, j] = vis.mean()
            got = cov.c(i, j)
            if max(got, vis.mean(), flow_vis.mean()) < 0.01:
                continue                                  # a pair nobody writes
            checked += 1
            assert got == pytest.approx(flow_vis.sum() / n, abs=1e-12), (i, j)
            differ = flow_vis != vis
            assert not np.any(differ & ~unsure), (i, j, int((differ & ~unsure).sum()))
            assert differ.mean() < 0.08, (i, j, differ.mean())
    assert checked >= 12
    # the scene is built so that these hold: a revisit, an occlusion, both directions differ
    assert oracle[6, 0] > 0.6 and cov.c(6, 0) > 0.6               # the last frame sees the first place again
    assert abs(oracle[0, 3] - oracle[3, 0]) > 0.05                 # not symmetric
    assert oracle[0, 4] < 0.3                                      # turned round: little in common


def test_a_stride_samples_the_same_rule(render):
    seq = RenderSequence(render)
    full = compute_covisibility(seq, CovisibilityParams(stride=1, threshold=0.01, loop_threshold=0.01))
    coarse = compute_covisibility(seq, CovisibilityParams(stride=3, threshold=0.01, loop_threshold=0.01))
    assert coarse.points[0] < full.points[0] / 6
    for i in range(N):
        for j in range(N):
            assert abs(coarse.c(i, j) - full.c(i, j)) < 0.08, (i, j)


def test_files_read_back_and_loop_closures_list_the_revisits(render, tmp_path):
    seq = RenderSequence(render)
    p = CovisibilityParams(stride=2, threshold=0.05, loop_threshold=0.3, min_gap_s=5.0)
    cov = compute_covisibility(seq, p)
    out = write_covisibility(render, cov)
    assert out == render / "covisibility" and (out / "pairs.csv").is_file()
    back = read_covisibility(render)
    assert back.params == p
    assert np.allclose(back.pairs, cov.pairs, atol=1e-6)
    lc = back.loop_closures
    t = back.timestamps_s
    assert len(lc) and all(t[q] - t[m] >= 5.0 for q, m in lc)
    assert (6, 0) in {tuple(x) for x in lc}
    for q, m in lc:
        assert back.c(q, m) >= 0.3
    # every written pair holds the threshold in one direction at least
    assert np.all(np.maximum(back.pairs[:, 2], back.pairs[:, 3]) >= 0.05)
    with pytest.raises(VoError, match="below"):
        back.positives(threshold=0.01)


def test_tile_pruning_changes_nothing(render):
    seq = RenderSequence(render)
    a = compute_covisibility(seq, CovisibilityParams(stride=2, threshold=0.01, loop_threshold=0.01, tiles=(1, 1)))
    b = compute_covisibility(seq, CovisibilityParams(stride=2, threshold=0.01, loop_threshold=0.01, tiles=(16, 12)))
    assert np.array_equal(a.pairs, b.pairs)


def test_bad_input_is_one_clear_error(render, tmp_path):
    with pytest.raises(VoError):
        CovisibilityParams(stride=0)
    with pytest.raises(VoError, match="view"):
        compute_covisibility(RenderSequence(render), CovisibilityParams(view="right"))
    with pytest.raises(VoError, match="compute it"):
        read_covisibility(tmp_path)
    d = tmp_path / "covisibility"
    d.mkdir()
    (d / "covisibility.json").write_text('{"format": "something else"}')
    with pytest.raises(VoError, match="not a"):
        read_covisibility(tmp_path)


def test_a_selection_of_stretches_gives_the_same_pairs(render, tmp_path):
    """``--frames 0:3,5:7``: the pairs among the chosen frames are the whole sequence's, and
    the files say which frames were computed."""
    import shutil
    from vo_reference.commands.main import main as vo
    whole = compute_covisibility(RenderSequence(render), CovisibilityParams(stride=2, threshold=0.05))
    r = tmp_path / "r"
    shutil.copytree(render, r)
    assert vo(["covisibility", str(r), "--stride", "2", "--frames", "0:3,5:7", "-q"]) == 0
    back = read_covisibility(r)
    chosen = [0, 1, 2, 5, 6]
    assert back.frames.tolist() == chosen
    expected = [row for row in whole.pairs if int(row[0]) in chosen and int(row[1]) in chosen]
    assert np.allclose(back.pairs, np.array(expected).reshape(-1, 4), atol=1e-6)
