"""TUM RGB-D layout of a render's left view: ``rgb/`` and ``depth/`` (16-bit, 5000 per
metre), ``rgb.txt``, ``depth.txt``, ``associations.txt``, ``groundtruth.txt``, ``camera.txt``."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from ..io.files import write_png16, write_png_rgb
from .driver import ExportOptions, image_rgb, progress_bar, refuse_options


TUM_DEPTH_SCALE = 5000.0  # 16-bit value per metre (TUM RGB-D)


def depth_to_tum_png16(depth: np.ndarray) -> np.ndarray:
    """uint16 round(z·5000); 0 = no depth (inf, or beyond 65535/5000 = 13.1 m)."""
    z = np.asarray(depth, dtype=np.float64)
    v = np.rint(np.where(np.isfinite(z), z, 0.0) * TUM_DEPTH_SCALE)
    v[(v > 65535) | (v < 0) | ~np.isfinite(z)] = 0
    return v.astype(np.uint16)


def export_tum(seq, out: Path, opts: ExportOptions) -> None:
    from ..io.trajectory import Trajectory, write_tum
    refuse_options(opts, "tum")
    frames = list(opts.frames)
    ts = seq.timestamps_s[frames]
    names = [f"{t:.6f}" for t in ts]
    if len(set(names)) != len(names):
        raise VoError("timestamps are not distinct at 1 µs: cannot name TUM files")
    # TUM's header names the recording; ours names the render folder (never the export's
    # temporary folder: two exports of one render are byte-identical)
    source = Path(seq.root or "").name or "sesgen"
    rgb_lines = ["# color images", f"# file: '{source}'", "# timestamp filename"]
    depth_lines = ["# depth maps", f"# file: '{source}'", "# timestamp filename"]
    assoc = []
    with progress_bar(opts, len(frames), "tum") as bar:
        for k, name in zip(frames, names):
            write_png_rgb(out / "rgb" / f"{name}.png", image_rgb(seq, k, "left", opts))
            write_png16(out / "depth" / f"{name}.png", depth_to_tum_png16(seq.depth(k, "left")))
            rgb_lines.append(f"{name} rgb/{name}.png")
            depth_lines.append(f"{name} depth/{name}.png")
            assoc.append(f"{name} rgb/{name}.png {name} depth/{name}.png")
            bar.update()
    atomic.write_text(out / "rgb.txt", "\n".join(rgb_lines) + "\n")
    atomic.write_text(out / "depth.txt", "\n".join(depth_lines) + "\n")
    atomic.write_text(out / "associations.txt", "\n".join(assoc) + "\n")
    write_tum(out / "groundtruth.txt", Trajectory(seq.T_world_cam("left")[frames], ts))
    K = seq.K
    atomic.write_text(out / "camera.txt", "# fx fy cx cy (pixels, OpenCV convention); depth scale 5000 per metre\n"
                      f"{K[0, 0]:.9g} {K[1, 1]:.9g} {K[0, 2]:.9g} {K[1, 2]:.9g}\n")
