"""Export target ``sintel``: a render as one scene of the MPI-Sintel training set (optical flow
with its depth and camera data), in the tree that flow loaders (RAFT's, PWC-Net's,
torchvision's ``Sintel``) and Sintel's own SDK read::

    OUT/training/clean/SCENE/frame_0001.png        8-bit RGB of the left camera (noise applies); frames from 1
    OUT/training/final/SCENE/frame_0001.png        the same image (the render's, with its sensor effects if any)
    OUT/training/flow/SCENE/frame_0001.flo         flow frame i -> i+1 (none for the last frame)
    OUT/training/occlusions/SCENE/frame_0001.png   255 where the point is not seen in frame i+1 (hidden or out of view)
    OUT/training/invalid/SCENE/frame_0001.png      255 where the flow is unknown (the point goes behind the camera)
    OUT/training/depth/SCENE/frame_0001.dpt        planar depth, metres
    OUT/training/camdata_left/SCENE/frame_0001.cam intrinsics M and extrinsics N of the frame

``SCENE`` is ``--sequence`` (default ``sesgen``); other scenes under OUT are left alone.
Formats (Sintel's SDK, ``sintel_io``): ``.flo`` = the float 202021.25 ('PIEH'), int32
width, height, then float32 (u, v) row-major (values > 1e9 unknown; OpenCV's
``readOpticalFlow`` reads it); ``.dpt`` = the same tag, int32 width, height, float32 depth;
``.cam`` = the tag, then M (3x3 float64, the camera matrix K, OpenCV pixels: the top-left
pixel's centre is (0, 0)) and N (3x4 float64, [R | t] world -> camera, OpenCV axes, the SES
world in metres). Flow is dense as Sintel's: pixels that see nothing are points at infinity
and move with the rotation alone (:mod:`.dense_gt`), and moving objects move their pixels.
Depth where nothing is hit: ``--opt background_depth`` (default 10000 m). Sintel's images
are pinhole: a render with a lens is refused (export with ``--undistort``).
"""
from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.se3 import invert

from ..errors import VoError
from ..io.files import write_image_atomic, write_png_rgb
from .dense_gt import dense_flow, pop_background_depth
from .exports import ExportOptions, image_rgb, progress_bar, sequence_folder
from .flow import FLO_MAGIC, write_flo

__all__ = ["export_sintel", "dpt_bytes", "cam_bytes", "KINDS", "DEFAULT_SCENE"]

KINDS = ("clean", "final", "flow", "occlusions", "invalid", "depth", "camdata_left")
DEFAULT_SCENE = "sesgen"


def dpt_bytes(depth: np.ndarray) -> bytes:
    """A Sintel ``.dpt`` depth file."""
    z = np.asarray(depth, dtype="<f4")
    H, W = z.shape
    return np.array([FLO_MAGIC], "<f4").tobytes() + np.array([W, H], "<i4").tobytes() + z.tobytes()


def cam_bytes(K: np.ndarray, T_world_cam: np.ndarray) -> bytes:
    """A Sintel ``.cam`` file: M = K, N = [R | t] of the world -> camera transform."""
    N = invert(np.asarray(T_world_cam, dtype=float))[:3, :4] + 0.0
    return (np.array([FLO_MAGIC], "<f4").tobytes() + np.asarray(K, "<f8").tobytes()
            + np.ascontiguousarray(N, "<f8").tobytes())


def export_sintel(seq, out: Path, opts: ExportOptions) -> Path:
    extra = dict(opts.extra)
    background = pop_background_depth(extra)
    if extra:
        raise VoError(f"sintel export: unknown option(s) {', '.join(sorted(extra))} (background_depth)")
    scene = opts.sequence if opts.sequence is not None else DEFAULT_SCENE
    frames = list(opts.frames)
    # one folder per kind, built and renamed together; clean/SCENE holds export.json
    main = sequence_folder(Path(out) / "training" / "clean", scene)
    ours = (main / "export.json").is_file()
    slots = {kind: sequence_folder(Path(out) / "training" / kind, scene, check=not ours) for kind in KINDS}
    with ExitStack() as stack:
        d = {kind: stack.enter_context(atomic.replacing_folder(slots[kind])) for kind in KINDS}
        with progress_bar(opts, len(frames), "sintel") as bar:
            for i, k in enumerate(frames):
                name = f"frame_{i + 1:04d}"
                rgb = image_rgb(seq, k, "left", opts)
                write_png_rgb(d["clean"] / f"{name}.png", rgb)
                write_png_rgb(d["final"] / f"{name}.png", rgb)
                z = np.asarray(seq.depth(k, "left"), dtype=np.float32)
                atomic.write_bytes(d["depth"] / f"{name}.dpt", dpt_bytes(np.where(np.isfinite(z), z, background)))
                atomic.write_bytes(d["camdata_left"] / f"{name}.cam", cam_bytes(seq.K, seq.T_world_cam("left")[k]))
                if i + 1 < len(frames):
                    f = dense_flow(seq, k, frames[i + 1], "left")
                    write_flo(d["flow"] / f"{name}.flo", f.flow)
                    write_image_atomic(d["occlusions"] / f"{name}.png", np.where(f.visible, 0, 255).astype(np.uint8))
                    unknown = ~np.all(np.isfinite(f.flow), axis=-1)
                    write_image_atomic(d["invalid"] / f"{name}.png", np.where(unknown, 255, 0).astype(np.uint8))
                bar.update()
    return main


export_sintel.takes_sequence = True
