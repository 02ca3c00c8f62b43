"""KITTI's pixel noise correlation at full size and binned (issue 28: the kitti profile's noise is
white; KITTI's full-size noise is correlated along the rows, bench/klt_causes.py's lag-1 +0.26).

    python bench/noise_correlation.py [--frames 51]

The rule is bench/klt_causes.py's: the flattest 5 % of B x B blocks (no 0/255; a plane removed),
their residuals' lag-l correlation along the rows (h) and the columns (v), median over frames;
a white noise reads below 0 by the plane's fit (printed). Prints, for KITTI sequence_1's left
and right images: lags 1-3 at full size (1226 px, B 8); lag 1 on even/odd column pairs (a
correlation made by a 2-pixel structure, e.g. a horizontally doubled readout, would sit on one
parity and vanish in a 2 x 2 binning); and lag 1 binned 2 x 2 (613 px, cv2.INTER_AREA, as
bench/twin.py brings KITTI to the render's size) with B 8 and with B 4 (the full size's block
footprint). Beside them, pure noise through the same rule: white, and a linear model (a
symmetric 3-tap filter along the rows and the columns, [b 1 b], fitted to KITTI's full-size
lag-1 h and v) at full size and binned: what a correlated-noise chain element with KITTI's
full-size figure would show at 613 px. Pure (numpy, OpenCV); ~10 s.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from klt_causes import flat_block_noise  # noqa: E402

KITTI = Path(__file__).resolve().parents[2] / "shared" / "data" / "kitti" / "sequence_1"


def lag_correlation(imgs, B: int = 8, frac: float = 0.05, lags: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """(h, v): lag 1..``lags`` correlation of the flattest ``frac`` of B x B blocks' residuals."""
    H, V = [], []
    for im in imgs:
        st, res = flat_block_noise(im, B)
        keep = res[st[:, 1] <= np.quantile(st[:, 1], frac)]
        p = np.mean(keep ** 2)
        H.append([np.mean(keep[:, :, k:] * keep[:, :, :-k]) / p for k in range(1, lags + 1)])
        V.append([np.mean(keep[:, k:, :] * keep[:, :-k, :]) / p for k in range(1, lags + 1)])
    return np.median(H, 0), np.median(V, 0)


def parity(imgs, B: int = 8, frac: float = 0.05) -> tuple[float, float]:
    """Lag-1 correlation along the rows on (even, odd) and on (odd, even) column pairs."""
    out = []
    for im in imgs:
        st, res = flat_block_noise(im, B)
        keep = res[st[:, 1] <= np.quantile(st[:, 1], frac)]
        p = np.mean(keep ** 2)
        out.append((np.mean(keep[:, :, 0:-1:2] * keep[:, :, 1::2]) / p, np.mean(keep[:, :, 1:-1:2] * keep[:, :, 2::2]) / p))
    return tuple(np.median(out, 0))


def half(imgs):
    return [cv2.resize(im, (im.shape[1] // 2, im.shape[0] // 2), interpolation=cv2.INTER_AREA) for im in imgs]


def filtered_noise(shape, bh: float, bv: float, rng, n: int = 4):
    """``n`` images of white noise through [bh 1 bh] along the rows and [bv 1 bv] along the columns."""
    out = []
    for _ in range(n):
        z = rng.normal(0.0, 2.0, (shape[0] + 2, shape[1] + 2))
        z = z[:, 1:-1] + bh * (z[:, :-2] + z[:, 2:])
        z = z[1:-1] + bv * (z[:-2] + z[2:])
        out.append(100.0 + z)
    return out


def fit_taps(target_h: float, target_v: float, shape, rng) -> tuple[float, float]:
    """The taps (bh, bv) whose noise reads KITTI's full-size lag-1 (h, v) by the rule (a few
    secant steps on each, the other held)."""
    bh, bv = 0.15, 0.05
    for _ in range(4):
        h, v = (x[0] for x in lag_correlation(filtered_noise(shape, bh, bv, rng, 2), frac=1.0, lags=1))
        bh = float(np.clip(bh + (target_h - h) * 0.6, 0.0, 0.5))
        bv = float(np.clip(bv + (target_v - v) * 0.6, 0.0, 0.5))
    return bh, bv


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=51)
    a = ap.parse_args(argv)
    if not KITTI.is_dir():
        print(f"{KITTI}: missing (../shared/data)", file=sys.stderr)
        return 2
    f3 = lambda x: " ".join(f"{v:+.3f}" for v in np.atleast_1d(x))  # noqa: E731
    full = {}
    for side in ("image_l", "image_r"):
        files = sorted((KITTI / side).glob("*.png"))[:a.frames]
        imgs = [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE).astype(np.float64) for f in files]
        full[side] = imgs
        h, v = lag_correlation(imgs)
        ev, od = parity(imgs)
        h2, v2 = lag_correlation(half(imgs), B=8, lags=1)
        h4, v4 = lag_correlation(half(imgs), B=4, lags=1)
        print(f"KITTI {side} ({len(imgs)} frames): full 1226 px B8 lags 1-3 h {f3(h)}, v {f3(v)}; lag-1 h on (even, odd) "
              f"/ (odd, even) column pairs {ev:+.3f} / {od:+.3f}; binned 613 px lag-1 B8 h {f3(h2)}, v {f3(v2)}, "
              f"B4 h {f3(h4)}, v {f3(v4)}")
    rng = np.random.default_rng(0)
    shape = full["image_l"][0].shape
    h, v = lag_correlation(full["image_l"], lags=1)
    white = filtered_noise(shape, 0.0, 0.0, rng)
    print(f"white noise by the same rule: full B8 h {f3(lag_correlation(white, frac=1.0, lags=1)[0])}, "
          f"v {f3(lag_correlation(white, frac=1.0, lags=1)[1])}; binned B8 "
          f"h {f3(lag_correlation(half(white), B=8, frac=1.0, lags=1)[0])}, "
          f"B4 h {f3(lag_correlation(half(white), B=4, frac=1.0, lags=1)[0])}")
    bh, bv = fit_taps(float(h[0]), float(v[0]), shape, rng)
    model = filtered_noise(shape, bh, bv, rng)
    mf, mh8, mh4 = (lag_correlation(model, frac=1.0, lags=1), lag_correlation(half(model), B=8, frac=1.0, lags=1),
                    lag_correlation(half(model), B=4, frac=1.0, lags=1))
    rho = lambda b: 2 * b / (1 + 2 * b * b)  # noqa: E731
    print(f"linear model [b 1 b] fitted to KITTI's left full-size lag 1 (taps h {bh:.3f}, v {bv:.3f}: true lag-1 "
          f"correlation h {rho(bh):.3f}, v {rho(bv):.3f}): full B8 h {f3(mf[0])}, v {f3(mf[1])}; binned 613 px B8 "
          f"h {f3(mh8[0])}, v {f3(mh8[1])}, B4 h {f3(mh4[0])}, v {f3(mh4[1])}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
