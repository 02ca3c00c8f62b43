"""Export targets ``middlebury`` and ``eth3d``: every exported stereo frame as one scene of
the Middlebury 2014 stereo dataset or of ETH3D's two-view benchmark, the layouts stereo
networks' loaders (RAFT-Stereo, IGEV, CREStereo, ...) and the benchmarks' SDKs read::

    middlebury:  OUT/NAME_000000/im0.png, im1.png       left, right (8-bit RGB; the export's noise applies)
                 OUT/NAME_000000/disp0.pfm, disp1.pfm   left / right disparity, float32, inf = unknown
                 OUT/NAME_000000/mask0nocc.png          255 seen by both cameras, 128 occluded in the right view, 0 unknown
                 OUT/NAME_000000/calib.txt
    eth3d:       OUT/two_view_training/NAME_000000/im0.png, im1.png   8-bit grey (as ETH3D's)
                 OUT/two_view_training/NAME_000000/calib.txt, cameras.txt, images.txt (COLMAP, the rectified pair)
                 OUT/two_view_training_gt/NAME_000000/disp0GT.pfm, mask0nocc.png

``NAME`` is ``--opt name=NAME`` (default ``sesgen``). ``calib.txt`` (Middlebury's format,
which ETH3D shares)::

    cam0=[f 0 cx; 0 f cy; 0 0 1]      the left camera; (0, 0) is the image's top-left corner: cx, cy are
                                      the OpenCV ones + 0.5 (see below)
    cam1=[f 0 cx; 0 f cy; 0 0 1]      the right camera: the same K (a rectified, parallel rig)
    doffs=0                           cx1 - cx0
    baseline=B                        millimetres
    width=W  height=H
    ndisp=N                           a bound on the disparity: d < ndisp everywhere (a multiple of 16)
    isint=0
    vmin=a  vmax=b                    floor / ceil of the frame's smallest and largest left disparity
    dyavg=0  dymax=0                  no vertical disparity (exact rectification)

so that Z = baseline · f / (d + doffs) is the planar depth in millimetres. The principal point
is in the convention both datasets' own data and tools use: ETH3D's two-view ``calib.txt``
holds the very numbers of its COLMAP ``cameras.txt`` (delivery_area_1l: 553.869 232.396 in
both), whose pipeline shifts its pixel-centre cameras by +0.5 when it writes them
(ETH3D/dataset-pipeline ``src/io/colmap_model.cc``); Middlebury's viewer cvkit (Hirschmüller)
reads ``cam0`` with the origin at the corner and back-projects pixel (i, k) at
(i + 0.5, k + 0.5) (roboception/cvkit ``gvr/model.cc``). Disparity is the
exact d = f·B/Z of the depth (left view: x_right = x − d; right view ``disp1``: x_left = x + d);
the masks are the stereo occlusion test of :mod:`.flow` (a left pixel whose point the right
camera does not see, hidden or outside its image, is 128). Both layouts describe pinhole
images: a render with a lens is refused (export with ``--undistort``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from ..io.files import write_image_atomic, write_png_rgb
from .colmap import write_colmap_text
from ..groundtruth.disparity import sequence_disparity, write_disparity
from .driver import ExportOptions, image_gray, image_rgb, progress_bar

__all__ = ["export_middlebury", "export_eth3d", "calib_text", "nocc_mask"]

MASK_VISIBLE, MASK_OCCLUDED, MASK_UNKNOWN = 255, 128, 0


def _num(x: float) -> str:
    return repr(float(x) + 0.0)


def _mm(metres: float) -> str:
    """A length in metres as Middlebury's millimetres."""
    return _num(metres * 1000.0)


def calib_text(seq, disp0: np.ndarray) -> str:
    """Middlebury / ETH3D ``calib.txt`` of one frame (module docstring)."""
    K = np.asarray(seq.K, dtype=float)
    W, H = seq.resolution
    cx, cy = K[0, 2] + 0.5, K[1, 2] + 0.5          # OpenCV pixel centres -> image-corner origin
    cam = f"[{_num(K[0, 0])} 0 {_num(cx)}; 0 {_num(K[1, 1])} {_num(cy)}; 0 0 1]"
    valid = np.isfinite(disp0)
    vmin = int(np.floor(disp0[valid].min())) if valid.any() else 0
    vmax = int(np.ceil(disp0[valid].max())) if valid.any() else 0
    ndisp = 16 * (vmax // 16 + 1)        # d <= vmax < ndisp
    return (f"cam0={cam}\ncam1={cam}\ndoffs=0\nbaseline={_mm(seq.baseline_m)}\n"
            f"width={int(W)}\nheight={int(H)}\nndisp={ndisp}\nisint=0\nvmin={vmin}\nvmax={vmax}\n"
            "dyavg=0\ndymax=0\n")


def nocc_mask(disp: np.ndarray, occluded: np.ndarray) -> np.ndarray:
    """uint8: 255 seen by both cameras, 128 occluded in the other view, 0 no disparity."""
    m = np.full(disp.shape, MASK_UNKNOWN, np.uint8)
    valid = np.isfinite(disp)
    m[valid] = MASK_OCCLUDED
    m[valid & ~occluded] = MASK_VISIBLE
    return m


def _scenes(seq, opts: ExportOptions, layout: str) -> tuple[str, list[int]]:
    if "right" not in seq.views or seq.baseline_m <= 0:
        raise VoError(f"{layout} needs a stereo render (views left and right)")
    extra = dict(opts.extra)
    name = extra.pop("name", "sesgen")
    if extra:
        raise VoError(f"{layout} export: unknown option(s) {', '.join(sorted(extra))} (name)")
    if not name or any(c in name for c in "/\\") or name in (".", ".."):
        raise VoError(f"name={name!r}: expected a folder name")
    return name, list(opts.frames)


def export_middlebury(seq, out: Path, opts: ExportOptions) -> None:
    from ..groundtruth.flow import sequence_stereo_occlusion
    name, frames = _scenes(seq, opts, "middlebury")
    with progress_bar(opts, len(frames), "middlebury") as bar:
        for i, k in enumerate(frames):
            d = out / f"{name}_{i:06d}"
            write_png_rgb(d / "im0.png", image_rgb(seq, k, "left", opts))
            write_png_rgb(d / "im1.png", image_rgb(seq, k, "right", opts))
            d0 = sequence_disparity(seq, k, "left")
            write_disparity(d / "disp0.pfm", d0)
            write_disparity(d / "disp1.pfm", sequence_disparity(seq, k, "right"))
            write_image_atomic(d / "mask0nocc.png", nocc_mask(d0, sequence_stereo_occlusion(seq, k, "left")))
            atomic.write_text(d / "calib.txt", calib_text(seq, d0))
            bar.update()


def export_eth3d(seq, out: Path, opts: ExportOptions) -> None:
    from ..groundtruth.flow import sequence_stereo_occlusion
    name, frames = _scenes(seq, opts, "eth3d")
    with progress_bar(opts, len(frames), "eth3d") as bar:
        for i, k in enumerate(frames):
            scene = f"{name}_{i:06d}"
            d, gt = out / "two_view_training" / scene, out / "two_view_training_gt" / scene
            write_png_rgb(d / "im0.png", image_gray(seq, k, "left", opts))
            write_png_rgb(d / "im1.png", image_gray(seq, k, "right", opts))
            d0 = sequence_disparity(seq, k, "left")
            atomic.write_text(d / "calib.txt", calib_text(seq, d0))
            write_colmap_text(d, seq, [(k, "left"), (k, "right")], ["im0.png", "im1.png"], rig=False)
            write_disparity(gt / "disp0GT.pfm", d0)
            write_image_atomic(gt / "mask0nocc.png", nocc_mask(d0, sequence_stereo_occlusion(seq, k, "left")))
            bar.update()
