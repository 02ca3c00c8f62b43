"""Frame and row timing (the one home of these conventions).

- Frame k is stamped at the **middle of its exposure**: ``t_k = start_s + k / rate_hz``.
- Global shutter: every row integrates light over ``[t_k - e/2, t_k + e/2]`` (e = exposure).
- Rolling shutter with readout time ``R`` (top to bottom): row r (0 = top) is read at
  ``t_k + (r + 0.5 - H/2) * R / H`` (its exposure is centred there), so the middle of the
  readout is the frame stamp and consecutive rows are ``R / H`` apart. This is exactly what
  Cycles' rolling shutter does with a shutter of ``e + R`` and a rolling duration
  ``e / (e + R)`` (measured in docs/rendering.md).
- EuRoC and ROS carry integer nanoseconds: :func:`to_ns` rounds to the nearest.
"""
from __future__ import annotations

import numpy as np


def frame_times_s(n: int, rate_hz: float, start_s: float = 0.0) -> np.ndarray:
    """(n,) stamps of frames 0..n-1 in seconds."""
    return float(start_s) + np.arange(int(n), dtype=float) / float(rate_hz)


def row_offsets_s(height: int, readout_s: float) -> np.ndarray:
    """(H,) capture time of each row relative to the frame stamp (0 for a global shutter)."""
    r = np.arange(int(height), dtype=float)
    return (r + 0.5 - height / 2.0) * float(readout_s) / float(height)


def row_time_s(t_frame_s: float, row, height: int, readout_s: float):
    """Capture time of (possibly fractional) image row(s) ``row`` of a frame stamped t_frame_s.

    A fractional row y (pixel centres at integers) is read at t + (y + 0.5 - H/2) R / H."""
    y = np.asarray(row, dtype=float)
    return float(t_frame_s) + (y + 0.5 - height / 2.0) * float(readout_s) / float(height)


def frame_window_s(t_frame_s: float, exposure_s: float, readout_s: float) -> tuple[float, float]:
    """First and last instant any row of the frame integrates light."""
    half = (float(exposure_s) + float(readout_s)) / 2.0
    return float(t_frame_s) - half, float(t_frame_s) + half


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
