"""Export target ``tartanair-v2``: a render as one trajectory of TartanAir V2, in the tree
that today's ``tartanair`` package (tartanairpy: ``ta.iterator``, ``ta.dataloader``, its
``TartanAirImageReader``) reads::

    OUT/ENV/Data_DIFF/PNNN/image_lcam_front/000000_lcam_front.png         8-bit RGB (noise applies)
    OUT/ENV/Data_DIFF/PNNN/image_rcam_front/000000_rcam_front.png
    OUT/ENV/Data_DIFF/PNNN/depth_lcam_front/000000_lcam_front_depth.png   planar depth, float32 packed into RGBA
    OUT/ENV/Data_DIFF/PNNN/depth_rcam_front/000000_rcam_front_depth.png
    OUT/ENV/Data_DIFF/PNNN/seg_lcam_front/000000_lcam_front_seg.png       uint8 object id (0 = nothing hit)
    OUT/ENV/Data_DIFF/PNNN/seg_rcam_front/000000_rcam_front_seg.png
    OUT/ENV/Data_DIFF/PNNN/flow_lcam_front/000000_000001_flow.png         left flow k -> k+1 + mask (below)
    OUT/ENV/Data_DIFF/PNNN/pose_lcam_front.txt, pose_rcam_front.txt      'tx ty tz qx qy qz qw', NED
    OUT/ENV/Data_DIFF/PNNN/seg_label_map.json                             {"name_map": {object name: id}}
    OUT/ENV/Data_DIFF/PNNN/camera.txt                                     fx fy cx cy baseline_m (ours)

``ENV/Data_DIFF/PNNN`` is ``--sequence`` (default ``sesgen/Data_easy/P000``); the package
finds trajectories as ``ROOT/ENV/Data_<difficulty>/<trajectory>``. Conventions:

- Depth: the RGBA PNG's bytes are the little-endian float32 depth (``cv2.imread(...,
  IMREAD_UNCHANGED).view("<f4")``), planar z in metres (TartanAir V2's ``depth_*``; its
  readers turn it into distance themselves); pixels that see nothing get
  ``--opt background_depth`` (default 10000 m, as V1's export).
- Flow (TartanAir V2's PNG flow, as its ``flow16to32`` and data cacher decode it): uint16
  channels (OpenCV order) 0, 1 = u·64 + 32768, v·64 + 32768 (1/64 px steps, ±512 px),
  channel 2 = the mask of TartanAir's flow tools: 0 valid, 1 hidden in k+1, 100 out of view
  (and where a component is beyond ±512 px, which 16 bits cannot hold: clipped, so masked).
  ``--opt flow=npz`` writes the newer ``000000_000001_lcam_front_flow.npz`` instead:
  ``flow_fwd``/``flow_bwd`` float32 (1, 2, H, W), ``fov_mask_*`` and ``covisible_mask_*``
  bool (1, H, W) (exact floats, both directions).
- Poses, segmentation (uint8, ids above 255 refused) and the NED frames are V1's
  (:mod:`.tartanair`); only the left front camera has flow, as in TartanAir V2.

TartanAir V2's IMU (``imu/``, 10 samples per frame) is not written: use the euroc or
rosbag export for the IMU.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from ..io.files import write_image_atomic, write_png_rgb
from ..groundtruth.dense import dense_flow, pop_background_depth
from .driver import ExportOptions, image_rgb, progress_bar, sequence_folder
from .tartanair import MASK_OUT_OF_VIEW, _check_ids, depth_and_seg, flow_mask, ned_poses, pose_lines

__all__ = ["export_tartanair_v2", "depth_rgba", "flow_png16", "CAMERA", "DEFAULT_SEQUENCE"]

CAMERA = {"left": "lcam_front", "right": "rcam_front"}
DEFAULT_SEQUENCE = "sesgen/Data_easy/P000"
FLOW_SCALE, FLOW_ZERO = 64.0, 32768.0


def depth_rgba(z: np.ndarray) -> np.ndarray:
    """(H, W, 4) uint8: the little-endian bytes of float32 depth (TartanAir V2's depth PNG)."""
    return np.ascontiguousarray(np.asarray(z, dtype="<f4"))[..., None].view(np.uint8)


def flow_png16(flow: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint16 in OpenCV channel order: u·64 + 32768, v·64 + 32768, mask. A vector
    the 16 bits cannot hold (a component beyond −512..+511.98 px) is clipped there and masked
    ``MASK_OUT_OF_VIEW`` (loaders that keep mask 0 drop it; ``--opt flow=npz`` holds it)."""
    f = np.nan_to_num(np.asarray(flow, dtype=np.float64), nan=0.0)
    code = np.rint(f * FLOW_SCALE + FLOW_ZERO)
    enc = np.clip(code, 0, 65535).astype(np.uint16)
    m = np.asarray(mask, np.uint16).copy()
    m[np.any((code < 0) | (code > 65535), axis=-1)] = MASK_OUT_OF_VIEW
    return np.dstack([enc[..., 0], enc[..., 1], m])


def _slot(sequence: str | None) -> str:
    rel = DEFAULT_SEQUENCE if sequence is None else str(sequence).strip().strip("/")
    parts = rel.split("/")
    if len(parts) != 3 or not parts[1].startswith("Data_") or not all(parts):
        raise VoError(f"--sequence {rel!r}: TartanAir V2 trajectories are ENV/Data_DIFFICULTY/TRAJECTORY, "
                      "e.g. office/Data_easy/P000")
    return rel


def _npz(path: Path, **arrays) -> None:
    import io
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic.write_bytes(path, buf.getvalue())


def export_tartanair_v2(seq, out: Path, opts: ExportOptions) -> Path:
    extra = dict(opts.extra)
    flow_kind = extra.pop("flow", "png")
    if flow_kind not in ("png", "npz"):
        raise VoError(f"flow={flow_kind!r}: expected png (TartanAir V2's 16-bit flow) or npz (float, both directions)")
    background = pop_background_depth(extra)
    if extra:
        raise VoError(f"tartanair-v2 export: unknown option(s) {', '.join(sorted(extra))} (flow, background_depth)")
    _check_ids(seq)
    views = [v for v in ("left", "right") if v in seq.views]
    frames = list(opts.frames)
    final = sequence_folder(out, _slot(opts.sequence))
    with atomic.replacing_folder(final) as root:
        with progress_bar(opts, len(frames) * len(views) + max(len(frames) - 1, 0), "tartanair-v2") as bar:
            for i, k in enumerate(frames):
                for v in views:
                    cam = CAMERA[v]
                    write_png_rgb(root / f"image_{cam}" / f"{i:06d}_{cam}.png", image_rgb(seq, k, v, opts))
                    z, seg = depth_and_seg(seq, k, v, background, "tartanair-v2")
                    write_image_atomic(root / f"depth_{cam}" / f"{i:06d}_{cam}_depth.png", depth_rgba(z))
                    write_image_atomic(root / f"seg_{cam}" / f"{i:06d}_{cam}_seg.png", seg)
                    bar.update()
                if i + 1 < len(frames):
                    fwd = dense_flow(seq, k, frames[i + 1], "left")
                    if flow_kind == "png":
                        write_image_atomic(root / "flow_lcam_front" / f"{i:06d}_{i + 1:06d}_flow.png",
                                           flow_png16(fwd.flow, flow_mask(fwd)))
                    else:
                        bwd = dense_flow(seq, frames[i + 1], k, "left")
                        _npz(root / "flow_lcam_front" / f"{i:06d}_{i + 1:06d}_lcam_front_flow.npz",
                             flow_fwd=fwd.flow.transpose(2, 0, 1)[None].astype(np.float32),
                             flow_bwd=bwd.flow.transpose(2, 0, 1)[None].astype(np.float32),
                             fov_mask_fwd=~fwd.out_of_image[None], fov_mask_bwd=~bwd.out_of_image[None],
                             covisible_mask_fwd=fwd.visible[None], covisible_mask_bwd=bwd.visible[None])
                    bar.update()
        for v in views:
            atomic.write_text(root / f"pose_{CAMERA[v]}.txt", pose_lines(ned_poses(seq.T_world_cam(v)[frames])))
        names = {}
        for o in seq.objects:
            if isinstance(o, dict) and "id" in o:
                name = str(o.get("name") or "object")
                names[name if names.get(name, o["id"]) == o["id"] else f"{name}_{o['id']}"] = int(o["id"])
        atomic.write_text(root / "seg_label_map.json", json.dumps({"name_map": names}, indent=4) + "\n")
        K = seq.K
        atomic.write_text(root / "camera.txt", "# fx fy cx cy baseline_m (pixels, metres)\n"
                          f"{K[0, 0]:.9g} {K[1, 1]:.9g} {K[0, 2]:.9g} {K[1, 2]:.9g} {seq.baseline_m:.9g}\n")
    return final


export_tartanair_v2.takes_sequence = True
