"""The one sequence interface every algorithm reads: renders and real datasets alike.

A :class:`Sequence` is a rectified stereo (or monocular) image sequence with optional
ground truth. Conventions (docs/output-format.md):

- ``K``: (3, 3) intrinsics of the left camera, OpenCV convention, pixels; pixel centres at
  integers, (0, 0) = centre of the top-left pixel.
- ``baseline_m``: distance between the left and right camera centres (0.0 for mono);
  right camera = left · trans(baseline_m, 0, 0), same K.
- images: ``image_rgb`` uint8 (H, W, 3) RGB (sRGB-encoded); ``image_gray`` uint8 (H, W).
- ``depth``: float32 planar z (along the optical axis, metres), +inf where nothing was hit;
  ``None`` when the sequence has no depth ground truth.
- ``ids``: int32 object ids, 0 = background; ``None`` when unknown.
- ``T_world_cam(view)``: (N, 4, 4) camera-to-world poses (OpenCV camera), or ``None``.

:func:`open_sequence` opens a render folder (``manifest.json``) or a KITTI odometry
folder, telling them apart by their content.
"""
from __future__ import annotations

from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import VoError

__all__ = ["Sequence", "open_sequence", "frame_range", "check_frame_view", "ImagesOnly"]


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


def frame_range(spec: str | None, n: int, min_frames: int = 1) -> range:
    """``--frames``: 'A:B' (Python slice: B exclusive, either may be empty or negative) or a
    single index 'A' -> the range of frames of a sequence of ``n``; at least ``min_frames``."""
    if spec is None or spec.strip() in ("", ":"):
        r = range(n)
    else:
        try:
            if ":" in spec:
                a, b = spec.split(":", 1)
                r = range(n)[slice(int(a) if a.strip() else None, int(b) if b.strip() else None)]
            else:
                a = int(spec)
                if not 0 <= a < n:
                    raise VoError(f"--frames {spec}: frame out of range 0..{n - 1}")
                r = range(a, a + 1)
        except ValueError:
            raise VoError(f"--frames {spec!r}: expected A:B (integers)") from None
    if len(r) < max(min_frames, 1):
        what = f"--frames {spec} selects {len(r)}" if spec and spec.strip() not in ("", ":") else f"the sequence has {n}"
        need = "at least 2 (for motion)" if min_frames >= 2 else "at least 1"
        raise VoError(f"{what} frame(s); this needs {need}")
    return r


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


def open_sequence(path) -> Sequence:
    """Open a render folder (has ``manifest.json``) or a KITTI odometry folder (has
    ``calib.txt`` and image_0/image_1, image_2/image_3 or image_l/image_r), by content."""
    p = Path(path)
    if p.is_file() and p.name == "manifest.json":
        p = p.parent
    if not p.exists():
        raise VoError(f"{p}: no such folder")
    if not p.is_dir():
        raise VoError(f"{p}: not a folder (expected a render folder or a KITTI sequence folder)")
    if (p / "manifest.json").is_file():
        from .render import RenderSequence
        return RenderSequence(p)
    from .kitti import KittiSequence, looks_like_kitti
    if looks_like_kitti(p):
        return KittiSequence(p)
    raise VoError(
        f"{p}: neither a render folder (no manifest.json) nor a KITTI odometry folder "
        "(calib.txt + image_0/image_1, image_2/image_3 or image_l/image_r)")
