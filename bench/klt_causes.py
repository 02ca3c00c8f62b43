"""Why the render's KLT forward-backward error is below KITTI's (issue 28): the table's KLT
(vo_reference.evaluate.realism.klt_fb_error: Shi-Tomasi corners of frame k tracked into k+1 and
back, the median per pair, the median over the pairs) taken apart per corner, on a twin render
(bench/twin.py's folder, draw 0 through today's chain) and on KITTI sequence_1 at the same size.

    python bench/klt_causes.py --out /work/runs/NAME/before/city [--frames 45] [--draw 0]

Prints, for both: the corners' image flow (how far each moves, px) and the rig's step; the fb
error by flow; by corner strength (the structure tensor's smaller eigenvalue, 21 x 21, terciles
of both pooled) at equal flow; by sixth of the image, and the weakest third by sixth at equal flow; the render's KLT at KITTI's speed (each
corner's fb scaled by the render's own fb-vs-flow curve from its flow to its flow times KITTI's
step over the render's: the drive's speed alone); the render's KLT reweighted to KITTI's flow
distribution (speed and depth); and the pixel noise: the flattest 8 x 8 blocks' residual
(a plane removed) at the bench's size by brightness, and its lag-1 correlation at KITTI's full
size (a white noise reads ~-0.05 by this rule: the plane's fit).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import twin  # noqa: E402
from vo_reference.evaluate.realism import CORNER_CAP, CORNER_MIN_DISTANCE, CORNER_QUALITY, LK_PARAMS  # noqa: E402

FLOW_BINS = (0, 2, 4, 8, 16, 1000)
LEVELS = ((10, 40), (40, 70), (70, 100), (100, 140), (140, 200))


def per_corner(frames, n: int) -> np.ndarray:
    """One row per corner tracked both ways: (pair k, x, y, fb error px, min eigenvalue, flow px),
    the table's KLT (realism.klt_fb_error) per corner."""
    rows = []
    for k in range(n - 1):
        a, b = frames.image_gray(k), frames.image_gray(k + 1)
        pts = cv2.goodFeaturesToTrack(a, CORNER_CAP, CORNER_QUALITY, CORNER_MIN_DISTANCE)
        if pts is None:
            continue
        p1, s1, _ = cv2.calcOpticalFlowPyrLK(a, b, pts, None, **LK_PARAMS)
        p0, s2, _ = cv2.calcOpticalFlowPyrLK(b, a, p1, None, **LK_PARAMS)
        ok = (s1.ravel() == 1) & (s2.ravel() == 1)
        P, fb = pts.reshape(-1, 2), np.linalg.norm((p0 - pts).reshape(-1, 2), axis=1)
        flow = np.linalg.norm((p1 - pts).reshape(-1, 2), axis=1)
        lam = cv2.cornerMinEigenVal(a, 21, 3)
        x, y = np.rint(P[:, 0]).astype(int), np.rint(P[:, 1]).astype(int)
        rows += [(k, P[i, 0], P[i, 1], fb[i], lam[y[i], x[i]], flow[i]) for i in np.where(ok)[0]]
    return np.array(rows, float).reshape(-1, 6)


def bench_klt(rows: np.ndarray, values=None) -> float:
    """The table's figure: the median over the pairs of each pair's median (of ``values``, default the fb error)."""
    v = rows[:, 3] if values is None else values
    return float(np.median([np.median(v[rows[:, 0] == k]) for k in np.unique(rows[:, 0])]))


def fb_flow_curve(rows: np.ndarray):
    """f(flow) -> the median fb error of corners moving that far (log-spaced bins, log-log interpolation)."""
    e = np.geomspace(0.3, 80, 25)
    c, med = np.sqrt(e[1:] * e[:-1]), []
    for lo, hi in zip(e[:-1], e[1:]):
        m = (rows[:, 5] >= lo) & (rows[:, 5] < hi)
        med.append(np.median(rows[m, 3]) if m.sum() >= 20 else np.nan)
    med = np.array(med)
    ok = np.isfinite(med) & (med > 0)
    return lambda f: np.exp(np.interp(np.log(np.clip(f, c[ok][0], c[ok][-1])), np.log(c[ok]), np.log(med[ok])))


def at_speed(rows: np.ndarray, speed_ratio: np.ndarray) -> np.ndarray:
    """Each corner's fb error had the rig driven ``speed_ratio[k]`` times as fast over pair k: the
    corner's fb times the render's fb-vs-flow curve's ratio at flow x ratio over flow."""
    f = fb_flow_curve(rows)
    s = np.asarray(speed_ratio, float)[rows[:, 0].astype(int)]
    return rows[:, 3] * f(rows[:, 5] * s) / f(rows[:, 5])


def flow_weights(rows: np.ndarray, target: np.ndarray, bins: int = 20) -> np.ndarray:
    """Weights that give ``rows``' corners ``target``'s flow distribution (quantile bins of both)."""
    e = np.quantile(np.concatenate([rows[:, 5], target[:, 5]]), np.linspace(0, 1, bins + 1))
    e[-1] += 1
    h_t, h_r = np.histogram(target[:, 5], e)[0], np.histogram(rows[:, 5], e)[0]
    return (h_t / np.maximum(h_r, 1))[np.clip(np.digitize(rows[:, 5], e) - 1, 0, bins - 1)]


def weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    i = np.argsort(x)
    c = np.cumsum(w[i])
    return float(x[i][np.searchsorted(c, c[-1] / 2)])


def flat_block_noise(img, B: int = 8):
    """(block mean, residual variance) of each B x B block without 0/255 (a plane removed), and
    the residuals themselves."""
    a = np.asarray(img, float)
    H, W = a.shape
    yy, xx = np.mgrid[0:B, 0:B]
    A = np.stack([np.ones(B * B), xx.ravel(), yy.ravel()], 1)
    P = A @ np.linalg.pinv(A)
    stats, res = [], []
    for y in range(0, H - B + 1, B):
        for x in range(0, W - B + 1, B):
            blk = a[y:y + B, x:x + B]
            if blk.max() >= 250 or blk.min() <= 10:
                continue
            r = blk.ravel() - P @ blk.ravel()
            stats.append((blk.mean(), r.var() * B * B / (B * B - 3)))
            res.append(r.reshape(B, B))
    return np.array(stats), np.array(res)


def noise_by_level(imgs) -> str:
    """The flattest blocks' residual sd (5th percentile within each brightness band, DN)."""
    st = np.concatenate([flat_block_noise(im)[0] for im in imgs])
    out = []
    for lo, hi in LEVELS:
        v = st[(st[:, 0] >= lo) & (st[:, 0] < hi), 1]
        out.append(f"{lo}-{hi} {np.sqrt(np.quantile(v, 0.05)):.2f}" if len(v) >= 20 else f"{lo}-{hi} -")
    return ", ".join(out)


def noise_correlation(imgs, frac: float = 0.05) -> tuple[float, float]:
    """Lag-1 correlation (horizontal, vertical) of the flattest ``frac`` of blocks' residuals."""
    hs, vs = [], []
    for im in imgs:
        st, res = flat_block_noise(im)
        keep = res[st[:, 1] <= np.quantile(st[:, 1], frac)]
        p = np.mean(keep ** 2)
        hs.append(np.mean(keep[:, :, 1:] * keep[:, :, :-1]) / p)
        vs.append(np.mean(keep[:, 1:, :] * keep[:, :-1, :]) / p)
    return float(np.median(hs)), float(np.median(vs))


def sixths(rows: np.ndarray, W: int, H: int) -> np.ndarray:
    return twin._sixth(rows[:, 1], rows[:, 2], W, H)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="a twin render folder (bench/twin.py's OUT/city)")
    ap.add_argument("--frames", type=int, default=45)
    ap.add_argument("--draw", type=int, default=0)
    a = ap.parse_args(argv)
    out = Path(a.out)
    if not (out / "manifest.json").is_file():
        print(f"{out}: not a render folder (bench/twin.py --out DIR writes DIR/city)", file=sys.stderr)
        return 2
    if not twin.DATA.is_dir():
        print(f"real data not found at {twin.DATA} (set SESGEN_SHARED_DATA)", file=sys.stderr)
        return 2
    from vo_reference.io.sequence import open_sequence
    real_seq = open_sequence(twin.DATA / "kitti" / "sequence_1")
    n = min(a.frames, open_sequence(out).num_frames, real_seq.num_frames)
    if n < 3:
        print("--frames: 3 or more", file=sys.stderr)
        return 2
    ours = twin.resensor(out, n, 0, a.draw)
    W, H = ours.resolution
    real = twin.resized(real_seq, n, (W, H))
    R, O = per_corner(real, n), per_corner(ours, n)
    step = lambda fr: np.linalg.norm(np.diff(np.asarray(fr.T_world_cam("left"))[:n, :3, 3], axis=0), axis=1)  # noqa: E731
    sr, so = step(real), step(ours)
    print(f"KLT per corner, {n} frames at {W}x{H} (render {out}, draw {a.draw}); KITTI sequence_1 / render:")
    print(f"  the table's KLT {bench_klt(R):.3f} / {bench_klt(O):.3f} px (ratio {bench_klt(O) / bench_klt(R):.2f}); "
          f"corners tracked {len(R)} / {len(O)}")
    print(f"  the rig's step {sr.mean():.3f} / {so.mean():.3f} m (render {so.min():.3f}-{so.max():.3f}); corners' "
          f"flow median {np.median(R[:, 5]):.2f} / {np.median(O[:, 5]):.2f} px")
    print("  fb by flow (px; median, corners): " + "; ".join(
        f"{lo}-{hi if hi < 1000 else ''}: {np.median(R[(R[:, 5] >= lo) & (R[:, 5] < hi), 3]):.3f} / "
        f"{np.median(O[(O[:, 5] >= lo) & (O[:, 5] < hi), 3]):.3f}"
        for lo, hi in zip(FLOW_BINS[:-1], FLOW_BINS[1:])))
    lq = np.quantile(np.concatenate([R[:, 4], O[:, 4]]), [0, 1 / 3, 2 / 3, 1])
    lq[-1] += 1
    print(f"  corner strength (min eigenvalue) median {np.median(R[:, 4]):.4f} / {np.median(O[:, 4]):.4f}; fb by "
          "strength tercile (weak, middle, strong) at equal flow:")
    for lo, hi in zip(FLOW_BINS[:-1], FLOW_BINS[1:]):
        cells = []
        for a_, b_ in zip(lq[:-1], lq[1:]):
            mr = (R[:, 5] >= lo) & (R[:, 5] < hi) & (R[:, 4] >= a_) & (R[:, 4] < b_)
            mo = (O[:, 5] >= lo) & (O[:, 5] < hi) & (O[:, 4] >= a_) & (O[:, 4] < b_)
            cells.append(f"{np.median(R[mr, 3]):.3f} / {np.median(O[mo, 3]):.3f}" if mr.sum() >= 20 and mo.sum() >= 20
                         else "-")
        print(f"    flow {lo}-{hi if hi < 1000 else ''} px: " + ", ".join(cells))
    gr, go = sixths(R, W, H), sixths(O, W, H)
    print("  by sixth (" + ", ".join(twin.REGIONS) + "): fb " + " | ".join(
        f"{np.median(R[gr == i, 3]):.3f} / {np.median(O[go == i, 3]):.3f}" for i in range(6))
        + "; flow " + " | ".join(f"{np.median(R[gr == i, 5]):.1f} / {np.median(O[go == i, 5]):.1f}" for i in range(6)))
    weak = lambda A: A[:, 4] < lq[1]  # noqa: E731
    cells = []
    for i in range(6):
        for lo, hi in ((2, 8), (8, 30)):
            mr = (gr == i) & weak(R) & (R[:, 5] >= lo) & (R[:, 5] < hi)
            mo = (go == i) & weak(O) & (O[:, 5] >= lo) & (O[:, 5] < hi)
            cells.append(f"{np.median(R[mr, 3]):.3f} / {np.median(O[mo, 3]):.3f}" if mr.sum() >= 15 and mo.sum() >= 15
                         else "-")
    print("  the weakest third by sixth at equal flow (2-8 px, 8-30 px; where KITTI's weak corners err more): " + " | ".join(
        f"{twin.REGIONS[i]} {cells[2 * i]}, {cells[2 * i + 1]}" for i in range(6)))
    ratio = sr.mean() / so
    sped = bench_klt(O, at_speed(O, ratio))
    w = flow_weights(O, R)
    print(f"  the render at KITTI's speed (fb along its own fb-vs-flow curve, step x {np.median(ratio):.3f}): KLT "
          f"{sped:.3f} (ratio {sped / bench_klt(R):.2f}); reweighted to KITTI's flow distribution: median fb "
          f"{weighted_median(O[:, 3], w):.3f} against KITTI's {np.median(R[:, 3]):.3f} (ratio "
          f"{weighted_median(O[:, 3], w) / np.median(R[:, 3]):.2f}; as is {np.median(O[:, 3]) / np.median(R[:, 3]):.2f})")
    every = range(0, n, 4)
    print(f"  pixel noise, flattest 8 x 8 blocks' residual sd by brightness (DN, 5th percentile): "
          f"{noise_by_level([real.image_gray(k) for k in every])} / {noise_by_level([ours.image_gray(k) for k in every])}")
    hr, vr = noise_correlation([real_seq.image_gray(k) for k in every])
    h2, v2 = noise_correlation([real.image_gray(k) for k in every])
    ho, vo = noise_correlation([ours.image_gray(k) for k in every])
    print(f"  noise lag-1 correlation (h, v; white reads ~-0.05): KITTI at {real_seq.resolution[0]} px {hr:+.2f}, "
          f"{vr:+.2f}; at {W} px {h2:+.2f}, {v2:+.2f}; render at {W} px {ho:+.2f}, {vo:+.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
