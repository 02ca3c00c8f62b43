"""Time and frame selection: timestamps of frames, and the one ``--frames`` syntax.

Frame k is stamped ``t_k = t_0 + k / fps`` seconds, the **middle of its exposure**.
Global shutter: every row integrates light over ``[t_k - e/2, t_k + e/2]`` (e = exposure).
Rolling shutter with readout time ``R`` (top to bottom): row r (0 = top) is read at
``t_k + (r + 0.5 - H/2) * R / H`` (its exposure is centred there), so the middle of the
readout is the frame stamp and consecutive rows are ``R / H`` apart (docs/rendering.md
measures that the renders follow it). EuRoC and ROS carry integer nanoseconds: :func:`to_ns`. ``--frames`` everywhere (render, export, VO) is a
Python slice of the frame indices: ``A:B`` (B exclusive), ``A:``, ``:B``, negative indices
counting from the end; a single ``K`` selects frame K alone.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .errors import ContractError

DEFAULT_FPS = 25.0
TIME_LIMIT_S = 1e12          # seconds: a Unix time (1.7e9) fits, 1e308 does not (the manifest's limit)
MAX_IMU_SAMPLES = 2_000_000  # 2.8 h at 200 Hz: its three CSV streams are built in memory
# what every command's --frames help says (the one convention, above)
FRAMES_HELP = "frames A..B-1 (A:B is half-open, a Python slice; also A:, :B, or K for frame K alone)"


def frame_timestamps(n: int, fps: float = DEFAULT_FPS, t0_s: float = 0.0) -> np.ndarray:
    """(n,) seconds of frames 0..n-1."""
    return t0_s + np.arange(int(n), dtype=float) / float(fps)


def stream_problem(n_frames: int, rate_hz: float, start_s: float = 0.0,
                   imu_rate_hz: Optional[float] = None) -> str:
    """'' when a sequence of ``n_frames`` at ``rate_hz`` from ``start_s`` stays within the
    limits, else what exceeds one: a timestamp beyond :data:`TIME_LIMIT_S`, or an IMU stream
    (``imu_rate_hz``, sampled over the frames' time span) of more than :data:`MAX_IMU_SAMPLES`
    samples. Asked before anything is allocated (the script's check, the render's options)."""
    span_s = (int(n_frames) - 1) / float(rate_hz)
    last_s = float(start_s) + span_s
    if not (abs(float(start_s)) <= TIME_LIMIT_S and abs(last_s) <= TIME_LIMIT_S):
        return (f"the last frame would be stamped {last_s:.4g} s ({n_frames} frames at {rate_hz:g} Hz from "
                f"{float(start_s):g} s), beyond the {TIME_LIMIT_S:g} s a timestamp may reach")
    if imu_rate_hz:
        samples = int(np.floor(span_s * float(imu_rate_hz) + 1e-6)) + 1
        if samples > MAX_IMU_SAMPLES:
            return (f"the IMU stream would hold {samples:.4g} samples ({span_s:.4g} s of {n_frames} frames at "
                    f"{rate_hz:g} Hz, sampled at {imu_rate_hz:g} Hz), more than the limit of {MAX_IMU_SAMPLES} "
                    "samples")
    return ""


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


# --- exposure and rolling-shutter rows ---------------------------------------------------

def row_offsets_s(height: int, readout_s: float) -> np.ndarray:
    """(H,) capture time of each row relative to the frame stamp (0 for a global shutter)."""
    r = np.arange(int(height), dtype=float)
    return (r + 0.5 - height / 2.0) * float(readout_s) / float(height)


def row_time_s(t_frame_s: float, row, height: int, readout_s: float):
    """Capture time of (possibly fractional) image row(s) ``row`` of a frame stamped t_frame_s.

    A fractional row y (pixel centres at integers) is read at t + (y + 0.5 - H/2) R / H."""
    y = np.asarray(row, dtype=float)
    return float(t_frame_s) + (y + 0.5 - height / 2.0) * float(readout_s) / float(height)


def cycles_shutter(exposure_s: float, readout_s: float, rate_hz: float) -> tuple[float, float]:
    """(shutter length in frames, rolling-shutter duration) for Cycles.

    Cycles' shutter (``render.motion_blur_shutter``, centred on the frame) spans the whole
    frame window ``e + R``; with a rolling shutter its ``rolling_shutter_duration`` is the
    fraction of that window one row integrates, ``e / (e + R)`` (0 = instantaneous rows)."""
    total = float(exposure_s) + float(readout_s)
    shutter = total * float(rate_hz)
    duration = float(exposure_s) / total if total > 0 and readout_s > 0 else 1.0
    return shutter, duration


def to_ns(t_s) -> np.ndarray:
    """Seconds -> integer nanoseconds (nearest), int64."""
    return np.rint(np.asarray(t_s, dtype=np.float64) * 1e9).astype(np.int64)
