"""What sets a standing camera's KLT forward-backward error: the hall's twin beside EuRoC V1_01.

    python bench/hall_klt.py RUN/hall [--frame 32]

RUN/hall is a render folder of ``bench/twin.py --scene hall --start K`` holding frame ``--frame``
(its EXR). Beside EuRoC's frames 0-5 (the rotors off: no shake), at 376 x 240 as bench/twin.py
brings both (EuRoC rectified with its sensor.yaml, INTER_AREA), it prints:

- the temporal noise by level (DN^2: half the variance of consecutive differences, each pair's
  median difference taken out, every unclipped pixel) and its lag-1 correlation across and down:
  EuRoC's frames 0-5; the render's one EXR developed with sensor seeds s..s+5 (the chain's noise
  alone, no shake, no path tracing);
- the KLT error (realism.klt_fb_error's corners, LK and rule) per corner by the corner's
  minimum eigenvalue (cv2.cornerMinEigenVal over LK's 21 px window) for both, and the pairs'
  median: at equal contrast the error is the noise's, the pairs' median also the corners' mix;
- the floor's texture (EuRoC: its plain carpet between the tapes, hand-marked, frames K..K+7;
  the render: the hall floor and the test carpet by object id, 1-4 m, rows below 100):
  pixel-scale deviation over the 5 x 5 mean (DN), the 2-8 px band (Gaussian 2 - Gaussian 8,
  DN) and Shi-Tomasi corners per 1000 px.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "bench"))

EUROC_CARPET = ((100, 170, 165, 235), (20, 120, 150, 150))     # x0, y0, x1, y1 at 376 x 240
BINS = (0, 0.002, 0.004, 0.008, 0.016, 0.032, 1.0)              # min eigenvalue bins


def per_corner(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(forward-backward error, min eigenvalue) of a's corners tracked both ways into b."""
    from vo_reference.evaluate.realism import CORNER_CAP, CORNER_MIN_DISTANCE, CORNER_QUALITY, LK_PARAMS
    pts = cv2.goodFeaturesToTrack(a, CORNER_CAP, CORNER_QUALITY, CORNER_MIN_DISTANCE)
    p1, s1, _ = cv2.calcOpticalFlowPyrLK(a, b, pts, None, **LK_PARAMS)
    p0, s2, _ = cv2.calcOpticalFlowPyrLK(b, a, p1, None, **LK_PARAMS)
    ok = (s1.ravel() == 1) & (s2.ravel() == 1)
    xy = pts.reshape(-1, 2).round().astype(int)
    lam = cv2.cornerMinEigenVal(a, 21, 3)[xy[:, 1], xy[:, 0]]
    return np.linalg.norm((p0 - pts).reshape(-1, 2), axis=1)[ok], lam[ok]


def noise_by_level(pairs, levels=(36, 68, 100, 132, 164, 196, 228)) -> str:
    lv, dd, cx, cy = [], [], [], []
    for a, b in pairs:
        d = b.astype(float) - a
        d -= np.median(d)
        ok = (a > 0) & (a < 255) & (b > 0) & (b < 255)
        lv.append(((a.astype(float) + b) / 2)[ok])
        dd.append(d[ok] ** 2 / 2)
        cx.append(np.corrcoef(d[:, :-1].ravel(), d[:, 1:].ravel())[0, 1])
        cy.append(np.corrcoef(d[:-1].ravel(), d[1:].ravel())[0, 1])
    lv, dd = np.concatenate(lv), np.concatenate(dd)
    return (", ".join(f"{c}: {dd[np.abs(lv - c) < 4].mean():.3f}" for c in levels if (np.abs(lv - c) < 4).sum() > 500)
            + f"; lag-1 across {np.mean(cx):+.2f}, down {np.mean(cy):+.2f}")


def klt_lines(name: str, pairs) -> list[str]:
    recs = [per_corner(a, b) for a, b in pairs]
    fb, lam = (np.concatenate(x) for x in zip(*recs))
    cells = []
    for lo, hi in zip(BINS[:-1], BINS[1:]):
        sel = (lam >= lo) & (lam < hi)
        if sel.sum() > 5:
            cells.append(f"[{lo:g}, {hi:g}) {np.median(fb[sel]):.5f} ({100 * sel.mean():.0f} %)")
    return [f"{name}: KLT error, pairs' median {np.median([np.median(r[0]) for r in recs]):.5f} px, "
            f"{len(fb) / len(recs):.0f} corners a pair, min eigenvalue median {np.median(lam):.4f}",
            "  by min eigenvalue (median error px, share of corners): " + ", ".join(cells)]


def floor_figures(img: np.ndarray, mask: np.ndarray) -> tuple[float, float, float]:
    from vo_reference.evaluate.realism import CORNER_CAP, CORNER_MIN_DISTANCE, CORNER_QUALITY
    x = img.astype(float)
    rob = lambda r: 1.4826 * float(np.median(np.abs(r - np.median(r))))  # noqa: E731
    pix = rob((x - cv2.blur(x, (5, 5)))[mask])
    band = rob((cv2.GaussianBlur(x, (0, 0), 2) - cv2.GaussianBlur(x, (0, 0), 8))[mask])
    pts = cv2.goodFeaturesToTrack(img, CORNER_CAP, CORNER_QUALITY, CORNER_MIN_DISTANCE).reshape(-1, 2).round().astype(int)
    return pix, band, 1000.0 * mask[pts[:, 1], pts[:, 0]].sum() / mask.sum()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("render", type=Path)
    ap.add_argument("--frame", type=int, default=32)
    a = ap.parse_args(argv)
    if not (a.render / "exr" / "left" / f"{a.frame:06d}.exr").is_file() or not (a.render / "scene.ses").is_file():
        print(f"{a.render}: not a hall render folder holding frame {a.frame}'s EXR", file=sys.stderr)
        return 2
    import twin
    from vo_reference.io.sequence import open_sequence
    real = twin.euroc_rectified(6, (376, 240), 0)._img["left"]
    ours = [twin.resensor(a.render, 1, a.frame, d)._img["left"][0] for d in range(6)]
    rp, op = list(zip(real[:-1], real[1:])), list(zip(ours[:-1], ours[1:]))
    print(f"temporal noise by level (DN: DN^2), EuRoC V1_01 frames 0-5 (rotors off): {noise_by_level(rp)}")
    print(f"temporal noise by level, render frame {a.frame}'s EXR with 6 sensor seeds: {noise_by_level(op)}")
    for line in klt_lines("EuRoC V1_01 frames 0-5", rp) + klt_lines(f"render frame {a.frame}, 6 sensor seeds", op):
        print(line)
    seq = open_sequence(a.render)
    n = sum(1 for k in range(a.frame, a.frame + 8) if seq.frame_complete(k))
    realk = twin.euroc_rectified(n, (376, 240), a.frame)._img["left"]
    oursk = twin.resensor(a.render, n, a.frame, 0)._img["left"]
    man = json.loads((a.render / "manifest.json").read_text())
    floor = [o["id"] for o in man["objects"] if o.get("name") in ("floor", "test_carpet")]
    fr, fo = [], []
    for k in range(n):
        m = np.zeros((240, 376), bool)
        for x0, y0, x1, y1 in EUROC_CARPET:
            m[y0:y1, x0:x1] = True
        fr.append(floor_figures(realk[k], m))
        mf = cv2.erode(np.isin(np.asarray(seq.ids(a.frame + k, "left")).astype(int), floor).astype(np.uint8),
                       np.ones((9, 9))) > 0
        mf[:100] = False
        fo.append(floor_figures(oursk[k], mf))
    for name, f in ((f"EuRoC V1_01's carpet (frames {a.frame}-{a.frame + n - 1})", fr), ("render's floor", fo)):
        f = np.median(np.array(f), axis=0)
        print(f"{name}: pixel-scale deviation {f[0]:.2f} DN, 2-8 px band {f[1]:.2f} DN, corners {f[2]:.2f} per 1000 px")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
