"""bench/quality_unbiased.py's estimate of a render's error against the truth from two noisy,
unbiased references (no Blender): synthetic images whose truth is known."""
import importlib.util
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
_spec = importlib.util.spec_from_file_location("quality_unbiased", REPO / "bench" / "quality_unbiased.py")
qu = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(qu)


def _scene(rng, h=92, w=120):
    truth = rng.uniform(0.2, 0.8, (h, w, 3))
    error = 0.02 * np.sin(np.arange(w) / 3.0)[None, :, None] * np.ones((h, 1, 3))  # the render's own error
    return truth, truth + error, float((error ** 2).mean())


def test_the_error_map_removes_the_references_noise():
    """References with noise (sigma 0.05) far above the render's error (~0.014 rms): the map's mean
    is the render's MSE against the truth; F against the references' mean is not."""
    rng = np.random.default_rng(1)
    truth, F, mse = _scene(rng)
    A = truth + rng.normal(0, 0.05, truth.shape)
    B = truth + rng.normal(0, 0.05, truth.shape)
    t = qu.truth_error_map(F, A, B)
    assert abs(t.mean() - mse) < 0.1 * mse
    assert ((F - (A + B) / 2) ** 2).mean() > 5 * mse       # the naive figure: the references' noise dominates
    row = qu.estimate(F, A, B)
    assert abs(row["mse_vs_truth_est"] - t.mean()) < 1e-12


def test_the_block_bootstrap_covers_the_truth_under_correlated_noise():
    """Reference noise correlated over ~6 px (as a denoiser's blotches): the 90 % interval of
    20-px blocks holds the true MSE in most draws; single pixels (block 1) claim far too narrow
    an interval and miss it more often."""
    from scipy.ndimage import uniform_filter
    rng = np.random.default_rng(2)
    hits, hits1 = 0, 0
    for _ in range(40):
        truth, F, mse = _scene(rng)
        noise = [uniform_filter(rng.normal(0, 0.25, truth.shape), (6, 6, 1)) for _ in range(2)]
        t = qu.truth_error_map(F, truth + noise[0], truth + noise[1])
        lo, hi = qu.block_bootstrap(t, block=20, draws=400, rng=int(rng.integers(1 << 30)))
        lo1, hi1 = qu.block_bootstrap(t, block=1, draws=400, rng=int(rng.integers(1 << 30)))
        p = qu.qb.psnr_mse(mse)
        assert lo <= hi
        hits += lo <= p <= hi
        hits1 += lo1 <= p <= hi1
    assert hits >= 30, hits
    assert hits1 < hits


def test_explain_shares_add_up_by_kind():
    rng = np.random.default_rng(3)
    t = rng.uniform(0, 1, (10, 10))
    kinds = np.where(np.arange(100).reshape(10, 10) < 30, "car", "tree")
    clipped = np.zeros((10, 10), bool)
    clipped[0, :5] = True
    where = qu.explain(t, kinds, clipped)
    assert abs(where["car"][0] + where["tree"][0] - 1) < 1e-12
    assert where["car"][1] == 0.3 and where["clipped"][1] == 0.05
    assert abs(where["clipped"][0] - t[0, :5].sum() / t.sum()) < 1e-12
