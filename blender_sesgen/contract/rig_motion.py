"""The rig's pose at any instant, with its velocities and accelerations (numpy only).

The script gives poses at the frame stamps ``t_k``; between (and slightly beyond) them the
rig moves as follows — the one definition the renderer (motion blur, rolling shutter), the
IMU and ``vo_reference`` (per-row poses) all use:

- ``ego_twist`` (EGO scripts): exactly the script's motion, a constant body twist over each
  frame step, ``T(t) = T_k exp(s xi_k)`` with ``s = (t - t_k) * rate`` and
  ``xi_k = log(T_k^-1 T_k+1)``; before frame 0 the first twist and after the last frame
  the last twist continue. Velocity is constant in the body frame within a step, so it
  jumps where consecutive EGO lines differ.
- ``c2_spline`` (POSE / TRAJECTORY keyframes): a C2-continuous interpolating spline, the
  natural cubic spline (zero second derivative at both ends, continued by the end
  polynomials beyond them) through the positions and through the unit quaternions (signs
  chosen so neighbours have a non-negative dot product, frame 0 with w >= 0); the rotation
  is the normalised quaternion, R(t) = M(q(t)) / |q(t)|^2, so it passes exactly through
  every keyframe and is C2 wherever q(t) != 0.
- ``static``: one pose for all time.

Poses are ``T_world_cam`` of the left (reference) camera: OpenCV camera, SES world.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .timing import row_offsets_s
from .se3 import R_to_quat_xyzw, invert, se3_exp, se3_log, skew

KINDS = ("static", "ego_twist", "c2_spline")


def _quat_bilinear(q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Symmetric bilinear B(q, r) with B(q, q) = |q|^2 R(q/|q|) (q, r: (..., 4) w first)."""
    w, x, y, z = (q[..., i] for i in range(4))
    a, b, c, d = (r[..., i] for i in range(4))
    M = np.empty(q.shape[:-1] + (3, 3))
    M[..., 0, 0] = w * a + x * b - y * c - z * d
    M[..., 1, 1] = w * a - x * b + y * c - z * d
    M[..., 2, 2] = w * a - x * b - y * c + z * d
    M[..., 0, 1] = (x * c + y * b) - (w * d + z * a)
    M[..., 1, 0] = (x * c + y * b) + (w * d + z * a)
    M[..., 0, 2] = (x * d + z * b) + (w * c + y * a)
    M[..., 2, 0] = (x * d + z * b) - (w * c + y * a)
    M[..., 1, 2] = (y * d + z * c) - (w * b + x * a)
    M[..., 2, 1] = (y * d + z * c) + (w * b + x * a)
    return M


def _natural_cubic_second_derivatives(y: np.ndarray, h: float) -> np.ndarray:
    """Second derivatives M (N, D) of the natural cubic spline through y (N, D), knots h apart."""
    n = len(y)
    M = np.zeros_like(y)
    if n < 3:
        return M
    # tridiagonal system for M_1..M_{n-2}: M_{i-1} + 4 M_i + M_{i+1} = 6 (y_{i+1} - 2 y_i + y_{i-1}) / h^2
    m = n - 2
    rhs = 6.0 * (y[2:] - 2 * y[1:-1] + y[:-2]) / h**2
    c = np.zeros(m)
    d = np.zeros_like(rhs)
    c[0], d[0] = 1.0 / 4.0, rhs[0] / 4.0
    for i in range(1, m):                      # Thomas algorithm
        denom = 4.0 - c[i - 1]
        c[i] = 1.0 / denom
        d[i] = (rhs[i] - d[i - 1]) / denom
    M[m] = d[m - 1]
    for i in range(m - 2, -1, -1):
        M[i + 1] = d[i] - c[i] * M[i + 2]
    return M


@dataclass(frozen=True)
class Kinematics:
    """State of the rig at times t (leading dimension n): rotation, position, first and
    second derivatives of both (world frame), and the body angular velocity (rad/s)."""
    R: np.ndarray          # (n, 3, 3) R_world_cam
    p: np.ndarray          # (n, 3) camera centre in the world
    R_dot: np.ndarray      # (n, 3, 3)
    R_ddot: np.ndarray     # (n, 3, 3)
    v: np.ndarray          # (n, 3) world velocity
    a: np.ndarray          # (n, 3) world acceleration
    omega_body: np.ndarray  # (n, 3) angular velocity in the camera frame

    def T(self) -> np.ndarray:
        T = np.tile(np.eye(4), (len(self.p), 1, 1))
        T[:, :3, :3] = self.R
        T[:, :3, 3] = self.p
        return T


class RigMotion:
    """Continuous-time motion of the rig through ``T_world_cam`` (N, 4, 4) at stamps
    ``t0 + k / rate``; see the module docstring for the interpolation ``kind``."""

    def __init__(self, T_world_cam, rate_hz: float, start_s: float = 0.0, kind: str = "c2_spline"):
        T = np.asarray(T_world_cam, dtype=float).reshape(-1, 4, 4)
        if kind not in KINDS:
            raise ValueError(f"unknown interpolation {kind!r} ({', '.join(KINDS)})")
        if len(T) == 1:
            kind = "static"
        self.T, self.rate_hz, self.start_s, self.kind = T, float(rate_hz), float(start_s), kind
        self.n = len(T)
        if kind == "ego_twist":
            self._twists = np.array([np.concatenate(se3_log(invert(T[k]) @ T[k + 1]))
                                     for k in range(self.n - 1)])     # (omega, v) per frame step
        elif kind == "c2_spline":
            q = R_to_quat_xyzw(T[:, :3, :3])[:, [3, 0, 1, 2]]           # (w, x, y, z), w >= 0
            for k in range(1, self.n):
                if np.dot(q[k], q[k - 1]) < 0:
                    q[k] = -q[k]
            self._y = np.concatenate([T[:, :3, 3], q], axis=1)        # (N, 7): p, q
            self._M = _natural_cubic_second_derivatives(self._y, 1.0)

    @classmethod
    def for_motion_kind(cls, T_world_cam, rate_hz: float, start_s: float, motion_kind: str) -> "RigMotion":
        """The interpolation of a script's motion (``model.Motion.kind``: ego, pose, trajectory, static)."""
        kind = {"ego": "ego_twist", "static": "static"}.get(motion_kind, "c2_spline")
        return cls(T_world_cam, rate_hz, start_s, kind)

    # --- evaluation ------------------------------------------------------------------------
    def _segment(self, t):
        s = (np.atleast_1d(np.asarray(t, dtype=float)) - self.start_s) * self.rate_hz   # frame units
        k = np.clip(np.floor(s).astype(int), 0, max(self.n - 2, 0))
        return k, s - k

    def _spline(self, t):
        """y, dy/dt, d2y/dt2 (n, 7) of the natural cubic spline (knot spacing 1 frame)."""
        k, u = self._segment(t)
        y0, y1 = self._y[k], self._y[k + 1]
        M0, M1 = self._M[k], self._M[k + 1]
        u = u[:, None]
        A, B = 1 - u, u
        y = A * y0 + B * y1 + ((A**3 - A) * M0 + (B**3 - B) * M1) / 6.0
        dy = (y1 - y0) + ((1 - 3 * A**2) * M0 + (3 * B**2 - 1) * M1) / 6.0
        ddy = A * M0 + B * M1
        r = self.rate_hz
        return y, dy * r, ddy * r * r

    def kinematics(self, t) -> Kinematics:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        n = len(t)
        if self.kind == "static":
            R = np.tile(self.T[0, :3, :3], (n, 1, 1))
            z3, z33 = np.zeros((n, 3)), np.zeros((n, 3, 3))
            return Kinematics(R, np.tile(self.T[0, :3, 3], (n, 1)), z33, z33.copy(), z3, z3.copy(), z3.copy())
        if self.kind == "ego_twist":
            return self._ego(t)
        y, dy, ddy = self._spline(t)
        p, q = y[:, :3], y[:, 3:]
        qd, qdd = dy[:, 3:], ddy[:, 3:]
        N = np.sum(q * q, axis=1)[:, None, None]
        Nd = 2 * np.sum(q * qd, axis=1)[:, None, None]
        Ndd = 2 * (np.sum(qd * qd, axis=1) + np.sum(q * qdd, axis=1))[:, None, None]
        M = _quat_bilinear(q, q)
        Md = 2 * _quat_bilinear(q, qd)
        Mdd = 2 * _quat_bilinear(qd, qd) + 2 * _quat_bilinear(q, qdd)
        R = M / N
        Rd = (Md - R * Nd) / N
        Rdd = (Mdd - 2 * Rd * Nd - R * Ndd) / N
        W = np.einsum("nji,njk->nik", R, Rd)
        omega = np.stack([W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0], W[:, 1, 0] - W[:, 0, 1]], axis=1) / 2
        return Kinematics(R, p, Rd, Rdd, dy[:, :3], ddy[:, :3], omega)

    def _ego(self, t) -> Kinematics:
        k, s = self._segment(t)
        r = self.rate_hz
        out = {name: [] for name in ("R", "p", "Rd", "Rdd", "v", "a", "w")}
        for kk, ss in zip(k, s):
            xi = self._twists[kk]
            T = self.T[kk] @ se3_exp(xi[:3] * ss, xi[3:] * ss)
            R = T[:3, :3]
            w_b, v_b = xi[:3] * r, xi[3:] * r           # body rates (rad/s, units/s)
            W = skew(w_b)
            out["R"].append(R)
            out["p"].append(T[:3, 3])
            out["Rd"].append(R @ W)
            out["Rdd"].append(R @ W @ W)
            out["v"].append(R @ v_b)
            out["a"].append(R @ (W @ v_b))
            out["w"].append(w_b)
        a = {key: np.array(v) for key, v in out.items()}
        return Kinematics(a["R"], a["p"], a["Rd"], a["Rdd"], a["v"], a["a"], a["w"])

    def T_world_cam(self, t) -> np.ndarray:
        """(n, 4, 4) poses at times t (seconds)."""
        return self.kinematics(t).T()

    def T_world_cam_rows(self, t_frame_s: float, height: int, readout_s: float) -> np.ndarray:
        """(H, 4, 4) pose of every image row of a rolling-shutter frame (row 0 = top)."""
        return self.T_world_cam(t_frame_s + row_offsets_s(height, readout_s))
