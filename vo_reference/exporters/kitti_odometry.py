"""Export targets ``kitti-odometry`` (the development kit's own tree) and ``kitti-folder``
(one self-contained sequence folder, the layout ``kitti-odometry`` wrote before).

``kitti-odometry`` writes the tree of the KITTI odometry benchmark (its ``readme.txt``:
"Folder 'sequences' ... the left and right images are stored in the sub-folders image_0
and image_1 ... Folder 'poses' ... NN.txt"), so that the devkit, pykitti
(``pykitti.odometry(OUT/dataset, 'NN')``) and every loader written for KITTI read it as is::

    OUT/dataset/sequences/NN/image_0/000000.png   grey left  (P0)
    OUT/dataset/sequences/NN/image_1/000000.png   grey right (P1; stereo renders only)
    OUT/dataset/sequences/NN/image_2/000000.png   colour left  (P2 = P0: one rig)
    OUT/dataset/sequences/NN/image_3/000000.png   colour right (P3 = P1)
    OUT/dataset/sequences/NN/calib.txt            P0: .. P3: (3x4, row-major), Tr: (identity)
    OUT/dataset/sequences/NN/times.txt            seconds from the first exported frame
    OUT/dataset/sequences/NN/export.json          source, frames, noise (ours; loaders ignore it)
    OUT/dataset/poses/NN.txt                      inv(T_0)·T_k of the left camera, 12 numbers a line

``--sequence NN`` (default 00) names the slot, so several renders go into one dataset; the
other sequences are not touched. The slot -- ``sequences/NN`` and ``poses/NN.txt`` -- is
replaced as one transaction by the export driver (``exports.export``): an interrupted
export leaves the old NN, or none, never images of one run with poses of another; an
``NN`` that is not an export of ours is never replaced.
"""
from __future__ import annotations

import re
from pathlib import Path

from blender_sesgen.contract import atomic
from blender_sesgen.contract.se3 import invert
from blender_sesgen.contract.trajectory_files import format_kitti, format_times

from ..errors import VoError
from ..io.files import write_png_rgb
from .driver import ExportOptions, calib_text, image_gray, image_rgb, progress_bar, refuse_options

__all__ = ["export_kitti_odometry", "export_kitti_folder", "sequence_name"]

DEFAULT_SEQUENCE = "00"


def sequence_name(spec: str | None) -> str:
    """'--sequence': digits, written with at least two (KITTI's 00..21); default 00."""
    if spec is None:
        return DEFAULT_SEQUENCE
    s = str(spec).strip()
    if not re.fullmatch(r"\d{1,6}", s):
        raise VoError(f"--sequence {spec!r}: a KITTI sequence is a number (00, 01, ... 21, ...)")
    return f"{int(s):02d}"


def write_sequence_folder(seq, folder: Path, opts: ExportOptions, label: str) -> list[int]:
    """image_0..3, calib.txt, times.txt of one sequence into ``folder``; returns the frames."""
    refuse_options(opts, label.split()[0])
    frames = list(opts.frames)
    stereo = "right" in seq.views
    with progress_bar(opts, len(frames), label) as bar:
        for i, k in enumerate(frames):
            name = f"{i:06d}.png"
            write_png_rgb(folder / "image_0" / name, image_gray(seq, k, "left", opts))
            write_png_rgb(folder / "image_2" / name, image_rgb(seq, k, "left", opts))
            if stereo:
                write_png_rgb(folder / "image_1" / name, image_gray(seq, k, "right", opts))
                write_png_rgb(folder / "image_3" / name, image_rgb(seq, k, "right", opts))
            bar.update()
    atomic.write_text(folder / "calib.txt", calib_text(seq))
    t = seq.timestamps_s[frames] - seq.timestamps_s[frames[0]]
    atomic.write_text(folder / "times.txt", format_times(t))
    return frames


def relative_poses_text(seq, frames: list[int]) -> str:
    T = seq.T_world_cam("left")[frames]
    return format_kitti(invert(T[0]) @ T)


def export_kitti_odometry(seq, out: Path, opts: ExportOptions) -> Path:
    nn = sequence_name(opts.sequence)
    dataset = Path(out) / "dataset"
    final = dataset / "sequences" / nn
    frames = write_sequence_folder(seq, final, opts, f"kitti-odometry {nn}")
    atomic.write_text(dataset / "poses" / f"{nn}.txt", relative_poses_text(seq, frames))
    return final


export_kitti_odometry.takes_sequence = True


def export_kitti_folder(seq, out: Path, opts: ExportOptions) -> None:
    """One folder: image_0..3/, calib.txt, times.txt and poses.txt side by side."""
    frames = write_sequence_folder(seq, Path(out), opts, "kitti-folder")
    atomic.write_text(Path(out) / "poses.txt", relative_poses_text(seq, frames))
