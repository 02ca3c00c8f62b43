"""The SESGen paper's per-frame egomotion table (Skulimowski & Strumillo 2015, Table 1).

The frame-to-frame motion of frame k is the relative pose
    T_k_k1 = inv(T_world_k) · T_world_k1   (frame k+1's camera pose in camera k's frame),
expressed in the camera frame at k (OpenCV: x right, y down, z forward) as six numbers
(U, V, W, α, β, γ), angles in degrees. Two parametrisations (the table says which):

- ``twist`` (default): the SE(3) log of T_k_k1, (ω, v) with T_k_k1 = exp([ω, v]): the
  constant body twist over the frame interval — exactly the ``EGO U V W alpha beta gamma``
  line of an SES script (ses-spec: T(k+1) = T(k)·exp([ω, v])). (U, V, W) = v,
  (α, β, γ) = ω in degrees.
- ``rotvec``: (U, V, W) = the translation of T_k_k1 (camera k+1's origin in camera k),
  (α, β, γ) = the rotation vector (axis·angle) of its rotation, in degrees.
The two agree to first order (they differ by O(|ω|·|v|)).

RMSE per component: sqrt(mean_k (est_k − gt_k)²) over the frames (angles in degrees).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blender_sesgen.contract.motion import ego_between
from blender_sesgen.contract.se3 import relative, so3_log

from ..errors import VoError
from .poses import as_poses

COLUMNS = ("U", "V", "W", "alpha_deg", "beta_deg", "gamma_deg")
PARAMETRISATIONS = ("twist", "rotvec")


def egomotion(T_world_cam, param: str = "twist") -> np.ndarray:
    """(N−1, 6) frame-to-frame motions (U, V, W, α°, β°, γ°) of N camera poses (see module doc)."""
    if param not in PARAMETRISATIONS:
        raise VoError(f"unknown egomotion parametrisation {param!r} (twist or rotvec)")
    T = as_poses(T_world_cam)
    if T.shape[0] < 2:
        raise VoError("the egomotion table needs at least 2 poses")
    if param == "twist":
        return ego_between(T[:-1], T[1:])
    rel = relative(T[:-1], T[1:])
    return np.column_stack([rel[:, :3, 3], np.degrees(so3_log(rel[:, :3, :3]))])


@dataclass(frozen=True)
class EgomotionTable:
    """Per-frame ground-truth and estimated motions (M, 6), their difference and RMSE per column."""

    frames: np.ndarray      # (M,) index k of the motion k -> k+1
    gt: np.ndarray          # (M, 6)
    est: np.ndarray         # (M, 6)
    error: np.ndarray       # (M, 6) est − gt
    rmse: np.ndarray        # (6,)
    param: str
    columns: tuple = COLUMNS

    def as_dict(self) -> dict:
        return {"param": self.param, "columns": list(self.columns),
                "rmse": dict(zip(self.columns, self.rmse.tolist())),
                "frames": self.frames.tolist(), "gt": self.gt.tolist(), "est": self.est.tolist()}

    def to_markdown(self, max_rows: int | None = 40, digits: int = 4) -> str:
        """Table 1 style: per frame the ground truth and the estimate of each component, then RMSE."""
        names = ("U", "V", "W", "α", "β", "γ")
        head = ["frame"] + [f"{n} {s}" for n in names for s in ("gt", "est")]
        lines = [f"Egomotion per frame ({self._param_text()}; angles in degrees)", "",
                 "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        rows = range(len(self.frames)) if max_rows is None else range(min(len(self.frames), max_rows))
        for r in rows:
            cells = [f"{self.frames[r]}→{self.frames[r] + 1}"]
            for c in range(6):
                cells += [f"{self.gt[r, c]:.{digits}f}", f"{self.est[r, c]:.{digits}f}"]
            lines.append("| " + " | ".join(cells) + " |")
        if max_rows is not None and len(self.frames) > max_rows:
            lines.append("| " + " | ".join([f"… {len(self.frames) - max_rows} more"] + [""] * 12) + " |")
        cells = ["RMSE"]
        for v in self.rmse:
            cells += ["", f"{v:.{digits}f}"]
        lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n"

    def _param_text(self) -> str:
        return ("twist: (U,V,W,α,β,γ) = log of T_k_k1 = inv(T_world_k)·T_world_k1, as the SES EGO line"
                if self.param == "twist" else
                "rotvec: (U,V,W) = translation of T_k_k1, (α,β,γ) = its rotation vector")


def egomotion_table(gt, est, param: str = "twist") -> EgomotionTable:
    """Per-frame egomotion of ``gt`` and ``est`` (same length, frame-aligned) and RMSE per component."""
    G, E = as_poses(gt), as_poses(est)
    if G.shape[0] != E.shape[0]:
        raise VoError(f"ground truth has {G.shape[0]} poses, estimate {E.shape[0]}")
    g, e = egomotion(G, param), egomotion(E, param)
    err = e - g
    return EgomotionTable(np.arange(g.shape[0]), g, e, err, np.sqrt(np.mean(err**2, axis=0)), param)
