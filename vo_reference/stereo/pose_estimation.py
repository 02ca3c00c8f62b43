"""Camera motion from 3-D points and their pixels in the next stereo pair: RANSAC PnP, the
Gauss–Newton refinement on SE(3) over both images, and the test that tells the camera's
motion from a moving object's. Used by the accurate stereo VO (``accurate.py``)."""
from __future__ import annotations

import cv2
import numpy as np

from blender_sesgen.contract import rig
from blender_sesgen.contract.camera import project
from blender_sesgen.contract.se3 import se3, se3_exp

from ..errors import VoError
from .motion_field import solve_small


def _project_jac(P: np.ndarray, K: np.ndarray):
    """Pixels (N, 2) and d(pixel)/dP (N, 2, 3) of camera-frame points."""
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    X, Y, Z = P[:, 0], P[:, 1], P[:, 2]
    iz = 1.0 / Z
    uv = np.stack([fx * X * iz + cx, fy * Y * iz + cy], axis=1)
    J = np.zeros((P.shape[0], 2, 3))
    J[:, 0, 0] = fx * iz
    J[:, 0, 2] = -fx * X * iz * iz
    J[:, 1, 1] = fy * iz
    J[:, 1, 2] = -fy * Y * iz * iz
    return uv, J


def refine_pose(P0: np.ndarray, obs_left: np.ndarray, obs_right: np.ndarray | None, K: np.ndarray,
                baseline_m: float, T_k1_k: np.ndarray, iterations: int = 10, huber_px: float = 0.5) -> np.ndarray:
    """Gauss–Newton on SE(3): T_k1_k minimising the reprojection error of the frame-k points
    ``P0`` (N, 3) in the left (and, where given and finite, right) image at k+1.

    Update T <- exp(delta) T with delta = [v, w]; Huber weights with threshold ``huber_px``.
    """
    T = T_k1_k.copy()
    has_r = obs_right is not None
    if has_r:
        rmask = np.all(np.isfinite(obs_right), axis=1)
    for _ in range(iterations):
        P1 = P0 @ T[:3, :3].T + T[:3, 3]
        if np.any(P1[:, 2] <= 0):
            raise VoError("pose refinement diverged (points behind the camera)")
        # dP1/ddelta = [I, -skew(P1)]
        dP = np.zeros((P1.shape[0], 3, 6))
        dP[:, 0, 0] = dP[:, 1, 1] = dP[:, 2, 2] = 1.0
        dP[:, 0, 4], dP[:, 0, 5] = P1[:, 2], -P1[:, 1]
        dP[:, 1, 3], dP[:, 1, 5] = -P1[:, 2], P1[:, 0]
        dP[:, 2, 3], dP[:, 2, 4] = P1[:, 1], -P1[:, 0]
        uv, J = _project_jac(P1, K)
        res = [uv - obs_left]
        jac = [J @ dP]
        if has_r:
            uvr, Jr = _project_jac(rig.points_in_view(P1[rmask], "right", baseline_m), K)
            res.append(uvr - obs_right[rmask])
            jac.append(Jr @ dP[rmask])
        r = np.concatenate(res).reshape(-1, 2)
        A = np.concatenate(jac)                                    # (M, 2, 6)
        e = np.linalg.norm(r, axis=1)
        w = np.where(e <= huber_px, 1.0, huber_px / np.maximum(e, 1e-12))
        Aw = A * w[:, None, None]
        Hm = np.einsum("nij,nik->jk", Aw, A)
        g = np.einsum("nij,ni->j", Aw, r)
        delta = -solve_small(Hm + 1e-9 * np.eye(6), g)
        T = se3_exp(delta[3:], delta[:3]) @ T
        if np.linalg.norm(delta) < 1e-12:
            break
    return T


def reprojection_errors(P0, obs_left, obs_right, K, baseline_m, T_k1_k):
    """Per point, the larger of its left and right reprojection errors (px) under T_k1_k; inf behind the camera."""
    P1 = P0 @ T_k1_k[:3, :3].T + T_k1_k[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        uv, _ = _project_jac(P1, K)
        e = np.linalg.norm(uv - obs_left, axis=1)
        if obs_right is not None:
            uvr, _ = _project_jac(rig.points_in_view(P1, "right", baseline_m), K)
            er = np.linalg.norm(uvr - obs_right, axis=1)
            e = np.where(np.isfinite(er), np.maximum(e, er), e)
    return np.where(P1[:, 2] > 0, e, np.inf)


def ransac_pnp(P0: np.ndarray, obs: np.ndarray, K: np.ndarray, p):
    """(T_k1_k, inliers) of OpenCV's P3P RANSAC (``p``: AccurateParams), or None when it finds no motion."""
    ok, rvec, tvec, idx = cv2.solvePnPRansac(P0.astype(np.float64), obs.astype(np.float64), K, None,
                                             iterationsCount=p.ransac_iterations,
                                             reprojectionError=p.ransac_px, confidence=0.999,
                                             flags=cv2.SOLVEPNP_P3P)
    if not ok or idx is None or len(idx) < 4:
        return None
    R, _ = cv2.Rodrigues(rvec)
    inl = np.zeros(P0.shape[0], bool)
    inl[idx.reshape(-1)] = True
    return se3(R, tvec.reshape(3)), inl


def coverage(pts: np.ndarray, box: tuple[float, float, float, float], cells: int = 8) -> int:
    """How many cells of a ``cells`` x ``cells`` grid over ``box`` (x0, y0, x1, y1) hold a point."""
    x0, y0, x1, y1 = box
    gx = np.clip(((pts[:, 0] - x0) / max(x1 - x0, 1e-9) * cells).astype(int), 0, cells - 1)
    gy = np.clip(((pts[:, 1] - y0) / max(y1 - y0, 1e-9) * cells).astype(int), 0, cells - 1)
    return int(np.unique(gy * cells + gx).size)


def _predict(T_k1_k: np.ndarray, P0: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Pixels of the points ``P0`` (camera frame at k) moved by T_k1_k."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return project(K, P0 @ T_k1_k[:3, :3].T + T_k1_k[:3, 3])


def background_motion(P0, obs, K, p, T, inl, prior_T_k1_k=None):
    """Moving objects: RANSAC's largest consistent set can be a close, well-textured moving
    object rather than the static background. When the outliers hold a second rigid motion
    (at least ``second_motion_min`` points, and it puts the points of both sets more than
    ``second_motion_px`` away from where the first does), the camera's motion is the one closer to the
    constant-velocity prediction ``prior_T_k1_k`` (median distance, over all points, between
    where each motion and the prediction put them); without a prediction (the first step),
    the one whose inliers spread over more of the image (cells of an 8x8 grid over all
    points): the background surrounds objects, an object covers one region. ``p``: the
    method's AccurateParams."""
    out = np.flatnonzero(~inl)
    if out.size < max(p.second_motion_min, int(0.2 * inl.size)):
        return T, inl
    second = ransac_pnp(P0[out], obs[out], K, p)
    if second is None or second[1].sum() < p.second_motion_min:
        return T, inl
    inl2 = np.zeros_like(inl)
    inl2[out[second[1]]] = True
    both = inl | inl2
    apart = np.nanmedian(np.linalg.norm(_predict(T, P0[both], K) - _predict(second[0], P0[both], K), axis=1))
    if not apart > p.second_motion_px:   # the same motion, split by noise: not a moving object
        return T, inl
    if prior_T_k1_k is not None:
        pred = _predict(prior_T_k1_k, P0, K)
        d1 = np.nanmedian(np.linalg.norm(_predict(T, P0, K) - pred, axis=1))
        d2 = np.nanmedian(np.linalg.norm(_predict(second[0], P0, K) - pred, axis=1))
        return (second[0], inl2) if d2 < d1 else (T, inl)
    box = (*obs.min(axis=0), *obs.max(axis=0))
    if coverage(obs[inl2], box) > coverage(obs[inl], box):
        return second[0], inl2
    return T, inl
