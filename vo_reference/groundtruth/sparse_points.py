"""Sparse 3-D points of a render with their 2-D observations, from the exact depth: the
points of the structure-from-motion layouts (COLMAP's ``points3D``, nerfstudio's seed
cloud).

Sampling: the images are visited in order (frame by frame, left before right); in each
image, every cell of a ``stride_px`` grid that no point seen so far covers gets a new point
at its centre pixel, back-projected with that pixel's planar depth along the camera's ray
(through the lens for a distorted render), where the pixel and its 8 neighbours see the
same static object (pixels on moving objects, the sky and object outlines give no point).
A scene seen for the first time is thus sampled once, at about one point per cell.

Visibility (the observations): a point is observed in an image when it lies in front of
the camera, projects (through the lens) inside the image, the nearest pixel shows its
object, and the image's depth there -- bilinear in inverse depth over the 2x2 cell,
exact for a plane -- equals the point's depth within ``rtol``: the point *is* the surface
the image shows, not something behind it or beside an outline. The observation is the
exact projection (OpenCV pixels), not a rounded pixel.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from blender_sesgen.contract.se3 import invert

from ..errors import VoError
from .flow import surface_inverse_depth
from .options import pop_number

__all__ = ["SparsePoints", "sparse_points", "default_stride", "pop_stride", "camera_lens", "observe"]

TARGET_POINTS_PER_IMAGE = 2000


@dataclass(frozen=True)
class SparsePoints:
    """Points in the SES world and where each image sees them."""
    images: tuple[tuple[int, str], ...]   # (source frame, view) of each image, in order
    xyz: np.ndarray                       # (P, 3) float64 world points, metres
    rgb: np.ndarray                       # (P, 3) uint8 colour of the pixel each point came from
    object_id: np.ndarray                 # (P,) int32
    observations: tuple                   # per image: (point indices (n,) int, pixels (n, 2) float64 OpenCV)

    @property
    def track_lengths(self) -> np.ndarray:
        n = np.zeros(len(self.xyz), np.int64)
        for idx, _ in self.observations:
            np.add.at(n, idx, 1)
        return n


def default_stride(width: int, height: int) -> int:
    """Grid step (px) giving about TARGET_POINTS_PER_IMAGE points in the first image."""
    return max(2, int(round(np.sqrt(width * height / TARGET_POINTS_PER_IMAGE))))


def pop_stride(extra: dict) -> int | None:
    """Take ``stride`` (the grid step in pixels, ``--opt stride=PX``) out of an export's
    options; None when not given."""
    return pop_number(extra, "stride", int, None, "a whole number of pixels")


def camera_lens(seq):
    """The render's lens (``contract.lens.Lens``), a pinhole one on K when it has none."""
    from blender_sesgen.contract.lens import Lens
    lens = seq.lens
    return lens if lens is not None else Lens.from_K("pinhole", (), seq.K)


def observe(xyz: np.ndarray, object_id: np.ndarray, T_world_cam: np.ndarray, depth: np.ndarray,
            ids: np.ndarray, lens, rtol: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """(visible (P,) bool, pixels (P, 2) float64, NaN where not visible) of world points in
    one image (module docstring)."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    T = invert(np.asarray(T_world_cam, dtype=np.float64))
    Xc = xyz @ T[:3, :3].T + T[:3, 3]
    H, W = depth.shape
    uv = np.full((len(xyz), 2), np.nan)
    front = Xc[:, 2] > 1e-9
    if front.any():
        uv[front] = lens.project(Xc[front])
    u, v = uv[:, 0], uv[:, 1]
    with np.errstate(invalid="ignore"):
        vis = front & (u >= -0.5) & (u < W - 0.5) & (v >= -0.5) & (v < H - 0.5)
    if vis.any():
        sel = np.flatnonzero(vis)
        xi = np.clip(np.rint(u[sel]), 0, W - 1).astype(np.intp)
        yi = np.clip(np.rint(v[sel]), 0, H - 1).astype(np.intp)
        same = np.asarray(ids)[yi, xi] == object_id[sel]
        inv = surface_inverse_depth(depth, u[sel], v[sel])
        vis[sel] = same & (np.abs(inv * Xc[sel, 2] - 1.0) <= rtol)
    uv[~vis] = np.nan
    return vis, uv


def _interior(depth: np.ndarray, ids: np.ndarray, moving: tuple[int, ...]) -> np.ndarray:
    """bool (H, W): the pixel and its 8 neighbours see the same static object."""
    finite = np.isfinite(depth)
    ok = finite & ~np.isin(ids, moving)
    H, W = ids.shape
    pad_i = np.pad(ids, 1, mode="edge")
    pad_f = np.pad(finite, 1, mode="constant", constant_values=False)
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            ok &= (pad_i[dy:dy + H, dx:dx + W] == ids) & pad_f[dy:dy + H, dx:dx + W]
    return ok


def sparse_points(seq, frames, views, stride_px: int | None = None, rtol: float = 1e-3,
                  rgb_of: Callable | None = None, tick: Callable | None = None) -> SparsePoints:
    """Sample points and find their observations in every image (module docstring).
    ``rgb_of(k, view)`` gives the colours (default ``seq.image_rgb``); ``tick()`` is called
    twice per image (selection, observation)."""
    W, H = seq.resolution
    s = int(stride_px) if stride_px else default_stride(W, H)
    if s < 1:
        raise VoError(f"point stride {stride_px}: expected >= 1 pixel")
    lens = camera_lens(seq)
    moving = tuple(seq.moving_ids)
    rgb_of = rgb_of or seq.image_rgb
    images = tuple((int(k), v) for k in frames for v in views)
    poses = {v: seq.T_world_cam(v) for v in views}
    gy, gx = np.mgrid[s // 2:H:s, s // 2:W:s]          # centre pixel of every grid cell
    xyz, rgb, oid = np.zeros((0, 3)), np.zeros((0, 3), np.uint8), np.zeros(0, np.int32)
    for k, view in images:
        depth, ids = seq.depth(k, view), seq.ids(k, view)
        if depth is None or ids is None:
            raise VoError(f"{seq!r} has no depth/id ground truth: cannot place points")
        covered = np.zeros(gy.shape, bool)
        if len(xyz):
            vis, uv = observe(xyz, oid, poses[view][k], depth, ids, lens, rtol)
            cx = np.floor((uv[vis, 0] + 0.5) / s).astype(np.intp)
            cy = np.floor((uv[vis, 1] + 0.5) / s).astype(np.intp)
            keep = (cx < gx.shape[1]) & (cy < gy.shape[0])
            covered[cy[keep], cx[keep]] = True
        new = ~covered & _interior(depth, ids, moving)[gy, gx]
        if new.any():
            px = np.stack([gx[new], gy[new]], axis=-1).astype(np.float64)
            rays = lens.unproject(px)
            z = np.asarray(depth, np.float64)[gy[new], gx[new]]
            Xc = rays / rays[:, 2:3] * z[:, None]
            T = poses[view][k]
            xyz = np.concatenate([xyz, Xc @ T[:3, :3].T + T[:3, 3]])
            rgb = np.concatenate([rgb, np.asarray(rgb_of(k, view))[gy[new], gx[new]].astype(np.uint8)])
            oid = np.concatenate([oid, ids[gy[new], gx[new]].astype(np.int32)])
        if tick:
            tick()
    observations = []
    for k, view in images:
        vis, uv = observe(xyz, oid, poses[view][k], seq.depth(k, view), seq.ids(k, view), lens, rtol)
        idx = np.flatnonzero(vis)
        observations.append((idx, uv[idx]))
        if tick:
            tick()
    return SparsePoints(images=images, xyz=xyz, rgb=rgb, object_id=oid, observations=tuple(observations))
