"""A render with a distorting lens seen through a pinhole camera: ``export --undistort``.

:class:`UndistortedSequence` wraps a distorted render and is itself a sequence of the same
rig with a pinhole camera of intrinsics :attr:`K` (the render's K when the lens covers that
whole pinhole image, else K with both focal lengths scaled up by the least factor that makes
it covered: :func:`pinhole_K`). Every export and ground-truth product then runs on it
unchanged (disparity fx·B/Z, flow, scene flow, occlusion, masks all come from its depth,
ids and poses), so the pinhole export holds the pinhole camera's ground truth:

- **images**: each pinhole pixel samples the distorted image where its ray lands
  (bilinear, ``cv2.remap``; the lookup table of ``contract.lens.undistortion_maps``);
- **ids**: the object of the nearest distorted pixel centre (never interpolated);
- **depth**: recomputed along the pinhole pixel's own ray: the ray is intersected with the
  surface plane at the nearest distorted sample, the plane through that sample's exact 3-D
  point (its planar depth along the lens's ray) and two neighbours of the same object that
  lie on one plane with it (of its four quadrants, the one most other neighbours confirm:
  on a face of a box that is the face's own plane, never one across its crease; on a curved
  surface, the quadrant the ray falls in). Planar surfaces come out exact; no value is ever
  mixed across an object's edge (only samples of the nearest sample's object are used;
  with no such neighbours the sample's own depth is taken, as a fronto-parallel patch).

Pixels of the pinhole image therefore see the scene as a pinhole render would, to the
sampling of the distorted render: exactly on planes, to second order on curved surfaces,
and within a pixel of every silhouette the nearest sample decides the object.
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from blender_sesgen.contract.lens import Lens, undistortion_maps

from ..errors import VoError
from ..io.color import rgb8_to_gray8

__all__ = ["UndistortedSequence", "pinhole_K"]

PLANE_RTOL = 5e-4   # a neighbour lies on a plane within this fraction of its depth (render depth: ~1e-4)
JUMP_RTOL = 0.1     # neighbours whose depth differs by more (relative) are not the same surface
# the four quadrants (dx, dy) around a sample, and its eight neighbours
QUADRANTS = ((1, 1), (-1, 1), (-1, -1), (1, -1))
NEIGHBOURS = tuple((dx, dy) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dx or dy)


def _covered(lens: Lens, K_new: np.ndarray, W: int, H: int) -> bool:
    """Every pixel centre of the pinhole image (K_new) lands inside the distorted image."""
    u = np.concatenate([np.arange(W), np.arange(W), np.zeros(H), np.full(H, W - 1.0)]).astype(float)
    v = np.concatenate([np.zeros(W), np.full(W, H - 1.0), np.arange(H), np.arange(H)]).astype(float)
    ray = np.stack([(u - K_new[0, 2]) / K_new[0, 0], (v - K_new[1, 2]) / K_new[1, 1], np.ones_like(u)], axis=-1)
    px = lens.project(ray)
    return bool(np.all((px[:, 0] >= -0.5) & (px[:, 0] <= W - 0.5) & (px[:, 1] >= -0.5) & (px[:, 1] <= H - 0.5)))


def pinhole_K(lens: Lens, width: int, height: int) -> np.ndarray:
    """The pinhole camera of the undistorted images: the lens's own K when the distorted
    image covers its whole view (barrel and fisheye lenses), else K with fx, fy scaled by the
    least s > 1 (to 1e-6) that makes it so (pincushion: the principal point stays)."""
    def zoomed(s: float) -> np.ndarray:
        K = lens.K
        K[0, 0] *= s
        K[1, 1] *= s
        return K
    if _covered(lens, zoomed(1.0), width, height):
        return zoomed(1.0)
    lo, hi = 1.0, 2.0
    while not _covered(lens, zoomed(hi), width, height):
        lo, hi = hi, 2 * hi
        if hi > 1e3:
            raise VoError("--undistort: no pinhole camera fits inside this lens's image")
    while hi - lo > 1e-6:
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if _covered(lens, zoomed(mid), width, height) else (mid, hi)
    return zoomed(hi)


class UndistortedSequence:
    """``seq`` (a distorted render) as a pinhole sequence of intrinsics :attr:`K` (module
    docstring). Everything that is not geometry (poses, times, objects, IMU, provenance) is
    the render's own."""

    def __init__(self, seq, cache_frames: int = 8):
        lens = seq.lens
        if lens is None:
            raise VoError(f"{seq!r} has no lens to undistort")
        self._seq = seq
        W, H = seq.resolution
        self.K = pinhole_K(lens, W, H)
        map_x, map_y = undistortion_maps(lens, W, H, self.K)
        self._maps = (map_x.astype(np.float32), map_y.astype(np.float32))
        self._near = (np.clip(np.rint(map_y), 0, H - 1).astype(np.intp), np.clip(np.rint(map_x), 0, W - 1).astype(np.intp))
        # the quadrant each pinhole ray falls in around its nearest sample
        self._side = (np.where(map_x >= self._near[1], 1, -1), np.where(map_y >= self._near[0], 1, -1))
        rays = lens.pixel_rays(W, H)
        self._rays_lens = rays / rays[..., 2:3]                   # distorted pixel centres, z = 1
        v, u = np.mgrid[0:H, 0:W].astype(float)
        self._rays_pinhole = np.stack([(u - self.K[0, 2]) / self.K[0, 0], (v - self.K[1, 2]) / self.K[1, 1],
                                       np.ones_like(u)], axis=-1)
        self._cache: OrderedDict = OrderedDict()
        self._cache_frames = int(cache_frames)

    lens = None   # a pinhole camera now

    def __getattr__(self, name):          # poses, times, objects, IMU, provenance: the render's
        return getattr(self._seq, name)

    def __repr__(self) -> str:
        return f"UndistortedSequence({self._seq!r})"

    def undistortion_maps(self):
        return None

    # --- images ---------------------------------------------------------------------------
    def image_rgb(self, k: int, view: str = "left") -> np.ndarray:
        return self._remap(self._seq.image_rgb(k, view))

    def image_gray(self, k: int, view: str = "left") -> np.ndarray:
        return rgb8_to_gray8(self.image_rgb(k, view))

    def rgb_linear(self, k: int, view: str = "left") -> np.ndarray:
        return self._remap(self._seq.rgb_linear(k, view))

    def raw_dn(self, k: int, view: str = "left"):
        return None        # a raw mosaic has no pinhole counterpart

    def sensor_file(self, kind: str, k: int, view: str = "left"):
        return None

    def _remap(self, image: np.ndarray) -> np.ndarray:
        import cv2
        return cv2.remap(image, *self._maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    # --- ground truth ---------------------------------------------------------------------
    def depth(self, k: int, view: str = "left") -> np.ndarray:
        return self._ground_truth(k, view)[0]

    def ids(self, k: int, view: str = "left") -> np.ndarray:
        return self._ground_truth(k, view)[1]

    def _ground_truth(self, k: int, view: str) -> tuple[np.ndarray, np.ndarray]:
        key = (int(k), view)
        if key not in self._cache:
            self._cache[key] = pinhole_ground_truth(self._seq.depth(k, view), self._seq.ids(k, view),
                                                    self._rays_lens, self._rays_pinhole, self._near, self._side)
            while len(self._cache) > self._cache_frames:
                self._cache.popitem(last=False)
        self._cache.move_to_end(key)
        return self._cache[key]


def _shifted(a: np.ndarray, dx: int, dy: int, fill) -> np.ndarray:
    """a[y + dy, x + dx] (``fill`` outside the image)."""
    H, W = a.shape[:2]
    out = np.full_like(a, fill)
    ys, yd = slice(max(dy, 0), H + min(dy, 0)), slice(max(-dy, 0), H + min(-dy, 0))
    xs, xd = slice(max(dx, 0), W + min(dx, 0)), slice(max(-dx, 0), W + min(-dx, 0))
    out[yd, xd] = a[ys, xs]
    return out


def pinhole_ground_truth(depth: np.ndarray, ids: np.ndarray, rays_lens: np.ndarray, rays_pinhole: np.ndarray,
                         near: tuple[np.ndarray, np.ndarray], side: tuple[np.ndarray, np.ndarray]):
    """(planar depth float32, ids int32) of the pinhole image from a distorted render's depth
    and ids (module docstring). ``rays_lens``: the distorted pixel centres' rays (z = 1),
    ``rays_pinhole`` the pinhole pixels' rays (z = 1), ``near`` the (row, col) of each pinhole
    pixel's nearest distorted sample, ``side`` the (x, y) signs of its quadrant there."""
    z = np.asarray(depth, dtype=np.float64)
    ids = np.asarray(ids)
    finite = np.isfinite(z) & (z > 0)
    P = rays_lens * np.where(finite, z, 0.0)[..., None]          # exact 3-D points of the samples
    nb_P = {d: _shifted(P, *d, 0.0) for d in NEIGHBOURS}
    nb_ok = {}
    for d in NEIGHBOURS:   # a neighbour of the same surface: same object, seen, no depth jump
        zn = _shifted(np.where(finite, z, 0.0), *d, 0.0)
        nb_ok[d] = finite & _shifted(finite, *d, False) & (_shifted(ids, *d, -1) == ids) \
            & (np.abs(zn - np.where(finite, z, 0.0)) <= JUMP_RTOL * z)
    normals, scores = [], []
    for dx, dy in QUADRANTS:
        n = np.cross(nb_P[(dx, 0)] - P, nb_P[(0, dy)] - P)
        norm = np.linalg.norm(n, axis=-1)
        valid = nb_ok[(dx, 0)] & nb_ok[(0, dy)] & (norm > 0)
        n = n / np.where(norm > 0, norm, 1.0)[..., None]
        support = np.zeros(z.shape, np.int32)
        for d in NEIGHBOURS:
            off = np.abs(np.einsum("...i,...i->...", n, nb_P[d] - P))
            support += nb_ok[d] & (off <= PLANE_RTOL * np.where(finite, z, 0.0))
        normals.append(n)
        scores.append(np.where(valid, 2 * support, -10))   # an invalid quadrant never wins
    iy, ix = near
    sx, sy = side
    best = np.full(iy.shape, -1, np.int32)
    normal = np.zeros(iy.shape + (3,))
    for q, (dx, dy) in enumerate(QUADRANTS):   # most support; ties: the quadrant the ray is in
        score = scores[q][iy, ix] + ((sx == dx) & (sy == dy))
        take = score > best
        best = np.where(take, score, best)
        normal[take] = normals[q][iy, ix][take]
    X0 = P[iy, ix]
    z0 = z[iy, ix]
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = np.einsum("...i,...i->...", normal, rays_pinhole)
        t = np.einsum("...i,...i->...", normal, X0) / denom
    cos = np.abs(denom) / np.linalg.norm(rays_pinhole, axis=-1)
    plane = (best >= 0) & (cos > 1e-3) & np.isfinite(t) & (t > 0)
    out = np.where(plane, t, z0)                 # planar depth = t: the pinhole ray has z = 1
    out = np.where(finite[iy, ix], out, np.inf)
    return out.astype(np.float32), ids[iy, ix].astype(np.int32)
