"""Export target ``sceneflow``: a render as one sequence of the SceneFlow datasets
(FlyingThings3D / Monkaa / Driving, Mayer et al., CVPR 2016), in FlyingThings3D's tree so
that stereo and scene-flow loaders (PSMNet, RAFT-Stereo, RAFT, ...) read it as is::

    OUT/frames_cleanpass/SEQ/left/0000.png                  8-bit RGB (right/ likewise)
    OUT/disparity/SEQ/left/0000.pfm                         float32 'Pf', both views
    OUT/optical_flow/SEQ/into_future/left/OpticalFlowIntoFuture_0000_L.pfm   'PF' (u, v, 0), k -> k+1
    OUT/optical_flow/SEQ/into_past/left/OpticalFlowIntoPast_0000_L.pfm       k -> k-1 (right: _R)
    OUT/disparity_change/SEQ/into_future/left/0000.pfm      'Pf': d_{k+1} − d_k of each pixel's point
    OUT/disparity_change/SEQ/into_past/left/0000.pfm        d_{k-1} − d_k
    OUT/frames_cleanpass/SEQ/camera.txt                     fx fy cx cy baseline_m (ours)
    OUT/frames_cleanpass/SEQ/export.json                    source, frames, noise (ours)

Every frame has its file in both directions, as FlyingThings3D ships them, so that loaders
that pair files by their position in a sorted listing (RAFT's and torchvision's
``FlyingThings3D``: image i with flow i into the future, image i+1 with flow i+1 into the
past) pair the right frames. The two boundary files (the last frame into the future, the
first into the past) flow into the neighbouring rendered frame when the render has it
(outside the exported range: its image is not exported; FlyingThings3D's edge files hold
the flow into frames it does not ship, lmb-freiburg/flownet2#210), else they hold NaN
(there is no frame to flow to; position-indexed loaders never read them).

``SEQ`` is ``--sequence`` (default ``TRAIN/A/0000``, FlyingThings3D's split/letter/number);
other sequences under OUT are left alone. PFM (as FlyingThings3D ships it): a text header
``Pf`` (one channel) or ``PF`` (three), ``W H``, a negative scale (little-endian), then the
rows bottom to top. SceneFlow's ground truth is dense; here too: disparity d = fx·B/Z is 0
where nothing is hit (a point at infinity), flow is defined for every pixel (points at
infinity move with the rotation alone, :mod:`.dense_gt`), NaN only where a point goes
behind the other camera. The right view's disparity is positive, x_left = x_right + d, as in
SceneFlow. Flow and disparity change move the pixels of moving objects with them
(the manifest's ``objects[i].T_world_obj``; :mod:`.dense_gt`, :mod:`.flow`).
"""
from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from ..io.files import write_png_rgb
from ..io.pfm import write_pfm
from ..groundtruth.dense import dense_flow, disparity_change
from ..groundtruth.disparity import sequence_disparity
from .driver import ExportOptions, image_rgb, progress_bar, sequence_folder

__all__ = ["export_sceneflow", "flow_pfm_array"]

DEFAULT_SEQUENCE = "TRAIN/A/0000"
KINDS = ("frames_cleanpass", "disparity", "optical_flow", "disparity_change")
VIEW_LETTER = {"left": "L", "right": "R"}


def flow_pfm_array(flow: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: u, v and a zero third channel, as SceneFlow's flow PFMs."""
    f = np.asarray(flow, dtype=np.float32)
    return np.concatenate([f, np.zeros(f.shape[:2] + (1,), np.float32)], axis=-1)


def export_sceneflow(seq, out: Path, opts: ExportOptions) -> Path:
    if dict(opts.extra):
        raise VoError(f"sceneflow export: unknown option(s) {', '.join(sorted(opts.extra))} (none)")
    if "right" not in seq.views or seq.baseline_m <= 0:
        raise VoError("sceneflow needs a stereo render (views left and right)")
    frames = list(opts.frames)
    rel = opts.sequence if opts.sequence is not None else DEFAULT_SEQUENCE
    # the sequence has one folder under each data kind, built and renamed together; the
    # frames_cleanpass one holds export.json, which vouches for its siblings
    main = sequence_folder(Path(out) / "frames_cleanpass", rel)
    ours = (main / "export.json").is_file()
    slots = {kind: sequence_folder(Path(out) / kind, rel, check=not ours) for kind in KINDS}
    step = opts.frames.step if isinstance(opts.frames, range) else 1
    with ExitStack() as stack:
        d = {kind: stack.enter_context(atomic.replacing_folder(slots[kind])) for kind in KINDS}
        with progress_bar(opts, len(frames) * 2, "sceneflow") as bar:
            for i, k in enumerate(frames):
                for view, L in VIEW_LETTER.items():
                    name = f"{i:04d}"
                    write_png_rgb(d["frames_cleanpass"] / view / f"{name}.png", image_rgb(seq, k, view, opts))
                    disp = sequence_disparity(seq, k, view)
                    write_pfm(d["disparity"] / view / f"{name}.pfm", np.nan_to_num(disp, nan=0.0))
                    # one file per frame in both directions, as FlyingThings3D ships them, so that
                    # loaders that pair files by position (RAFT, torchvision) pair the right frames
                    for k_tgt, when, word in ((k + step, "into_future", "Future"), (k - step, "into_past", "Past")):
                        flow, dchange = _towards(seq, k, k_tgt, view)
                        write_pfm(d["optical_flow"] / when / view / f"OpticalFlowInto{word}_{name}_{L}.pfm",
                                  flow_pfm_array(flow))
                        write_pfm(d["disparity_change"] / when / view / f"{name}.pfm", dchange)
                    bar.update()
        K = seq.K
        atomic.write_text(d["frames_cleanpass"] / "camera.txt", "# fx fy cx cy baseline_m (pixels, metres)\n"
                          f"{K[0, 0]:.9g} {K[1, 1]:.9g} {K[0, 2]:.9g} {K[1, 2]:.9g} {seq.baseline_m:.9g}\n")
    return main


export_sceneflow.takes_sequence = True
export_sceneflow.reads_neighbours = (-1, 1)   # flow into the past and the future (driver.export)


def _towards(seq, k: int, k_tgt: int, view: str) -> tuple[np.ndarray, np.ndarray]:
    """(flow (H, W, 2), disparity change (H, W)) of frame k towards frame k_tgt; all NaN when
    the render has no such frame (the boundary files: there is nothing to flow to)."""
    if 0 <= k_tgt < seq.num_frames and seq.frame_complete(k_tgt):
        return dense_flow(seq, k, k_tgt, view).flow, disparity_change(seq, k, k_tgt, view)
    W, H = seq.resolution
    return np.full((H, W, 2), np.nan, np.float32), np.full((H, W), np.nan, np.float32)
