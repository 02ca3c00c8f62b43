"""Auto-exposure that adapts over time like a camera's (one frame of latency).

A real camera meters its own digitised output (the MT9V034's AEC a histogram of its pixel
values, Point Grey's cameras the average image intensity over a region): a burnt-out pixel
counts at full scale, not at its radiance. So the metered brightness of frame j is the mean
m_j of the luminance its sensor receives (the render times the lens's vignetting), each pixel
clipped where frame j's own exposure E_j = t_j * g_j brings the output to full scale
(``full_scale``; a mono sensor clips its luminance, a colour one each channel), in the render's
radiance units. It is taken by a **metering pass** before any frame renders: a small,
deterministic preview of every frame before the render's last one (``METERING_WIDTH_PX`` wide,
``METERING_SAMPLES`` samples, seed 0, denoised, no motion blur; ``blender/exposure.py:
meter_frames``), in order, since E_j follows from m_0..m_{j-1}
(``render_plan.SensorPlan.meter``). The values are stored in the manifest
(``sensor.metered``; the sequence's last frame's stays null: no exposure follows it) and
every later writer of the folder reads them, so a frame's exposure is the same whether it is
rendered alone (``--frames A:B``), in a farm's chunk or after ``--resume``. The exposure
product E = t * g (exposure time times analog gain) that would bring the normalised signal
``m * E / (t_nom * full_scale_nominal)`` (0 at the black level, 1 at full scale) to ``target``
is ``E*_j = target * full_scale_nominal * t_nom / m_j``. Frame k uses
``log E_k = log E_{k-1} + (1 - exp(-speed / rate)) (log E*_{k-1} - log E_{k-1})``;
E is split into the longest exposure time allowed (``min(max_exposure, 1 / rate - readout)``,
at least ``min_exposure``) and a gain in [1, max_gain] for the rest; the E actually used
feeds the next step. A drive into a dark area therefore darkens the image first and recovers
at the configured speed.

Frame 0 (``AUTOEXPOSURE start converged``, the default): a real camera has been running before
the sequence's first frame, so its exposure is the controller's **steady state for what frame 0
sees**: the fixed point ``E_0 = E*(m_0(E_0))`` of frame 0's own metering, where ``m_0(E)``
depends on E through the clipping at full scale (a brighter exposure burns out more pixels,
which then count at full scale), E bounded by the exposure and gain limits as above
(``converged_exposure``: iterated on frame 0's metering preview until the next step moves
log E by less than ``CONVERGED_TOL``; the map is monotone with slope in [0, 1], so a solution
exists and is unique while any pixel is unclipped). Frame 0 is therefore metered too (by a
render of frame 0 alone as well) and the stored ``metered[0]`` is ``m_0(E_0)``, from which
``E_0 = E*(metered[0])`` follows (one step at speed infinity): every writer of the folder reads
the same start. With ``start nominal`` frame 0 is exposed at ``E_0 = t_nom * g_nom`` (a camera
switched on as the sequence begins) and converges from there at the configured speed.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LUMA = np.array([0.2126, 0.7152, 0.0722])
METERING_WIDTH_PX = 96     # the metering preview's width (its aspect ratio is the render's)
METERING_SAMPLES = 8
# denoised: the clipped mean of a path-traced preview is biased low by its noise (a pixel's
# fireflies clip, its misses stay dark; a camera meters converged light): the hall's 8-sample
# preview metered 0.43 x its full-size frame's value undenoised and the exposure ran away
METERING_DENOISE = True
CONVERGED_TOL = 1e-6      # |d log E| of the converged start's last step (the fixed point's residual)
CONVERGED_ITERATIONS = 200
METERING_RULE = (f"metering pass before the frames, in order: mean linear luminance of a {METERING_WIDTH_PX} px wide, "
                 f"{METERING_SAMPLES}-sample left-view preview of each frame before the render's last (seed 0, "
                 f"{'denoised (OpenImageDenoise, albedo and normal, CPU)' if METERING_DENOISE else 'no denoiser'}, "
                 "no motion blur; at film exposure 1, times the frames'; frame 0's from the automatic exposure's "
                 "preview rendered the same way where there is one) as the sensor receives it (times the lens's vignetting), each pixel clipped at the "
                 "output's full scale at that frame's own exposure and gain (a mono sensor's luminance, else each channel); "
                 "start converged: frame 0 metered too, its exposure the fixed point E_0 = target * saturation * t_nom "
                 f"/ m_0(E_0) within the exposure and gain limits (|d log E| < {CONVERGED_TOL:g}), metered[0] = m_0(E_0)")


def meter(linear_rgb: np.ndarray, full_scale: float = np.inf, illumination=None, mono: bool = True) -> float:
    """Mean linear luminance of a frame as its camera meters it: ``linear_rgb`` times
    ``illumination`` (the lens's relative illumination per pixel, None: 1), each pixel clipped
    at ``full_scale`` (the linear value that brings the output to full scale: the luminance of
    a ``mono`` sensor, else each channel, as the sensor's pixels saturate). The defaults: the
    plain mean linear luminance."""
    rgb = np.asarray(linear_rgb, dtype=np.float64)[..., :3]
    if illumination is not None:
        rgb = rgb * np.asarray(illumination, dtype=np.float64)[..., None]
    if mono:
        return float(np.mean(np.minimum(rgb @ LUMA, full_scale)))
    return float(np.mean(np.minimum(rgb, full_scale) @ LUMA))


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
    saturation: float              # linear value the output's full scale is at (t_nom, gain 1)
    max_exposure_s: float          # 0: the frame period minus the readout
    max_gain: float
    min_exposure_s: float
    converged_start: bool = False  # frame 0 at the fixed point of its own metering (else at t_nom * g_nom)


def metered_frames(frames, n: int, converged: bool = False) -> int:
    """How many leading frames of an ``n``-frame sequence a render of ``frames`` meters: those
    before its last frame (frame k's exposure follows frames 0..k-1 only), so a render of frames
    0:2 meters frame 0 (the exposure preview's where it is the metering preview) and no render meters the
    sequence's last frame (no exposure follows it). ``converged`` (the converged start): frame 0's
    exposure follows frame 0's own metering, so every render meters frame 0 at least (a
    one-frame sequence its only frame)."""
    upto = max(0, min(n - 1, max(frames, default=0)))
    return max(upto, 1) if converged and n > 0 else upto


def _t_max(c: ExposureControl) -> float:
    t_max = 1.0 / c.rate_hz - c.readout_s
    if c.max_exposure_s > 0:
        t_max = min(t_max, c.max_exposure_s)
    return max(t_max, c.min_exposure_s)


def _usable(m) -> bool:
    return m is not None and m > 0 and bool(np.isfinite(m))


def _target_exposure(m: float, c: ExposureControl) -> float:
    """E* = target * saturation * t_nom / m: the exposure product that brings a frame that
    metered ``m`` to the target."""
    return c.target * c.saturation * c.nominal_exposure_s / m


def _answer(m: float, c: ExposureControl) -> tuple[float, float]:
    """(exposure_s, gain) that would bring a frame that metered ``m`` to the target
    (``_target_exposure``), within the limits."""
    return split_exposure(_target_exposure(m, c), c.nominal_gain, c.min_exposure_s, _t_max(c), c.max_gain)


def start_exposure(m0, c: ExposureControl) -> tuple[float, float]:
    """(exposure_s, gain) of frame 0: with ``c.converged_start`` the answer to frame 0's own
    metered value ``m0`` (stored at the fixed point, ``converged_exposure``: the answer is that
    point), else (or when nothing is lit, ``m0`` <= 0) the nominal exposure and gain."""
    if c.converged_start and _usable(m0):
        return _answer(float(m0), c)
    return split_exposure(c.nominal_exposure_s * c.nominal_gain, c.nominal_gain, c.min_exposure_s, _t_max(c),
                          c.max_gain)


def converged_exposure(meter_at, c: ExposureControl) -> tuple[float, float]:
    """(exposure_s, gain) at which a frame's metering ``meter_at(exposure_s, gain)`` (its
    image clipped at that exposure's full scale) is answered by itself: the fixed point E of
    ``F(E) = E*(meter_at(E))`` within the limits. F is non-decreasing with slope in [0, 1] in
    log E (more exposure clips more, never more than all of the signal), so u = log E is
    found as the root of the non-increasing h(u) = log F(e^u) - u: secant steps inside a
    bracket, fixed-point steps until one is found, bisection where a secant leaves it; done
    when |h| < ``CONVERGED_TOL``. A black frame (nothing metered): the nominal exposure."""
    t, g = start_exposure(None, c)
    m = meter_at(t, g)
    if not _usable(m):
        return t, g
    lo, hi = -np.inf, np.inf
    u, prev = float(np.log(t * g)), None
    for _ in range(CONVERGED_ITERATIONS):
        tn, gn = _answer(m, c)
        h = float(np.log(tn * gn)) - u
        if abs(h) < CONVERGED_TOL:
            return t, g
        if h > 0:
            lo = max(lo, u)
        else:
            hi = min(hi, u)
        step = u + h                                   # the fixed-point step (never overshoots)
        if prev is not None and u != prev[0]:
            slope = (h - prev[1]) / (u - prev[0])
            if slope < 0:
                step = u - h / slope                   # secant
        if not lo < step < hi:
            step = 0.5 * (lo + hi) if np.isfinite(lo) and np.isfinite(hi) else u + h
        prev = (u, h)
        t, g = split_exposure(float(np.exp(step)), c.nominal_gain, c.min_exposure_s, _t_max(c), c.max_gain)
        u = float(np.log(t * g))
        m = meter_at(t, g)
        if not _usable(m):     # cannot happen for a lit frame (metering only falls with clipping); be safe
            return start_exposure(None, c)
    return t, g


def exposure_step(t: float, g: float, m, c: ExposureControl) -> tuple[float, float]:
    """(exposure_s, gain) of the frame after one exposed at (t, g) that metered ``m``."""
    E = t * g
    if _usable(m):
        alpha = 1.0 - np.exp(-float(c.speed) / float(c.rate_hz))
        E_star = _target_exposure(m, c)
        E = float(np.exp(np.log(E) + alpha * (np.log(E_star) - np.log(E))))
    return split_exposure(E, c.nominal_gain, c.min_exposure_s, _t_max(c), c.max_gain)


def exposure_schedule(metered: list[float], c: ExposureControl) -> list[tuple[float, float]]:
    """(exposure_s, gain) of frames 0..len(metered): frame k depends on metered[:k], and with
    the converged start frame 0 on metered[0] (``start_exposure``; ValueError without it)."""
    if c.converged_start and not metered:
        raise ValueError("the converged start's frame 0 exposure follows frame 0's metering: none given")
    out = [start_exposure(metered[0] if metered else None, c)]
    for m in metered:
        out.append(exposure_step(*out[-1], m, c))
    return out
