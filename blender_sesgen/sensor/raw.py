"""The raw image sensor: electrons, noise, colour filter array, quantisation, demosaic and
the camera response (numpy only; the model of docs/rendering.md, "Raw sensor").

Per pixel, in electrons (e-): signal ``S = full_well * L / saturation * t / t_nom`` from the
linear render value L (one colour channel, picked by the CFA), then

    e = Poisson(S * (1 + PRNU)) + Poisson(dark * t) + DSNU + N(0, read^2) + row offset N(0, row^2)

clipped to [0, full_well] before the read chain, and digital numbers
``DN = clip(round(black + e * K), 0, 2^bits - 1)`` with the conversion gain
``K = gain * (2^bits - 1) / full_well`` DN/e-. PRNU (relative) and DSNU (e-) are fixed
per camera (seeded by the sensor seed and the view); shot, dark, read and row noise are
drawn per frame from the seed, the frame and the view — independent of Cycles' seed.
So mean and variance follow the photon-transfer line var(DN) = K * mean(DN - black)
+ K^2 (read^2 + row^2) + 1/12 below saturation (tests/test_sensor_raw.py).
"""
from __future__ import annotations

import numpy as np

from ..contract.cfa import cfa_channels

def fixed_pattern(shape, prnu: float, dsnu_e: float, seed: int, view_index: int):
    """Per-camera PRNU (relative gain - 1) and DSNU (e-) maps of the given shape."""
    rng = np.random.default_rng([int(seed), int(view_index), 0xF97])
    g = rng.standard_normal(shape) * float(prnu) if prnu else np.zeros(shape)
    o = rng.standard_normal(shape) * float(dsnu_e) if dsnu_e else np.zeros(shape)
    return g, o


def conversion_gain(full_well_e: float, bits: int, gain: float) -> float:
    """K in DN per electron."""
    return float(gain) * (2 ** int(bits) - 1) / float(full_well_e)


def capture(signal_e: np.ndarray, sensor, *, gain: float, exposure_s: float = 0.0, fixed_pattern=(None, None),
            rng=None) -> np.ndarray:
    """Mean signal (electrons, (H, W) or (H, W, C)) -> noisy digital numbers (uint16).

    ``sensor``: the electrical model (``model.Sensor``: full well, read noise, dark current,
    row noise, bits, black level); ``gain``: this frame's analog gain; ``fixed_pattern``:
    (PRNU map, DSNU map) or None for either (:func:`fixed_pattern`)."""
    full_well_e, read_noise_e, dark_current_e_s = sensor.full_well_e, sensor.read_noise_e, sensor.dark_current_e_s
    row_noise_e, bits, black_level_dn = sensor.row_noise_e, sensor.bits, sensor.black_level_dn
    prnu_map, dsnu_map = fixed_pattern
    rng = rng if rng is not None else np.random.default_rng(0)
    s = np.clip(np.asarray(signal_e, dtype=np.float64), 0.0, None)
    if prnu_map is not None:
        s = s * np.clip(1.0 + prnu_map, 0.0, None)
    e = rng.poisson(s).astype(np.float64)
    if dark_current_e_s and exposure_s:
        e += rng.poisson(float(dark_current_e_s) * float(exposure_s), size=s.shape)
    e = np.minimum(e, float(full_well_e))
    if dsnu_map is not None:
        e += dsnu_map
    if read_noise_e:
        e += rng.standard_normal(s.shape) * float(read_noise_e)
    if row_noise_e:
        e += (rng.standard_normal(s.shape[0]) * float(row_noise_e)).reshape((-1,) + (1,) * (s.ndim - 1))
    K = conversion_gain(full_well_e, bits, gain)
    dn = np.rint(float(black_level_dn) + e * K)
    return np.clip(dn, 0, 2 ** int(bits) - 1).astype(np.uint16)


# --- demosaic ----------------------------------------------------------------------------

def _correlate(img: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    k = np.asarray(kernel, dtype=np.float64)
    r = k.shape[0] // 2
    p = np.pad(img, r, mode="reflect")
    H, W = img.shape
    out = np.zeros((H, W))
    for i in range(k.shape[0]):
        for j in range(k.shape[1]):
            if k[i, j]:
                out += k[i, j] * p[i:i + H, j:j + W]
    return out


def demosaic_bilinear(raw: np.ndarray, pattern: str) -> np.ndarray:
    """(H, W) mosaic -> (H, W, 3) float64 by bilinear interpolation of each colour plane."""
    raw = np.asarray(raw, dtype=np.float64)
    ch = cfa_channels(pattern, *raw.shape)
    k_rb = np.array([[1, 2, 1], [2, 4, 2], [1, 2, 1]]) / 4.0
    k_g = np.array([[0, 1, 0], [1, 4, 1], [0, 1, 0]]) / 4.0
    out = np.empty(raw.shape + (3,))
    for c in range(3):
        out[..., c] = _correlate(np.where(ch == c, raw, 0.0), k_g if c == 1 else k_rb)
    return out


# Malvar, He, Cutler, "High-quality linear interpolation for demosaicing of Bayer-patterned
# color images", ICASSP 2004: 5x5 gradient-corrected kernels (x 1/8).
_MHC_G_AT_RB = np.array([[0, 0, -1, 0, 0], [0, 0, 2, 0, 0], [-1, 2, 4, 2, -1], [0, 0, 2, 0, 0], [0, 0, -1, 0, 0]]) / 8
_MHC_ROW = np.array([[0, 0, .5, 0, 0], [0, -1, 0, -1, 0], [-1, 4, 5, 4, -1], [0, -1, 0, -1, 0], [0, 0, .5, 0, 0]]) / 8
_MHC_COL = _MHC_ROW.T
_MHC_DIAG = np.array([[0, 0, -1.5, 0, 0], [0, 2, 0, 2, 0], [-1.5, 0, 6, 0, -1.5], [0, 2, 0, 2, 0], [0, 0, -1.5, 0, 0]]) / 8


def demosaic_mhc(raw: np.ndarray, pattern: str) -> np.ndarray:
    """(H, W) mosaic -> (H, W, 3) float64, Malvar-He-Cutler."""
    raw = np.asarray(raw, dtype=np.float64)
    H, W = raw.shape
    ch = cfa_channels(pattern, H, W)
    rows = np.arange(H)[:, None] * np.ones((1, W), dtype=int)
    # which colour shares the row with a green pixel: look at its horizontal neighbour
    left = np.roll(ch, 1, axis=1)
    left[:, 0] = ch[:, 1]
    g_at_rb = _correlate(raw, _MHC_G_AT_RB)
    row_est = _correlate(raw, _MHC_ROW)
    col_est = _correlate(raw, _MHC_COL)
    diag_est = _correlate(raw, _MHC_DIAG)
    out = np.empty((H, W, 3))
    out[..., 1] = np.where(ch == 1, raw, g_at_rb)
    for c, other in ((0, 2), (2, 0)):
        v = np.where(ch == c, raw, 0.0)
        v = np.where(ch == other, diag_est, v)
        green = ch == 1
        same_row = green & (left == c)          # c is to the left/right of this green pixel
        v = np.where(same_row, row_est, v)
        v = np.where(green & ~same_row, col_est, v)
        out[..., c] = v
    del rows
    return out


# --- response and quantisation ------------------------------------------------------------

def response(x: np.ndarray, kind: str = "srgb", gamma: float = 2.2) -> np.ndarray:
    """Camera response curve on normalised linear values (clipped to [0, 1])."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    if kind == "linear":
        return x
    if kind == "gamma":
        return x ** (1.0 / float(gamma))
    if kind == "srgb":   # IEC 61966-2-1, the contract's one definition
        from ..contract.colour import linear_to_srgb
        return linear_to_srgb(x).astype(np.float64)
    raise ValueError(f"unknown response {kind!r} (linear, srgb, gamma)")


def quantise(x01: np.ndarray, bits: int) -> np.ndarray:
    """[0, 1] -> integers 0 .. 2^bits - 1 (nearest), uint8 for 8 bits else uint16."""
    q = np.rint(np.clip(x01, 0.0, 1.0) * (2 ** int(bits) - 1))
    return q.astype(np.uint8 if bits <= 8 else np.uint16)
