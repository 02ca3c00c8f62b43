"""Export target ``tartanair``: the layout of one TartanAir trajectory folder
(``ENV/Easy/P000``), as its tools' README and ``data_type.md`` describe it, so that loaders
written for TartanAir (TartanVO, DROID-SLAM, DPVO, ...) read a render as is::

    OUT/image_left/000000_left.png        8-bit RGB (the export's noise applies)
    OUT/image_right/000000_right.png
    OUT/depth_left/000000_left_depth.npy  float32 (H, W), planar depth in metres
    OUT/depth_right/000000_right_depth.npy
    OUT/seg_left/000000_left_seg.npy      uint8 (H, W): the object id (0 = nothing hit)
    OUT/seg_right/000000_right_seg.npy
    OUT/flow/000000_000001_flow.npy       float32 (H, W, 2): left-camera flow k -> k+1 (u, v) px
    OUT/flow/000000_000001_mask.npy       uint8 (H, W): 0 valid, 1 hidden in frame k+1, 100 out of view
    OUT/pose_left.txt                     'tx ty tz qx qy qz qw' per frame, NED (below)
    OUT/pose_right.txt
    OUT/camera.txt                        fx fy cx cy baseline_m (TartanAir itself fixes 320 320 320 240, 0.25 m)

Poses (TartanAir: "the camera motion is defined in the NED frame ... x-axis is pointing to
the camera's forward, the y-axis ... right, the z-axis ... downward"; position of the
optical centre and orientation of the camera in a fixed world frame):

- camera: the NED body frame of the camera, v_cv = (y, z, x)_ned, i.e.
  ``R_cv_ned = [[0,1,0],[0,0,1],[1,0,0]]`` (the matrix of TartanAir's ``ned2cam``, which
  undoes this conversion: ned2cam of our file is diag(1, −1, −1)·T_world_cam);
- world: north = the view direction of an unrotated START camera (−Z of the SES world),
  east = +X, down = −Y (gravity), i.e. ``R_ned_ses = [[0,0,-1],[1,0,0],[0,-1,0]]``;
- ``T_ned = R_ned_ses · T_world_cam · R_cv_ned`` (as 4x4), quaternion with qw >= 0.

A level camera looking along −Z_ses has the identity orientation; a reader that turns the
file back into camera axes the way DROID-SLAM does (columns [1, 2, 0, 4, 5, 3, 6]) gets
diag(1, −1, −1)·T_world_cam: the SES world turned 180 deg about x (y down, as KITTI).

Depth: pixels that see nothing get ``background_depth`` (default 10000 m, finite as
TartanAir's sky; ``--opt background_depth=inf`` for +inf). Flow: every pixel, background
included (points at infinity move with the rotation alone, see :mod:`.dense_gt`); the mask
uses TartanAir's flow tools' codes (``flow_and_warping_error.py``: CROSS_OCC = 1,
SELF_OCC = 10, OUT_OF_FOV = 100): 100 where the point leaves the image or goes behind the
camera, 1 where the next frame's depth shows a surface in front of it (our depth test finds
every occlusion, so 10 is not used), else 0. Segmentation is uint8 as in TartanAir, so
object ids must be <= 255.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from ..io.files import write_png_rgb
from ..groundtruth.dense import dense_flow, pop_background_depth
from .driver import ExportOptions, image_rgb, progress_bar, sequence_folder

__all__ = ["export_tartanair", "ned_poses", "pose_lines", "flow_mask", "depth_and_seg", "R_CV_NED", "R_NED_SES"]

R_CV_NED = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])   # v_cv = R_CV_NED @ v_ned
R_NED_SES = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # world: north = -Z, east = X, down = -Y
MASK_VALID, MASK_HIDDEN, MASK_OUT_OF_VIEW = 0, 1, 100


def ned_poses(T_world_cam: np.ndarray) -> np.ndarray:
    """(N, 4, 4) TartanAir NED poses (world NED, camera NED body) of OpenCV ``T_world_cam``."""
    A = np.eye(4)
    A[:3, :3] = R_NED_SES
    C = np.eye(4)
    C[:3, :3] = R_CV_NED
    return A @ np.asarray(T_world_cam, dtype=float) @ C


def pose_lines(T_ned: np.ndarray) -> str:
    """'tx ty tz qx qy qz qw' per pose, quaternion scalar last with qw >= 0."""
    from blender_sesgen.contract.se3 import R_to_quat_xyzw
    T = np.asarray(T_ned, dtype=float)
    q = R_to_quat_xyzw(T[:, :3, :3])
    q = np.where(q[:, 3:4] < 0, -q, q)
    return "".join(" ".join(f"{x:.9e}" for x in (*t[:3, 3], *qq)) + "\n" for t, qq in zip(T, q))


def flow_mask(f) -> np.ndarray:
    """uint8 TartanAir mask of a :class:`~vo_reference.groundtruth.dense.DenseFlow`."""
    m = np.full(f.hidden.shape, MASK_VALID, np.uint8)
    m[f.hidden] = MASK_HIDDEN
    m[f.out_of_image] = MASK_OUT_OF_VIEW
    return m


def depth_and_seg(seq, k: int, view: str, background: float, layout: str = "tartanair"):
    """(float32 depth, ``background`` where nothing is hit; uint8 object ids) of one image."""
    z = np.asarray(seq.depth(k, view), dtype=np.float32)
    ids = seq.ids(k, view)
    if ids.size and (ids.min() < 0 or ids.max() > 255):
        raise VoError(f"{layout}: frame {k} ({view}) has object ids outside 0..255")
    return np.where(np.isfinite(z), z, np.float32(background)).astype(np.float32), ids.astype(np.uint8)


def _npy(path: Path, a: np.ndarray) -> None:
    import io
    buf = io.BytesIO()
    np.save(buf, a)
    atomic.write_bytes(path, buf.getvalue())


def _options(opts: ExportOptions) -> float:
    extra = dict(opts.extra)
    value = pop_background_depth(extra)
    if extra:
        raise VoError(f"tartanair export: unknown option(s) {', '.join(sorted(extra))} (background_depth)")
    return value


def _check_ids(seq) -> None:
    ids = [int(o.get("id", 0)) for o in seq.objects if isinstance(o, dict)]
    big = [i for i in ids if not 0 <= i <= 255]
    if big:
        raise VoError(f"tartanair: object id(s) {', '.join(map(str, big[:5]))} do not fit TartanAir's "
                      "uint8 segmentation (0..255); renumber the objects in the script")


def export_tartanair(seq, out: Path, opts: ExportOptions) -> Path:
    background = _options(opts)
    _check_ids(seq)
    views = [v for v in ("left", "right") if v in seq.views]
    frames = list(opts.frames)
    final = sequence_folder(out, opts.sequence)
    with atomic.replacing_folder(final) as root:
        steps = len(frames) * len(views) + max(len(frames) - 1, 0)
        with progress_bar(opts, steps, "tartanair") as bar:
            for i, k in enumerate(frames):
                for v in views:
                    write_png_rgb(root / f"image_{v}" / f"{i:06d}_{v}.png", image_rgb(seq, k, v, opts))
                    z, seg = depth_and_seg(seq, k, v, background)
                    _npy(root / f"depth_{v}" / f"{i:06d}_{v}_depth.npy", z)
                    _npy(root / f"seg_{v}" / f"{i:06d}_{v}_seg.npy", seg)
                    bar.update()
                if i + 1 < len(frames):
                    f = dense_flow(seq, k, frames[i + 1], "left")
                    name = f"{i:06d}_{i + 1:06d}"
                    _npy(root / "flow" / f"{name}_flow.npy", f.flow.astype(np.float32))
                    _npy(root / "flow" / f"{name}_mask.npy", flow_mask(f))
                    bar.update()
        for v in views:
            atomic.write_text(root / f"pose_{v}.txt", pose_lines(ned_poses(seq.T_world_cam(v)[frames])))
        K = seq.K
        atomic.write_text(root / "camera.txt", "# fx fy cx cy baseline_m (pixels, metres)\n"
                          f"{K[0, 0]:.9g} {K[1, 1]:.9g} {K[0, 2]:.9g} {K[1, 2]:.9g} {seq.baseline_m:.9g}\n")
    return final


export_tartanair.takes_sequence = True
