"""Frame-to-frame monocular VO: correspondences k−1 -> k, relative pose (ours and,
optionally, OpenCV's on the very same matches), scaled step, accumulated trajectory.

T_world_cam[k] = T_world_cam[k−1] · [R_k | s_k · ĉ_k] where (R_k, ĉ_k) is the unit-length
camera motion of frame k in frame k−1 and s_k comes from the scale source. A frame whose
two-view estimate fails keeps the previous motion direction (constant velocity) and is
flagged. The first pose is the ground truth's first pose when there is one (else I).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from blender_sesgen.contract.se3 import se3

from ..errors import VoError
from .features import CORNER_MIN_DISTANCE, CORNER_QUALITY, LK_LEVELS, LK_WINDOW, MatchParams, correspondences
from .relative_pose import TwoViewParams, estimate_relative_pose


@dataclass
class MonoVoConfig:
    features: str = "klt"          # klt | orb | sift
    best_n: int = 1000             # keep the best N correspondences by error
    n_features: int = 3000         # corners / keypoints detected per frame
    ratio: float = 0.75            # Lowe's ratio test (orb, sift)
    fb_threshold_px: float = 1.0   # LK forward-backward check
    lk_window: int = LK_WINDOW     # LK window side (px)
    lk_levels: int = LK_LEVELS     # LK pyramid levels above the image
    corner_quality: float = CORNER_QUALITY        # Shi-Tomasi quality (fraction of the best corner)
    corner_min_distance: int = CORNER_MIN_DISTANCE  # Shi-Tomasi minimum distance (px)
    threshold_px: float = 1.0      # RANSAC Sampson threshold
    confidence: float = 0.999
    max_iterations: int = 5000
    seed: int | None = 0
    refine: str = "sampson"        # none | pnp | sampson
    solver: str = "5pt"            # minimal solver in our RANSAC: 5pt (calibrated E) | 8pt (F)
    score: str = "msac"            # hypothesis selection: msac (truncated quadratic) | count (inliers)
    min_flow_px: float = 0.5       # median flow below this: no motion estimated (static)
    compare_opencv: bool = False
    opencv_method: str = "usac"    # usac (USAC_ACCURATE) | ransac (classic RANSAC)

    def matching(self) -> MatchParams:
        return MatchParams(method=self.features, best_n=self.best_n, n_features=self.n_features, ratio=self.ratio,
                           fb_threshold_px=self.fb_threshold_px, lk_window=self.lk_window, lk_levels=self.lk_levels,
                           corner_quality=self.corner_quality, corner_min_distance=self.corner_min_distance)

    def two_view(self) -> TwoViewParams:
        return TwoViewParams(threshold_px=self.threshold_px, confidence=self.confidence,
                             max_iterations=self.max_iterations, seed=self.seed, refine=self.refine,
                             solver=self.solver, select=self.score)


@dataclass
class FrameRecord:
    k: int
    n_matches: int = 0
    n_inliers: int = 0
    step_m: float = 0.0
    T_rel: np.ndarray | None = None           # our unit camera motion (4, 4), None if failed
    status: str = "ok"                        # ok | static | failed (reason in message)
    message: str = ""
    n_inliers_cv: int = 0
    T_rel_cv: np.ndarray | None = None
    seconds: float = 0.0

    @property
    def inlier_ratio(self) -> float:
        return self.n_inliers / self.n_matches if self.n_matches else 0.0


@dataclass
class MonoVoResult:
    T_world_cam: np.ndarray                   # (N, 4, 4) ours
    records: list[FrameRecord]
    T_world_cam_cv: np.ndarray | None = None  # (N, 4, 4) OpenCV's, same scale
    info: dict = field(default_factory=dict)


FORWARD = se3(np.eye(3), np.array([0.0, 0.0, 1.0]))   # straight ahead: a prior hypothesis


def _step(T_rel: np.ndarray, s: float) -> np.ndarray:
    return se3(T_rel[:3, :3], s * T_rel[:3, 3])


def run_mono_vo(gray_of: Callable[[int], np.ndarray], num_frames: int, K: np.ndarray, scale,
                cfg: MonoVoConfig | None = None, mask: np.ndarray | None = None,
                T_world_first: np.ndarray | None = None,
                progress: Callable[[FrameRecord], None] | None = None) -> MonoVoResult:
    """Run the pipeline over frames 0..num_frames−1 of ``gray_of(k)`` (prepared uint8 grey)."""
    cfg = cfg or MonoVoConfig()
    if num_frames < 2:
        raise VoError(f"mono VO needs at least 2 frames, got {num_frames}")
    K = np.asarray(K, dtype=float)
    T0 = np.eye(4) if T_world_first is None else np.asarray(T_world_first, dtype=float)
    T = np.tile(T0, (num_frames, 1, 1))
    Tcv = np.tile(T0, (num_frames, 1, 1)) if cfg.compare_opencv else None
    records = [FrameRecord(0, status="first")]
    prev_img = gray_of(0)
    last_rel, last_rel_cv = np.eye(4), np.eye(4)
    matching, two_view = cfg.matching(), cfg.two_view()
    for k in range(1, num_frames):
        t_start = time.perf_counter()
        img = gray_of(k)
        rec = FrameRecord(k)
        m = correspondences(prev_img, img, matching, mask)
        rec.n_matches = len(m)
        rel = rel_cv = None
        if len(m) >= 8 and np.median(np.linalg.norm(m.x2 - m.x1, axis=1)) < cfg.min_flow_px:
            rec.status, rec.message = "static", "median flow below min_flow_px"
        elif len(m) < 8:
            rec.status, rec.message = "failed", f"{len(m)} matches"
        else:
            try:
                rel = estimate_relative_pose(m.x1, m.x2, K, two_view, priors=(last_rel, FORWARD),
                                             triangulate=scale.needs_points)
                rec.T_rel, rec.n_inliers = rel.T_c1_c2, rel.n_inliers
            except VoError as e:
                rec.status, rec.message = "failed", str(e)
            if cfg.compare_opencv:
                from .opencv_ref import opencv_relative_pose
                try:
                    rel_cv = opencv_relative_pose(m.x1, m.x2, K, cfg.threshold_px, cfg.confidence, cfg.seed,
                                                  cfg.opencv_method)
                    rec.T_rel_cv, rec.n_inliers_cv = rel_cv.T_c1_c2, rel_cv.n_inliers
                except VoError as e:
                    rec.message += f" (OpenCV: {e})"
        s = 0.0
        if rel is not None:
            s = scale.step_length(k, rel, m.x1[rel.inliers])
            if s is None:
                s = records[-1].step_m
                rec.message = "no scale for this step: previous step length used"
        elif rec.status != "static":
            s = scale.step_length(k, None, np.zeros((0, 2))) if scale.name in ("gt", "speed", "none") else records[-1].step_m
        rec.step_m = float(s)
        if rec.status == "static":
            s_ours = s_cv = 0.0
        else:
            s_ours = s_cv = rec.step_m
        if rec.T_rel is not None:
            last_rel = rec.T_rel
        if rec.T_rel_cv is not None:
            last_rel_cv = rec.T_rel_cv
        T[k] = T[k - 1] @ (_step(last_rel, s_ours) if rec.status != "static" else np.eye(4))
        if Tcv is not None:
            Tcv[k] = Tcv[k - 1] @ (_step(last_rel_cv, s_cv) if rec.status != "static" else np.eye(4))
        rec.seconds = time.perf_counter() - t_start
        records.append(rec)
        if progress is not None:
            progress(rec)
        prev_img = img
    return MonoVoResult(T, records, Tcv, {"features": cfg.features, "refine": cfg.refine,
                                             "solver": cfg.solver, "score": cfg.score,
                                             "scale": scale.name})
