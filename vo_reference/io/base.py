"""The one sequence interface every algorithm reads: renders and real datasets alike.

A :class:`Sequence` is a rectified stereo (or monocular) image sequence with optional
ground truth. Conventions (docs/output-format.md; the contract's ``camera`` and ``depth``):

- ``K``: (3, 3) intrinsics of the left camera, OpenCV convention, pixels; pixel centres at
  integers, (0, 0) = centre of the top-left pixel.
- ``baseline_m``: distance between the left and right camera centres (0.0 for mono);
  right camera = left · trans(baseline_m, 0, 0), same K.
- images: ``image_rgb`` uint8 (H, W, 3) RGB (sRGB-encoded); ``image_gray`` uint8 (H, W).
- ``depth``: float32 planar z (along the optical axis, metres), +inf where nothing was hit;
  ``None`` when the sequence has no depth ground truth.
- ``ids``: int32 object ids, 0 = background; ``None`` when unknown.
- ``T_world_cam(view)``: (N, 4, 4) camera-to-world poses (OpenCV camera), or ``None``.

Readers subclass :class:`Sequence`: besides the images and poses every reader has, it
declares the **optional capabilities** a reader may have (ground truth, the render's
object table, lens, rolling shutter, IMU, completion state), each with the default of a
reader that lacks it, so that algorithms and exporters ask for them directly instead of
probing with ``getattr``. :func:`vo_reference.io.sequence.open_sequence` picks the reader.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Protocol, runtime_checkable

import numpy as np

from ..errors import VoError


@runtime_checkable
class Sequence(Protocol):
    """A stereo (or mono) image sequence with optional ground truth."""

    K: np.ndarray                     # (3,3) left camera, OpenCV convention, pixels
    baseline_m: float                 # 0.0 for monocular
    resolution: tuple[int, int]       # (W, H)
    num_frames: int
    views: tuple[str, ...]            # ("left", "right") or ("left",)
    timestamps_s: np.ndarray          # (N,)

    def image_rgb(self, k: int, view: str = "left") -> np.ndarray:
        """uint8 (H, W, 3) RGB, sRGB-encoded."""
        ...

    def image_gray(self, k: int, view: str = "left") -> np.ndarray:
        """uint8 (H, W) grey."""
        ...

    def T_world_cam(self, view: str = "left") -> np.ndarray | None:
        """(N, 4, 4) ground-truth camera poses (OpenCV camera) or None."""
        ...

    # --- optional capabilities: each default is what a reader without it answers ---------
    root: Optional[Path] = None       # where it was read from (for messages)
    objects: tuple = ()               # a render's object table (manifest ``objects`` entries)
    moving_ids: tuple[int, ...] = ()  # ids of the objects that move (a render's)
    lens = None                       # ``contract.lens.Lens`` of a distorted camera
    readout_s: float = 0.0            # rolling-shutter readout (0: global shutter)

    def depth(self, k: int, view: str = "left") -> np.ndarray | None:
        """float32 (H, W) planar z in metres, +inf = nothing hit; None without ground truth."""
        check_frame_view(self, k, view)
        return None

    def ids(self, k: int, view: str = "left") -> np.ndarray | None:
        """int32 (H, W) object ids, 0 = background; None without ground truth."""
        check_frame_view(self, k, view)
        return None

    def frame_complete(self, k: int) -> bool:
        """Whether frame k is finished (a render being written may not be)."""
        return 0 <= int(k) < self.num_frames

    def T_world_obj(self, obj_id: int) -> np.ndarray | None:
        """(N, 4, 4) poses of a moving object, None for one that does not move."""
        return None

    def undistortion_maps(self):
        """(map_x, map_y) taking the distorted images to the pinhole K, or None."""
        return None

    @property
    def rate_hz(self) -> float:
        """Frames per second (from the timestamps where the reader knows no rate; 0 if unknown)."""
        dt = np.diff(np.asarray(self.timestamps_s, dtype=float))
        return float(1.0 / np.median(dt)) if dt.size and np.median(dt) > 0 else 0.0

    def imu_calibration(self):
        """The IMU's calibration and files (``contract.manifest_sections.ImuSection``), or None."""
        return None

    def imu(self, kind: str = "noisy") -> dict | None:
        """An IMU stream {t_s, gyro, accel}, or None without an IMU."""
        return None

    def imu_groundtruth(self) -> dict | None:
        """The IMU body's ground-truth states, or None without an IMU."""
        return None

    def provenance(self) -> dict:
        """What identifies the source of a derived product (a render: its format and scene
        hash); {} where there is nothing to say."""
        return {}


def check_frame_view(seq, k: int, view: str) -> None:
    """Raise VoError for a frame index or view the sequence does not have."""
    if view not in seq.views:
        raise VoError(f"view {view!r} not in this sequence (views: {', '.join(seq.views)})")
    if not 0 <= int(k) < seq.num_frames:
        raise VoError(f"frame {k} out of range (0..{seq.num_frames - 1})")
