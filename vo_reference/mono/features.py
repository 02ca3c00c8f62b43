"""Correspondences between two grey frames: ORB / SIFT descriptors with Lowe's ratio test,
or pyramidal Lucas-Kanade tracking of Shi-Tomasi corners with a forward-backward check.
Every method returns :class:`Matches` sorted by error (best first), cut to the best N.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import VoError

METHODS = ("klt", "orb", "sift")

# KLT defaults. LK assumes that a window only translates; in forward motion the flow of a
# window also scales and shears (most on the road, at grazing angles), so a large window
# biases the track, while a small one has too little gradient on smooth texture. 15 px
# (was 21): direction error 0.19 -> 0.11 deg on the 640x480 street render, 0.39 -> 0.27
# deg on the smooth synthetic corridor of the tests, KITTI 0.41 -> 0.35 deg
# (docs/mono-vo.md); 11 px is better on the street but worse on the smooth corridor.
LK_WINDOW = 15
LK_LEVELS = 3
CORNER_QUALITY = 0.01
CORNER_MIN_DISTANCE = 8


@dataclass(frozen=True)
class Matches:
    x1: np.ndarray     # (N, 2) pixels in frame 1
    x2: np.ndarray     # (N, 2) pixels in frame 2
    error: np.ndarray  # (N,) lower is better: descriptor distance ratio, or FB error (px)

    def __len__(self) -> int:
        return len(self.x1)

    def best(self, n: int | None) -> "Matches":
        order = np.argsort(self.error, kind="stable")
        if n is not None and n > 0:
            order = order[:n]
        return Matches(self.x1[order], self.x2[order], self.error[order])


def _inside(mask: np.ndarray | None, x: np.ndarray) -> np.ndarray:
    if mask is None:
        return np.ones(len(x), bool)
    h, w = mask.shape
    xi = np.round(x).astype(int)
    ok = (xi[:, 0] >= 0) & (xi[:, 0] < w) & (xi[:, 1] >= 0) & (xi[:, 1] < h)
    ok[ok] = mask[xi[ok, 1], xi[ok, 0]] > 0
    return ok


def match_descriptors(img1: np.ndarray, img2: np.ndarray, method: str = "orb",
                      mask: np.ndarray | None = None, n_features: int = 3000,
                      ratio: float = 0.75) -> Matches:
    """Detect and describe in both frames, 2-NN match 1 -> 2, keep matches passing the
    ratio test d1 < ratio · d2; error = d1 / d2."""
    import cv2
    if method == "orb":
        det = cv2.ORB_create(nfeatures=n_features, fastThreshold=10)
        norm = cv2.NORM_HAMMING
    elif method == "sift":
        det = cv2.SIFT_create(nfeatures=n_features)
        norm = cv2.NORM_L2
    else:
        raise VoError(f"unknown descriptor method {method!r} (orb or sift)")
    k1, d1 = det.detectAndCompute(img1, mask)
    k2, d2 = det.detectAndCompute(img2, mask)
    if d1 is None or d2 is None or len(k1) < 2 or len(k2) < 2:
        return Matches(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))
    pairs = cv2.BFMatcher(norm).knnMatch(d1, d2, k=2)
    x1, x2, err = [], [], []
    for p in pairs:
        if len(p) == 2 and p[0].distance < ratio * p[1].distance:
            x1.append(k1[p[0].queryIdx].pt)
            x2.append(k2[p[0].trainIdx].pt)
            err.append(p[0].distance / max(p[1].distance, 1e-9))
    return Matches(np.array(x1, float).reshape(-1, 2), np.array(x2, float).reshape(-1, 2),
                   np.array(err, float))


def detect_corners(img: np.ndarray, mask: np.ndarray | None = None, max_corners: int = 3000,
                   min_distance: int = CORNER_MIN_DISTANCE, quality: float = CORNER_QUALITY) -> np.ndarray:
    """Shi-Tomasi corners (N, 2)."""
    import cv2
    pts = cv2.goodFeaturesToTrack(img, maxCorners=max_corners, qualityLevel=quality,
                                  minDistance=min_distance, mask=mask, blockSize=7)
    return np.zeros((0, 2)) if pts is None else pts.reshape(-1, 2).astype(float)


def lk_track(img1: np.ndarray, img2: np.ndarray, x1: np.ndarray, win: int = LK_WINDOW, levels: int = LK_LEVELS,
             fb_threshold_px: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pyramidal LK 1 -> 2 and back 2 -> 1 for every point of ``x1`` (N, 2).

    Returns (x2 (N, 2), forward-backward distance (N,), ok (N,) bool): ok where both passes
    converged and the round trip lands within ``fb_threshold_px`` of the start."""
    import cv2
    n = len(x1)
    if n == 0:
        return np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool)
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01)
    p1 = np.ascontiguousarray(x1, dtype=np.float32).reshape(-1, 1, 2)
    p2, st, _ = cv2.calcOpticalFlowPyrLK(img1, img2, p1, None, winSize=(win, win), maxLevel=levels, criteria=crit)
    p1b, stb, _ = cv2.calcOpticalFlowPyrLK(img2, img1, p2, None, winSize=(win, win), maxLevel=levels, criteria=crit)
    fb = np.linalg.norm(p1b.reshape(-1, 2) - np.asarray(x1, float), axis=1)
    ok = (st.ravel() == 1) & (stb.ravel() == 1) & (fb < fb_threshold_px)
    return p2.reshape(-1, 2).astype(float), fb, ok


def track_lk(img1: np.ndarray, img2: np.ndarray, x1: np.ndarray, win: int = LK_WINDOW, levels: int = LK_LEVELS,
             fb_threshold_px: float = 1.0) -> Matches:
    """LK tracks of ``x1`` passing the forward-backward check; error = the FB distance."""
    x2, fb, ok = lk_track(img1, img2, x1, win, levels, fb_threshold_px)
    return Matches(np.asarray(x1, float)[ok], x2[ok], fb[ok])


@dataclass(frozen=True)
class MatchParams:
    """How :func:`correspondences` matches: ``method`` (klt, orb, sift), ``n_features``
    detected per frame, the best ``best_n`` kept; ``ratio`` (Lowe's test, orb/sift); for klt
    the LK window and pyramid levels, the forward-backward threshold and the Shi-Tomasi
    quality and minimum distance."""
    method: str = "klt"
    best_n: int | None = 1000
    n_features: int = 3000
    ratio: float = 0.75
    fb_threshold_px: float = 1.0
    lk_window: int = LK_WINDOW
    lk_levels: int = LK_LEVELS
    corner_quality: float = CORNER_QUALITY
    corner_min_distance: int = CORNER_MIN_DISTANCE


def correspondences(img1: np.ndarray, img2: np.ndarray, params: MatchParams | None = None,
                    mask: np.ndarray | None = None, **overrides) -> Matches:
    """Matches from frame 1 to frame 2 (``params``; fields may also be given as keywords),
    both ends inside the mask, sorted by error and cut to the best ``best_n``."""
    p = replace(params or MatchParams(), **overrides)
    if p.method == "klt":
        x1 = detect_corners(img1, mask, p.n_features, p.corner_min_distance, p.corner_quality)
        m = track_lk(img1, img2, x1, p.lk_window, p.lk_levels, p.fb_threshold_px)
    elif p.method in ("orb", "sift"):
        m = match_descriptors(img1, img2, p.method, mask, p.n_features, p.ratio)
    else:
        raise VoError(f"unknown feature method {p.method!r} ({', '.join(METHODS)})")
    keep = _inside(mask, m.x1) & _inside(mask, m.x2)
    h, w = img2.shape[:2]
    keep &= (m.x2[:, 0] >= 0) & (m.x2[:, 0] <= w - 1) & (m.x2[:, 1] >= 0) & (m.x2[:, 1] <= h - 1)
    return Matches(m.x1[keep], m.x2[keep], m.error[keep]).best(p.best_n)
