"""How much of a real sequence's translation RPE is its ground truth's own error (issue 28):
KITTI's poses (OXTS RT3003 GPS/INS, projected into the left camera) against the steps of VOs
that never saw them, by the three-cornered hat, and a smoothness bound.

    python bench/gt_noise.py [--render OUT/city] [--frames N] [--draws 3] [--boot 2000]

**The three-cornered hat** (Allan's, as for three clocks). Three estimates of each step's
translation (in camera k's frame) -- the poses' ``g`` and two VOs' ``a``, ``b`` -- each the
true step plus its own error. The variance over the steps of each pair's difference is the sum
of the two errors' variances when the errors are independent: V_ga = s_g + s_a, V_gb = s_g +
s_b, V_ab = s_a + s_b, so s_g = (V_ga + V_gb - V_ab) / 2 per axis (x right, y down, z forward).
The VO-vs-VO difference carries no ground-truth error; the VO-vs-poses differences carry it.
Two VOs on the same images make correlated errors (the same scene's depth, the same texture):
V_ab = s_a + s_b - 2 rho sqrt(s_a s_b) then, and the plain rule reads their covariance as the
ground truth's. On a render the ground truth is exact, so the plain rule must give ~0 there:
what it gives instead is the VOs' covariance, and rho measured there (``vo_correlation``)
corrects the real estimate (``cornered_hat(..., rho)``), assuming the twin's VOs correlate as
on the real images. Intervals: a block bootstrap over the steps (blocks of ``BLOCK`` steps: the
differences are autocorrelated), 5-95 %.

**The smoothness bound.** A car's position at 10 Hz is smooth: its third difference is the jerk
times dt^3 (1 m/s^3 -> 1 mm). A white noise of sigma per pose adds sigma sqrt(20) to it, so
rms(third difference) / sqrt(20) bounds a white pose noise, and sqrt(2) times that its per-step
noise. A slowly varying error (the INS's heading and pitch: the step is expressed in the poses'
own camera frame, so 0.1 deg of heading error moves a 1.2 m step 2.1 mm sideways) passes it.

``main`` prints KITTI sequence_1 (all its 50 steps by default, the three VOs of bench/twin.py at the twin's
613 px), with ``--render`` the check on a twin render's draws (bench/twin.py's folder), and
KITTI sequence 00's poses against ORB-SLAM2's and S-PTAM's (shared/data/trajectories: 4540
steps, the same hat with two SLAM systems; no render to calibrate their correlation).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

AXES = ("x", "y", "z")
BLOCK = 5           # the block bootstrap's block (steps): KITTI's poses-vs-VO differences' lag-1 autocorrelation 0.5-0.7
BOOT = 2000


def step_vectors(T_world_cam) -> np.ndarray:
    """Each step's translation in camera k's frame (the translation of inv(T_k) T_k+1), m, (n-1, 3)."""
    T = np.asarray(T_world_cam, float)
    return np.einsum("kji,kj->ki", T[:-1, :3, :3], T[1:, :3, 3] - T[:-1, :3, 3])


def rotvec(R) -> np.ndarray:
    """Rotation matrices (..., 3, 3) as rotation vectors (..., 3), rad: the axis times the angle
    (the angle by atan2 of the skew part's norm and the trace: exact for small angles, where
    the arccos of the trace is not)."""
    R = np.asarray(R, float)
    w = 0.5 * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    s = np.linalg.norm(w, axis=-1)
    angle = np.arctan2(s, 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0))
    return w * (np.where(s > 1e-15, angle / np.maximum(s, 1e-300), 1.0))[..., None]


def step_rotations(T_world_cam) -> np.ndarray:
    """Each step's rotation (of inv(T_k) T_k+1) as a rotation vector, rad, (n-1, 3)."""
    T = np.asarray(T_world_cam, float)
    return rotvec(np.einsum("kji,kjl->kil", T[:-1, :3, :3], T[1:, :3, :3]))


def cornered_hat(g, a, b, rho=0.0) -> np.ndarray:
    """The error variance of ``g`` per axis (units^2) from three estimates of the same steps,
    (n, 3) each: the three-cornered hat (module doc), ``rho`` (scalar or per axis) the
    correlation of ``a``'s and ``b``'s errors (0: independent, the plain rule). May be negative
    where the differences' sampling scatter exceeds the error (a small or absent error)."""
    g, a, b = (np.asarray(x, float) for x in (g, a, b))
    Vga, Vgb, Vab = np.var(g - a, axis=0), np.var(g - b, axis=0), np.var(a - b, axis=0)
    s = (Vga + Vgb - Vab) / 2
    rho = np.broadcast_to(np.asarray(rho, float), s.shape)
    if np.any(rho != 0):
        # V_ab = s_a + s_b - 2 rho sqrt(s_a s_b), s_a = V_ga - s_g, s_b = V_gb - s_g: a fixed point
        # (a contraction while rho (s_a + s_b) / (2 sqrt(s_a s_b)) < 1; the twin's rho are 0.1-0.5)
        plain = s.copy()
        for _ in range(200):
            sa, sb = np.maximum(Vga - s, 0), np.maximum(Vgb - s, 0)
            s, last = plain - rho * np.sqrt(sa * sb), s
            if np.all(np.abs(s - last) <= 1e-9 * np.maximum(Vga + Vgb, 1e-30)):
                break
    return s


def vo_correlation(truths, a_draws, b_draws) -> np.ndarray:
    """Per axis, the correlation of two VOs' step errors against an exact ground truth (a
    render), pooled over draws: lists of (n, 3) arrays (each draw's errors centred on its own
    mean: a draw's bias is not a correlation)."""
    ea = [np.asarray(a, float) - t for a, t in zip(a_draws, truths)]
    eb = [np.asarray(b, float) - t for b, t in zip(b_draws, truths)]
    ea = np.concatenate([e - e.mean(axis=0) for e in ea])
    eb = np.concatenate([e - e.mean(axis=0) for e in eb])
    return np.sum(ea * eb, axis=0) / np.sqrt(np.sum(ea ** 2, axis=0) * np.sum(eb ** 2, axis=0))


def block_resamples(n: int, boot: int = BOOT, block: int = BLOCK, seed: int = 0):
    """``boot`` index arrays of length n, each a moving-block bootstrap resample of 0..n-1."""
    rng = np.random.default_rng(seed)
    block = max(1, min(block, n))
    starts = np.arange(n - block + 1)
    for _ in range(boot):
        idx = np.concatenate([np.arange(s, s + block) for s in rng.choice(starts, -(-n // block))])[:n]
        yield idx


def hat_with_interval(g, a, b, rho=0.0, boot: int = BOOT, block: int = BLOCK, seed: int = 0) -> dict:
    """``cornered_hat`` on all steps and on block-bootstrap resamples: ``axes`` the estimate
    per axis, ``total`` their sum (the 3D mean square), ``lo``/``hi`` the total's 5 and 95 %
    and ``axes_lo``/``axes_hi`` each axis's."""
    g, a, b = (np.asarray(x, float) for x in (g, a, b))
    est = cornered_hat(g, a, b, rho)
    res = np.array([cornered_hat(g[i], a[i], b[i], rho) for i in block_resamples(len(g), boot, block, seed)])
    tot = res.sum(axis=1)
    return {"axes": est, "total": float(est.sum()), "lo": float(np.percentile(tot, 5)),
            "hi": float(np.percentile(tot, 95)), "axes_lo": np.percentile(res, 5, axis=0),
            "axes_hi": np.percentile(res, 95, axis=0), "resamples": tot}


def smoothness_bound(T_world_cam) -> np.ndarray:
    """Per axis (camera k's frame), the largest per-step rms a white noise of the poses'
    positions can have: rms(third difference) / sqrt(20) per pose, times sqrt(2) a step (m)."""
    T = np.asarray(T_world_cam, float)
    d3 = np.diff(T[:, :3, 3], 3, axis=0)
    d3 = np.einsum("kji,kj->ki", T[1:-2, :3, :3], d3)
    return np.sqrt(np.mean(d3 ** 2, axis=0) / 20.0 * 2.0)


def rpe_pct(truth, est) -> np.ndarray:
    """Per step, the translation error in % of the true step (bench/twin.py's ``step_errors``:
    |t_est - t_true| / |t_true|, both in camera k's frame)."""
    truth, est = np.asarray(truth, float), np.asarray(est, float)
    return 100 * np.linalg.norm(est - truth, axis=1) / np.maximum(np.linalg.norm(truth, axis=1), 1e-9)


def rpe_without_truth_error(truth, est, s_truth_total: float) -> float:
    """The median translation RPE (% of the step) of ``est`` with a ground-truth error of mean
    square ``s_truth_total`` (3D, units^2) removed in quadrature: the measured median times
    sqrt(1 - s / mean|est - truth|^2) (the error's shape kept, its power less the truth's; a
    negative estimate of s, within its sampling scatter of 0, removes nothing)."""
    e2 = float(np.mean(np.sum((np.asarray(est, float) - np.asarray(truth, float)) ** 2, axis=1)))
    return float(np.median(rpe_pct(truth, est)) * np.sqrt(max(e2 - max(s_truth_total, 0.0), 0.0) / e2))


def rpe_with_drawn_truth_error(truth, est, s_truth_axes, draws: int = 50, seed: int = 0) -> float:
    """The median translation RPE (% of the step) of ``est`` against ``truth`` plus a drawn
    Gaussian error of variance ``s_truth_axes`` per axis (negative estimates: none), the median
    over ``draws`` draws: an exact ground truth given a real one's error."""
    truth = np.asarray(truth, float)
    sd = np.sqrt(np.maximum(np.asarray(s_truth_axes, float), 0.0))
    rng = np.random.default_rng(seed)
    return float(np.median([np.median(rpe_pct(truth + rng.normal(size=truth.shape) * sd, est))
                            for _ in range(draws)]))


def heading_offset_rad(truth, vo_steps) -> float:
    """The poses' heading against the images' (rad): the mean over the steps of the poses' step's
    lateral offset from the VOs' median step (per axis) over its forward length. A yaw between
    the poses' camera frame and the camera that took the images (KITTI: the GPS/INS-to-camera
    calibration) turns every step's translation by it; the VOs' median step is the images' (on
    a render with exact poses this reads ~0: the check). Positive: the poses' step lies right of the VOs'."""
    truth = np.asarray(truth, float)
    c = np.median(np.stack([np.asarray(v, float) for v in vo_steps]), axis=0)
    return float(np.mean((truth[:, 0] - c[:, 0]) / np.maximum(truth[:, 2], 1e-9)))


def turned(truth, psi_rad: float) -> np.ndarray:
    """Steps (n, 3) turned about camera k's y axis by -psi: a heading offset psi taken out."""
    c, s = np.cos(psi_rad), np.sin(psi_rad)
    t = np.asarray(truth, float)
    return np.stack([c * t[:, 0] - s * t[:, 2], t[:, 1], s * t[:, 0] + c * t[:, 2]], axis=1)


def load_kitti_poses(path) -> np.ndarray:
    """A KITTI pose file (12 numbers a line, 3 x 4 row-major T_world_cam) as (n, 4, 4)."""
    P = np.loadtxt(path).reshape(-1, 3, 4)
    T = np.tile(np.eye(4), (len(P), 1, 1))
    T[:, :3, :] = P
    return T


def mm(v) -> str:
    """Variances (m^2) as rms mm, a negative variance as its signed root."""
    v = np.atleast_1d(np.asarray(v, float))
    return "/".join(f"{np.sign(x) * np.sqrt(abs(x)) * 1e3:.1f}" for x in v)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--render", default=None, help="a twin render folder (bench/twin.py's OUT/city) for the check")
    ap.add_argument("--frames", type=int, default=None,
                    help="frames of KITTI sequence_1 and of the render (default all: KITTI's 51 poses, 50 steps)")
    ap.add_argument("--draws", type=int, default=3, help="the render's sensor-noise draws (default 3)")
    ap.add_argument("--boot", type=int, default=BOOT)
    a = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import twin
    if not twin.DATA.is_dir():
        print(f"real data not found at {twin.DATA} (set SESGEN_SHARED_DATA)", file=sys.stderr)
        return 2
    if (a.frames is not None and a.frames < 8) or a.draws < 1 or a.boot < 10:
        print("--frames 8 or more, --draws 1 or more, --boot 10 or more", file=sys.stderr)
        return 2
    from vo_reference.io.sequence import open_sequence
    seq = open_sequence(twin.DATA / "kitti" / "sequence_1")
    size = (613, 185)
    rho = np.zeros(3)
    if a.render:
        out = Path(a.render)
        if not (out / "manifest.json").is_file():
            print(f"{out}: not a render folder", file=sys.stderr)
            return 2
        rs = open_sequence(out)
        n_r = 0
        while n_r < min(a.frames or 10 ** 9, rs.num_frames) and rs.frame_complete(n_r):
            n_r += 1
        if n_r < 8:
            print(f"{out}: only {n_r} frame(s) rendered completely (8 at least)", file=sys.stderr)
            return 2
        runs, headings = [], []
        for d in range(a.draws):
            fr = twin.resensor(out, n_r, 0, d)
            t = step_vectors(fr.T_world_cam("left")[:n_r])
            st = {vo: step_vectors_of(twin.vo_steps(fr, vo, n_r)) for vo in twin.VOS}
            runs.append((t, st["opencv-baseline"], st["accurate"]))
            headings.append(np.degrees(heading_offset_rad(t, list(st.values()))))
        truths, A, B = zip(*runs)
        rho = vo_correlation(truths, A, B)
        print(f"render {out} ({n_r} frames, {a.draws} draws; exact ground truth): the OpenCV and accurate VOs' step "
              f"errors correlate by rho x/y/z " + "/".join(f"{r:.2f}" for r in rho)
              + "; the poses' heading against the images' by draw " + ", ".join(f"{h:+.2f}" for h in headings) + " deg")
        for d, (t, x, y) in enumerate(runs):
            plain = hat_with_interval(t, x, y, 0.0, a.boot)
            others = [i for i in range(a.draws) if i != d] or [d]
            r_loo = vo_correlation([truths[i] for i in others], [A[i] for i in others], [B[i] for i in others])
            corr = hat_with_interval(t, x, y, r_loo, a.boot)
            print(f"  draw {d}: the hat's ground-truth error (should be 0) plain {mm(plain['axes'])} mm "
                  f"(3D {mm(plain['total'])} [{mm(plain['lo'])}, {mm(plain['hi'])}]), corrected with the other draws' "
                  f"rho {mm(corr['axes'])} (3D {mm(corr['total'])} [{mm(corr['lo'])}, {mm(corr['hi'])}])")
    n = min(a.frames or 10 ** 9, seq.num_frames)
    real = twin.resized(seq, n, size)
    T = real.T_world_cam("left")[:n]
    n = len(T)
    g = step_vectors(T)
    vos = {vo: step_vectors_of(twin.vo_steps(real, vo, n)) for vo in twin.VOS}
    print(f"KITTI sequence_1 ({n - 1} steps, {size[0]} px): poses' error by the hat of the OpenCV and accurate VOs")
    for label, r in (("plain", 0.0), ("rho from the render" if a.render else "rho 0 (no --render)", rho)):
        h = hat_with_interval(g, vos["opencv-baseline"], vos["accurate"], r, a.boot)
        print(f"  {label}: x/y/z {mm(h['axes'])} mm a step (3D {mm(h['total'])}, 90 % [{mm(h['lo'])}, {mm(h['hi'])}])")
        for vo in ("opencv-baseline", "accurate"):
            print(f"    {vo}: RPE {np.median(rpe_pct(g, vos[vo])):.3f} % of the step, without the poses' share "
                  f"{rpe_without_truth_error(g, vos[vo], h['total']):.3f} % "
                  f"[{rpe_without_truth_error(g, vos[vo], h['hi']):.3f}, {rpe_without_truth_error(g, vos[vo], h['lo']):.3f}]")
    print("  the poses' step minus the VOs' (mean, mm, x/y/z): " + ", ".join(
        f"{vo} " + "/".join(f"{v:+.1f}" for v in 1e3 * (g - vos[vo]).mean(axis=0)) for vo in twin.VOS))
    psi = heading_offset_rad(g, list(vos.values()))
    print(f"  the poses' heading against the images' (their step's lateral offset from the VOs' median step): "
          f"{np.degrees(psi):+.2f} deg; RPE with it turned out: " + ", ".join(
              f"{vo} {np.median(rpe_pct(g, vos[vo])):.3f} -> {np.median(rpe_pct(turned(g, psi), vos[vo])):.3f} %"
              for vo in twin.VOS))
    print("  smoothness bound on a white pose noise (per step, x/y/z): "
          + "/".join(f"{v * 1e3:.1f}" for v in smoothness_bound(T)) + " mm")
    base = twin.DATA / "trajectories"
    if (base / "KITTI_00_gt.txt").is_file():
        gt, orb, sptam = (step_vectors(load_kitti_poses(base / f"KITTI_00_{x}.txt")) for x in ("gt", "ORB", "SPTAM"))
        h = hat_with_interval(gt, orb, sptam, 0.0, a.boot)
        print(f"KITTI sequence 00 ({len(gt)} steps of {1e3 * np.median(np.linalg.norm(gt, axis=1)):.0f} mm): poses' error "
              f"by the hat of ORB-SLAM2 and S-PTAM, x/y/z {mm(h['axes'])} mm (3D {mm(h['total'])}, 90 % "
              f"[{mm(h['lo'])}, {mm(h['hi'])}]); smoothness bound x/y/z "
              + "/".join(f"{v * 1e3:.1f}" for v in smoothness_bound(load_kitti_poses(base / 'KITTI_00_gt.txt'))) + " mm")
    return 0


def step_rotations_of(steps) -> np.ndarray:
    """The rotation vectors (rad) of a list of step transforms T_k_k1, (n, 3)."""
    return rotvec(np.array([np.asarray(S, float)[:3, :3] for S in steps]))


def step_vectors_of(steps) -> np.ndarray:
    """The translations of a list of step transforms T_k_k1 (bench/twin.py's ``vo_steps``), (n, 3)."""
    return np.array([np.asarray(S, float)[:3, 3] for S in steps])


if __name__ == "__main__":
    raise SystemExit(main())
