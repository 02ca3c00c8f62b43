"""The trajectory files that ``TRAJECTORY`` replays (TUM and KITTI), read strictly.

The formats are the contract's (``contract.trajectory_files``); a script's input is held to
more than a file a reader merely evaluates: TUM quaternions must be unit and a KITTI 3x3
part a rotation (both to ``TOLERANCE``). Errors are TrajectoryFileError with the 1-based
line in the file; the parser reports them at the script's ``file`` token.
"""
from __future__ import annotations

import numpy as np

from ..contract.errors import ContractError
from ..contract.inputs import MiB, read_text
from ..contract.trajectory_files import parse_kitti, parse_tum

TOLERANCE = 1e-3
MAX_TRAJECTORY_BYTES = 64 * MiB  # a regular file only (a FIFO or a device is refused)


class TrajectoryFileError(ValueError):
    pass


def read_trajectory(path: str, fmt: str) -> np.ndarray:
    """(N, 4, 4) poses T_world_cam of a TUM or KITTI file (N >= 1)."""
    try:
        text = read_text(path, MAX_TRAJECTORY_BYTES, "trajectory file")
    except ContractError as e:
        raise TrajectoryFileError(f"line {e.line}: {e.detail}" if e.line else e.detail) from None
    try:
        if fmt == "tum":
            return parse_tum(text, path, unit_tolerance=TOLERANCE)[1]
        return parse_kitti(text, path, rotation_tolerance=TOLERANCE)[0]
    except ContractError as e:
        raise TrajectoryFileError(f"line {e.line}: {e.detail}" if e.line else e.detail) from None
