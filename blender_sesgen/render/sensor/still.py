"""A still camera's frames (``TIMING still on``, the default): the path tracer's noise held.

A real camera on a stand sees the same light frame after frame; its frames differ by photon
and read noise only (EuRoC V1_01's standing frames: 0.7 DN, KLT forward-backward 0.0002 px).
A path tracer draws new noise every frame (the hall: 5-6 DN, KLT 0.013 px), a flicker that a
tracker sees and a camera has not. So within a *still stretch* -- consecutive frames whose
cameras only turn about (almost) fixed centres in a world that does not move -- every frame's
beauty is the stretch's first frame's render, reprojected to the frame's own pose with the
frame's own ground-truth depth; the sensor chain then adds the frame's own sensor noise.

Exact: for a turn about the camera's centre the image moves by the homography K R K^-1
whatever the depth; a centre moving by up to :data:`CENTRE_TOLERANCE_M` (a stereo rig turning
about its left camera moves its right one) is reprojected through the frame's depth, exact
but at depth edges. Each frame's beauty is a function of its own frame number and the plan
(the reference render is drawn again in every frame, with the reference frame's seed), so
``--frames``, ``--resume`` and farm chunks give the same bytes however the frames are split.
Ground truth (depth, ids, flow) is always the frame's own render.

Pure numpy: stretch finding (:func:`still_references`) and the reprojection
(:func:`reproject`, cubic B-spline interpolation, which neither blurs a sub-pixel shift as
bilinear does nor quantises the coordinates as OpenCV's warps do).
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from ...contract.camera import pixel_rays
from ...contract.depth import BACKGROUND_THRESHOLD
from ...contract.se3 import rotation_angle_rad

# A stretch's cameras may move their centres by 0.1 mm: the parallax this leaves at depth
# edges (where a pixel mixes two depths) is f * 1e-4 / Z px, 0.05 px at 1 m for EuRoC's f.
CENTRE_TOLERANCE_M = 1e-4
# ... and turn by at most this much of the image (px at the image's corners): the border
# pixels a turn brings in from outside the reference are mirrored, a band this wide.
MAX_SHIFT_PX = 2.0

_POLE = np.sqrt(3.0) - 2.0      # the cubic B-spline's prefilter pole


def still_references(T_world_cam: dict[str, np.ndarray], K: np.ndarray, width: int, height: int,
                     world_moves: bool = False) -> tuple[int, ...]:
    """The reference frame of every frame: a stretch's first frame for the frames of the
    stretch, the frame itself elsewhere. ``T_world_cam``: {view: (n, 4, 4)} poses of every
    view at every frame; ``world_moves``: something in view moves (then no stretch).

    Greedy from frame 0: frame k joins the stretch of reference r while every view's centre
    stays within :data:`CENTRE_TOLERANCE_M` of r's and its turn from r moves no image corner
    by more than :data:`MAX_SHIFT_PX`; else k starts a stretch of its own."""
    n = len(next(iter(T_world_cam.values())))
    refs = list(range(n))
    if world_moves or n == 0:
        return tuple(refs)
    r = 0
    for k in range(1, n):
        if all(_joins(T[r], T[k], K, width, height) for T in T_world_cam.values()):
            refs[k] = r
        else:
            r = k
    return tuple(refs)


def stretches(refs: Sequence[int]) -> list[list[int]]:
    """[first, last] of each still stretch of more than one frame (the manifest's record)."""
    out: list[list[int]] = []
    for k, r in enumerate(refs):
        if r != k:
            if out and out[-1][0] == r:
                out[-1][1] = k
            else:
                out.append([r, k])
    return out


def _joins(T_r: np.ndarray, T_k: np.ndarray, K: np.ndarray, width: int, height: int) -> bool:
    if np.linalg.norm(T_k[:3, 3] - T_r[:3, 3]) > CENTRE_TOLERANCE_M:
        return False
    R = T_r[:3, :3].T @ T_k[:3, :3]            # frame k's camera axes in frame r's camera
    if rotation_angle_rad(R) > np.pi / 4:
        return False
    corners = np.array([[0, 0, 1], [width - 1, 0, 1], [0, height - 1, 1], [width - 1, height - 1, 1]], float)
    p = (K @ R @ np.linalg.solve(K, corners.T)).T
    return bool(np.all(np.hypot(*(p[:, :2] / p[:, 2:] - corners[:, :2]).T) <= MAX_SHIFT_PX))


def source_pixels(depth_k: np.ndarray, K: np.ndarray, T_world_cam_r: np.ndarray,
                  T_world_cam_k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) in frame r's image of what every pixel of frame k sees (OpenCV pixel centres),
    through frame k's planar depth (the background, depth past BACKGROUND_THRESHOLD, at
    infinity: turned, not moved)."""
    h, w = depth_k.shape
    rays = pixel_rays(K, w, h)                                  # z = 1 in camera k
    R_rk = T_world_cam_r[:3, :3].T @ T_world_cam_k[:3, :3]
    t_rk = T_world_cam_r[:3, :3].T @ (T_world_cam_k[:3, 3] - T_world_cam_r[:3, 3])
    z = depth_k.astype(np.float64)
    far = ~(z < BACKGROUND_THRESHOLD)
    X = rays @ R_rk.T + np.where(far, 0.0, 1.0 / np.where(far, 1.0, z))[..., None] * t_rk
    return K[0, 0] * X[..., 0] / X[..., 2] + K[0, 2], K[1, 1] * X[..., 1] / X[..., 2] + K[1, 2]


def reprojection(depth_k: np.ndarray, K: np.ndarray, T_world_cam_r: np.ndarray,
                 T_world_cam_k: np.ndarray) -> Callable[[dict], dict]:
    """A function taking frame r's image channels to frame k's camera (same dtype and shape);
    the sampling positions are found once, for every image it is given (the EXR's, the PNG's)."""
    taps = _taps(*source_pixels(depth_k, K, T_world_cam_r, T_world_cam_k), depth_k.shape)

    def move(channels_r: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {name: _evaluate(bspline_coefficients(a.astype(np.float64)), taps).astype(a.dtype)
                for name, a in channels_r.items()}
    return move


def reproject(channels_r: dict[str, np.ndarray], depth_k: np.ndarray, K: np.ndarray,
              T_world_cam_r: np.ndarray, T_world_cam_k: np.ndarray) -> dict[str, np.ndarray]:
    """Frame r's image channels as frame k's camera sees them (same dtype and shape)."""
    return reprojection(depth_k, K, T_world_cam_r, T_world_cam_k)(channels_r)


def bspline_coefficients(img: np.ndarray) -> np.ndarray:
    """The cubic B-spline coefficients interpolating ``img`` (2-D), mirror boundaries
    (scipy.ndimage.spline_filter(order=3, mode='mirror'))."""
    c = img
    for axis in (0, 1):
        c = np.moveaxis(_prefilter_1d(np.moveaxis(c, axis, 0)), 0, axis)
    return c


def _prefilter_1d(s: np.ndarray) -> np.ndarray:
    """Unser's recursive cubic B-spline prefilter along axis 0 (mirror-symmetric signal)."""
    z, n = _POLE, s.shape[0]
    if n == 1:
        return s.copy()
    c = np.empty_like(s)
    horizon = min(n, 40)                                        # z^40 ~ 1e-23
    # the causal start sum_i z^i s[i] by Horner's rule, elementwise: a BLAS dot here (the
    # tensordot this was) woke every core's BLAS thread for each image row and column of a
    # still frame (OpenBLAS threads a dot of 40 x >= 231 values), which then spin ~0.1 s
    # waiting for more (issue 29: the hall's +11 CPU s a stereo frame on 16 cores since session
    # 14, by that reckoning); and its result could depend on how the BLAS splits the work
    c0 = s[horizon - 1].copy()
    for i in range(horizon - 2, -1, -1):
        c0 = s[i] + z * c0
    c[0] = c0
    for i in range(1, n):
        c[i] = s[i] + z * c[i - 1]
    c[n - 1] = (z / (z * z - 1.0)) * (c[n - 1] + z * c[n - 2])
    for i in range(n - 2, -1, -1):
        c[i] = z * (c[i + 1] - c[i])
    return 6.0 * c


def _weights(t: np.ndarray) -> list[np.ndarray]:
    """Cubic B-spline weights of the taps i-1 .. i+2 for the fraction t in [0, 1)."""
    t2, t3 = t * t, t * t * t
    return [(1 - t) ** 3 / 6, (3 * t3 - 6 * t2 + 4) / 6, (-3 * t3 + 3 * t2 + 3 * t + 1) / 6, t3 / 6]


def _mirror(i: np.ndarray, n: int) -> np.ndarray:
    if n == 1:
        return np.zeros_like(i)
    period = 2 * (n - 1)
    i = np.mod(i, period)
    return np.where(i >= n, period - i, i)


def _taps(x: np.ndarray, y: np.ndarray, shape: tuple[int, int]):
    h, w = shape
    ix, iy = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    wx, wy = _weights(x - ix), _weights(y - iy)
    cols = [_mirror(ix + d, w) for d in (-1, 0, 1, 2)]
    rows = [_mirror(iy + d, h) for d in (-1, 0, 1, 2)]
    return rows, cols, wy, wx


def _evaluate(coeffs: np.ndarray, taps) -> np.ndarray:
    rows, cols, wy, wx = taps
    out = np.zeros(rows[0].shape)
    for r, a in zip(rows, wy):
        line = np.zeros(rows[0].shape)
        for c, b in zip(cols, wx):
            line += b * coeffs[r, c]
        out += a * line
    return out
