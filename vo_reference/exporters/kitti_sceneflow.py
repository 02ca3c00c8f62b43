"""Export target ``kitti-sceneflow``: the KITTI scene flow 2015 training layout, with
instance and motion masks (exact ground truth, moving objects included).

One *pair* per source frame k whose next frame k+1 is rendered, numbered i = 0, 1, ...::

    image_2/iiiiii_10.png  image_2/iiiiii_11.png   left colour images of frames k, k+1
    image_3/iiiiii_10.png  image_3/iiiiii_11.png   right colour images
    disp_occ_0/iiiiii_10.png   disparity of frame k (every left pixel with depth)
    disp_noc_0/iiiiii_10.png   ... without the pixels hidden in / outside the right view
    disp_occ_1/iiiiii_10.png   disparity at frame k+1 of each frame-k pixel's point (moved with
                               its object), stored at the frame-k pixel (KITTI's "mapped into the
                               reference frame via the true optical flow")
    disp_noc_1/iiiiii_10.png   ... where that point is visible in both frame-(k+1) views
    flow_occ/iiiiii_10.png     optical flow k -> k+1 of every left pixel with depth
    flow_noc/iiiiii_10.png     ... without pixels hidden at, or leaving the image by, k+1
    obj_map/iiiiii_10.png      uint8: 0 = static background, n = the pixel lies on the n-th
                               moving object (1-based rank of its id among the render's
                               moving ids, 255 for rank >= 255) and it moves between k and k+1
    instance_map/iiiiii_10.png uint16: the object id of every pixel at frame k (0 = none)  [ours]
    motion_mask/iiiiii_10.png  uint8: 255 where the pixel's surface point moves k -> k+1   [ours]
    calib_cam_to_cam/iiiiii.txt  KITTI 2015's camera calibration of the pair (P_rect_02, P_rect_03, ...)

Formats as the KITTI devkit's readme specifies: disparity uint16 PNG, d = I/256, I = 0
invalid; flow 3-channel uint16 PNG (R = u·64 + 2^15, G = v·64 + 2^15, B = valid); the
object map an 8-bit grey PNG, 0 background and > 0 foreground (how the devkit's
evaluation splits its bg/fg errors).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract import rig

from ..errors import VoError
from ..io.files import write_png16, write_png_rgb
from ..groundtruth.disparity import disparity_from_depth, write_disparity_png16
from .driver import ExportOptions, calib_cam_to_cam_text, image_rgb, progress_bar, refuse_options
from ..groundtruth.flow import hidden_behind, sequence_stereo_occlusion, write_kitti_flow_png
from ..groundtruth.scene_flow import SceneFlow, moving_object_ids, sequence_scene_flow

MAX_OBJ_MAP = 255


def visible_in_right(sf: SceneFlow, depth_right_tgt: np.ndarray, K: np.ndarray, baseline_m: float,
                     rtol: float = 1e-3) -> np.ndarray:
    """bool (H, W): the moved point (``sf.X_tgt``, left camera at the target frame) projects
    inside the target frame's right image and is not behind its depth map there."""
    X = rig.points_in_view(sf.X_tgt, "right", baseline_m)
    H, W = depth_right_tgt.shape
    with np.errstate(divide="ignore", invalid="ignore"):
        u = K[0, 0] * X[..., 0] / X[..., 2] + K[0, 2]
        v = K[1, 1] * X[..., 1] / X[..., 2] + K[1, 2]
        inside = sf.valid & (X[..., 2] > 1e-12) & (u >= -0.5) & (u < W - 0.5) & (v >= -0.5) & (v < H - 0.5)
    out = np.zeros((H, W), bool)
    out[inside] = ~hidden_behind(depth_right_tgt, u[inside], v[inside], X[..., 2][inside], rtol)
    return out


def object_map(sf: SceneFlow, movers: tuple[int, ...]) -> np.ndarray:
    """uint8 KITTI object map: rank (1-based) of the moving object a dynamic pixel lies on."""
    out = np.zeros(sf.valid.shape, np.uint8)
    if sf.ids is None:
        return out
    for rank, obj_id in enumerate(movers, start=1):
        out[sf.dynamic & (sf.ids == obj_id)] = min(rank, MAX_OBJ_MAP)
    return out


def export_kitti_sceneflow(seq, out: Path, opts: ExportOptions) -> None:
    refuse_options(opts, "kitti-sceneflow")
    if "right" not in seq.views or seq.baseline_m <= 0:
        raise VoError("kitti-sceneflow needs a stereo render (views left and right)")
    pairs = [k for k in opts.frames if k + 1 < seq.num_frames and seq.frame_complete(k + 1)]
    if not pairs:
        raise VoError("kitti-sceneflow needs pairs of frames k, k+1: the selected frames have no rendered successor")
    K, B = np.asarray(seq.K, float), float(seq.baseline_m)
    fx = K[0, 0]
    movers = moving_object_ids(seq)
    with progress_bar(opts, len(pairs), "kitti-sceneflow") as bar:
        for i, k in enumerate(pairs):
            n10, n11 = f"{i:06d}_10.png", f"{i:06d}_11.png"
            for view, folder in (("left", "image_2"), ("right", "image_3")):
                write_png_rgb(out / folder / n10, image_rgb(seq, k, view, opts))
                write_png_rgb(out / folder / n11, image_rgb(seq, k + 1, view, opts))
            z0 = seq.depth(k, "left")
            d0 = disparity_from_depth(z0, fx, B)
            write_disparity_png16(out / "disp_occ_0" / n10, d0)
            write_disparity_png16(out / "disp_noc_0" / n10, np.where(sequence_stereo_occlusion(seq, k, "left"), np.nan, d0))
            sf = sequence_scene_flow(seq, k, k + 1, "left")
            d1 = sf.disparity_tgt(fx, B)
            write_disparity_png16(out / "disp_occ_1" / n10, d1)
            both = sf.noc & visible_in_right(sf, seq.depth(k + 1, "right"), K, B)
            write_disparity_png16(out / "disp_noc_1" / n10, np.where(both, d1, np.nan))
            write_kitti_flow_png(out / "flow_occ" / n10, sf.flow, sf.valid)
            write_kitti_flow_png(out / "flow_noc" / n10, sf.flow, sf.noc)
            write_png_rgb(out / "obj_map" / n10, object_map(sf, movers))
            ids = seq.ids(k, "left")
            write_png16(out / "instance_map" / n10, np.clip(ids, 0, 65535).astype(np.uint16))
            write_png_rgb(out / "motion_mask" / n10, np.where(sf.dynamic, 255, 0).astype(np.uint8))
            bar.update()
    calib = calib_cam_to_cam_text(seq)
    for i in range(len(pairs)):
        atomic.write_text(out / "calib_cam_to_cam" / f"{i:06d}.txt", calib)
    atomic.write_text(out / "pairs.txt", "# pair source_frame_10 source_frame_11\n"
                      + "".join(f"{i:06d} {k} {k + 1}\n" for i, k in enumerate(pairs)))


export_kitti_sceneflow.reads_neighbours = (1,)   # each pair is frames k, k+1 (driver.export)
