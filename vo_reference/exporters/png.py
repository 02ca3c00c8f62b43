"""The plain per-view layout: noisy 8-bit RGB, object ids (PNG16 and a colour palette) and
disparity (PNG16 x256) for every exported frame."""
from __future__ import annotations

from pathlib import Path

from ..io.files import write_png_rgb
from ..groundtruth.disparity import sequence_disparity, write_disparity_png16
from .driver import ExportOptions, image_rgb, progress_bar, refuse_options


def export_png(seq, out: Path, opts: ExportOptions) -> None:
    from ..groundtruth.segmentation import write_ids_colour, write_ids_png16
    refuse_options(opts, "png")
    frames = list(opts.frames)
    stereo = "right" in seq.views and seq.baseline_m > 0
    with progress_bar(opts, len(frames) * len(seq.views), "png") as bar:
        for i, k in enumerate(frames):
            name = f"{i:06d}.png"
            for view in seq.views:
                write_png_rgb(out / view / "rgb" / name, image_rgb(seq, k, view, opts))
                ids = seq.ids(k, view)
                write_ids_png16(out / view / "ids" / name, ids)
                write_ids_colour(out / view / "ids_colour" / name, ids)
                if stereo:
                    write_disparity_png16(out / view / "disparity" / name, sequence_disparity(seq, k, view))
                bar.update()
