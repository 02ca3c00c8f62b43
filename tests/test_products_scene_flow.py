"""Optical flow, scene flow, occlusion, motion masks and disparity change with moving
objects, against the analytic ray-cast oracle (tests/raycast.py) at pixel centres.

The oracle never uses the products' code: it casts each pixel centre's ray into the
frame-k scene, carries the hit point with its object's rigid motion (built with scipy in
tests/dynamic_scene.py), projects it into the target camera and asks the ray caster
whether anything of the target-frame scene lies in front of it.
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import dynamic_scene as ds
import raycast

from vo_reference.io.render import RenderSequence
from vo_reference.products.flow import flow_from_depth, sequence_flow
from vo_reference.products.scene_flow import (
    motion_mask, moving_objects_mask, scene_flow_from_depth, sequence_scene_flow)

GOLDEN = Path(__file__).resolve().parent / "golden" / "static_flow.npz"


@pytest.fixture(scope="module")
def scene():
    return ds.make_scene()


@pytest.fixture(scope="module")
def seq(scene, tmp_path_factory):
    return RenderSequence(ds.write(tmp_path_factory.mktemp("dyn") / "render", scene))


def _oracle(scene, k, kt):
    """Per pixel centre of frame k: expected flow (H, W, 2), scene flow (H, W, 3), target depth,
    ids, in-image flag and visibility of the moved point in frame kt."""
    vv, uu = np.mgrid[0:ds.H, 0:ds.W].astype(float)
    X, ids = raycast.hit_point(scene.prims(k), ds.K, scene.T_left[k], uu, vv)
    hit = np.isfinite(X).all(axis=1)
    Xm = X.copy()
    for obj_id, M in scene.M.items():
        on = hit & (ids == obj_id)
        step = M[kt] @ np.linalg.inv(M[k])
        Xm[on] = X[on] @ step[:3, :3].T + step[:3, 3]
    Tc = np.linalg.inv(scene.T_left[kt])
    Xc = Xm @ Tc[:3, :3].T + Tc[:3, 3]
    with np.errstate(invalid="ignore", divide="ignore"):
        u = ds.K[0, 0] * Xc[:, 0] / Xc[:, 2] + ds.K[0, 2]
        v = ds.K[1, 1] * Xc[:, 1] / Xc[:, 2] + ds.K[1, 2]
    flow = np.stack([u - uu.ravel(), v - vv.ravel()], axis=1)
    sf = (Xm - X) @ scene.T_left[k][:3, :3]          # world motion in camera-k axes: R^T (X' - X)
    inside = hit & (Xc[:, 2] > 0) & (u >= -0.5) & (u < ds.W - 0.5) & (v >= -0.5) & (v < ds.H - 0.5)
    vis = np.zeros(len(X), bool)
    vis[inside] = raycast.visible(scene.prims(kt), scene.T_left[kt], Xm[inside])
    shape = (ds.H, ds.W)
    return (flow.reshape(*shape, 2), sf.reshape(*shape, 3), Xc[:, 2].reshape(shape), ids.reshape(shape),
            hit.reshape(shape), inside.reshape(shape), vis.reshape(shape), u.reshape(shape), v.reshape(shape))


def _near_edge(ids_tgt, u, v, radius=1.0):
    x0, x1 = int(np.floor(u - radius)), int(np.ceil(u + radius))
    y0, y1 = int(np.floor(v - radius)), int(np.ceil(v + radius))
    patch = ids_tgt[max(y0, 0):min(y1, ds.H - 1) + 1, max(x0, 0):min(x1, ds.W - 1) + 1]
    return len(np.unique(patch)) > 1


@pytest.mark.parametrize("k, kt", [(0, 1), (1, 2), (1, 0), (2, 1)], ids=["fw01", "fw12", "bw10", "bw21"])
def test_flow_scene_flow_and_disparity_change_match_the_oracle(scene, seq, k, kt):
    sf = sequence_scene_flow(seq, k, kt)
    flow, s3, z_t, ids, hit, inside, vis, _, _ = _oracle(scene, k, kt)
    assert np.array_equal(sf.valid, hit)
    assert np.abs(sf.flow[hit] - flow[hit]).max() <= 1e-4                        # px
    assert np.abs(sf.scene_flow[hit] - s3[hit]).max() <= 1e-5                    # m
    front = hit & (z_t > 0)
    assert np.abs(sf.depth_tgt[front] / z_t[front] - 1).max() <= 1e-6
    fB = ds.K[0, 0] * ds.BASELINE
    assert np.abs(sf.disparity_tgt(ds.K[0, 0], ds.BASELINE)[front] - fB / z_t[front]).max() <= 1e-4
    z_s = seq.depth(k)
    dd = sf.disparity_change(z_s, ds.K[0, 0], ds.BASELINE)
    assert np.abs(dd[front] - (fB / z_t[front] - fB / z_s[front])).max() <= 1e-4
    # the movers' pixels: scene flow non-zero, and the static-scene flow would be wrong by pixels
    assert np.array_equal(sf.dynamic, hit & np.isin(ids, [3, 4]))
    assert sf.dynamic.sum() > 300
    assert np.all(sf.scene_flow[hit & ~sf.dynamic] == 0)
    assert np.median(np.linalg.norm(sf.scene_flow[sf.dynamic], axis=1)) > 0.2
    static = flow_from_depth(z_s, seq.K, seq.T_world_cam()[k], seq.T_world_cam()[kt])
    assert np.median(np.linalg.norm(static.flow[sf.dynamic] - sf.flow[sf.dynamic], axis=1)) > 2.0


@pytest.mark.parametrize("k, kt", [(0, 1), (2, 1)], ids=["fw01", "bw21"])
def test_dense_layouts_move_the_movers_too(scene, seq, k, kt):
    """The dense products of the TartanAir / vKITTI 2 / SceneFlow exports (flow for every
    pixel, disparity change) agree with the oracle on the movers."""
    from vo_reference.products.dense_gt import dense_flow, disparity_change
    flow, _, z_t, _, hit, _, _, _, _ = _oracle(scene, k, kt)
    fl = dense_flow(seq, k, kt)
    assert np.abs(fl.flow[hit] - flow[hit]).max() <= 1e-4
    fB = ds.K[0, 0] * ds.BASELINE
    dd = disparity_change(seq, k, kt)
    front = hit & (z_t > 0)
    assert np.abs(dd[front] - (fB / z_t[front] - fB / seq.depth(k)[front])).max() <= 1e-4


@pytest.mark.parametrize("k, kt", [(0, 1), (1, 0), (1, 2)], ids=["fw01", "bw10", "fw12"])
def test_occlusion_accounts_for_moving_objects(scene, seq, k, kt):
    sf = sequence_scene_flow(seq, k, kt)
    _, _, _, ids, hit, inside, vis, u, v = _oracle(scene, k, kt)
    ids_t = ds.truth(scene, kt)[1]
    checked = hidden = hidden_by_or_on_movers = 0
    for y, x in zip(*np.nonzero(hit)):
        if inside[y, x] and _near_edge(ids_t, u[y, x], v[y, x]):
            continue  # a depth map cannot decide closer than a pixel from an edge
        truth = (not inside[y, x]) or (not vis[y, x])
        assert bool(sf.occluded[y, x]) == truth, (y, x, truth)
        assert bool(sf.out_of_image[y, x]) == (not inside[y, x])
        checked += 1
        if inside[y, x] and not vis[y, x]:
            hidden += 1
            uu, vv = int(round(u[y, x])), int(round(v[y, x]))
            hidden_by_or_on_movers += ids[y, x] in (3, 4) or ids_t[min(vv, ds.H - 1), min(uu, ds.W - 1)] in (3, 4)
    assert checked > 0.8 * hit.sum()
    assert hidden > 15 and hidden_by_or_on_movers > 15   # occlusions the objects' motion causes


def test_motion_masks(scene, seq):
    ids0 = seq.ids(0)
    assert np.array_equal(motion_mask(seq, 0, 1), np.isin(ids0, [3, 4]))
    assert np.array_equal(moving_objects_mask(seq, 0), np.isin(ids0, [3, 4]))
    assert seq.moving_ids == (3, 4) and seq.T_world_obj(1) is None
    np.testing.assert_array_equal(seq.T_world_obj(3), scene.T_world_obj[3])


def test_static_pixels_take_the_static_path_to_the_bit(seq):
    """In a scene with movers, every pixel of a static object gets the bits of the static computation."""
    k, kt = 0, 1
    z_s, z_t, ids = seq.depth(k), seq.depth(kt), seq.ids(k)
    T = seq.T_world_cam()
    objs = {i: (seq.T_world_obj(i)[k], seq.T_world_obj(i)[kt]) for i in seq.moving_ids}
    dyn = flow_from_depth(z_s, seq.K, T[k], T[kt], z_t, ids_src=ids, object_poses=objs)
    sta = flow_from_depth(z_s, seq.K, T[k], T[kt], z_t)
    still = ~np.isin(ids, [3, 4])
    assert np.array_equal(dyn.flow[still], sta.flow[still], equal_nan=True)
    assert np.array_equal(dyn.occluded[still], sta.occluded[still])
    sf = scene_flow_from_depth(z_s, seq.K, T[k], T[kt], ids_src=ids, object_poses=objs, depth_tgt=z_t)
    assert sf.flow.tobytes() == dyn.flow.tobytes() and np.array_equal(sf.occluded, dyn.occluded)


def test_static_scene_products_unchanged_to_the_bit(tmp_path):
    """Flow, occlusion and disparity of a static scene are those of the code before moving
    objects existed (tests/golden/make_static_flow.py wrote them with commit 9808421)."""
    spec = importlib.util.spec_from_file_location("make_static_flow", GOLDEN.parent / "make_static_flow.py")
    make_static_flow = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_static_flow)
    products = make_static_flow.products
    root = ds.write(tmp_path / "static", ds.make_scene(static=True), moving=False)
    now = products(RenderSequence(root))
    golden = np.load(GOLDEN)
    assert set(now) == set(golden.files)
    for name in golden.files:
        assert now[name].dtype == golden[name].dtype and now[name].tobytes() == golden[name].tobytes(), name
    # and the scene-flow path gives the same flow and occlusion bits there
    seq = RenderSequence(root)
    sf = sequence_scene_flow(seq, 0, 1)
    assert sf.flow.tobytes() == golden["flow_0_1"].tobytes() and np.array_equal(sf.occluded, golden["occluded_0_1"])
    assert not sf.dynamic.any() and np.all(sf.scene_flow[sf.valid] == 0)


def test_sequence_flow_moves_the_movers(seq):
    f = sequence_flow(seq, 0, 1)
    sf = sequence_scene_flow(seq, 0, 1)
    assert f.flow.tobytes() == sf.flow.tobytes()


def test_a_manifest_without_moving_objects_reads_as_static(tmp_path, scene):
    root = ds.write(tmp_path / "old", scene, moving=False)
    seq = RenderSequence(root)
    assert seq.moving_ids == () and seq.T_world_obj(3) is None
    assert not sequence_scene_flow(seq, 0, 1).dynamic.any()


def test_bad_object_poses_in_the_manifest(tmp_path, scene):
    import json
    from vo_reference.errors import VoError
    root = ds.write(tmp_path / "bad", scene)
    m = json.loads((root / "manifest.json").read_text())
    m["objects"][2]["T_world_obj"] = m["objects"][2]["T_world_obj"][:2]
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(VoError, match=r"T_world_obj has shape \(2, 4, 4\), expected \(3, 4, 4\)"):
        RenderSequence(root)
