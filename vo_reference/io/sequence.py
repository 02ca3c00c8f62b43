"""Open any sequence by its content: a render folder or a KITTI odometry folder.

The interface every reader implements is :class:`vo_reference.io.base.Sequence`.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

from ..errors import VoError
from .base import Sequence

__all__ = ["Sequence", "open_sequence"]


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
    if (p / "manifest.json").exists():
        from .render import RenderSequence
        return RenderSequence(p)
    from .kitti import KittiSequence, looks_like_kitti
    if looks_like_kitti(p):
        return KittiSequence(p)
    raise VoError(
        f"{p}: neither a render folder (no manifest.json) nor a KITTI odometry folder "
        "(calib.txt + image_0/image_1, image_2/image_3 or image_l/image_r)")


def require_complete(seq, frames: Iterable[int]) -> None:
    """VoError naming the frames of ``frames`` that a render has not finished (recorded
    complete with every view's EXR present); sequences without that notion pass. Export,
    stereo and mono VO read only complete frames: a half-written render is resumed
    (``render --resume``) or read over a ``--frames`` range it has finished."""
    missing = [k for k in frames if not seq.frame_complete(k)]
    if missing:
        shown = ", ".join(map(str, missing[:10])) + (" ..." if len(missing) > 10 else "")
        raise VoError(f"{seq.root or 'input'}: {len(missing)} frame(s) not rendered completely ({shown}); "
                      "finish the render (--resume) or choose --frames")
