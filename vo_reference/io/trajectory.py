"""Trajectories and their files: TUM, KITTI, EuRoC and sesgen renders.

A :class:`Trajectory` is a stack of poses ``T_world_cam`` (N, 4, 4) with timestamps in
seconds. The file formats themselves (parsing, formatting) are the contract's
(``blender_sesgen.contract.trajectory_files``): this module reads and writes files with
them. KITTI files carry no timestamps (optionally a separate ``times.txt``); a sesgen render
(its folder or ``manifest.json``) gives each view's poses and timestamps.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.errors import ContractError
from blender_sesgen.contract.inputs import read_text
from blender_sesgen.contract.manifest import MANIFEST, Manifest
from blender_sesgen.contract.trajectory_files import (check_rotations, format_euroc, format_kitti, format_tum,
                                                      parse_euroc, parse_kitti, parse_times, parse_tum)

from ..errors import VoError, as_vo_error

__all__ = ["Trajectory", "read_tum", "read_kitti", "read_euroc", "write_tum", "write_kitti", "write_euroc",
           "read_render_poses", "read_trajectory", "guess_format", "read_times"]

ROTATION_TOLERANCE = 1e-3  # max |R^T R - I| of a KITTI row: files hold 6+ digits; beyond, it is not a pose


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


def _text(path: Path) -> str:
    """The text of a trajectory file: a regular file of bounded size (contract.inputs)."""
    path = Path(path)
    if not path.exists():
        raise VoError(f"{path}: no such trajectory file")
    with as_vo_error():
        return read_text(path, what="trajectory file", strict=False)


def read_tum(path) -> Trajectory:
    with as_vo_error():
        t, T, _ = parse_tum(_text(path), str(path))
    return Trajectory(T, t)


def read_kitti(path, times_path=None) -> Trajectory:
    """A KITTI poses file (its 3x3 parts must be rotations to ``ROTATION_TOLERANCE``; they
    are used as written), optionally with its ``times.txt``."""
    with as_vo_error():
        T, lines = parse_kitti(_text(path), str(path))
        check_rotations(T[:, :3, :3], lines, str(path), ROTATION_TOLERANCE)
    if times_path is not None:
        ts = read_times(times_path)
        if len(ts) != len(T):
            raise VoError(f"{times_path}: {len(ts)} timestamps for {len(T)} poses")
    else:
        ts = np.arange(len(T), dtype=float)
    return Trajectory(T, ts)


def read_times(path) -> np.ndarray:
    """KITTI ``times.txt``: one finite number (seconds) per line, non-decreasing."""
    with as_vo_error():
        t = parse_times(_text(path), str(path))
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        raise VoError(f"{path}: times go backwards after value {back[0] + 1} ({t[back[0]]:g} -> {t[back[0] + 1]:g})")
    return t


def read_euroc(path) -> Trajectory:
    with as_vo_error():
        t, T, _ = parse_euroc(_text(path), str(path))
    return Trajectory(T, t)


def write_tum(path, traj: Trajectory) -> None:
    atomic.write_text(path, format_tum(traj.timestamps_s, traj.T_world_cam))


def write_kitti(path, traj_or_poses) -> None:
    T = traj_or_poses.T_world_cam if isinstance(traj_or_poses, Trajectory) else np.asarray(traj_or_poses)
    atomic.write_text(path, format_kitti(T))


def write_euroc(path, traj: Trajectory) -> None:
    atomic.write_text(path, format_euroc(np.rint(traj.timestamps_s * 1e9).astype(np.int64), traj.T_world_cam))


def read_render_poses(render_dir_or_manifest, view: str = "left") -> Trajectory:
    """Ground-truth poses of one view of a sesgen render (``T_world_cam``, OpenCV camera),
    timestamped as its manifest says. ``render_dir_or_manifest``: the folder or its manifest."""
    path = Path(render_dir_or_manifest)
    root = path.parent if path.name == MANIFEST else path
    if not (root / MANIFEST).exists():
        raise VoError(f"{root / MANIFEST}: no render manifest (expected a render folder or its manifest.json)")
    try:
        m = Manifest.read(root)
    except ContractError as e:  # a defect at a line is reported there; otherwise say what the file is not
        raise VoError(str(e) if e.line else f"{root / MANIFEST}: not a sesgen render ({e.detail})") from None
    if view not in m.views:
        raise VoError(f"{root / MANIFEST}: no poses for view {view!r} (have {list(m.views)})")
    return Trajectory(m.poses[view], m.timestamps_s)


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
    for line in _text(path).split("\n"):
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
