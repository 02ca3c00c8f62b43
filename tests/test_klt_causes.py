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


def test_twin_carries_the_renders_klt_to_the_real_rigs_speed(monkeypatch):
    """bench/twin.py's klt_at_speed: a KLT error growing as the step squared (a stand-in tracker
    reading each frame's travelled distance from its grey level) is carried from the render's
    1.0 m steps to the real rig's 1.2 m: x 1.44, the exponent 2."""
    import twin
    import vo_reference.evaluate.realism as realism
    monkeypatch.setattr(realism, "klt_fb_error", lambda a, b: 0.05 * ((float(b[0, 0]) - float(a[0, 0])) / 10.0) ** 2)

    def frames(step, n=8):
        T = np.tile(np.eye(4), (n, 1, 1))
        T[:, 2, 3] = step * np.arange(n)
        img = [np.full((4, 4), 10.0 * step * k) for k in range(n)]
        return twin.Frames(img, img, np.eye(3), 0.5, T)
    real, ours = frames(1.2), frames(1.0)
    line = twin.klt_at_speed(real, ours, 8, real_klt=0.05 * 1.2 ** 2)
    assert "mean step real 1.200 m, render 1.000 m" in line
    assert "step^2.00" in line and "render / real 0.69 -> 1.00" in line
