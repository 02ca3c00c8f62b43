"""The ``run`` report: the paper-style egomotion RMSE table, then per method its evaluation,
the numbers that separate scale from shape errors, failed steps and plots — built here,
written by ``run`` as ``summary.md`` (Markdown) and ``report.json``."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from blender_sesgen.contract.motion import EGO_COLUMNS

# The SESGen paper, Sec. 5: RMSE of the estimated motion components over its sequence
# (distances in OpenGL units, angles in degrees).
PAPER_TABLE1_RMSE = {"U": 0.0049, "V": 0.0101, "W": 0.0062, "alpha_deg": 0.101, "beta_deg": 0.091, "gamma_deg": 0.057}
PAPER_ROW = "SESGen paper, Table 1 (OpenGL units, 40 frames)"
NAMES = ("U", "V", "W", "α (deg)", "β (deg)", "γ (deg)")


def shape_errors(gt, est) -> dict:
    """End-point drift, Sim3-aligned position RMSE and mean step-length ratio (est / gt): the
    three numbers that separate scale from shape errors (docs/stereo-vo.md)."""
    from ..evaluate.align import align
    L = max(gt.path_length(), 1e-12)
    drift = float(np.linalg.norm(est.positions[-1] - gt.positions[-1]))
    out = {"path_length": gt.path_length(), "end_point_drift": drift, "end_point_drift_pct": 100 * drift / L}
    if len(gt) >= 3:
        sim3, _ = align(est, gt, "sim3")
        rmse = float(np.sqrt(np.mean(np.sum((sim3.positions - gt.positions) ** 2, axis=1))))
        out.update(sim3_position_rmse=rmse, sim3_position_rmse_pct=100 * rmse / L)
    steps_gt = np.linalg.norm(np.diff(gt.positions, axis=0), axis=1)
    moving = steps_gt > 1e-9
    if moving.any():
        steps_est = np.linalg.norm(np.diff(est.positions, axis=0), axis=1)
        out["step_length_ratio"] = float(np.mean(steps_est[moving] / steps_gt[moving]))
    return out


def shape_line(shape: dict) -> str:
    """One sentence of :func:`shape_errors`."""
    line = (f"End-point drift {shape['end_point_drift']:.4f} ({shape['end_point_drift_pct']:.2f} % of the "
            f"{shape['path_length']:.3f} path)")
    if "sim3_position_rmse" in shape:
        line += f"; Sim3-aligned position RMSE {shape['sim3_position_rmse']:.4f} ({shape['sim3_position_rmse_pct']:.3f} %)"
    if "step_length_ratio" in shape:
        line += f"; step length est/gt {shape['step_length_ratio']:.4f}"
    return line


def rmse_table_markdown(rows: dict[str, dict]) -> str:
    """Markdown table: one row per source, RMSE of U V W α β γ."""
    lines = ["| | " + " | ".join(NAMES) + " |", "|---|" + "---|" * 6]
    for name, r in rows.items():
        lines.append(f"| {name} | " + " | ".join(f"{r[c]:.5f}" if r.get(c) is not None else "–" for c in EGO_COLUMNS)
                     + " |")
    return "\n".join(lines) + "\n"


@dataclass
class RunReport:
    """What ``run`` found, method by method; :meth:`markdown` and :meth:`as_json` render it."""
    root: Path
    frames: tuple[int, int]
    K: np.ndarray
    baseline_m: float
    resolution: tuple[int, int]
    gt_depth: bool = False
    gt_flow: bool = False
    plots: bool = True
    rmse_rows: dict = field(default_factory=lambda: {PAPER_ROW: dict(PAPER_TABLE1_RMSE)})
    methods: dict = field(default_factory=dict)
    sections: list = field(default_factory=list)

    def add_method(self, name: str, label: str, ev, shape: dict, res, summary: list[str], files: dict,
                   failed_line: str | None) -> None:
        """One method's results: its evaluation ``ev``, ``shape_errors``, the VO result ``res``."""
        rmse = dict(zip(EGO_COLUMNS, ev.egomotion.rmse.tolist()))
        self.rmse_rows[f"{label} (ours)"] = rmse
        self.methods[name] = {"egomotion_rmse": rmse, "ape_trans_rmse": ev.ape.trans.rmse,
                              "ape_rot_rmse_deg": ev.ape.rot_deg.rmse, "rpe_trans_rmse": ev.rpe.trans.rmse,
                              "rpe_rot_rmse_deg": ev.rpe.rot_deg.rmse, **shape, "fps": res.fps,
                              "failed_steps": [[k, why] for k, why in res.failed],
                              "report": {k: str(v) for k, v in files.items()}}
        self.sections += [f"## {label}", "", "```", *summary, "```", "",
                          f"{shape_line(shape)}; {res.fps:.1f} frames/s; details: [{name}/summary.md]({name}/summary.md)",
                          ""]
        if failed_line:
            self.sections += [f"**{failed_line}**", ""]
        if self.plots:
            self.sections += [f"![{name} trajectory]({name}/trajectories.png) ![{name} egomotion]({name}/egomotion.png)",
                              ""]

    def markdown(self) -> str:
        W, H = self.resolution
        lines = [f"# Stereo VO report: {self.root.name}", "",
                 f"Sequence `{self.root}`, frames {self.frames[0]}..{self.frames[1]}, left camera; "
                 f"K f = {self.K[0, 0]:g} px, baseline {self.baseline_m:g}, {W}x{H}.", "",
                 "## Per-frame egomotion RMSE (the SESGen paper's Table 1 measure)", "",
                 "RMSE over frames of the estimated minus true frame-to-frame motion (U V W: scene units per frame; "
                 "α β γ: degrees per frame), ours beside the values the paper reports for its own scene.", "",
                 rmse_table_markdown(self.rmse_rows), *self.sections]
        return "\n".join(lines)

    def as_json(self) -> dict:
        return {"input": str(self.root), "frames": list(self.frames), "gt_depth": self.gt_depth,
                "gt_flow": self.gt_flow, "paper_table1_rmse": PAPER_TABLE1_RMSE, "methods": self.methods}
