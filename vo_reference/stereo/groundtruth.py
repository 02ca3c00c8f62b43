"""Ground truth at keypoints, for the error-source switches ``--gt-depth`` / ``--gt-flow`` /
``--mask-dynamic-gt``.

From a render's exact planar depth (``depth_m``, +inf = background), the intrinsics K and
the ground-truth relative motion ``T_k_k1`` (pose of the left camera at k+1 in the left
camera frame at k), this gives each keypoint's depth and where it lands in the next frame's
left and right images. The render's depth pass is point-sampled at the pixel centre
(blender-facts.md), so at integer keypoint positions it is the exact depth of the ray.

With moving objects (``ids_m`` and ``point_motion`` {id: D}, D = how a point fixed on
the object moves from k to k+1, in camera-k coordinates — see groundtruth.scene_flow) a
keypoint on a mover lands where the *moved* point projects, and :meth:`static` tells the
keypoints off the movers (the ground-truth motion mask, grown by ``MASK_MARGIN_PX`` so that
a keypoint rounding onto a mover's edge counts as on it).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from blender_sesgen.contract import rig
from blender_sesgen.contract.camera import backproject, project
from blender_sesgen.contract.se3 import invert


MASK_MARGIN_PX = 1  # --mask-dynamic-gt also drops keypoints within 1 px of a moving object


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
    ids_m: np.ndarray | None = None                    # (H, W) object ids at frame k
    point_motion: dict = field(default_factory=dict)   # id -> (4, 4) D: the object's motion k -> k+1, camera-k coords

    def depth(self, pts: np.ndarray) -> np.ndarray:
        return depth_at(self.depth_m, pts)

    def dynamic_mask(self, margin_px: int = 0) -> np.ndarray:
        """bool (H, W): pixels at k on an object that moves from k to k+1, grown by ``margin_px``."""
        H, W = self.depth_m.shape
        if self.ids_m is None or not self.point_motion:
            return np.zeros((H, W), bool)
        m = np.isin(self.ids_m, list(self.point_motion))
        if margin_px > 0 and m.any():
            import cv2
            k = 2 * int(margin_px) + 1
            m = cv2.dilate(m.astype(np.uint8), np.ones((k, k), np.uint8)).astype(bool)
        return m

    def dynamic_share(self) -> float:
        """Fraction of the image's pixels on objects that move from k to k+1."""
        return float(self.dynamic_mask().mean())

    def static(self, pts: np.ndarray, margin_px: int = None) -> np.ndarray:
        """bool (N,): keypoints (x, y) off the moving objects (at the rounded pixel, the
        motion mask grown by ``margin_px``, default MASK_MARGIN_PX); outside the image: True."""
        m = self.dynamic_mask(MASK_MARGIN_PX if margin_px is None else margin_px)
        p = np.rint(np.asarray(pts, dtype=float)).astype(np.int64).reshape(-1, 2)
        H, W = m.shape
        inside = (p[:, 0] >= 0) & (p[:, 0] < W) & (p[:, 1] >= 0) & (p[:, 1] < H)
        out = np.ones(p.shape[0], bool)
        out[inside] = ~m[p[inside, 1], p[inside, 0]]
        return out

    def correspondences(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where keypoints of the left image at k land at k+1: left (N, 2) and right (N, 2) pixels.

        NaN where the keypoint has no usable depth or lands behind the camera.
        """
        Z = self.depth(pts)
        P0 = backproject(self.K, pts, Z)
        if self.point_motion and self.ids_m is not None:   # points on movers move with them
            p = np.rint(np.asarray(pts, dtype=float)).astype(np.int64).reshape(-1, 2)
            H, W = self.ids_m.shape
            ok = (p[:, 0] >= 0) & (p[:, 0] < W) & (p[:, 1] >= 0) & (p[:, 1] < H)
            ids = np.zeros(p.shape[0], np.int64)
            ids[ok] = self.ids_m[p[ok, 1], p[ok, 0]]
            for obj_id, D in self.point_motion.items():
                on = ids == obj_id
                P0[on] = P0[on] @ D[:3, :3].T + D[:3, 3]
        T_k1_k = invert(self.T_k_k1)
        P1 = P0 @ T_k1_k[:3, :3].T + T_k1_k[:3, 3]
        P1[P1[:, 2] <= 0] = np.nan
        left = project(self.K, P1)
        right = project(self.K, rig.points_in_view(P1, "right", self.baseline_m))
        return left, right
