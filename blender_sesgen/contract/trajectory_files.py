"""Trajectory text formats (TUM, KITTI, EuRoC) and the EGO table: one parser and one
formatter each, for the renderer's outputs, the exports and every reader.

- TUM: ``timestamp tx ty tz qx qy qz qw`` per line (seconds; quaternion scalar last).
- KITTI: 12 numbers per line, the 3x4 top of T row-major; no timestamps.
- EuRoC ``state_groundtruth_estimate0/data.csv``: ``#timestamp [ns], p xyz, q wxyz``, then
  velocity (m/s) and gyro/accelerometer biases (readers accept 8 or more columns).
- EGO table: ``step U V W alpha_deg beta_deg gamma_deg`` (contract.motion).
Poses are ``T_world_cam`` (OpenCV camera). Parsers raise :class:`ContractError` naming
``source:line``; blank lines, ``#`` comments and header lines starting with a letter are
skipped; every value must be a finite decimal number.
"""
from __future__ import annotations

import math
import re
from typing import Optional, Sequence

import numpy as np

from .errors import ContractError
from .inputs import is_number
from .se3 import R_to_quat_xyzw, not_rotations, orthonormality_error, quat_xyzw_to_R

TUM_HEADER = "# timestamp tx ty tz qx qy qz qw"
EUROC_HEADER = ("#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
                "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], "
                "b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], "
                "b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]")  # as the dataset writes it
EGO_HEADER = "# step U V W alpha_deg beta_deg gamma_deg  (motion from frame k to k+1 in the left camera frame at k)"
LIMIT = 1e9  # metres: no position of ours is farther out; 1e308 in a file is an error, not a pose


def parse_table(text: str, ncols: Sequence[int], source: str = "<text>",
                what: str = "a row") -> tuple[np.ndarray, list[int]]:
    """Rows of numbers (n, c) and their 1-based line numbers; every row has one of ``ncols``.

    Header lines (a first word that is not a number) are skipped before the first row only;
    ``nan``/``inf`` are numbers, so a row of them is an error, never a skipped line.
    """
    rows, lines = [], []
    for lineno, raw in enumerate(re.split(r"\r\n|\r|\n", text), 1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.replace(",", " ").split()
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            if not rows and not is_number(parts[0]):
                continue  # a header line
            raise ContractError(f"not a number in {s[:60]!r}", source, lineno) from None
        if len(vals) not in ncols:
            want = str(ncols[0]) if len(ncols) == 1 else f"{min(ncols)} to {max(ncols)}"
            raise ContractError(f"{what} has {want} numbers, got {len(vals)}", source, lineno)
        if rows and len(vals) != len(rows[0]):
            raise ContractError(f"{len(vals)} numbers where line {lines[0]} has {len(rows[0])}", source, lineno)
        if not all(math.isfinite(v) for v in vals):
            raise ContractError("numbers must be finite", source, lineno)
        rows.append(vals)
        lines.append(lineno)
    if not rows:
        raise ContractError("holds no poses", source)
    return np.array(rows, dtype=float), lines


def _poses(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    T = np.tile(np.eye(4), (len(t), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, t
    return T


def _check_magnitudes(values: np.ndarray, lines: list[int], source: str) -> None:
    """Every pose value (not the timestamps) within LIMIT: 1e308 is corruption, not a pose."""
    bad = np.flatnonzero(np.abs(values).reshape(len(values), -1).max(axis=1) > LIMIT)
    if bad.size:
        raise ContractError(f"a value beyond {LIMIT:g} is not a pose", source, lines[bad[0]])


def check_rotations(R: np.ndarray, lines: list[int], source: str, tolerance: float) -> None:
    """Each (3, 3) of ``R`` (n, 3, 3) a rotation within ``tolerance`` (max |R^T R - I|,
    det > 0); else ContractError at the first bad line. Values must be within LIMIT."""
    bad = np.flatnonzero(not_rotations(R, tolerance))
    if bad.size:
        err = orthonormality_error(R[bad[:1]])[0]
        raise ContractError(f"the 3x3 part is not a rotation (|R^T R - I| = {err:.2g}, "
                            f"tolerance {tolerance:g})", source, lines[bad[0]])


def _quaternions_to_R(q: np.ndarray, lines: list[int], source: str, unit_tolerance: Optional[float]) -> np.ndarray:
    norms = np.linalg.norm(q, axis=1)
    bad = np.flatnonzero(norms < 1e-6)
    if bad.size:
        raise ContractError("a zero quaternion is not a rotation", source, lines[bad[0]])
    if unit_tolerance is not None:
        bad = np.flatnonzero(np.abs(norms - 1.0) > unit_tolerance)
        if bad.size:
            raise ContractError(f"quaternion norm is {norms[bad[0]]:.6g}, expected 1", source, lines[bad[0]])
    return quat_xyzw_to_R(q)


def parse_tum(text: str, source: str = "<text>",
              unit_tolerance: Optional[float] = None) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """(timestamps_s (n,), T_world_cam (n, 4, 4), line numbers) of a TUM file's text.

    Quaternions are normalised; with ``unit_tolerance`` their norms must be 1 within it."""
    a, lines = parse_table(text, (8,), source, "a TUM pose")
    _check_magnitudes(a[:, 1:], lines, source)
    T = _poses(_quaternions_to_R(a[:, 4:8], lines, source, unit_tolerance), a[:, 1:4])
    return a[:, 0], T, lines


def parse_kitti(text: str, source: str = "<text>",
                rotation_tolerance: Optional[float] = None) -> tuple[np.ndarray, list[int]]:
    """(T_world_cam (n, 4, 4), line numbers) of a KITTI poses file's text.

    Rotations as written; with ``rotation_tolerance`` each 3x3 part must be a rotation
    within it (max |R^T R - I|, det > 0) and is re-orthonormalised (files hold ~6 digits)."""
    a, lines = parse_table(text, (12,), source, "a KITTI pose")
    _check_magnitudes(a, lines, source)
    T = np.tile(np.eye(4), (len(a), 1, 1))
    T[:, :3, :] = a.reshape(-1, 3, 4)
    if rotation_tolerance is not None:
        R = T[:, :3, :3]
        check_rotations(R, lines, source, rotation_tolerance)
        U, _, Vt = np.linalg.svd(R)
        T[:, :3, :3] = U @ Vt
    return T, lines


def parse_euroc(text: str, source: str = "<text>") -> tuple[np.ndarray, np.ndarray, list[int]]:
    """(timestamps_s (n,), T_world_body (n, 4, 4), line numbers) of an EuRoC state csv."""
    a, lines = parse_table(text, tuple(range(8, 40)), source, "an EuRoC pose")
    _check_magnitudes(a[:, 1:8], lines, source)
    T = _poses(_quaternions_to_R(a[:, [5, 6, 7, 4]], lines, source, None), a[:, 1:4])
    return a[:, 0] * 1e-9, T, lines


def parse_times(text: str, source: str = "<text>") -> np.ndarray:
    """KITTI ``times.txt``: one value (seconds) per line."""
    return parse_table(text, (1,), source, "a timestamp")[0][:, 0]


def format_tum(timestamps_s: Sequence[float], T_world_cam: np.ndarray, comment: Optional[str] = None) -> str:
    """TUM text: a header comment, then ``t tx ty tz qx qy qz qw`` (t to the nanosecond)."""
    T = np.asarray(T_world_cam, dtype=float).reshape(-1, 4, 4)
    q = R_to_quat_xyzw(T[:, :3, :3])
    lines = [TUM_HEADER + (f"  ({comment})" if comment else "")]
    for t, p, qq in zip(timestamps_s, T[:, :3, 3], q):
        lines.append(f"{float(t):.9f} " + " ".join(f"{x:.9g}" for x in (*p, *qq)))
    return "\n".join(lines) + "\n"


def format_kitti(T_world_cam: np.ndarray) -> str:
    """KITTI text: the 3x4 top of each pose, row-major, 12 numbers per line."""
    return "".join(" ".join(f"{x:.12e}" for x in T[:3, :4].reshape(-1)) + "\n"
                   for T in np.asarray(T_world_cam, dtype=float).reshape(-1, 4, 4))


def format_times(timestamps_s: Sequence[float]) -> str:
    """KITTI ``times.txt``."""
    return "".join(f"{float(t):.6e}\n" for t in timestamps_s)


def format_euroc(t_ns: Sequence[int], T_world_body: np.ndarray, v_world: Optional[np.ndarray] = None) -> str:
    """EuRoC ground-truth csv: position, quaternion (w first), velocity (by central differences
    of the positions when not given, one-sided at the ends), biases 0."""
    T = np.asarray(T_world_body, dtype=float).reshape(-1, 4, 4)
    t = np.asarray(t_ns, dtype=np.int64)
    p = T[:, :3, 3]
    q = R_to_quat_xyzw(T[:, :3, :3])
    if v_world is None:
        v_world = np.gradient(p, t * 1e-9, axis=0) if len(p) > 1 else np.zeros_like(p)
    lines = [EUROC_HEADER]
    for ts, pp, qq, vv in zip(t, p, q, np.asarray(v_world, dtype=float)):
        vals = (*pp, qq[3], qq[0], qq[1], qq[2], *vv, *(0.0,) * 6)
        lines.append(",".join([str(int(ts))] + [f"{x:.17g}" for x in vals]))
    return "\n".join(lines) + "\n"


def format_ego_table(ego: np.ndarray) -> str:
    """One line per frame step k -> k+1: ``k U V W alpha beta gamma`` (camera frame at k, deg)."""
    lines = [EGO_HEADER]
    for k, row in enumerate(np.asarray(ego, dtype=float).reshape(-1, 6)):
        lines.append(f"{k} " + " ".join(f"{x:.12g}" for x in row))
    return "\n".join(lines) + "\n"
