"""A small render folder with exact depth, for the dataset-layout tests: a floor, a back wall
and a box face ray-cast in closed form, sky above the wall, seen by a level rig that looks
along −Z of the SES world (Y up), drives forward and turns right a little each frame."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from synthetic_render import write_render

W, H, F, B = 48, 32, 36.0, 0.3
K = np.array([[F, 0.0, W / 2 - 0.5], [0.0, F, H / 2 - 0.5], [0.0, 0.0, 1.0]])
# (normal, offset d of n·X = d, bounds (lo, hi) of X, id): floor y = 0, wall z = -8, box face z = -3
PLANES = (
    (np.array([0.0, 1.0, 0.0]), 0.0, ((-6, -1, -8), (6, 1, 4)), 1),
    (np.array([0.0, 0.0, 1.0]), -8.0, ((-6, 0, -9), (6, 2.6, -7)), 2),
    (np.array([0.0, 0.0, 1.0]), -3.0, ((-0.6, 0, -4), (0.6, 1.0, -2)), 3),
)
OBJECTS = [
    {"id": 1, "name": "floor", "shape": "QUAD", "class": "road"},
    {"id": 2, "name": "wall", "shape": "QUAD", "class": "building"},
    {"id": 3, "name": "box", "shape": "CUBOID"},   # no class
]
YAW_DEG, STEP_M = 2.0, 0.15


def rot_y(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def rig_poses(n: int) -> np.ndarray:
    """T_world_cam of the left camera: OpenCV camera, level, looking along −Z; turning right
    (towards +X) by YAW_DEG and moving STEP_M forward per frame."""
    T = np.tile(np.eye(4), (n, 1, 1))
    level = np.diag([1.0, -1.0, -1.0])             # camera x = X, y (down) = -Y, z (forward) = -Z
    pos = np.array([0.0, 1.2, 1.0])
    for k in range(n):
        R = rot_y(-YAW_DEG * k) @ level              # yaw right: forward turns from -Z towards +X
        T[k, :3, :3] = R
        T[k, :3, 3] = pos
        pos = pos + STEP_M * (R @ np.array([0.0, 0.0, 1.0]))
    return T


def view_pose(n: int, k: int, view: str) -> np.ndarray:
    """T_world_cam of ``view`` at frame k of the n-frame rig (right = left moved B along its x)."""
    T = rig_poses(n)[k].copy()
    if view == "right":
        T[:3, 3] += T[:3, :3] @ np.array([B, 0, 0])
    return T


def export_layout(render, out, target: str, *extra: str) -> Path:
    """``vo-reference export RENDER OUT --to TARGET`` without noise; asserts it succeeded."""
    from vo_reference.commands.main import main
    assert main(["export", str(render), str(out), "--to", target, "--noise", "0", "-q", *extra]) == 0
    return Path(out)


def export_fixture(target: str, into: str = ".", *extra: str, part: str = "", name: str = "exported"):
    """A module fixture ``name``: the shared ``layout_render`` (tests/conftest.py) exported ``--to
    TARGET`` into the folder ``into`` of a fresh one (``export_layout``); its ``part`` is returned."""
    import pytest

    @pytest.fixture(scope="module", name=name)
    def exported(layout_render, tmp_path_factory) -> Path:
        return export_layout(layout_render, tmp_path_factory.mktemp(target) / into, target, *extra) / part
    return exported


def raycast(T_world_cam: np.ndarray, lens=None) -> tuple[np.ndarray, np.ndarray]:
    """(planar depth float32 with +inf for sky, ids int32) of one camera at its pixel
    centres (through ``lens``, a ``contract.lens.Lens``, for a distorted camera)."""
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    z, ids = raycast_pixels(T_world_cam, np.stack([u, v], -1), lens)
    return z.astype(np.float32), ids


def raycast_pixels(T_world_cam: np.ndarray, px: np.ndarray, lens=None) -> tuple[np.ndarray, np.ndarray]:
    """(planar depth float64, ids) seen through any pixels (..., 2) (OpenCV convention)."""
    px = np.asarray(px, dtype=float)
    if lens is None:
        rays_cam = np.stack([(px[..., 0] - K[0, 2]) / F, (px[..., 1] - K[1, 2]) / F, np.ones(px.shape[:-1])], -1)
    else:
        r = lens.unproject(px)
        rays_cam = r / r[..., 2:3]
    rays = rays_cam @ T_world_cam[:3, :3].T
    C = T_world_cam[:3, 3]
    z = np.full(px.shape[:-1], np.inf)
    ids = np.zeros(px.shape[:-1], np.int32)
    for n, d, (lo, hi), oid in PLANES:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (d - n @ C) / (rays @ n)
        X = C + t[..., None] * rays
        hit = (t > 0) & np.all((X >= np.array(lo) - 1e-9) & (X <= np.array(hi) + 1e-9), axis=-1) & (t < z)
        z[hit], ids[hit] = t[hit], oid
    return z, ids


def texture(T_world_cam: np.ndarray, z: np.ndarray, lens=None) -> np.ndarray:
    """Linear RGB that is a smooth function of the world point (sky: a flat blue)."""
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    zz = np.where(np.isfinite(z), z, 0.0)
    if lens is None:
        Xc = np.stack([(u - K[0, 2]) / F * zz, (v - K[1, 2]) / F * zz, zz], -1)
    else:
        r = lens.unproject(np.stack([u, v], -1))
        Xc = r / r[..., 2:3] * zz[..., None]
    X = Xc @ T_world_cam[:3, :3].T + T_world_cam[:3, 3]
    rgb = 0.45 + 0.4 * np.stack([np.sin(3.1 * X[..., 0]), np.sin(2.3 * X[..., 1] + 1), np.sin(1.7 * X[..., 2])], -1)
    rgb[~np.isfinite(z)] = (0.2, 0.4, 0.8)
    return rgb.astype(np.float32)


def write_layout_render(root, n: int = 4, stereo: bool = True, objects=None, noise=None, lens=None, extra=None):
    """The render folder; ``lens`` (model, coeffs), e.g. ("brown", (k1, k2, p1, p2, k3)): a
    distorted camera (depth and ids at the distorted pixel centres, manifest ``lens``)."""
    from blender_sesgen.contract.lens import Lens
    cam = None if lens is None else Lens.from_K(lens[0], lens[1], K)
    T = rig_poses(n)
    frames = []
    for k in range(n):
        fr = {}
        for view, dx in (("left", 0.0), ("right", B))[: 2 if stereo else 1]:
            Tv = T[k].copy()
            Tv[:3, 3] += Tv[:3, :3] @ np.array([dx, 0.0, 0.0])
            z, ids = raycast(Tv, cam)
            fr[view] = (texture(Tv, z, cam), z, ids)
        frames.append(fr)
    extra = {"fps": 10, **(extra or {})}
    if cam is not None:
        extra["lens"] = {"model": cam.model, "coeffs": list(cam.coeffs)}
    return write_render(root, K=K, baseline_m=B if stereo else 0.0, T_world_left=T, frames=frames,
                        noise=noise, objects=OBJECTS if objects is None else objects, extra=extra)


def analytic_flow(T_src: np.ndarray, T_tgt: np.ndarray):
    """Expected flow of a camera from pose T_src to T_tgt in the closed-form scene (pinhole):
    (flow (H, W, 2), the point's depth in the target, inside the target image, the target
    depth at the nearest pixel's 3x3 neighbourhood: min and max)."""
    z, _ = raycast(T_src)
    zt_map, _ = raycast(T_tgt)
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    r = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1)
    Rs, Cs, Rt, Ct = T_src[:3, :3], T_src[:3, 3], T_tgt[:3, :3], T_tgt[:3, 3]
    fin = np.isfinite(z)
    # surface points move with the full motion, points at infinity with the rotation only
    Xt = np.where(fin[..., None], (Cs + (r * np.where(fin, z, 0)[..., None]) @ Rs.T - Ct) @ Rt, (r @ Rs.T) @ Rt)
    p = Xt @ K.T
    up, vp = p[..., 0] / p[..., 2], p[..., 1] / p[..., 2]
    flow = np.stack([up - u, vp - v], -1)
    inside = (Xt[..., 2] > 0) & (up >= -0.5) & (up < W - 0.5) & (vp >= -0.5) & (vp < H - 0.5)
    zpt = np.where(fin, Xt[..., 2], np.inf)
    xi, yi = np.clip(np.rint(up), 0, W - 1).astype(int), np.clip(np.rint(vp), 0, H - 1).astype(int)
    pad = np.pad(zt_map, 1, mode="edge")
    nb = np.stack([pad[yi + 1 + dy, xi + 1 + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)])
    return flow, zpt, inside, nb.min(0), nb.max(0)
