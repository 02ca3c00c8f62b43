"""Allan deviation of inertial sensor streams (IEEE Std 952 / 1554 definitions).

The overlapping Allan variance of a rate signal x sampled at ``rate_hz``, for a cluster time
tau = m / rate: with theta the integrated signal (theta_0 = 0, theta_i = sum x_j / rate),
sigma^2(tau) = sum_k (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2 / (2 tau^2 (N - 2m)).
White noise of density N gives sigma = N / sqrt(tau); a random walk of density K gives
sigma = K sqrt(tau / 3). :func:`fit_noise_densities` reads both from a curve.
"""
from __future__ import annotations

import numpy as np


def allan_deviation(x: np.ndarray, rate_hz: float, taus_s=None, points: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """(tau_s, adev) per column of x ((n,) or (n, c)); taus log-spaced up to n / (4 rate) by default."""
    x = np.asarray(x, dtype=np.float64)
    squeeze = x.ndim == 1
    x = x.reshape(len(x), -1)
    n = len(x)
    theta = np.concatenate([np.zeros((1, x.shape[1])), np.cumsum(x, axis=0) / rate_hz])
    if taus_s is None:
        ms = np.unique(np.logspace(0, np.log10(max(n // 4, 1)), points).astype(int))
    else:
        ms = np.unique(np.maximum(1, np.rint(np.asarray(taus_s) * rate_hz).astype(int)))
        ms = ms[2 * ms < n]
    taus = ms / rate_hz
    adev = np.empty((len(ms), x.shape[1]))
    theta = np.ascontiguousarray(theta.T)          # one row per column: hours of samples stream through once
    for i, m in enumerate(ms):
        lag = theta[:, m:] - theta[:, :-m]          # theta_{k+m} - theta_k
        d = lag[:, m:] - lag[:, :-m]                # theta_{k+2m} - 2 theta_{k+m} + theta_k
        adev[i] = np.sqrt(np.einsum("ij,ij->i", d, d) / (2 * taus[i] ** 2 * (n + 1 - 2 * m)))
    return taus, (adev[:, 0] if squeeze else adev)


def fit_noise_densities(taus_s: np.ndarray, adev: np.ndarray) -> tuple[float, float]:
    """(white noise density N, random-walk density K) from sigma^2 = N^2 / tau + K^2 tau / 3,
    least squares on the relative (log-like) error of the variance."""
    t = np.asarray(taus_s, dtype=float)
    v = np.asarray(adev, dtype=float) ** 2
    A = np.stack([1.0 / t, t / 3.0], axis=1) / v[:, None]
    coef, *_ = np.linalg.lstsq(A, np.ones_like(v), rcond=None)
    return float(np.sqrt(max(coef[0], 0.0))), float(np.sqrt(max(coef[1], 0.0)))
