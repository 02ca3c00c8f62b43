"""Ground truth at keypoints, for the error-source switches ``--gt-depth`` / ``--gt-flow``.

From a render's exact planar depth (``depth_m``, +inf = background), the intrinsics K and
the ground-truth relative motion ``T_k_k1`` (pose of the left camera at k+1 in the left
camera frame at k), this gives each keypoint's depth and where it lands in the next frame's
left and right images. The render's depth pass is point-sampled at the pixel centre
(blender-facts.md), so at integer keypoint positions it is the exact depth of the ray.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blender_sesgen.contract.camera import backproject, project
from blender_sesgen.contract.se3 import invert



def depth_at(depth_m: np.ndarray, pts: np.ndarray, smooth_tol: float | None = 0.02) -> np.ndarray:
    """Depth (N,) at integer keypoints (x, y); NaN outside the image or on background.

    With ``smooth_tol``, keypoints whose 3x3 neighbourhood spans a depth discontinuity
    (relative spread > tol) get NaN: a corner on an occluding edge sees two surfaces,
    and an image-based tracker follows neither exactly.
    """
    p = np.rint(np.asarray(pts, dtype=float)).astype(np.int64)
    H, W = depth_m.shape
    out = np.full(p.shape[0], np.nan)
    ok = (p[:, 0] >= 1) & (p[:, 0] < W - 1) & (p[:, 1] >= 1) & (p[:, 1] < H - 1)
    x, y = p[ok, 0], p[ok, 1]
    z = depth_m[y, x].astype(float)
    if smooth_tol is not None:
        nb = np.stack([depth_m[y + dy, x + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=1).astype(float)
        with np.errstate(invalid="ignore"):
            spread = (nb.max(axis=1) - nb.min(axis=1)) / z
        z = np.where(np.isfinite(spread) & (spread <= smooth_tol), z, np.nan)
    z = np.where(np.isfinite(z) & (z > 0), z, np.nan)
    out[ok] = z
    return out


@dataclass
class GroundTruthStep:
    """Ground truth of one frame step k -> k+1 of a rectified rig."""

    depth_m: np.ndarray       # (H, W) left planar depth at frame k (+inf background)
    K: np.ndarray             # (3, 3)
    baseline_m: float
    T_k_k1: np.ndarray        # (4, 4) left camera at k+1 in the left camera frame at k

    def depth(self, pts: np.ndarray) -> np.ndarray:
        return depth_at(self.depth_m, pts)

    def correspondences(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where keypoints of the left image at k land at k+1: left (N, 2) and right (N, 2) pixels.

        NaN where the keypoint has no usable depth or lands behind the camera.
        """
        Z = self.depth(pts)
        P0 = backproject(self.K, pts, Z)
        T_k1_k = invert(self.T_k_k1)
        P1 = P0 @ T_k1_k[:3, :3].T + T_k1_k[:3, 3]
        P1[P1[:, 2] <= 0] = np.nan
        left = project(self.K, P1)
        right = project(self.K, P1 - np.array([self.baseline_m, 0.0, 0.0]))
        return left, right
