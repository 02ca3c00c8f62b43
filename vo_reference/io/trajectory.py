"""Trajectory files: TUM, KITTI, EuRoC (the one home of these formats).

A :class:`Trajectory` is a stack of poses ``T_world_cam`` (N, 4, 4) with timestamps in
seconds. Formats:
- TUM: ``timestamp tx ty tz qx qy qz qw`` (quaternion scalar last), '#' comments.
- KITTI: 12 numbers per line, the first 3 rows of T row-major; no timestamps in the
  file (optionally a separate ``times.txt``, one second value per line).
- EuRoC csv: ``#timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z, ...`` (scalar first).
- sesgen render: a render folder (or its ``manifest.json``, format ``sesgen-render/1``) whose
  ``poses`` key holds ``{"left": [4x4 per frame], "right": [...]}``; optional ``timestamps``
  (a list, or one list per view) or ``fps``; otherwise the frame index is the timestamp.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import json

import numpy as np

from ..errors import VoError
from ..lie import R_to_quat_xyzw, quat_xyzw_to_R

__all__ = ["Trajectory", "read_tum", "read_kitti", "read_euroc", "write_tum", "write_kitti", "write_euroc",
           "read_render_poses", "read_trajectory", "guess_format"]


@dataclass(frozen=True)
class Trajectory:
    T_world_cam: np.ndarray   # (N, 4, 4)
    timestamps_s: np.ndarray  # (N,)

    def __post_init__(self):
        T = np.asarray(self.T_world_cam, dtype=float)
        t = np.asarray(self.timestamps_s, dtype=float)
        if T.ndim != 3 or T.shape[1:] != (4, 4) or t.shape != (T.shape[0],):
            raise VoError(f"trajectory needs (N,4,4) poses and N timestamps, got {T.shape} and {t.shape}")
        object.__setattr__(self, "T_world_cam", T)
        object.__setattr__(self, "timestamps_s", t)

    def __len__(self) -> int:
        return self.T_world_cam.shape[0]

    @property
    def positions(self) -> np.ndarray:
        return self.T_world_cam[:, :3, 3]

    def path_length(self) -> float:
        return float(np.linalg.norm(np.diff(self.positions, axis=0), axis=1).sum())

    @classmethod
    def from_poses(cls, T_world_cam: np.ndarray, timestamps_s: Optional[np.ndarray] = None) -> "Trajectory":
        T = np.asarray(T_world_cam, dtype=float)
        ts = np.arange(T.shape[0], dtype=float) if timestamps_s is None else timestamps_s
        return cls(T, ts)


def _load_table(path: Path, ncols: tuple[int, ...], delimiter=None) -> np.ndarray:
    path = Path(path)
    if not path.is_file():
        raise VoError(f"{path}: no such trajectory file")
    rows = []
    with open(path, encoding="utf-8", errors="replace") as f:
        for lineno, line in enumerate(f, 1):
            s = line.strip()
            if not s or s.startswith("#") or (s[0].isalpha()):
                continue
            parts = s.replace(",", " ").split() if delimiter is None else s.split(delimiter)
            try:
                vals = [float(p) for p in parts]
            except ValueError:
                raise VoError(f"{path}:{lineno}: expected numbers, got {s[:60]!r}") from None
            if len(vals) not in ncols:
                raise VoError(f"{path}:{lineno}: expected {' or '.join(map(str, ncols))} values, got {len(vals)}")
            if not np.all(np.isfinite(vals)):
                raise VoError(f"{path}:{lineno}: non-finite value")
            rows.append(vals)
    if not rows:
        raise VoError(f"{path}: no poses in file")
    return np.array(rows)


def read_tum(path) -> Trajectory:
    a = _load_table(path, (8,))
    T = np.tile(np.eye(4), (len(a), 1, 1))
    T[:, :3, :3] = quat_xyzw_to_R(a[:, 4:8])
    T[:, :3, 3] = a[:, 1:4]
    return Trajectory(T, a[:, 0])


def read_kitti(path, times_path=None) -> Trajectory:
    a = _load_table(path, (12,))
    T = np.tile(np.eye(4), (len(a), 1, 1))
    T[:, :3, :] = a.reshape(-1, 3, 4)
    if times_path is not None:
        ts = _load_table(times_path, (1,))[:, 0]
        if len(ts) != len(a):
            raise VoError(f"{times_path}: {len(ts)} timestamps for {len(a)} poses")
    else:
        ts = np.arange(len(a), dtype=float)
    return Trajectory(T, ts)


def read_euroc(path) -> Trajectory:
    a = _load_table(path, tuple(range(8, 40)))
    T = np.tile(np.eye(4), (len(a), 1, 1))
    T[:, :3, :3] = quat_xyzw_to_R(a[:, [5, 6, 7, 4]])
    T[:, :3, 3] = a[:, 1:4]
    return Trajectory(T, a[:, 0] * 1e-9)


def write_tum(path, traj: Trajectory) -> None:
    q = R_to_quat_xyzw(traj.T_world_cam[:, :3, :3])
    a = np.column_stack([traj.timestamps_s, traj.positions, q])
    _write_atomic(path, "\n".join(" ".join(f"{x:.9g}" if i else f"{x:.6f}" for i, x in enumerate(r)) for r in a) + "\n")


def write_kitti(path, traj_or_poses) -> None:
    T = traj_or_poses.T_world_cam if isinstance(traj_or_poses, Trajectory) else np.asarray(traj_or_poses)
    _write_atomic(path, "\n".join(" ".join(f"{x:.9e}" for x in row[:3, :].ravel()) for row in T) + "\n")


def write_euroc(path, traj: Trajectory) -> None:
    q = R_to_quat_xyzw(traj.T_world_cam[:, :3, :3])
    lines = ["#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []"]
    for ts, p, qq in zip(traj.timestamps_s, traj.positions, q):
        lines.append(",".join([str(int(round(ts * 1e9)))] + [f"{x:.9g}" for x in (*p, qq[3], qq[0], qq[1], qq[2])]))
    _write_atomic(path, "\n".join(lines) + "\n")


def _write_atomic(path, text: str) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)


def read_render_poses(render_dir_or_manifest, view: str = "left") -> Trajectory:
    """Ground-truth poses of one view of a sesgen render (``T_world_cam``, OpenCV camera).

    ``render_dir_or_manifest`` is the render folder or its ``manifest.json``. Timestamps come
    from the manifest's ``timestamps`` key (a list, or ``{view: list}``), else from ``fps``
    (frame k at k / fps), else they are the frame indices 0, 1, 2, ...
    """
    path = Path(render_dir_or_manifest)
    if path.is_dir():
        path = path / "manifest.json"
    if not path.is_file():
        raise VoError(f"{path}: no render manifest (expected a render folder or its manifest.json)")
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise VoError(f"{path}: not a readable JSON manifest ({e})") from None
    fmt = str(manifest.get("format", "")) if isinstance(manifest, dict) else ""
    if not fmt.startswith("sesgen-render/"):
        raise VoError(f"{path}: not a sesgen render manifest (format {fmt or 'missing'!r})")
    poses = manifest.get("poses")
    if not isinstance(poses, dict) or view not in poses:
        have = sorted(poses) if isinstance(poses, dict) else []
        raise VoError(f"{path}: no poses for view {view!r} (have {have})")
    try:
        T_rows = np.asarray(poses[view], dtype=float)
    except (TypeError, ValueError):
        raise VoError(f"{path}: poses[{view!r}] is not a list of 4x4 matrices") from None
    n = T_rows.shape[0] if T_rows.ndim >= 1 else 0
    if n == 0:
        raise VoError(f"{path}: poses[{view!r}] is empty")
    T = np.tile(np.eye(4), (n, 1, 1))
    if T_rows.shape[1:] in ((4, 4), (3, 4)):
        T[:, : T_rows.shape[1], :] = T_rows
    elif T_rows.shape[1:] in ((16,), (12,)):
        T[:, :3, :] = T_rows[:, :12].reshape(n, 3, 4)
    else:
        raise VoError(f"{path}: poses[{view!r}] has shape {T_rows.shape}, expected (N, 4, 4)")
    if not np.all(np.isfinite(T)):
        raise VoError(f"{path}: poses[{view!r}] holds non-finite values")
    ts = manifest.get("timestamps")
    if isinstance(ts, dict):
        ts = ts.get(view)
    if ts is not None:
        ts = np.asarray(ts, dtype=float)
        if ts.shape != (n,):
            raise VoError(f"{path}: {ts.size} timestamps for {n} poses")
    elif manifest.get("fps"):
        ts = np.arange(n, dtype=float) / float(manifest["fps"])
    else:
        ts = np.arange(n, dtype=float)
    return Trajectory(T, ts)


def read_trajectory(path, fmt: str = "auto", times_path=None, view: str = "left") -> Trajectory:
    """Read a trajectory, guessing the format from the content when ``fmt='auto'``.

    ``fmt``: ``tum``, ``kitti`` (``times_path``: optional KITTI ``times.txt``), ``euroc``,
    ``sesgen`` (a render folder or manifest; ``view`` picks the camera) or ``auto``.
    """
    path = Path(path)
    if fmt == "auto":
        fmt = guess_format(path)
    readers = {"tum": read_tum, "euroc": read_euroc}
    if fmt == "kitti":
        return read_kitti(path, times_path)
    if fmt == "sesgen":
        return read_render_poses(path, view)
    if fmt not in readers:
        raise VoError(f"unknown trajectory format {fmt!r} (tum, kitti, euroc, sesgen)")
    return readers[fmt](path)


def guess_format(path: Path) -> str:
    path = Path(path)
    if path.is_dir() or path.name == "manifest.json":
        return "sesgen"
    if not path.is_file():
        raise VoError(f"{path}: no such trajectory file")
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            n = len(s.replace(",", " ").split())
            if "," in s and n >= 8:
                return "euroc"
            if n == 12:
                return "kitti"
            if n == 8:
                return "tum"
            break
    raise VoError(f"{path}: cannot tell the trajectory format (use --format tum|kitti|euroc)")
