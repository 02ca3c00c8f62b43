"""Fundamental matrix: Hartley-normalised 8-point, Sampson distance, our own RANSAC.

Convention: ``x2ᵀ F x1 = 0`` for a point seen at pixel ``x1`` in view 1 and ``x2`` in
view 2 (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., Alg. 11.1 and 11.4).
Points are (N, 2) arrays of pixel coordinates.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import VoError


def hartley_normalisation(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Similarity ``T`` moving the centroid to the origin and the mean distance to √2.

    ``x``: (..., N, 2). Returns the normalised points (..., N, 2) and T (..., 3, 3).
    """
    x = np.asarray(x, dtype=float)
    c = x.mean(axis=-2, keepdims=True)
    d = np.linalg.norm(x - c, axis=-1).mean(axis=-1)
    s = np.sqrt(2.0) / np.maximum(d, 1e-12)
    T = np.zeros(x.shape[:-2] + (3, 3))
    T[..., 0, 0] = s
    T[..., 1, 1] = s
    T[..., 0, 2] = -s * c[..., 0, 0]
    T[..., 1, 2] = -s * c[..., 0, 1]
    T[..., 2, 2] = 1.0
    return (x - c) * s[..., None, None], T


def _design_matrix(x1n: np.ndarray, x2n: np.ndarray) -> np.ndarray:
    """Rows of A f = 0 with f = F row-major (..., N, 9)."""
    u1, v1 = x1n[..., 0], x1n[..., 1]
    u2, v2 = x2n[..., 0], x2n[..., 1]
    one = np.ones_like(u1)
    return np.stack([u2 * u1, u2 * v1, u2, v2 * u1, v2 * v1, v2, u1, v1, one], axis=-1)


def enforce_rank2(F: np.ndarray) -> np.ndarray:
    """Closest rank-2 matrix (Frobenius) by zeroing the smallest singular value."""
    U, S, Vt = np.linalg.svd(F)
    S = S.copy()
    S[..., 2] = 0.0
    return U @ (S[..., :, None] * Vt)


def eight_point(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """Normalised 8-point algorithm (H&Z Alg. 11.1), rank 2, ‖F‖ = 1.

    ``x1, x2``: (..., N, 2) with N ≥ 8; a leading batch axis solves many samples at once.
    """
    x1 = np.asarray(x1, dtype=float)
    x2 = np.asarray(x2, dtype=float)
    if x1.shape != x2.shape or x1.shape[-1] != 2 or x1.shape[-2] < 8:
        raise VoError(f"eight_point needs two (N>=8, 2) point sets, got {x1.shape} and {x2.shape}")
    x1n, T1 = hartley_normalisation(x1)
    x2n, T2 = hartley_normalisation(x2)
    A = _design_matrix(x1n, x2n)
    _, _, Vt = np.linalg.svd(A, full_matrices=True)
    Fn = enforce_rank2(Vt[..., -1, :].reshape(x1.shape[:-2] + (3, 3)))
    F = np.swapaxes(T2, -1, -2) @ Fn @ T1
    return F / np.linalg.norm(F, axis=(-2, -1), keepdims=True)


def sampson_distance(F: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """First-order geometric error (pixels) of each correspondence, H&Z eq. 11.9.

    ``F``: (3, 3) or (B, 3, 3); returns (N,) or (B, N): sqrt of the Sampson error.
    """
    h1 = np.column_stack([x1, np.ones(len(x1))])
    h2 = np.column_stack([x2, np.ones(len(x2))])
    Fx1 = h1 @ np.swapaxes(F, -1, -2)            # (..., N, 3) rows F x1
    Ftx2 = h2 @ F                                # (..., N, 3) rows Fᵀ x2
    num = np.einsum("...ni,ni->...n", Fx1, h2)
    den = Fx1[..., 0] ** 2 + Fx1[..., 1] ** 2 + Ftx2[..., 0] ** 2 + Ftx2[..., 1] ** 2
    return np.abs(num) / np.sqrt(np.maximum(den, 1e-300))


@dataclass(frozen=True)
class RansacResult:
    F: np.ndarray            # (3, 3), refit on all inliers
    inliers: np.ndarray      # (N,) bool
    iterations: int          # hypotheses drawn

    @property
    def inlier_ratio(self) -> float:
        return float(self.inliers.mean()) if self.inliers.size else 0.0


def ransac_iterations(inlier_ratio: float, confidence: float, sample_size: int = 8) -> float:
    """Samples needed to draw one all-inlier sample with probability ``confidence``."""
    w = float(np.clip(inlier_ratio, 1e-9, 1.0))
    p_good = w**sample_size
    if p_good >= 1.0 - 1e-15:
        return 1.0
    return float(np.log(1.0 - confidence) / np.log1p(-p_good))


class SampleBudget:
    """RANSAC's adaptive sampling: random minimal samples of ``sample_size`` of ``n`` matches,
    drawn ``batch`` at a time, until the count :func:`ransac_iterations` gives for the best
    inlier count so far (:meth:`update`) is reached, within [``min_iterations``,
    ``max_iterations``]. ``drawn`` counts the samples drawn."""

    def __init__(self, rng, n: int, sample_size: int, confidence: float, min_iterations: int,
                 max_iterations: int, batch: int):
        self.rng, self.n, self.k, self.confidence = rng, n, sample_size, confidence
        self.min_iterations, self.max_iterations, self.batch = min_iterations, max_iterations, batch
        self.needed, self.drawn = float(max_iterations), 0

    def _target(self) -> float:
        return min(max(self.needed, self.min_iterations), self.max_iterations)

    def batches(self):
        """Index arrays (b, sample_size) of the samples, batch by batch."""
        while self.drawn < self._target():
            b = int(min(self.batch, max(1, self._target() - self.drawn)))
            idx = np.argpartition(self.rng.random((b, self.n)), self.k, axis=1)[:, :self.k]
            self.drawn += b
            yield idx

    def update(self, best_inliers: int) -> None:
        self.needed = ransac_iterations(best_inliers / self.n, self.confidence, sample_size=self.k)


def calibrated_fundamental(F: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Project F (..., 3, 3) onto the fundamental matrices of a calibrated pair with
    intrinsics K: E = KᵀFK with singular values forced to (1, 1, 0), F = K⁻ᵀ E K⁻¹."""
    E = K.T @ F @ K
    U, _, Vt = np.linalg.svd(E)
    E = U @ (np.array([1.0, 1.0, 0.0])[:, None] * Vt)
    Kinv = np.linalg.inv(K)
    F = Kinv.T @ E @ Kinv
    return F / np.linalg.norm(F, axis=(-2, -1), keepdims=True)


def _msac(F, x1, x2, threshold_px):
    d = sampson_distance(F, x1, x2)
    inl = d < threshold_px
    return inl, int(inl.sum()), float(np.where(inl, d**2, threshold_px**2).sum())


def _better(count, cost, best_count, best_cost, by_cost):
    """Hypothesis order: MSAC cost first (``by_cost``) or inlier count first."""
    if by_cost:
        return cost < best_cost or (cost == best_cost and count > best_count)
    return count > best_count or (count == best_count and cost < best_cost)


def _local_optimisation(F, count, cost, x1, x2, threshold_px, K=None, rounds: int = 4, by_cost: bool = False):
    """LO-RANSAC (Chum et al. 2003): refit a new best hypothesis on its own inliers with the
    8-point algorithm while that raises the inlier count (or lowers the cost)."""
    inl = sampson_distance(F, x1, x2) < threshold_px
    for _ in range(rounds):
        if inl.sum() < 8:
            break
        F_new = eight_point(x1[inl], x2[inl])
        if K is not None:
            F_new = calibrated_fundamental(F_new, K)
        inl_new, c_new, cost_new = _msac(F_new, x1, x2, threshold_px)
        if _better(c_new, cost_new, count, cost, by_cost):
            F, inl, count, cost = F_new, inl_new, c_new, cost_new
        else:
            break
    return count, cost, F


def ransac_fundamental(x1: np.ndarray, x2: np.ndarray, threshold_px: float = 1.0,
                       confidence: float = 0.999, max_iterations: int = 5000,
                       seed: int | None = 0, batch: int = 64, min_iterations: int = 256,
                       K: np.ndarray | None = None, score: str = "count") -> RansacResult:
    """RANSAC over 8-point samples, scored by inlier count with Sampson distance.

    The number of iterations adapts to the best inlier ratio seen (H&Z Alg. 4.5),
    at least ``min_iterations`` (with noisy points an all-inlier 8-point sample is not
    necessarily a good model, so the textbook count stops too early) and at most
    ``max_iterations``; ``seed`` fixes the sampling (``None``: random). Each new
    best hypothesis is locally optimised (refit on its inliers, LO-RANSAC); the winner is
    refit on its inliers, re-selecting them, until the inlier set is stable (≤ 5 rounds).

    With intrinsics ``K`` every hypothesis is first projected onto the calibrated
    fundamental matrices (:func:`calibrated_fundamental`, i.e. E = KᵀFK with singular values
    (1, 1, 0)) and scored as such: 5 instead of 7 degrees of freedom, which stops a wrong F
    fitted to a dominant plane from out-scoring the true motion. The returned F is then
    calibrated too.
    Hypotheses are drawn and scored ``batch`` at a time. ``score='count'`` (default) ranks
    them by inlier count (MSAC cost as tie-break), ``score='msac'`` by the MSAC cost
    Σ min(d², τ²) (inlier count as tie-break).
    """
    if score not in ("count", "msac"):
        raise VoError(f"unknown RANSAC score {score!r} (msac, count)")
    by_cost = score == "msac"
    x1 = np.asarray(x1, dtype=float)
    x2 = np.asarray(x2, dtype=float)
    n = len(x1)
    if n < 8 or x2.shape != x1.shape:
        raise VoError(f"RANSAC needs at least 8 correspondences, got {n}")
    budget = SampleBudget(np.random.default_rng(seed), n, 8, confidence, min_iterations, max_iterations, batch)
    best_count, best_cost, best_F = -1, np.inf, None
    for idx in budget.batches():
        with np.errstate(all="ignore"):
            F = eight_point(x1[idx], x2[idx])
        ok = np.all(np.isfinite(F), axis=(1, 2))
        if not ok.any():
            continue
        F = F[ok]
        if K is not None:
            F = calibrated_fundamental(F, K)
        d = sampson_distance(F, x1, x2)
        inl = d < threshold_px
        count = inl.sum(axis=1)
        cost = np.where(inl, d**2, threshold_px**2).sum(axis=1)   # MSAC tie-break
        j = int(np.lexsort((-count, cost))[0] if by_cost else np.lexsort((cost, -count))[0])
        if best_F is None or _better(count[j], cost[j], best_count, best_cost, by_cost):
            best_count, best_cost, best_F = _local_optimisation(F[j], int(count[j]), float(cost[j]),
                                                                x1, x2, threshold_px, K, by_cost=by_cost)
            budget.update(best_count)
    if best_F is None or best_count < 8:
        raise VoError(f"RANSAC found no fundamental matrix with 8 inliers among {n} matches")
    F, inliers = best_F, sampson_distance(best_F, x1, x2) < threshold_px
    for _ in range(5):   # refit on the inliers until the inlier set is stable
        F_new = eight_point(x1[inliers], x2[inliers])
        if K is not None:
            F_new = calibrated_fundamental(F_new, K)
        inl_new = sampson_distance(F_new, x1, x2) < threshold_px
        if inl_new.sum() < 8:
            break
        F = F_new
        if np.array_equal(inl_new, inliers):
            break
        inliers = inl_new
    return RansacResult(F, inliers, budget.drawn)
