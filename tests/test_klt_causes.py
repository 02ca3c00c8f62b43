"""bench/klt_causes.py's helpers against analytic oracles: the flat blocks' noise level and
correlation (white vs interpolated noise of known correlation), the flow reweighting and the
speed scaling along a known fb-vs-flow law."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
import klt_causes as kc  # noqa: E402


def test_flat_block_noise_reads_the_level_and_an_interpolations_correlation():
    rng = np.random.default_rng(0)
    white = [100 + 1.5 * rng.normal(size=(185, 613)) for _ in range(2)]
    h, v = kc.noise_correlation(white, frac=1.0)
    assert -0.09 < h < -0.02 and -0.09 < v < -0.02          # a plane fit's residual of white noise
    st, _ = kc.flat_block_noise(white[0])
    assert np.sqrt(np.median(st[:, 1])) == pytest.approx(1.5, rel=0.05)
    # a horizontal linear interpolation halfway between pixels: lag-1 correlation 0.5 (sd 1.5 / sqrt 2)
    interp = [0.5 * (w[:, 1:] + w[:, :-1]) for w in white]
    h, v = kc.noise_correlation(interp, frac=1.0)
    assert 0.38 < h < 0.5 and -0.09 < v < -0.02


def test_flow_weights_and_speed_scaling():
    rng = np.random.default_rng(1)
    flow_o, flow_r = rng.lognormal(1.8, 0.8, 20000), rng.lognormal(2.0, 0.8, 20000)
    law = lambda f: 0.01 * f ** 1.5  # noqa: E731  (fb error growing with flow)
    O = np.stack([np.arange(20000) % 40, np.zeros(20000), np.zeros(20000), law(flow_o) * rng.lognormal(0, 0.3, 20000),
                  np.ones(20000), flow_o], axis=1)
    R = O.copy()
    R[:, 5] = flow_r
    R[:, 3] = law(flow_r) * rng.lognormal(0, 0.3, 20000)
    w = kc.flow_weights(O, R)
    assert kc.weighted_median(O[:, 5], w) == pytest.approx(np.median(flow_r), rel=0.05)
    assert kc.weighted_median(O[:, 3], w) == pytest.approx(np.median(R[:, 3]), rel=0.08)
    # the same rig 1.2x as fast: each flow 1.2x, so fb 1.2^1.5 x along the law
    s = kc.at_speed(O, np.full(40, 1.2))
    assert np.median(s) / np.median(O[:, 3]) == pytest.approx(1.2 ** 1.5, rel=0.06)
    assert np.allclose(kc.at_speed(O, np.ones(40)), O[:, 3])
    assert kc.bench_klt(O) == pytest.approx(np.median(O[:, 3]), rel=0.05)
