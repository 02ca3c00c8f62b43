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

Readers implement it; :func:`vo_reference.io.sequence.open_sequence` picks the reader.
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

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

    def depth(self, k: int, view: str = "left") -> np.ndarray | None:
        """float32 (H, W) planar z in metres, +inf = nothing hit; None without ground truth."""
        ...

    def ids(self, k: int, view: str = "left") -> np.ndarray | None:
        """int32 (H, W) object ids, 0 = background; None without ground truth."""
        ...

    def T_world_cam(self, view: str = "left") -> np.ndarray | None:
        """(N, 4, 4) ground-truth camera poses (OpenCV camera) or None."""
        ...


def check_frame_view(seq, k: int, view: str) -> None:
    """Raise VoError for a frame index or view the sequence does not have."""
    if view not in seq.views:
        raise VoError(f"view {view!r} not in this sequence (views: {', '.join(seq.views)})")
    if not 0 <= int(k) < seq.num_frames:
        raise VoError(f"frame {k} out of range (0..{seq.num_frames - 1})")


class ImagesOnly:
    """Mixin for real-data sequences: no dense ground truth (depth, ids) per frame."""

    def depth(self, k: int, view: str = "left") -> None:
        check_frame_view(self, k, view)
        return None

    def ids(self, k: int, view: str = "left") -> None:
        check_frame_view(self, k, view)
        return None
