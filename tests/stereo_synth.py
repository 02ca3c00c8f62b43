"""A textured slanted plane seen by a moving stereo rig, rendered exactly by ray casting
(independent of the VO code): images, planar depth and poses for the stereo VO tests."""
from __future__ import annotations

import cv2
import numpy as np

from blender_sesgen.contract.se3 import se3_exp
from vo_reference.io.base import Sequence

F, W, H, B = 300.0, 320, 240, 0.12
K = np.array([[F, 0, (W - 1) / 2], [0, F, (H - 1) / 2], [0, 0, 1.0]])
N_PLANE = np.array([0.15, -0.1, 1.0]) / np.linalg.norm([0.15, -0.1, 1.0])
D_PLANE = 3.0                      # plane n.X = d in the world (= camera 0) frame
TEX_UNITS_PER_PX = 0.004


def _texture(seed=0, size=2048):
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.uniform(0, 255, (size, size)).astype(np.float32), (0, 0), 2.5)
    t = (t - t.mean()) / t.std() * 45 + 128
    return np.clip(t, 0, 255).astype(np.float32)


def view(T_world_cam, tex):
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    r = np.stack([(u - K[0, 2]) / F, (v - K[1, 2]) / F, np.ones_like(u)], -1)
    R, C = T_world_cam[:3, :3], T_world_cam[:3, 3]
    s = (D_PLANE - N_PLANE @ C) / (r @ (R.T @ N_PLANE))
    Xw = C + s[..., None] * (r @ R.T)
    e1 = np.cross([0, 1.0, 0], N_PLANE); e1 /= np.linalg.norm(e1)
    e2 = np.cross(N_PLANE, e1)
    mx = (Xw @ e1 / TEX_UNITS_PER_PX + tex.shape[1] / 2).astype(np.float32)
    my = (Xw @ e2 / TEX_UNITS_PER_PX + tex.shape[0] / 2).astype(np.float32)
    img = cv2.remap(tex, mx, my, cv2.INTER_LINEAR)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8), s.astype(np.float32)


def sequence(twists, seed=0):
    """Images (left, right), left depth and left poses of a rig moving by ``twists`` (N-1, 6)
    [U V W alpha beta gamma] (rad), T(k+1) = T(k) exp([omega, v])."""
    tex = _texture(seed)
    T = [np.eye(4)]
    for X in twists:
        T.append(T[-1] @ se3_exp(np.asarray(X[3:]), np.asarray(X[:3])))
    T_right = np.eye(4)
    T_right[0, 3] = B
    frames = []
    for Tk in T:
        left, depth = view(Tk, tex)
        right, depth_r = view(Tk @ T_right, tex)
        frames.append({"left": left, "right": right, "depth": depth, "depth_right": depth_r})
    return frames, np.stack(T)


def smooth_twists(n, seed=1):
    """Paper-sized per-frame motions (Table 1 magnitudes), varying smoothly."""
    k = np.arange(n)[:, None]
    amp = np.array([0.02, 0.02, 0.03, np.radians(0.6), np.radians(0.5), np.radians(0.3)])
    phase = np.random.default_rng(seed).uniform(0, 2 * np.pi, 6)
    return amp * np.sin(0.3 * k + phase)


class ArraySequence(Sequence):
    """The :class:`vo_reference.io.sequence.Sequence` interface over in-memory frames."""

    def __init__(self, frames, T_world_left):
        self.frames, self._T = frames, T_world_left
        self.K, self.baseline_m, self.resolution = K, B, (W, H)
        self.num_frames, self.views = len(frames), ("left", "right")
        self.timestamps_s = np.arange(len(frames), dtype=float)

    def image_gray(self, k, view="left"):
        return self.frames[k][view]

    def depth(self, k, view="left"):
        return self.frames[k]["depth" if view == "left" else "depth_right"]

    def T_world_cam(self, view="left"):
        if view == "left":
            return self._T
        Tr = np.eye(4)
        Tr[0, 3] = B
        return self._T @ Tr


def rel_errors(res) -> np.ndarray:
    """Per-step |estimated - true twist| / |true twist| of a VO result (twist [U, V, W,
    alpha, beta, gamma], rad)."""
    e = np.linalg.norm(res.twists - res.gt_twists, axis=1)
    return e / np.linalg.norm(res.gt_twists, axis=1)
