"""KITTI stereo/flow 2015 layout of a render: image_2/3 ``*_10``/``*_11`` pairs, disparity
(``disp_occ_0``/``disp_noc_0``) and flow (``flow_occ``/``flow_noc``) in KITTI's PNG16
encodings, and KITTI 2015's ``calib_cam_to_cam/NNNNNN.txt`` per pair (``P_rect_02``,
``P_rect_03``, ...; docs/output-format.md)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from ..io.files import write_png_rgb
from ..groundtruth.disparity import sequence_disparity, write_disparity_png16
from .driver import ExportOptions, calib_cam_to_cam_text, image_rgb, progress_bar, refuse_options


def export_kitti_stereo(seq, out: Path, opts: ExportOptions) -> None:
    from ..groundtruth.flow import sequence_flow, sequence_stereo_occlusion, write_kitti_flow_png
    refuse_options(opts, "kitti-stereo")
    if "right" not in seq.views or seq.baseline_m <= 0:
        raise VoError("kitti-stereo needs a stereo render (views left and right)")
    frames = list(opts.frames)
    with progress_bar(opts, len(frames), "kitti-stereo") as bar:
        for i, k in enumerate(frames):
            n10 = f"{i:06d}_10.png"
            write_png_rgb(out / "image_2" / n10, image_rgb(seq, k, "left", opts))
            write_png_rgb(out / "image_3" / n10, image_rgb(seq, k, "right", opts))
            d = sequence_disparity(seq, k, "left")
            write_disparity_png16(out / "disp_occ_0" / n10, d)
            d_noc = np.where(sequence_stereo_occlusion(seq, k, "left"), np.nan, d)
            write_disparity_png16(out / "disp_noc_0" / n10, d_noc)
            if k + 1 < seq.num_frames and seq.frame_complete(k + 1):
                n11 = f"{i:06d}_11.png"
                write_png_rgb(out / "image_2" / n11, image_rgb(seq, k + 1, "left", opts))
                write_png_rgb(out / "image_3" / n11, image_rgb(seq, k + 1, "right", opts))
                fl = sequence_flow(seq, k, k + 1, "left")
                write_kitti_flow_png(out / "flow_occ" / n10, fl.flow, fl.valid)
                write_kitti_flow_png(out / "flow_noc" / n10, fl.flow, fl.noc)
            bar.update()
    calib = calib_cam_to_cam_text(seq)
    for i in range(len(frames)):
        atomic.write_text(out / "calib_cam_to_cam" / f"{i:06d}.txt", calib)


export_kitti_stereo.reads_neighbours = (1,)   # frame k's *_11 image and flow are frame k+1's (driver.export)
