"""16-bit ground-truth encodings at the ends of their range: a value the encoding cannot hold
is written invalid, never clipped to a plausible wrong one.

KITTI's disparity PNG holds d = I/256 up to 255.996 px and its flow PNG (I - 2^15)/64 within
-512..+511.98 px (the devkit readme); a near object of a wide stereo rig has more disparity
(fx·B/Z = 300 px here), a fast turn more flow. Read back by readers written from the devkit
readme and TartanAir V2's flow16to32, against closed forms (d = fx·B/Z; the flow of a pure
rotation, p' ~ K R K^-1 p, whatever the depth).
"""
from __future__ import annotations

import numpy as np
import pytest

from synthetic_render import write_render

cv2 = pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")

W, H, FX, B = 16, 12, 2000.0, 0.3
K = np.array([[FX, 0.0, W / 2 - 0.5], [0.0, FX, H / 2 - 0.5], [0.0, 0.0, 1.0]])
Z_NEAR, Z_FAR = 2.0, 4.0                 # left half: d = 300 px (too much for PNG16), right half 150 px
# frame 0 -> 1: ~730 px of flow; 1 -> 2: about 512 px, on either side of it across the image; 2 -> 3: ~7 px
TURN_DEG = (20.0, float(np.degrees(np.arctan(511.9 / FX))), 0.2)


def _rot_y(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def _poses() -> np.ndarray:
    T = np.tile(np.eye(4), (len(TURN_DEG) + 1, 1, 1))
    for k in range(1, len(TURN_DEG) + 1):
        T[k, :3, :3] = T[k - 1, :3, :3] @ _rot_y(TURN_DEG[k - 1])
    return T


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    z = np.full((H, W), Z_FAR, np.float32)
    z[:, : W // 2] = Z_NEAR
    frames = [{v: (np.full((H, W, 3), 0.3, np.float32), z, np.ones((H, W), np.int32)) for v in ("left", "right")}
              for _ in range(len(TURN_DEG) + 1)]
    return write_render(tmp_path_factory.mktemp("range") / "r", K=K, baseline_m=B, T_world_left=_poses(),
                        frames=frames, objects=[{"id": 1, "name": "wall", "shape": "QUAD"}], extra={"fps": 10})


def devkit_disparity(path):
    """KITTI devkit readme: d = I / 256, I = 0 invalid."""
    I = cv2.imread(str(path), cv2.IMREAD_UNCHANGED).astype(np.float64)
    return np.where(I > 0, I / 256.0, np.nan)


def devkit_flow(path):
    """KITTI devkit readme: R, G = u, v as (I - 2^15) / 64, B > 0 valid (OpenCV reads BGR)."""
    bgr = cv2.imread(str(path), cv2.IMREAD_UNCHANGED).astype(np.float64)
    return (bgr[..., 2:0:-1] - 2 ** 15) / 64.0, bgr[..., 0] > 0


def rotation_flow(deg: float) -> np.ndarray:
    """(H, W, 2) flow of the camera turning by ``deg`` about its y axis (any depth)."""
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    rays = np.linalg.inv(K) @ np.stack([u.ravel(), v.ravel(), np.ones(u.size)])
    p = K @ _rot_y(deg).T @ rays          # X_tgt = R_tgt_src X_src, R_tgt_src = R_y(deg)^T
    return np.stack([p[0] / p[2] - u.ravel(), p[1] / p[2] - v.ravel()], -1).reshape(H, W, 2)


@pytest.mark.parametrize("target, name", [("kitti-stereo", "disp_occ_0/000000_10.png"),
                                          ("kitti-sceneflow", "disp_occ_0/000000_10.png"),
                                          ("png", "left/disparity/000000.png")])
def test_a_disparity_beyond_256_px_is_invalid_not_clipped(render, tmp_path, target, name):
    from vo_reference.exporters.driver import export
    d = devkit_disparity(export(render, target, tmp_path / "o", noise=None, progress=False) / name)
    assert np.all(np.isnan(d[:, : W // 2]))                     # 300 px: not 255.996
    assert np.allclose(d[:, W // 2:], FX * B / Z_FAR, atol=1 / 512)


@pytest.mark.parametrize("target", ["kitti-stereo", "kitti-sceneflow"])
def test_a_flow_beyond_512_px_is_invalid_not_clipped(render, tmp_path, target):
    from vo_reference.exporters.driver import export
    out = export(render, target, tmp_path / "o", noise=None, progress=False)
    for pair, deg in enumerate(TURN_DEG):
        truth = rotation_flow(deg)
        flow, valid = devkit_flow(out / "flow_occ" / f"{pair:06d}_10.png")
        code = np.rint(truth * 64 + 2 ** 15)
        fits = np.all((code >= 0) & (code <= 65535), axis=-1)
        assert fits.any() == (pair > 0) and (pair != 1 or not fits.all())
        assert np.array_equal(valid, fits), pair
        assert np.abs(flow[valid] - truth[valid]).max(initial=0) <= 1 / 128


def test_tartanair_v2_png_flow_masks_what_16_bits_cannot_hold():
    """TartanAir V2's flow16to32: flow = (I[..., :2] - 32768) / 64, mask = I[..., 2]; a loader
    keeping mask == 0 must never keep a clipped vector."""
    from vo_reference.exporters.tartanair_v2 import flow_png16
    f = np.array([[[600.0, 3.0], [-2.5, 0.25]], [[10.0, -700.0], [511.0, -512.0]]])
    I = flow_png16(f, np.zeros((2, 2), np.uint8))
    flow, mask = (I[..., :2].astype(np.float64) - 32768) / 64, I[..., 2]
    keep = mask == 0
    assert keep.tolist() == [[False, True], [False, True]]
    assert np.array_equal(flow[keep], f[keep])
