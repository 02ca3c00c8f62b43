"""Per-frame two-view errors: rotation angle and translation-direction angle between
camera motions T_c(k−1)_c(k) (4, 4), e.g. ours vs ground truth or ours vs OpenCV."""
from __future__ import annotations

import numpy as np

from blender_sesgen.contract.se3 import invert, rotation_angle_rad



def rotation_difference_deg(T_a: np.ndarray, T_b: np.ndarray) -> float:
    return float(np.degrees(rotation_angle_rad(T_a[:3, :3].T @ T_b[:3, :3])))


def direction_difference_deg(T_a: np.ndarray, T_b: np.ndarray) -> float:
    """Angle between the translation directions (nan if either has no translation)."""
    a, b = T_a[:3, 3], T_b[:3, 3]
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na < 1e-12 or nb < 1e-12:
        return float("nan")
    return float(np.degrees(np.arccos(np.clip(a @ b / (na * nb), -1.0, 1.0))))


def gt_motions(T_world_cam: np.ndarray) -> np.ndarray:
    """(N−1, 4, 4) ground-truth camera motions T_c(k−1)_c(k)."""
    T = np.asarray(T_world_cam, dtype=float)
    return invert(T[:-1]) @ T[1:]


def per_frame_errors(records, T_gt: np.ndarray | None) -> dict[str, np.ndarray]:
    """Columns over frames 1..N−1 (nan where a motion is missing): ``rot_gt_deg``,
    ``dir_gt_deg`` (ours vs ground truth), ``rot_cv_gt_deg``, ``dir_cv_gt_deg`` (OpenCV vs
    ground truth), ``rot_ours_cv_deg``, ``dir_ours_cv_deg`` (ours vs OpenCV)."""
    recs = [r for r in records if r.k > 0]
    gtm = gt_motions(T_gt) if T_gt is not None else None
    cols = {name: np.full(len(recs), np.nan) for name in
            ("rot_gt_deg", "dir_gt_deg", "rot_cv_gt_deg", "dir_cv_gt_deg", "rot_ours_cv_deg", "dir_ours_cv_deg")}
    for i, r in enumerate(recs):
        if gtm is not None and r.T_rel is not None:
            cols["rot_gt_deg"][i] = rotation_difference_deg(r.T_rel, gtm[r.k - 1])
            cols["dir_gt_deg"][i] = direction_difference_deg(r.T_rel, gtm[r.k - 1])
        if gtm is not None and r.T_rel_cv is not None:
            cols["rot_cv_gt_deg"][i] = rotation_difference_deg(r.T_rel_cv, gtm[r.k - 1])
            cols["dir_cv_gt_deg"][i] = direction_difference_deg(r.T_rel_cv, gtm[r.k - 1])
        if r.T_rel is not None and r.T_rel_cv is not None:
            cols["rot_ours_cv_deg"][i] = rotation_difference_deg(r.T_rel, r.T_rel_cv)
            cols["dir_ours_cv_deg"][i] = direction_difference_deg(r.T_rel, r.T_rel_cv)
    return cols
