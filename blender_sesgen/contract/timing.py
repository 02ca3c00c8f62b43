"""Time and frame selection: timestamps of frames, and the one ``--frames`` syntax.

Frame k is stamped ``t_k = t_0 + k / fps`` seconds (the middle of its exposure once a
sensor model sets an exposure time). ``--frames`` everywhere (render, export, VO) is a
Python slice of the frame indices: ``A:B`` (B exclusive), ``A:``, ``:B``, negative indices
counting from the end; a single ``K`` selects frame K alone.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .errors import ContractError

DEFAULT_FPS = 25.0


def frame_timestamps(n: int, fps: float = DEFAULT_FPS, t0_s: float = 0.0) -> np.ndarray:
    """(n,) seconds of frames 0..n-1."""
    return t0_s + np.arange(int(n), dtype=float) / float(fps)


@dataclass(frozen=True)
class FrameSelection:
    """A parsed ``--frames`` value; :meth:`resolve` turns it into frames of an n-frame sequence."""
    start: Optional[int] = None
    stop: Optional[int] = None
    single: bool = False          # written as one index 'K'
    text: str = ":"

    @classmethod
    def parse(cls, text: Optional[str]) -> "FrameSelection":
        """'A:B', 'A:', ':B', ':' or 'K' (integers); ContractError otherwise."""
        if text is None or text.strip() in ("", ":"):
            return cls()
        t = text.strip()
        try:
            if ":" in t:
                a, b = t.split(":", 1)
                return cls(int(a) if a.strip() else None, int(b) if b.strip() else None, False, t)
            k = int(t)
        except ValueError:
            raise ContractError(f"--frames {text!r}: expected A:B, A:, :B or K (frame indices)") from None
        return cls(k, k + 1 if k != -1 else None, True, t)

    @classmethod
    def of(cls, start: int, stop: int) -> "FrameSelection":
        """Frames start..stop-1."""
        return cls(int(start), int(stop), False, f"{start}:{stop}")

    def resolve(self, n: int, min_frames: int = 1) -> range:
        """The selected frames of a sequence of ``n``; ContractError if fewer than ``min_frames``."""
        if self.single and not -n <= int(self.start) < n:
            raise ContractError(f"--frames {self.text}: frame out of range 0..{n - 1}")
        r = range(n)[slice(self.start, self.stop)]
        if len(r) < max(min_frames, 1):
            what = (f"--frames {self.text} selects {len(r)}" if self.text != ":" else f"the sequence has {n}")
            need = "at least 2 (for motion)" if min_frames >= 2 else "at least 1"
            raise ContractError(f"{what} frame(s) of a {n}-frame sequence (frames 0..{n - 1}); this needs {need}")
        return r


def frame_range(spec: Optional[str], n: int, min_frames: int = 1) -> range:
    """Shorthand: ``FrameSelection.parse(spec).resolve(n, min_frames)``."""
    return FrameSelection.parse(spec).resolve(n, min_frames)
