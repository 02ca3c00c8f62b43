"""Calibrated minimal solver: the 5-point essential matrix, and our RANSAC around it.

Nistér (2004) / Stewénius, Engels & Nistér (2006), in our own numpy code:

1. Each correspondence of normalised image points q = K⁻¹x gives one linear equation
   q₂ᵀ E q₁ = 0 in the nine entries of E (row-major, the same design matrix as the 8-point
   algorithm). Five of them leave a 4-dimensional null space: E = x·X + y·Y + z·Z + W
   (the right singular vectors of the 5×9 matrix with the smallest singular values; with
   more than five points the least-squares null space, a non-minimal solver).
2. E is essential iff det(E) = 0 and 2 E Eᵀ E − trace(E Eᵀ) E = 0: ten cubic equations in
   (x, y, z). Their coefficients on the 20 monomials of degree ≤ 3 are computed by
   expanding the products of the linear forms E_ij(x, y, z, 1) (a 4×4×4 tensor per
   product, folded onto monomials), batched over many samples.
3. Gauss–Jordan elimination of the ten cubic monomials expresses each of them in the
   basis B = (x², xy, xz, y², yz, z², x, y, z, 1) of the quotient ring (for ten solutions in
   general position no conic vanishes on all of them, so B is a basis and the 10×10 cubic
   block is invertible: the ten equations are already a Gröbner basis). The action matrix
   of multiplication by x on B (10×10) has the monomial vectors B(x, y, z) of the solutions
   as eigenvectors; the real ones (up to ten) give (x, y, z) = (v₆, v₇, v₈) / v₉ and
   E = xX + yY + zZ + W. :func:`five_point` polishes each root by two Gauss–Newton steps on
   the ten cubics (eigenvectors alone: ~1e-8 relative; polished: ~1e-12).

Conventions as in ``essential.py``: x̂₂ᵀ E x̂₁ = 0, E = [t]ₓR for the point transform
x₂ = R x₁ + t. Returned E matrices have unit Frobenius norm.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import VoError
from .fundamental import SampleBudget, sampson_distance

# monomials x^a y^b z^c as exponent triples: the ten cubics first, then the basis B
CUBICS = [(3, 0, 0), (2, 1, 0), (2, 0, 1), (1, 2, 0), (1, 1, 1), (1, 0, 2), (0, 3, 0), (0, 2, 1),
          (0, 1, 2), (0, 0, 3)]
BASIS = [(2, 0, 0), (1, 1, 0), (1, 0, 1), (0, 2, 0), (0, 1, 1), (0, 0, 2), (1, 0, 0), (0, 1, 0),
         (0, 0, 1), (0, 0, 0)]
MONOMIALS = CUBICS + BASIS
_INDEX = {m: i for i, m in enumerate(MONOMIALS)}


def _fold_matrix() -> np.ndarray:
    """(64, 20): entry (a, b, c) of a product tensor over v = (x, y, z, 1) -> its monomial."""
    S = np.zeros((4, 4, 4, 20))
    for a in range(4):
        for b in range(4):
            for c in range(4):
                e = [0, 0, 0]
                for i in (a, b, c):
                    if i < 3:
                        e[i] += 1
                S[a, b, c, _INDEX[tuple(e)]] = 1.0
    return S.reshape(64, 20)


_FOLD = _fold_matrix()
_EPS = np.zeros((3, 3, 3))
for _i, _j, _k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
    _EPS[_i, _j, _k], _EPS[_i, _k, _j] = 1.0, -1.0


def _action_rows() -> list[tuple[str, int]]:
    """x · B[i] as ('cubic', index into CUBICS) or ('basis', index into BASIS)."""
    rows = []
    for a, b, c in BASIS:
        m = (a + 1, b, c)
        rows.append(("cubic", CUBICS.index(m)) if m in CUBICS else ("basis", BASIS.index(m)))
    return rows


_ACTION = _action_rows()


def constraint_matrix(N: np.ndarray) -> np.ndarray:
    """The ten cubic constraints on E = xX + yY + zZ + W as a (..., 10, 20) coefficient
    matrix over ``MONOMIALS``; ``N``: (..., 4, 3, 3) = (X, Y, Z, W)."""
    c = np.moveaxis(np.asarray(N, dtype=float), -3, -1)                # (..., 3, 3, 4): E_ij = c_ij · v
    lead = c.shape[:-3]
    det = np.einsum("ijk,...ia,...jb,...kc->...abc", _EPS, c[..., 0, :, :], c[..., 1, :, :], c[..., 2, :, :],
                    optimize=True)
    EEt = np.einsum("...pia,...jib->...pjab", c, c, optimize=True)          # (E Eᵀ)_pj
    EEtE = np.einsum("...pjab,...jqc->...pqabc", EEt, c, optimize=True)
    tr = np.einsum("...ppab->...ab", EEt)
    trE = np.einsum("...ab,...pqc->...pqabc", tr, c)
    cub = (2.0 * EEtE - trE).reshape(lead + (9, 64))
    G = np.concatenate([det.reshape(lead + (1, 64)), cub], axis=-2)
    return G @ _FOLD


def _null_space_basis(q1: np.ndarray, q2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(..., 4, 3, 3) basis of the (least-squares) null space of the epipolar equations,
    and the singular values of the design matrix (..., min(N, 9))."""
    u1, v1 = q1[..., 0], q1[..., 1]
    u2, v2 = q2[..., 0], q2[..., 1]
    one = np.ones_like(u1)
    A = np.stack([u2 * u1, u2 * v1, u2, v2 * u1, v2 * v1, v2, u1, v1, one], axis=-1)
    if A.shape[-2] > 9:                     # the normal equations' eigenvectors: same null space, cheaper
        _, s, Vt = np.linalg.svd(np.swapaxes(A, -1, -2) @ A)
        s = np.sqrt(np.maximum(s, 0.0))
    else:
        _, s, Vt = np.linalg.svd(A, full_matrices=True)
    return Vt[..., 5:, :].reshape(A.shape[:-2] + (4, 3, 3)), s


_EXP = np.array(MONOMIALS, dtype=float)                                    # (20, 3)


def _monomials(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Monomial values (..., 20) and their gradients (..., 20, 3) at points p (..., 3)."""
    p = p[..., None, :]                                                     # (..., 1, 3)
    powers = p ** _EXP                                                      # (..., 20, 3)
    val = powers.prod(axis=-1)
    grad = np.empty(val.shape + (3,))
    for k in range(3):
        e = _EXP.copy()
        e[:, k] = np.maximum(e[:, k] - 1, 0)
        grad[..., k] = _EXP[:, k] * (p ** e).prod(axis=-1)
    return val, grad


def _polish(G: np.ndarray, xyz: np.ndarray, steps: int = 2) -> np.ndarray:
    """Gauss–Newton on the ten cubic residuals G·m(x, y, z) for each root (B, 3, S): the
    eigenvector gives the roots to ~1e-8, two steps to machine precision."""
    p = np.swapaxes(xyz, 1, 2)                                              # (B, S, 3)
    with np.errstate(all="ignore"):
        for _ in range(steps):
            val, grad = _monomials(p)
            r = np.einsum("bem,bsm->bse", G, val)                           # (B, S, 10)
            J = np.einsum("bem,bsmk->bsek", G, grad)                        # (B, S, 10, 3)
            JtJ = np.swapaxes(J, -1, -2) @ J
            Jtr = np.einsum("bsek,bse->bsk", J, r)
            ok = np.all(np.isfinite(JtJ), axis=(-2, -1)) & (np.abs(np.linalg.det(JtJ)) > 1e-300)
            JtJ[~ok] = np.eye(3)
            dp = np.linalg.solve(JtJ, Jtr[..., None])[..., 0]
            p = np.where(ok[..., None] & np.all(np.isfinite(dp), axis=-1, keepdims=True), p - dp, p)
    return np.swapaxes(p, 1, 2)


def _solve_from_basis(N: np.ndarray, polish: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """E candidates (B, 10, 3, 3) and a validity mask (B, 10) from null-space bases (B, 4, 3, 3)."""
    G = constraint_matrix(N)
    Bn = len(N)
    with np.errstate(all="ignore"):
        try:
            C = np.linalg.solve(G[:, :, :10], G[:, :, 10:])                 # cubic_i = −C_i · B
        except np.linalg.LinAlgError:
            C = np.stack([np.linalg.lstsq(g[:, :10], g[:, 10:], rcond=None)[0] for g in G])
        M = np.zeros((Bn, 10, 10))
        for i, (kind, j) in enumerate(_ACTION):
            if kind == "cubic":
                M[:, i] = -C[:, j]
            else:
                M[:, i, j] = 1.0
        ok_m = np.all(np.isfinite(M), axis=(1, 2))
        M[~ok_m] = 0.0
        lam, V = np.linalg.eig(M)                                           # M v = x v, v ∝ B(x, y, z)
        real = np.abs(lam.imag) <= 1e-9 * np.maximum(1.0, np.abs(lam.real))
        V = V.real
        w = V[:, 9, :]
        xyz = V[:, 6:9, :] / w[:, None, :]                                  # (B, 3, 10)
        if polish:
            xyz = _polish(G, xyz)
        E = (np.einsum("bks,bkij->bsij", xyz, N[:, :3]) + N[:, 3][:, None])
        nrm = np.linalg.norm(E, axis=(2, 3))
        E = E / nrm[..., None, None]
    valid = (ok_m[:, None] & real & (np.abs(w) > 1e-12 * np.abs(V).max(axis=1))
             & np.all(np.isfinite(E), axis=(2, 3)) & (nrm > 0))
    E[~valid] = 0.0
    return E, valid


def _check_points(q1: np.ndarray, q2: np.ndarray) -> None:
    if q1.shape != q2.shape or q1.ndim != 2 or q1.shape[1] != 2:
        raise VoError(f"five_point needs two (N, 2) point sets, got {q1.shape} and {q2.shape}")
    if len(q1) < 5:
        raise VoError(f"the 5-point solver needs at least 5 correspondences, got {len(q1)}")
    if not (np.all(np.isfinite(q1)) and np.all(np.isfinite(q2))):
        raise VoError("five_point: non-finite point coordinates")
    for name, q in (("view 1", q1), ("view 2", q2)):
        h = np.column_stack([q, np.ones(len(q))])
        s = np.linalg.svd(h / np.linalg.norm(h, axis=1, keepdims=True), compute_uv=False)
        if s[2] < 1e-9 * s[0]:
            raise VoError(f"degenerate input for the 5-point solver: the points of {name} are collinear")


def five_point(q1: np.ndarray, q2: np.ndarray) -> list[np.ndarray]:
    """All real essential matrices (unit Frobenius norm, up to ten) with q₂ᵀ E q₁ = 0 for
    the normalised image points (K⁻¹x, (N, 2), N ≥ 5; with N > 5 the constraints hold in
    the least-squares sense: the null space is that of the N×9 system's four smallest
    singular values).

    Raises :class:`VoError` for fewer than five points, collinear points in either view,
    or a rank-deficient system (e.g. repeated points).
    """
    q1 = np.asarray(q1, dtype=float)
    q2 = np.asarray(q2, dtype=float)
    _check_points(q1, q2)
    N, s = _null_space_basis(q1, q2)
    if s[4] < 1e-10 * s[0]:
        raise VoError("degenerate input for the 5-point solver: the epipolar equations have rank < 5")
    E, valid = _solve_from_basis(N[None])
    return [e for e, ok in zip(E[0], valid[0]) if ok]


def five_point_batch(q1: np.ndarray, q2: np.ndarray, polish: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Minimal samples (B, 5, 2) at once: E (B, 10, 3, 3) and validity (B, 10); degenerate
    samples simply give no valid solution. Without ``polish`` (RANSAC: noisy samples) the
    roots are the eigenvectors' (~1e-8 relative); with it, two Gauss–Newton steps too."""
    N, s = _null_space_basis(np.asarray(q1, dtype=float), np.asarray(q2, dtype=float))
    E, valid = _solve_from_basis(N, polish)
    valid &= (s[:, 4] > 1e-10 * s[:, 0])[:, None]
    return E, valid


def essential_residuals(E: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """|det(E)| and ‖2EEᵀE − trace(EEᵀ)E‖ (Frobenius) for E (..., 3, 3) of unit norm."""
    EEt = E @ np.swapaxes(E, -1, -2)
    tr = np.trace(EEt, axis1=-2, axis2=-1)
    return np.abs(np.linalg.det(E)), np.linalg.norm(2 * EEt @ E - tr[..., None, None] * E, axis=(-2, -1))


@dataclass(frozen=True)
class EssentialRansacResult:
    E: np.ndarray            # (3, 3) essential matrix, unit Frobenius norm, singular values (s, s, 0)
    F: np.ndarray            # (3, 3) K⁻ᵀ E K⁻¹, unit norm (pixels)
    inliers: np.ndarray      # (N,) bool (Sampson distance in pixels < threshold)
    iterations: int          # minimal samples drawn

    @property
    def inlier_ratio(self) -> float:
        return float(self.inliers.mean()) if self.inliers.size else 0.0


def _to_F(E: np.ndarray, Kinv: np.ndarray) -> np.ndarray:
    F = Kinv.T @ E @ Kinv
    return F / np.linalg.norm(F, axis=(-2, -1), keepdims=True)


def _score(E, Kinv, x1, x2, threshold_px):
    d = sampson_distance(_to_F(E, Kinv), x1, x2)
    inl = d < threshold_px
    return inl, inl.sum(axis=-1), np.where(inl, d**2, threshold_px**2).sum(axis=-1)


def _better(count, cost, best_count, best_cost, by_cost):
    if by_cost:
        return cost < best_cost or (cost == best_cost and count > best_count)
    return count > best_count or (count == best_count and cost < best_cost)


def _pick(count, cost, by_cost):
    return int(np.lexsort((-count, cost))[0] if by_cost else np.lexsort((cost, -count))[0])


def _refit(E, inl, count, cost, q1, q2, Kinv, x1, x2, threshold_px, rounds, by_cost=True):
    """Non-minimal 5-point on the inliers (least-squares null space), keeping the solution
    with the most inliers (then the lowest MSAC cost), while that improves the score."""
    for _ in range(rounds):
        if inl.sum() < 6:
            break
        try:
            cands = five_point(q1[inl], q2[inl])
        except VoError:
            break
        if not cands:
            break
        Ec = np.stack(cands)
        inl_c, cnt_c, cost_c = _score(Ec, Kinv, x1, x2, threshold_px)
        j = _pick(cnt_c, cost_c, by_cost)
        if _better(cnt_c[j], cost_c[j], count, cost, by_cost):
            E, inl, count, cost = Ec[j], inl_c[j], int(cnt_c[j]), float(cost_c[j])
        else:
            break
    return E, inl, count, cost


def ransac_essential(x1: np.ndarray, x2: np.ndarray, K: np.ndarray, threshold_px: float = 1.0,
                     confidence: float = 0.999, max_iterations: int = 5000, seed: int | None = 0,
                     batch: int = 32, min_iterations: int = 256, score: str = "msac") -> EssentialRansacResult:
    """RANSAC over minimal 5-point samples of the normalised points K⁻¹x.

    Every real solution of every sample is a hypothesis, scored in *pixels* by the
    Sampson distance d of F = K⁻ᵀEK⁻¹: ``score='msac'`` (default) minimises the MSAC cost
    Σ min(d², τ²) (Torr & Zisserman 2000; inlier count as tie-break), ``score='count'``
    maximises the inlier count (MSAC cost as tie-break). The number of
    samples adapts to the best inlier ratio, log(1−p)/log(1−w⁵), within
    [``min_iterations``, ``max_iterations``]; ``seed`` fixes the sampling. Each new best is
    locally optimised (non-minimal 5-point refit on its inliers, LO-RANSAC) and the winner
    is refit until its inlier set is stable.
    """
    x1 = np.asarray(x1, dtype=float)
    x2 = np.asarray(x2, dtype=float)
    n = len(x1)
    if score not in ("msac", "count"):
        raise VoError(f"unknown RANSAC score {score!r} (msac, count)")
    if n < 5 or x2.shape != x1.shape:
        raise VoError(f"the 5-point RANSAC needs at least 5 correspondences, got {n}")
    K = np.asarray(K, dtype=float)
    Kinv = np.linalg.inv(K)
    q1 = x1 @ Kinv[:2, :2].T + Kinv[:2, 2]
    q2 = x2 @ Kinv[:2, :2].T + Kinv[:2, 2]
    by_cost = score == "msac"
    budget = SampleBudget(np.random.default_rng(seed), n, 5, confidence, min_iterations, max_iterations, batch)
    best = None                                   # (E, inliers, count, cost)
    for idx in budget.batches():
        E, valid = five_point_batch(q1[idx], q2[idx])
        E = E[valid]
        if not len(E):
            continue
        inl, count, cost = _score(E, Kinv, x1, x2, threshold_px)
        j = _pick(count, cost, by_cost)
        if best is None or _better(count[j], cost[j], best[2], best[3], by_cost):
            best = _refit(E[j], inl[j], int(count[j]), float(cost[j]), q1, q2, Kinv, x1, x2,
                          threshold_px, rounds=4, by_cost=by_cost)
            budget.update(best[2])
    if best is None or best[2] < 5:
        raise VoError(f"the 5-point RANSAC found no essential matrix with 5 inliers among {n} matches")
    E, inl, count, cost = best
    for _ in range(5):                            # refit until the inlier set is stable
        E2, inl2, count2, cost2 = _refit(E, inl, count, cost, q1, q2, Kinv, x1, x2, threshold_px, rounds=1,
                                                  by_cost=by_cost)
        if E2 is E:
            break
        E, inl, count, cost = E2, inl2, count2, cost2
    return EssentialRansacResult(E, _to_F(E, Kinv), inl, budget.drawn)
