"""Dense per-pixel ground truth for the learning-data layouts (TartanAir, Virtual KITTI 2,
SceneFlow): optical flow for *every* pixel, background included, and the disparity change.

The surface pixels' flow and visibility come from :func:`vo_reference.groundtruth.flow.sequence_flow`
(the one flow product). Pixels that see nothing (depth +inf) are points at infinity: they
move with the rotation alone, p' = π(K·R_tgt_src·K⁻¹·p), which is the limit of the flow of
ever farther points and what those datasets hold for their sky (TartanAir computes its flow
from a sky depth of ~10 km). Such a pixel is *out of image* when p' falls outside the
target image (same bounds as :mod:`.flow`) and *hidden* when the target sees a surface at
the pixel nearest to p'.

Disparity change (SceneFlow's ``disparity_change``): d_tgt − d_src = fx·B/z_tgt − fx·B/z_src,
z_tgt the point's depth in the target camera (the warp of
:func:`vo_reference.groundtruth.flow.warp_depth`, which moves the pixels of moving objects with
them); 0 for points at infinity.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blender_sesgen.contract.depth import disparity_of_depth
from blender_sesgen.contract.se3 import invert

from ..errors import VoError
from .flow import object_transforms, sequence_flow, sequence_object_poses, warp_depth
from .options import pop_number

__all__ = ["DenseFlow", "dense_flow", "flow_at_infinity", "disparity_change", "pop_background_depth",
           "DEFAULT_BACKGROUND_DEPTH"]

DEFAULT_BACKGROUND_DEPTH = 10000.0   # metres: what the learning layouts' depth holds for the sky


@dataclass(frozen=True)
class DenseFlow:
    """Flow from a source frame to a target frame of one view (all arrays (H, W))."""
    flow: np.ndarray          # float32 (H, W, 2); NaN only where the point is behind the target camera
    has_depth: np.ndarray     # bool (H, W): the source pixel sees a surface (else: a point at infinity)
    out_of_image: np.ndarray  # bool: p' outside the target image or behind its camera
    hidden: np.ndarray        # bool: in the image but behind a surface of the target view

    @property
    def visible(self) -> np.ndarray:
        return ~(self.out_of_image | self.hidden)


def _pixel_grid(H: int, W: int) -> tuple[np.ndarray, np.ndarray]:
    return np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))


def flow_at_infinity(K: np.ndarray, R_tgt_src: np.ndarray, H: int, W: int) -> tuple[np.ndarray, np.ndarray]:
    """(flow (H, W, 2) float64, in_front (H, W) bool) of points at infinity: p' = π(K R K⁻¹ p)."""
    K = np.asarray(K, dtype=np.float64)
    uu, vv = _pixel_grid(H, W)
    pix = np.stack([uu, vv, np.ones_like(uu)], axis=-1)
    rays = pix @ np.linalg.inv(K).T @ np.asarray(R_tgt_src, dtype=np.float64).T
    front = rays[..., 2] > 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        proj = rays @ K.T
        u = np.where(front, proj[..., 0] / proj[..., 2], np.nan)
        v = np.where(front, proj[..., 1] / proj[..., 2], np.nan)
    return np.stack([u - uu, v - vv], axis=-1), front


def dense_flow(seq, k_src: int, k_tgt: int, view: str = "left", rtol: float = 1e-3) -> DenseFlow:
    """Flow of ``view`` from frame ``k_src`` to ``k_tgt`` for every pixel (module docstring)."""
    T = seq.T_world_cam(view)
    if T is None:
        raise VoError(f"{seq!r} has no pose ground truth: cannot derive optical flow")
    fl = sequence_flow(seq, k_src, k_tgt, view, rtol)
    H, W = fl.valid.shape
    R = (invert(T[k_tgt]) @ T[k_src])[:3, :3]
    f_inf, front = flow_at_infinity(seq.K, R, H, W)
    bg = ~fl.valid
    flow = np.where(bg[..., None], f_inf, fl.flow).astype(np.float32)
    uu, vv = _pixel_grid(H, W)
    u, v = uu + f_inf[..., 0], vv + f_inf[..., 1]
    inside = front & (u >= -0.5) & (u < W - 0.5) & (v >= -0.5) & (v < H - 0.5)
    out_bg = bg & ~inside
    hidden_bg = np.zeros_like(bg)
    z_tgt = seq.depth(k_tgt, view)
    sel = bg & inside
    if sel.any():
        xi = np.clip(np.rint(u[sel]), 0, W - 1).astype(np.intp)
        yi = np.clip(np.rint(v[sel]), 0, H - 1).astype(np.intp)
        hidden_bg[sel] = np.isfinite(z_tgt[yi, xi])
    hidden = (fl.valid & fl.occluded & ~fl.out_of_image) | hidden_bg
    return DenseFlow(flow=flow, has_depth=fl.valid, out_of_image=(fl.valid & fl.out_of_image) | out_bg,
                     hidden=hidden)


def disparity_change(seq, k_src: int, k_tgt: int, view: str = "left") -> np.ndarray:
    """float32 (H, W): fx·B/z_tgt − fx·B/z_src of each source pixel's point, moved with its
    object when it moves (0 at infinity; NaN where the point is behind the target camera)."""
    if seq.baseline_m <= 0:
        raise VoError("disparity change needs a stereo sequence (baseline 0)")
    T = seq.T_world_cam(view)
    z_src = seq.depth(k_src, view)
    if T is None or z_src is None:
        raise VoError(f"{seq!r} has no depth/pose ground truth: cannot derive the disparity change")
    objs = sequence_object_poses(seq, k_src, k_tgt)
    w = warp_depth(z_src, seq.K, invert(T[k_tgt]) @ T[k_src], ids_src=seq.ids(k_src, view) if objs else None,
                   T_tgt_src_by_id=object_transforms(T[k_src], T[k_tgt], objs))
    out = np.zeros(z_src.shape, dtype=np.float64)
    ok = w.valid & np.isfinite(w.z)
    out[ok] = (disparity_of_depth(w.z[ok], seq.K[0, 0], seq.baseline_m)
               - disparity_of_depth(np.asarray(z_src, np.float64)[ok], seq.K[0, 0], seq.baseline_m))
    out[w.valid & ~np.isfinite(w.z)] = np.nan
    return out.astype(np.float32)


def pop_background_depth(extra: dict, default: float = DEFAULT_BACKGROUND_DEPTH) -> float:
    """Take ``background_depth`` (``--opt background_depth=M``, metres or inf: the depth
    written where a pixel sees nothing) out of an export's options."""
    return pop_number(extra, "background_depth", float, default, "metres (a number or inf)")
