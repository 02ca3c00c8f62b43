"""Scene flow, motion masks and disparity change of scenes with moving objects (exact).

For a source frame k (depth, ids) and a target frame k' (k+1 forward, k-1 backward) of one
camera, with the camera poses T_world_cam and every moving object's T_world_obj at both
frames (the render manifest's ``objects[i].T_world_obj``):

- a pixel's surface point X (source camera, from planar depth) lies on object i (its id);
  between the two instants the object moves by M_i = T_world_obj_i(k') · T_world_obj_i(k)⁻¹
  (the identity for static objects and the background);
- **scene flow** = the 3-D motion of that surface point, expressed in the source camera's
  frame at k, in metres: S = D_i·X − X with D_i = T_world_cam(k)⁻¹ · M_i · T_world_cam(k).
  Static points have zero scene flow whatever the camera does;
- **optical flow** = where the moved point projects in the target camera, minus the pixel:
  X' = T_world_cam(k')⁻¹ · T_world_cam(k) · (X + S), p' = π(K X');
- **occlusion**: X' outside the target image, behind the camera, or behind the target
  frame's depth map at p' (which shows every object where it is at k');
- **dynamic** (motion mask): the pixel's object moves between k and k' (M_i ≠ I);
- **disparity change** (stereo): f·B / Z'(X') − f·B / Z(X), Z' the point's planar depth in
  the target left camera; ``disparity_tgt`` = f·B / Z' is KITTI's ``disp_1`` (the second
  pair's disparity mapped into the reference frame via the flow).

All from :func:`vo_reference.products.flow.warp_depth`, so static pixels give the same
flow and occlusion as the static-scene products, to the bit.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blender_sesgen.contract.depth import disparity_of_depth
from blender_sesgen.contract.se3 import invert

from ..errors import VoError
from .flow import object_transforms, sequence_object_poses, warp_depth


@dataclass(frozen=True)
class SceneFlow:
    """Ground truth of one source frame towards one target frame (all (H, W) maps)."""
    flow: np.ndarray          # float32 (H, W, 2) optical flow (u, v), NaN where not valid
    scene_flow: np.ndarray    # float32 (H, W, 3) metres, source camera frame, NaN where not valid
    depth_tgt: np.ndarray     # float32 planar depth of the moved point in the target camera (NaN: not valid/behind)
    valid: np.ndarray         # bool: source depth finite
    occluded: np.ndarray      # bool: valid and hidden or out of image in the target frame
    out_of_image: np.ndarray  # bool: valid and outside the target image (or behind the camera)
    dynamic: np.ndarray       # bool: valid and on an object that moves between the two frames
    ids: np.ndarray | None    # int32 source id map (None if the sequence has none)
    X_tgt: np.ndarray | None = None  # float64 (H, W, 3) the moved point in the target camera (NaN: not valid)

    @property
    def noc(self) -> np.ndarray:
        """Valid and not occluded (KITTI's 'noc')."""
        return self.valid & ~self.occluded

    def disparity_tgt(self, fx: float, baseline_m: float) -> np.ndarray:
        """float32 f·B / Z' (KITTI ``disp_1``), NaN where not valid or behind the camera."""
        d = disparity_of_depth(self.depth_tgt, fx, baseline_m)
        return np.where(self.valid & (self.depth_tgt > 0), d, np.nan).astype(np.float32)

    def disparity_change(self, depth_src: np.ndarray, fx: float, baseline_m: float) -> np.ndarray:
        """float32 f·B/Z' − f·B/Z (positive: the point comes closer), NaN where not valid."""
        from .disparity import disparity_from_depth
        d0 = disparity_from_depth(depth_src, fx, baseline_m).astype(np.float64)
        return (self.disparity_tgt(fx, baseline_m).astype(np.float64) - d0).astype(np.float32)


def object_motion_in_camera(T_world_cam: np.ndarray, T_world_obj_src: np.ndarray,
                            T_world_obj_tgt: np.ndarray) -> np.ndarray:
    """D = T_world_cam⁻¹ · T_world_obj_tgt · T_world_obj_src⁻¹ · T_world_cam: how a point
    fixed on the object moves, in the coordinates of the (source) camera."""
    T_wc = np.asarray(T_world_cam, float)
    M = np.asarray(T_world_obj_tgt, float) @ invert(np.asarray(T_world_obj_src, float))
    return invert(T_wc) @ M @ T_wc


def scene_flow_from_depth(depth_src, K, T_world_src, T_world_tgt, *, ids_src=None,
                          object_poses: dict | None = None, depth_tgt=None, rtol: float = 1e-3,
                          lens=None) -> SceneFlow:
    """Scene flow, optical flow, occlusion and the motion mask from a source frame to a
    target frame (``object_poses`` {id: (T_world_obj at source, at target)}; ``lens``: of a
    distorted render)."""
    z_src = np.asarray(depth_src)
    T_ws, T_wt = np.asarray(T_world_src, float), np.asarray(T_world_tgt, float)
    movers = object_transforms(T_ws, T_wt, object_poses)
    if movers and ids_src is None:
        raise VoError("moving objects need the source id map to find their pixels")
    T_tgt_src = invert(T_wt) @ T_ws
    w = warp_depth(z_src, K, T_tgt_src, depth_tgt, rtol, lens, ids_src=ids_src, T_tgt_src_by_id=movers)
    H, W = z_src.shape
    uu, vv = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    flow = np.stack([w.u - uu, w.v - vv], axis=-1)
    flow[~w.valid] = np.nan
    sf = np.zeros((H, W, 3))
    dynamic = np.zeros((H, W), bool)
    ids = None if ids_src is None else np.asarray(ids_src).astype(np.int32)
    for obj_id in movers:
        on = w.valid & (ids == obj_id)
        if not on.any():
            continue
        T_src, T_tgt = object_poses[obj_id]
        D = object_motion_in_camera(T_ws, T_src, T_tgt)
        X = w.X_src[on]
        sf[on] = X @ D[:3, :3].T + D[:3, 3] - X
        dynamic |= on
    sf[~w.valid] = np.nan
    X_tgt = np.where(w.valid[..., None], w.X_tgt, np.nan)
    return SceneFlow(flow=flow.astype(np.float32), scene_flow=sf.astype(np.float32),
                     depth_tgt=w.z.astype(np.float32), valid=w.valid, occluded=w.valid & w.occluded,
                     out_of_image=w.out_of_image, dynamic=dynamic, ids=ids, X_tgt=X_tgt)


def sequence_scene_flow(seq, k_src: int, k_tgt: int, view: str = "left", rtol: float = 1e-3) -> SceneFlow:
    """:func:`scene_flow_from_depth` of ``view`` from frame k_src to k_tgt of a sequence with
    depth, ids and poses (a render folder)."""
    T = seq.T_world_cam(view)
    z_src = seq.depth(k_src, view)
    if T is None or z_src is None:
        raise VoError(f"{seq!r} has no depth/pose ground truth: cannot derive scene flow")
    objs = sequence_object_poses(seq, k_src, k_tgt)
    ids = seq.ids(k_src, view)
    return scene_flow_from_depth(z_src, seq.K, T[k_src], T[k_tgt], ids_src=ids, object_poses=objs,
                                 depth_tgt=seq.depth(k_tgt, view), rtol=rtol, lens=seq.lens)


def moving_object_ids(seq) -> tuple[int, ...]:
    """Ids of the objects that move at some time in the sequence (() for static scenes)."""
    return tuple(seq.moving_ids)


def motion_mask(seq, k_src: int, k_tgt: int, view: str = "left") -> np.ndarray:
    """bool (H, W): pixels of frame k_src on an object that moves between k_src and k_tgt."""
    objs = {i: p for i, p in sequence_object_poses(seq, k_src, k_tgt).items() if not np.array_equal(*p)}
    ids = seq.ids(k_src, view)
    if ids is None:
        W, H = seq.resolution
        return np.zeros((H, W), bool)
    return np.isin(ids, list(objs)) if objs else np.zeros(ids.shape, bool)


def moving_objects_mask(seq, k: int, view: str = "left") -> np.ndarray:
    """bool (H, W): pixels of frame k on any object that moves at some time in the sequence
    (an instance mask of the movers, e.g. a parked car that drives off later)."""
    ids = seq.ids(k, view)
    movers = moving_object_ids(seq)
    if ids is None or not movers:
        W, H = seq.resolution
        return np.zeros((H, W), bool)
    return np.isin(ids, movers)
