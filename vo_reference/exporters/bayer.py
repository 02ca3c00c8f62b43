"""Export target ``bayer``: a render as raw Bayer frames in the RobotCar style, so the mono
VO runs on ground truth end to end (demosaic -> undistort -> features -> geometry).

``python -m vo_reference export RENDER OUT --to bayer [--opt pattern=gbrg]
[--opt dist=k1,k2,p1,p2[,k3]] [--opt view=left]`` writes::

    OUT/<microseconds>.png      8-bit Bayer mosaics (one channel), pattern ``pattern``
    OUT/stereo.timestamps       '<microseconds> 1' per frame (RobotCar layout)
    OUT/model.txt               RobotCar camera model: fx fy cx cy + G_camera_image (= I)
    OUT/poses.txt               ground truth T_world_cam of the view, KITTI format
    OUT/model_distortion_lut.bin   with ``dist`` only: the undistortion table, RobotCar
                                binary layout (float64, all u then all v, row-major,
                                0-based: undistorted pixel -> distorted pixel to sample)
    OUT/bayer.json              pattern, distortion (model, coefficients) or null, source frames

A render with a distorting ``LENS`` is already distorted: its frames are mosaicked as they
are and the lens is written (``bayer.json`` ``distortion``: its model and coefficients) with
its lookup table (``model_distortion_lut.bin``, the same as the render's
``lens/undistort_lut.bin``); ``dist`` is then refused (it would distort twice). With ``dist``
(OpenCV coefficients on the render's K) on a pinhole render each frame is first distorted —
the lens acts before the colour filter array — then mosaicked; pixels that would sample
outside the ideal image are black. Read it back with
``python -m vo_reference mono-vo OUT --bayer gbrg [--lut OUT/model_distortion_lut.bin]``.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from ..io.files import write_image_atomic
from ..camera.bayer import check_pattern, mosaic
from ..camera.camera_model import write_camera_model
from ..camera.undistort import distortion_maps, lut_from_distortion, parse_distortion, remap, write_lut


def timestamp_names(timestamps_s: np.ndarray) -> list[str]:
    """16-digit microsecond names of the frames' times: the names are the only stamps of the
    layout, so times that cannot be named as they are (negative, or not increasing at 1 µs)
    are a VoError, never shifted or nudged into names."""
    us = np.round(np.asarray(timestamps_s, dtype=float) * 1e6).astype(np.int64)
    if len(us) and us.min() < 0:
        raise VoError("bayer: timestamps must be >= 0 to name the files in microseconds (TIMING start)")
    if np.any(np.diff(us) <= 0):
        raise VoError("bayer: timestamps are not increasing at 1 µs: cannot name the frames")
    return [f"{u:016d}" for u in us]


def write_bayer_frames(frames_rgb, timestamps_s, T_world_cam, K, out, pattern: str = "gbrg",
                       dist=None, lens=None) -> Path:
    """Write RGB frames (iterable of uint8 (H, W, 3)) in the layout of the module docstring;
    ``lens`` (``contract.lens.Lens``): the frames are already distorted by it (its table is
    written, the frames are not resampled)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    pattern = check_pattern(pattern)
    names = timestamp_names(timestamps_s)
    maps = None
    for name, rgb in zip(names, frames_rgb):
        rgb = np.asarray(rgb)
        if rgb.dtype != np.uint8 or rgb.ndim != 3:
            raise VoError(f"Bayer export needs uint8 RGB frames, got {rgb.dtype} {rgb.shape}")
        if lens is not None and name == names[0]:   # the lens's own table, once
            from blender_sesgen.contract.lens import robotcar_lut_bytes, undistortion_maps
            h, w = rgb.shape[:2]
            atomic.write_bytes(out / "model_distortion_lut.bin", robotcar_lut_bytes(*undistortion_maps(lens, w, h)))
        if dist is not None:
            if maps is None:
                h, w = rgb.shape[:2]
                maps = distortion_maps(K, dist, w, h)
                write_lut(out / "model_distortion_lut.bin", *lut_from_distortion(K, dist, w, h))
            rgb = remap(rgb, *maps)
        write_image_atomic(out / f"{name}.png", mosaic(rgb, pattern))
    atomic.write_text(out / "stereo.timestamps", "".join(f"{n} 1\n" for n in names))
    write_camera_model(out / "model.txt", K)
    if T_world_cam is not None:
        T = np.asarray(T_world_cam)
        atomic.write_text(out / "poses.txt", "".join(" ".join(f"{v:.9e}" for v in P[:3].ravel()) + "\n" for P in T))
    return out


def export_bayer(seq, out: Path, opts) -> None:
    """The ``bayer`` target of :mod:`vo_reference.exporters.driver` (options via --opt)."""
    from .driver import image_rgb
    extra = dict(opts.extra)
    pattern = check_pattern(extra.pop("pattern", "gbrg"))
    dist = parse_distortion(extra.pop("dist", None))
    view = extra.pop("view", "left")
    if extra:
        raise VoError(f"bayer export: unknown option(s) {', '.join(sorted(extra))} (pattern, dist, view)")
    if view not in seq.views:
        raise VoError(f"bayer export: no view {view!r} (views: {', '.join(seq.views)})")
    lens = seq.lens
    if lens is not None and dist is not None:
        raise VoError("bayer export: the render is already distorted by its LENS; drop --opt dist "
                      "(or add --undistort to start from pinhole images)")
    frames = list(opts.frames)
    T = seq.T_world_cam(view)
    write_bayer_frames((image_rgb(seq, k, view, opts) for k in frames), seq.timestamps_s[frames],
                       None if T is None else T[frames], seq.K, out, pattern, dist, lens)
    distortion = (None if dist is None else {"model": "brown", "coeffs": [float(c) for c in dist]}) \
        if lens is None else {"model": lens.model, "coeffs": list(lens.coeffs)}
    info = {"pattern": pattern, "view": view, "distortion": distortion,
            "lut": None if distortion is None else "model_distortion_lut.bin",
            "source_frames": frames, "K": np.asarray(seq.K).tolist()}
    atomic.write_text(Path(out) / "bayer.json", json.dumps(info, indent=1) + "\n")


export_bayer.keeps_lens = True   # a distorted render is written as it is, with its lens (docs/output-format.md)
