"""Optical flow and occlusion ground truth from depth + K + poses (+ ids and object poses).

A source pixel p = (u, v) with planar depth Z back-projects to X_src = Z·K⁻¹(u, v, 1)ᵀ,
moves to the target camera X_tgt = T_tgt_src·X_src and projects to p' = π(K·X_tgt); the
flow is p' − p. On a moving object (its id in the source frame's id map) the point also
moves with the object: X_tgt = T_tgt_src_i·X_src with
T_tgt_src_i = T_world_tgt⁻¹ · T_world_obj_i(tgt) · T_world_obj_i(src)⁻¹ · T_world_src
(:mod:`vo_reference.groundtruth.scene_flow` adds the 3-D motion, motion masks and disparity
change). Pixels of static objects take the static path unchanged, to the bit. The point
is checked against the target frame's own depth map (which shows every object where it
is at the target time):

- *out of image*: p' outside the target image (pixel centres at integers, the image
  covers [−0.5, W−0.5) × [−0.5, H−0.5)) or X_tgt behind the camera;
- *hidden*: the target depth at p' is smaller than X_tgt's depth (something is in front).
  The target depth is sampled by bilinear interpolation of **inverse** depth over the
  2×2 neighbours of p' (exact for a plane; extrapolated in the half-pixel image border),
  with relative tolerance ``rtol``;
- *occluded* = out of image or hidden; *valid* = the source depth is finite.

Stereo occlusion uses the same test with T_right_left = trans(−B, 0, 0): a left pixel
whose point has no visible partner in the right view.

Flow arrays are float32 (H, W, 2) (u, v), NaN where the source pixel has no depth.
Files: Middlebury ``.flo`` (invalid = 1e10, readers treat > 1e9 as unknown) and KITTI
flow PNG (16-bit RGB: u·64 + 2¹⁵, v·64 + 2¹⁵, valid flag).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract import rig
from blender_sesgen.contract.se3 import invert

from ..errors import VoError
from ..io.files import read_binary, read_image, write_image_atomic

FLO_MAGIC = 202021.25
FLO_UNKNOWN = 1e10


@dataclass(frozen=True)
class Warp:
    """Where each source pixel goes in the target view (all (H, W))."""
    u: np.ndarray          # float64 target x, NaN where not valid
    v: np.ndarray          # float64 target y
    z: np.ndarray          # float64 depth in the target camera
    valid: np.ndarray      # bool: source depth finite (and > 0)
    out_of_image: np.ndarray  # bool: valid and (p' outside the image or behind the camera)
    hidden: np.ndarray     # bool: valid, in the image, and behind the target's surface
    X_src: np.ndarray | None = None  # float64 (H, W, 3) source-camera point (0 where not valid)
    X_tgt: np.ndarray | None = None  # float64 (H, W, 3) the point in the target camera

    @property
    def occluded(self) -> np.ndarray:
        return self.out_of_image | self.hidden

    @property
    def visible(self) -> np.ndarray:
        return self.valid & ~self.occluded


def warp_depth(depth_src: np.ndarray, K: np.ndarray, T_tgt_src: np.ndarray,
               depth_tgt: np.ndarray | None = None, rtol: float = 1e-3, lens=None,
               ids_src: np.ndarray | None = None, T_tgt_src_by_id: dict | None = None) -> Warp:
    """Project every source pixel into the target view and test its visibility there
    (``depth_tgt`` None: only the out-of-image test). ``lens`` (``contract.lens.Lens``): the
    images are distorted; pixels back-project along the lens's rays and project through it.
    ``T_tgt_src_by_id`` {id: 4x4} moves the pixels of those ids (``ids_src``) with their own
    transform instead of ``T_tgt_src`` (moving objects)."""
    z_src = np.asarray(depth_src, dtype=np.float64)
    H, W = z_src.shape
    K = np.asarray(K, dtype=np.float64)
    T = np.asarray(T_tgt_src, dtype=np.float64)
    valid = np.isfinite(z_src) & (z_src > 0)
    uu, vv = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    zs = np.where(valid, z_src, 0.0)
    # back-project: X = Z·K⁻¹(u, v, 1) (general K, skew included)
    if lens is None:
        Kinv = np.linalg.inv(K)
        pix = np.stack([uu, vv, np.ones_like(uu)], axis=-1)
        Xs = (pix @ Kinv.T) * zs[..., None]
    else:   # planar depth along the lens's ray of each (distorted) pixel
        rays = lens.pixel_rays(W, H)
        Xs = rays / rays[..., 2:3] * zs[..., None]
    Xt = Xs @ T[:3, :3].T + T[:3, 3]
    if T_tgt_src_by_id and ids_src is not None:
        ids = np.asarray(ids_src)
        if ids.shape != (H, W):
            raise VoError(f"id map is {ids.shape}, depth {(H, W)}")
        for obj_id, T_obj in T_tgt_src_by_id.items():
            on = valid & (ids == obj_id)
            if on.any():
                T_obj = np.asarray(T_obj, dtype=np.float64)
                Xt[on] = Xs[on] @ T_obj[:3, :3].T + T_obj[:3, 3]
    zt = Xt[..., 2]
    front = valid & (zt > 1e-12)
    with np.errstate(divide="ignore", invalid="ignore"):
        if lens is None:
            proj = Xt @ K.T
            u = np.where(front, proj[..., 0] / proj[..., 2], np.nan)
            v = np.where(front, proj[..., 1] / proj[..., 2], np.nan)
        else:
            px = lens.project(np.where(front[..., None], Xt, np.array([0.0, 0.0, 1.0])))
            u = np.where(front, px[..., 0], np.nan)
            v = np.where(front, px[..., 1], np.nan)
    inside = front & (u >= -0.5) & (u < W - 0.5) & (v >= -0.5) & (v < H - 0.5)
    out = valid & ~inside
    hidden = np.zeros_like(valid)
    if depth_tgt is not None:
        zt_map = np.asarray(depth_tgt, dtype=np.float64)
        if zt_map.shape != (H, W):
            raise VoError(f"target depth is {zt_map.shape}, source {(H, W)}")
        hidden[inside] = hidden_behind(zt_map, u[inside], v[inside], zt[inside], rtol)
    return Warp(u=u, v=v, z=np.where(front, zt, np.nan), valid=valid, out_of_image=out, hidden=hidden,
                X_src=Xs, X_tgt=Xt)


def hidden_behind(depth_map: np.ndarray, u: np.ndarray, v: np.ndarray, z: np.ndarray,
                  rtol: float = 1e-3) -> np.ndarray:
    """bool: points at pixels (u, v) (inside the image) with planar depth ``z`` lie behind
    the surface of ``depth_map`` there by more than ``rtol`` (relative). The surface's
    depth is bilinear in inverse depth over the 2x2 cell around (u, v) (exact for a plane;
    in the half-pixel image border the cell's plane is extrapolated)."""
    # hidden  <=>  z_point > z_surface·(1+rtol)  <=>  inv_surface·z_point > 1 + rtol
    return surface_inverse_depth(depth_map, u, v) * z > 1.0 + rtol


def surface_inverse_depth(depth_map: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """1/z of the surface of ``depth_map`` at pixels (u, v): bilinear in inverse depth over
    the 2x2 cell around (u, v) (0 where the map sees nothing; exact for a plane)."""
    zt_map = np.asarray(depth_map, dtype=np.float64)
    H, W = zt_map.shape
    with np.errstate(divide="ignore"):
        inv = np.where(np.isfinite(zt_map) & (zt_map > 0), 1.0 / zt_map, 0.0)
    x0 = np.clip(np.floor(u), 0, max(W - 2, 0)).astype(np.intp)
    y0 = np.clip(np.floor(v), 0, max(H - 2, 0)).astype(np.intp)
    x1 = np.minimum(x0 + 1, W - 1)
    y1 = np.minimum(y0 + 1, H - 1)
    ax = u - x0
    ay = v - y0
    return ((1 - ax) * (1 - ay) * inv[y0, x0] + ax * (1 - ay) * inv[y0, x1]
            + (1 - ax) * ay * inv[y1, x0] + ax * ay * inv[y1, x1])


@dataclass(frozen=True)
class Flow:
    flow: np.ndarray        # float32 (H, W, 2), NaN where not valid
    valid: np.ndarray       # bool: source depth known
    occluded: np.ndarray    # bool: valid but hidden or out of image in the target frame
    out_of_image: np.ndarray

    @property
    def noc(self) -> np.ndarray:
        """Valid and not occluded (KITTI's 'noc')."""
        return self.valid & ~self.occluded


def object_transforms(T_world_src, T_world_tgt, object_poses: dict | None) -> dict:
    """{id: T_tgt_src_i} for the objects that move between the two instants
    (``object_poses`` {id: (T_world_obj at source, T_world_obj at target)}; objects whose two
    poses are equal are left out: their pixels take the static path)."""
    out = {}
    if not object_poses:
        return out
    T_tgt_world = invert(np.asarray(T_world_tgt, float))
    T_world_src = np.asarray(T_world_src, float)
    for obj_id, (T_obj_src, T_obj_tgt) in object_poses.items():
        T_obj_src, T_obj_tgt = np.asarray(T_obj_src, float), np.asarray(T_obj_tgt, float)
        if np.array_equal(T_obj_src, T_obj_tgt):
            continue
        out[int(obj_id)] = T_tgt_world @ (T_obj_tgt @ invert(T_obj_src)) @ T_world_src
    return out


def flow_from_depth(depth_src, K, T_world_src, T_world_tgt, depth_tgt=None, rtol: float = 1e-3,
                    lens=None, ids_src=None, object_poses: dict | None = None) -> Flow:
    """Flow from a source frame to a target frame of the same camera; ``lens``: of a
    distorted render (flow between distorted images). With ``ids_src`` and ``object_poses``
    {id: (T_world_obj at source, at target)} the pixels of moving objects move with them;
    without, the scene is static."""
    T_tgt_src = invert(np.asarray(T_world_tgt, float)) @ np.asarray(T_world_src, float)
    w = warp_depth(depth_src, K, T_tgt_src, depth_tgt, rtol, lens, ids_src=ids_src,
                   T_tgt_src_by_id=object_transforms(T_world_src, T_world_tgt, object_poses))
    H, W = w.u.shape
    uu, vv = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    f = np.stack([w.u - uu, w.v - vv], axis=-1)
    f[~w.valid] = np.nan
    return Flow(flow=f.astype(np.float32), valid=w.valid, occluded=w.valid & w.occluded,
                out_of_image=w.out_of_image)


def sequence_object_poses(seq, k_src: int, k_tgt: int) -> dict:
    """{id: (T_world_obj at k_src, at k_tgt)} of a sequence's moving objects ({} if none)."""
    ids = seq.moving_ids
    out = {}
    for obj_id in ids:
        T = seq.T_world_obj(obj_id)
        out[obj_id] = (T[k_src], T[k_tgt])
    return out


def sequence_flow(seq, k_src: int, k_tgt: int, view: str = "left", rtol: float = 1e-3) -> Flow:
    """Flow of ``view`` from frame k_src to frame k_tgt (forward: k+1, backward: k-1);
    moving objects (the manifest's ``T_world_obj``) move their pixels."""
    T = seq.T_world_cam(view)
    z_src = seq.depth(k_src, view)
    if T is None or z_src is None:
        raise VoError(f"{seq!r} has no depth/pose ground truth: cannot derive optical flow")
    objs = sequence_object_poses(seq, k_src, k_tgt)
    ids = seq.ids(k_src, view) if objs else None
    if objs and ids is None:
        raise VoError(f"{seq!r} has moving objects but no id maps: cannot tell their pixels apart")
    return flow_from_depth(z_src, seq.K, T[k_src], T[k_tgt], seq.depth(k_tgt, view), rtol,
                           lens=seq.lens, ids_src=ids, object_poses=objs)


def forward_flow(seq, k: int, view: str = "left") -> Flow:
    return sequence_flow(seq, k, k + 1, view)


def backward_flow(seq, k: int, view: str = "left") -> Flow:
    return sequence_flow(seq, k, k - 1, view)


def stereo_occlusion(depth_left, depth_right, K, baseline_m: float, rtol: float = 1e-3) -> np.ndarray:
    """bool (H, W): left pixels with depth whose point has no visible partner in the right
    view (hidden there or outside the right image)."""
    w = warp_depth(depth_left, K, rig.T_right_left(baseline_m), depth_right, rtol)
    return w.valid & w.occluded


def stereo_occlusion_right(depth_right, depth_left, K, baseline_m: float, rtol: float = 1e-3) -> np.ndarray:
    """The same for right pixels (partner sought in the left view)."""
    w = warp_depth(depth_right, K, rig.T_left_right(baseline_m), depth_left, rtol)
    return w.valid & w.occluded


def sequence_stereo_occlusion(seq, k: int, view: str = "left", rtol: float = 1e-3) -> np.ndarray:
    if seq.baseline_m <= 0 or "right" not in seq.views:
        raise VoError("stereo occlusion needs a stereo sequence")
    zl, zr = seq.depth(k, "left"), seq.depth(k, "right")
    if zl is None or zr is None:
        raise VoError(f"{seq!r} has no depth ground truth")
    if view == "left":
        return stereo_occlusion(zl, zr, seq.K, seq.baseline_m, rtol)
    return stereo_occlusion_right(zr, zl, seq.K, seq.baseline_m, rtol)


# --- files ------------------------------------------------------------------------------

def write_flo(path, flow: np.ndarray) -> Path:
    """Middlebury .flo: 'PIEH' (float 202021.25), int32 W, H, float32 (u, v) row-major;
    NaN -> 1e10 (unknown)."""
    f = np.asarray(flow, dtype=np.float32)
    if f.ndim != 3 or f.shape[2] != 2:
        raise VoError(f"{path}: flow must be (H, W, 2), got {f.shape}")
    H, W = f.shape[:2]
    f = np.where(np.isfinite(f), f, np.float32(FLO_UNKNOWN)).astype("<f4")
    data = np.array([FLO_MAGIC], "<f4").tobytes() + np.array([W, H], "<i4").tobytes() + f.tobytes()
    return atomic.write_bytes(path, data)


def read_flo(path) -> np.ndarray:
    """(H, W, 2) float32, NaN where unknown (|value| > 1e9)."""
    path = Path(path)
    raw = read_binary(path, ".flo file")
    if len(raw) < 12 or np.frombuffer(raw[:4], "<f4")[0] != np.float32(FLO_MAGIC):
        raise VoError(f"{path}: not a Middlebury .flo file (bad magic)")
    W, H = (int(x) for x in np.frombuffer(raw[4:12], "<i4"))
    if not (0 < W <= 65536 and 0 < H <= 65536):
        raise VoError(f"{path}: .flo size {W}x{H} is not an image size")
    if len(raw) < 12 + 8 * W * H:
        raise VoError(f"{path}: .flo data has {len(raw) - 12} bytes, {W}x{H} needs {8 * W * H} (truncated?)")
    f = np.frombuffer(raw, "<f4", count=2 * W * H, offset=12).reshape(H, W, 2).astype(np.float32)
    f[np.abs(f) > 1e9] = np.nan
    return f


def write_kitti_flow_png(path, flow: np.ndarray, valid: np.ndarray | None = None) -> Path:
    """KITTI flow PNG (16-bit, 3 channels R, G, B = u·64 + 2¹⁵, v·64 + 2¹⁵, valid).
    ``valid`` defaults to the finite flow vectors; a vector the encoding cannot hold (a
    component beyond −512..+511.98 px) is written invalid, never clipped: clipped, it would
    read back as a plausible but wrong flow."""
    f = np.asarray(flow, dtype=np.float64)
    ok = np.all(np.isfinite(f), axis=-1) if valid is None else (np.asarray(valid, bool) & np.all(np.isfinite(f), axis=-1))
    code = np.rint(np.where(np.isfinite(f), f, 0.0) * 64.0 + 32768.0)
    ok &= np.all((code >= 0) & (code <= 65535), axis=-1)
    img = np.zeros(f.shape[:2] + (3,), np.uint16)
    for c in range(2):
        img[..., c][ok] = code[..., c][ok].astype(np.uint16)
    img[..., 2] = ok
    return write_image_atomic(path, img[..., ::-1])  # OpenCV writes BGR


def read_kitti_flow_png(path) -> tuple[np.ndarray, np.ndarray]:
    """-> (flow (H, W, 2) float32 with NaN where invalid, valid bool)."""
    img = read_image(path)
    if img.dtype != np.uint16 or img.ndim != 3 or img.shape[2] != 3:
        raise VoError(f"{path}: expected a 16-bit 3-channel PNG (KITTI flow), got {img.dtype} {img.shape}")
    rgb = img[..., ::-1].astype(np.float64)
    valid = rgb[..., 2] > 0
    f = ((rgb[..., :2] - 32768.0) / 64.0).astype(np.float32)
    f[~valid] = np.nan
    return f, valid
