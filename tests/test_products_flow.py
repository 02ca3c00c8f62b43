"""Optical flow and occlusion ground truth against independent oracles.

- flow endpoints: a per-pixel loop back-projects and re-projects in float64;
- occlusion: a scene of random rectangles ray-cast exactly; a pixel is visible in the
  target view iff the segment from the target camera centre to its 3-D point crosses no
  rectangle (brute force over pixels and rectangles) and it projects inside the image.
"""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.errors import VoError
from blender_sesgen.contract.se3 import se3_exp
from vo_reference.products.flow import (
    flow_from_depth, read_flo, read_kitti_flow_png, stereo_occlusion, write_flo, write_kitti_flow_png)

W, H = 48, 36
K = np.array([[40.0, 0.0, 23.5], [0.0, 42.0, 17.5], [0.0, 0.0, 1.0]])


def _random_pose(rng, rot=0.15, trans=0.4):
    return se3_exp(rng.normal(0, rot, 3), rng.normal(0, trans, 3))


def test_flow_ends_at_the_exact_projection(tmp_path):
    rng = np.random.default_rng(0)
    for trial in range(5):
        depth = rng.uniform(0.5, 20.0, (H, W)).astype(np.float32)
        depth[rng.random((H, W)) < 0.1] = np.inf
        T_w_s, T_w_t = _random_pose(rng), _random_pose(rng)
        fl = flow_from_depth(depth, K, T_w_s, T_w_t)
        T_t_s = np.linalg.inv(T_w_t) @ T_w_s
        n_checked = 0
        for y in range(H):
            for x in range(W):
                z = float(depth[y, x])
                if not np.isfinite(z):
                    assert not fl.valid[y, x] and np.all(np.isnan(fl.flow[y, x]))
                    continue
                # independent: ray through the pixel centre scaled to planar depth z
                Xc = np.array([(x - K[0, 2]) / K[0, 0] * z, (y - K[1, 2]) / K[1, 1] * z, z, 1.0])
                Xt = T_t_s @ Xc
                if Xt[2] <= 0:
                    assert fl.out_of_image[y, x]
                    continue
                ut = K[0, 0] * Xt[0] / Xt[2] + K[0, 2]
                vt = K[1, 1] * Xt[1] / Xt[2] + K[1, 2]
                assert fl.valid[y, x]
                assert abs(x + fl.flow[y, x, 0] - ut) <= 1e-4 and abs(y + fl.flow[y, x, 1] - vt) <= 1e-4
                inside = -0.5 <= ut < W - 0.5 and -0.5 <= vt < H - 0.5
                assert fl.out_of_image[y, x] == (not inside)
                n_checked += 1
        assert n_checked > 0.5 * W * H


# --- an analytic scene: rectangles in front of a back wall ------------------------------

class Rects:
    def __init__(self, rng, n=6):
        self.c, self.a, self.b, self.ha, self.hb = [], [], [], [], []
        # back wall, fronto-parallel-ish, huge
        self._add(np.array([0, 0, 12.0]), np.array([1.0, 0, 0.1]), np.array([0, 1.0, 0]), 40, 40)
        for _ in range(n):
            c = np.array([rng.uniform(-2.5, 2.5), rng.uniform(-2, 2), rng.uniform(3, 9)])
            R = se3_exp(rng.normal(0, 0.5, 3), np.zeros(3))[:3, :3]
            self._add(c, R[:, 0], R[:, 1], rng.uniform(0.4, 1.5), rng.uniform(0.4, 1.5))

    def _add(self, c, a, b, ha, hb):
        a = a / np.linalg.norm(a)
        b = b - a * (a @ b)
        b = b / np.linalg.norm(b)
        self.c.append(c), self.a.append(a), self.b.append(b), self.ha.append(ha), self.hb.append(hb)

    def hits(self, o, d):
        """Ray parameters t (o + t·d) of every rectangle hit, inf where missed."""
        ts = []
        for c, a, b, ha, hb in zip(self.c, self.a, self.b, self.ha, self.hb):
            n = np.cross(a, b)
            den = d @ n
            if abs(den) < 1e-12:
                ts.append(np.inf)
                continue
            t = ((c - o) @ n) / den
            p = o + t * d - c
            ts.append(t if t > 0 and abs(p @ a) <= ha and abs(p @ b) <= hb else np.inf)
        return np.array(ts)

    def depth(self, T_world_cam):
        """Planar depth and rectangle index (-1 = nothing) at every pixel centre."""
        z = np.full((H, W), np.inf)
        ids = np.full((H, W), -1)
        R, o = T_world_cam[:3, :3], T_world_cam[:3, 3]
        for y in range(H):
            for x in range(W):
                d = R @ np.array([(x - K[0, 2]) / K[0, 0], (y - K[1, 2]) / K[1, 1], 1.0])  # planar z = t
                t = self.hits(o, d)
                z[y, x] = t.min()
                ids[y, x] = np.argmin(t) if np.isfinite(t.min()) else -1
        return z, ids

    def visible_from(self, X, T_world_cam):
        """Brute force: no rectangle between the camera centre and X."""
        o = T_world_cam[:3, 3]
        t = self.hits(o, X - o)  # X at t = 1
        return not np.any(t < 1 - 1e-6)


def _near_edge(ids_tgt, u, v, radius=1.0):
    """True if p' is within `radius` px of an object boundary in the target view."""
    x0, x1 = int(np.floor(u - radius)), int(np.ceil(u + radius))
    y0, y1 = int(np.floor(v - radius)), int(np.ceil(v + radius))
    patch = ids_tgt[max(y0, 0):min(y1, H - 1) + 1, max(x0, 0):min(x1, W - 1) + 1]
    return len(np.unique(patch)) > 1


def _check_masks(scene, T_w_s, T_w_t, occluded, z_src, ids_tgt):
    T_t_s = np.linalg.inv(T_w_t) @ T_w_s
    checked = n_occ = n_hidden = 0
    for y in range(H):
        for x in range(W):
            z = z_src[y, x]
            if not np.isfinite(z):
                continue
            Xc = np.array([(x - K[0, 2]) / K[0, 0] * z, (y - K[1, 2]) / K[1, 1] * z, z, 1.0])
            Xw = (T_w_s @ Xc)[:3]
            Xt = T_t_s @ Xc
            if Xt[2] <= 0:
                truth = True
            else:
                u = K[0, 0] * Xt[0] / Xt[2] + K[0, 2]
                v = K[1, 1] * Xt[1] / Xt[2] + K[1, 2]
                inside = -0.5 <= u < W - 0.5 and -0.5 <= v < H - 0.5
                if inside and _near_edge(ids_tgt, u, v):
                    continue  # the depth map cannot decide closer than a pixel from an edge
                hidden = inside and not scene.visible_from(Xw, T_w_t)
                n_hidden += hidden
                truth = (not inside) or hidden
            checked += 1
            n_occ += truth
            assert truth == bool(occluded[y, x]), (x, y, truth)
    return checked, n_occ, n_hidden


@pytest.mark.slow
def test_temporal_occlusion_matches_brute_force_visibility():
    rng = np.random.default_rng(7)
    total_occ = total_hidden = 0
    for trial in range(3):
        scene = Rects(rng)
        T_w_s = _random_pose(rng, 0.05, 0.3)
        T_w_t = T_w_s @ _random_pose(rng, 0.08, 0.6)
        (z_s, _), (z_t, ids_t) = scene.depth(T_w_s), scene.depth(T_w_t)
        fl = flow_from_depth(z_s.astype(np.float32), K, T_w_s, T_w_t, z_t.astype(np.float32))
        checked, n_occ, n_hidden = _check_masks(scene, T_w_s, T_w_t, fl.occluded, z_s.astype(np.float32), ids_t)
        assert checked > 0.6 * W * H
        total_occ += n_occ
        total_hidden += n_hidden
    assert total_occ > 200 and total_hidden > 30  # hidden, not merely out-of-image, points occur


@pytest.mark.slow
def test_stereo_occlusion_matches_brute_force_visibility():
    rng = np.random.default_rng(11)
    B = 0.6
    for trial in range(2):
        scene = Rects(rng)
        T_w_l = _random_pose(rng, 0.05, 0.3)
        T_l_r = np.eye(4)
        T_l_r[0, 3] = B
        T_w_r = T_w_l @ T_l_r
        (z_l, _), (z_r, ids_r) = scene.depth(T_w_l), scene.depth(T_w_r)
        occ = stereo_occlusion(z_l.astype(np.float32), z_r.astype(np.float32), K, B)
        checked, n_occ, n_hidden = _check_masks(scene, T_w_l, T_w_r, occ, z_l.astype(np.float32), ids_r)
        assert checked > 0.6 * W * H and n_occ > 20 and n_hidden > 10


def test_flo_round_trip_and_layout(tmp_path):
    rng = np.random.default_rng(1)
    f = rng.normal(0, 20, (5, 7, 2)).astype(np.float32)
    f[1, 2] = np.nan
    p = write_flo(tmp_path / "a.flo", f)
    raw = p.read_bytes()
    assert raw[:4] == b"PIEH" and np.frombuffer(raw[4:12], "<i4").tolist() == [7, 5]
    assert len(raw) == 12 + 5 * 7 * 2 * 4
    assert np.frombuffer(raw[12:20], "<f4").tolist() == f[0, 0].tolist()
    back = read_flo(p)
    ok = np.isfinite(f)
    assert np.array_equal(back[ok], f[ok]) and np.all(np.isnan(back[1, 2]))


def test_kitti_flow_png_round_trip(tmp_path):
    import cv2
    rng = np.random.default_rng(2)
    f = rng.uniform(-300, 300, (6, 8, 2)).astype(np.float32)
    f[0, 0] = np.nan
    p = write_kitti_flow_png(tmp_path / "f.png", f)
    raw = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)  # BGR: B = valid, G = v, R = u
    assert raw.dtype == np.uint16 and raw.shape == (6, 8, 3)
    assert raw[0, 0, 0] == 0 and np.all(raw[1:, :, 0] == 1)
    assert raw[2, 3, 2] == np.rint(f[2, 3, 0] * 64 + 32768)
    back, valid = read_kitti_flow_png(p)
    assert not valid[0, 0] and valid[1:].all()
    assert np.abs(back[valid] - f[valid]).max() <= 1 / 128


def test_errors(tmp_path):
    (tmp_path / "x.flo").write_bytes(b"XXXX\x00\x00\x00\x00")
    with pytest.raises(VoError, match="bad magic"):
        read_flo(tmp_path / "x.flo")
    with pytest.raises(VoError, match="no such"):
        read_flo(tmp_path / "none.flo")


def test_sequence_forward_and_backward_flow_on_a_render(tmp_path):
    """Rig moving +0.1 m along x in front of a plane at 4 m, f = 50: flow = ∓1.25 px."""
    from vo_reference.io.sequence import open_sequence
    from synthetic_render import plane_scene
    from vo_reference.products.flow import backward_flow, forward_flow, sequence_stereo_occlusion
    seq = open_sequence(plane_scene(tmp_path / "p", frames=3, step_m=0.1, f=50.0, plane_z=4.0))
    fw, bw = forward_flow(seq, 1), backward_flow(seq, 1)
    assert np.allclose(fw.flow[..., 0], -1.25, atol=1e-5) and np.allclose(fw.flow[..., 1], 0, atol=1e-5)
    assert np.allclose(bw.flow[..., 0], 1.25, atol=1e-5)
    # the columns that leave the image are exactly the occluded ones
    assert np.array_equal(fw.occluded.any(axis=0), np.arange(64) < 1) and not fw.occluded[:, 1:].any()
    assert bw.occluded[:, -1].all() and not bw.occluded[:, :-1].any()
    # stereo: d = 50·0.2/4 = 2.5 px, the first 2 left columns have no partner in the right view
    occ = sequence_stereo_occlusion(seq, 0)
    assert occ[:, :2].all() and not occ[:, 2:].any()
