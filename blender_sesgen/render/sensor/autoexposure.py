"""Auto-exposure that adapts over time like a camera's (one frame of latency).

The metered brightness of frame j is the mean Rec. 709 luminance m_j of its linear render
(independent of the exposure: the render is radiance), taken by a **metering pass** before
any frame renders: a small, deterministic preview of every frame before the render's last one
(``METERING_WIDTH_PX`` wide, ``METERING_SAMPLES`` samples, seed 0, no denoiser, no motion
blur; ``blender/exposure.py: meter_frames``). The values are stored in the manifest
(``sensor.metered``; the sequence's last frame's stays null: no exposure follows it) and
every later writer of the folder reads them, so a frame's exposure is the same whether it is
rendered alone (``--frames A:B``), in a farm's chunk or after ``--resume``. The exposure
product E = t * g (exposure time times analog gain) that would bring the normalised signal
``m * E / (t_nom * saturation)`` to ``target`` is ``E*_j = target * saturation * t_nom / m_j``.
Frame k uses
``log E_k = log E_{k-1} + (1 - exp(-speed / rate)) (log E*_{k-1} - log E_{k-1})``,
from ``E_0 = t_nom * g_nom``; E is split into the longest exposure time allowed
(``min(max_exposure, 1 / rate - readout)``, at least ``min_exposure``) and a gain in
[1, max_gain] for the rest; the E actually used feeds the next step. A drive into a dark
area therefore darkens the image first and recovers at the configured speed.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LUMA = np.array([0.2126, 0.7152, 0.0722])
METERING_WIDTH_PX = 96     # the metering preview's width (its aspect ratio is the render's)
METERING_SAMPLES = 8
METERING_RULE = (f"metering pass before the frames: mean linear luminance of a {METERING_WIDTH_PX} px wide, "
                 f"{METERING_SAMPLES}-sample left-view preview of each frame before the render's last (seed 0, no denoiser, "
                 "no motion blur; at film exposure 1, times the frames'; frame 0's from the automatic exposure's preview where there is one)")


def meter(linear_rgb: np.ndarray) -> float:
    """Mean linear luminance of a frame (its metered brightness)."""
    return float(np.mean(np.asarray(linear_rgb, dtype=np.float64)[..., :3] @ LUMA))


def split_exposure(E: float, nominal_gain: float, t_min: float, t_max: float, max_gain: float) -> tuple[float, float]:
    t = float(np.clip(E / nominal_gain, t_min, t_max))
    g = float(np.clip(E / t, 1.0, max_gain))
    return t, g


@dataclass(frozen=True)
class ExposureControl:
    """The camera's exposure and the controller's settings (AUTOEXPOSURE, TIMING, SENSOR)."""
    nominal_exposure_s: float      # t_nom: the TIMING exposure
    nominal_gain: float            # g_nom: the SENSOR gain
    rate_hz: float                 # frame rate
    readout_s: float               # rolling-shutter readout (limits the exposure)
    target: float                  # mean normalised signal to aim for
    speed: float                   # 1/s
    saturation: float              # linear value that fills the well at t_nom
    max_exposure_s: float          # 0: the frame period minus the readout
    max_gain: float
    min_exposure_s: float


def metered_frames(frames, n: int) -> int:
    """How many leading frames of an ``n``-frame sequence a render of ``frames`` meters: those
    before its last frame (frame k's exposure follows frames 0..k-1 only), so a render of frames
    0:2 meters frame 0 (the exposure preview's, no pass before frame 0) and no render meters the
    sequence's last frame (no exposure follows it)."""
    return max(0, min(n - 1, max(frames, default=0)))


def exposure_schedule(metered: list[float], c: ExposureControl) -> list[tuple[float, float]]:
    """(exposure_s, gain) of frames 0..len(metered): frame k depends on metered[:k]."""
    nominal_exposure_s, nominal_gain, rate_hz = c.nominal_exposure_s, c.nominal_gain, c.rate_hz
    readout_s, target, speed, saturation = c.readout_s, c.target, c.speed, c.saturation
    max_exposure_s, max_gain, min_exposure_s = c.max_exposure_s, c.max_gain, c.min_exposure_s
    t_max = 1.0 / rate_hz - readout_s
    if max_exposure_s > 0:
        t_max = min(t_max, max_exposure_s)
    t_max = max(t_max, min_exposure_s)
    alpha = 1.0 - np.exp(-float(speed) / float(rate_hz))
    t, g = split_exposure(nominal_exposure_s * nominal_gain, nominal_gain, min_exposure_s, t_max, max_gain)
    out = [(t, g)]
    for m in metered:
        E = t * g
        if m > 0 and np.isfinite(m):
            E_star = target * saturation * nominal_exposure_s / m
            E = float(np.exp(np.log(E) + alpha * (np.log(E_star) - np.log(E))))
        t, g = split_exposure(E, nominal_gain, min_exposure_s, t_max, max_gain)
        out.append((t, g))
    return out
