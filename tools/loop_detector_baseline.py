"""A baseline loop-closure detector, run as a user's system would be, to put numbers on
``vo-reference evaluate-slam --detections`` (docs/slam.md): not part of vo_reference, which
evaluates detections and does not make them.

Each frame (left view) gets a global descriptor, its grey image shrunk to 64 x 20 with zero mean
and unit norm; each query's ``--candidates`` most similar frames at least ``--min-gap`` seconds
earlier are verified geometrically: ORB features (OpenCV, 1000 a frame), mutual nearest
neighbours under Lowe's ratio test, a fundamental matrix by RANSAC (1 px); the score of a
candidate is its number of inliers, and candidates with at least ``--min-inliers`` are written
as ``query match score`` lines, the detections file evaluate-slam reads.

    python tools/loop_detector_baseline.py RENDER --out loops.txt [--frames A:B,C:D] [--min-gap 30]
"""
from __future__ import annotations

import argparse
import resource
import time

import cv2
import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.timing import frame_range
from vo_reference.io.render import RenderSequence

THUMB = (64, 20)
RATIO = 0.8


def descriptor(gray: np.ndarray) -> np.ndarray:
    """The global descriptor: the shrunk image, zero mean, unit norm."""
    d = cv2.resize(gray, THUMB, interpolation=cv2.INTER_AREA).astype(np.float32).ravel()
    d -= d.mean()
    return d / max(float(np.linalg.norm(d)), 1e-9)


def inliers(a, b, matcher) -> int:
    """RANSAC inliers of the fundamental matrix between two frames' ORB features (kps, des)."""
    (ka, da), (kb, db) = a, b
    if da is None or db is None or len(da) < 8 or len(db) < 8:
        return 0
    ab = [m for m, n in (p for p in matcher.knnMatch(da, db, k=2) if len(p) == 2) if m.distance < RATIO * n.distance]
    back = {m.queryIdx: m.trainIdx for m in matcher.match(db, da)}
    good = [m for m in ab if back.get(m.trainIdx) == m.queryIdx]
    if len(good) < 8:
        return 0
    pa = np.float32([ka[m.queryIdx].pt for m in good])
    pb = np.float32([kb[m.trainIdx].pt for m in good])
    F, mask = cv2.findFundamentalMat(pa, pb, cv2.FM_RANSAC, 1.0, 0.999)
    return 0 if F is None or mask is None else int(mask.sum())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("render")
    ap.add_argument("--out", required=True, help="detections file: 'query match score' per line")
    ap.add_argument("--frames", metavar="A:B[,C:D]", help="only these frames (ranges separated by commas)")
    ap.add_argument("--min-gap", type=float, default=30.0, metavar="S", help="candidates at least S s earlier")
    ap.add_argument("--candidates", type=int, default=3, help="verified candidates per query")
    ap.add_argument("--min-inliers", type=int, default=15, help="write candidates with at least this many inliers")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    seq = RenderSequence(a.render)
    ranges = a.frames.split(",") if a.frames else [None]
    frames = np.array(sorted({k for r in ranges for k in frame_range(r, seq.num_frames, 1)}))
    orb = cv2.ORB_create(nfeatures=1000)
    matcher = cv2.BFMatcher(cv2.NORM_HAMMING)
    desc, feats = [], {}
    for n, k in enumerate(frames):
        g = seq.image_gray(int(k))
        desc.append(descriptor(g))
        feats[int(k)] = orb.detectAndCompute(g, None)
        if (n + 1) % 200 == 0:
            print(f"features: {n + 1}/{len(frames)} frames", flush=True)
    D = np.stack(desc)
    t = seq.timestamps_s[frames]
    lines, verified = [], 0
    for i, q in enumerate(frames):
        earlier = np.flatnonzero(t <= t[i] - a.min_gap)
        if not len(earlier):
            continue
        sim = D[earlier] @ D[i]
        for j in earlier[np.argsort(-sim)[:a.candidates]]:
            score = inliers(feats[int(q)], feats[int(frames[j])], matcher)
            verified += 1
            if score >= a.min_inliers:
                lines.append(f"{int(q)} {int(frames[j])} {score}")
    atomic.write_text(a.out, "# query match score (RANSAC inliers): tools/loop_detector_baseline.py\n"
                      + "".join(ln + "\n" for ln in lines))
    ru = resource.getrusage(resource.RUSAGE_SELF)
    print(f"{len(frames)} frames, {verified} candidates verified, {len(lines)} detections -> {a.out}; "
          f"{ru.ru_utime + ru.ru_stime:.1f} CPU s, {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
