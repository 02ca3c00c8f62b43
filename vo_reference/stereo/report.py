"""The ``run`` report: the paper-style egomotion RMSE table, then per method its evaluation,
the numbers that separate scale from shape errors, failed steps and plots — built here,
written by ``run`` as ``summary.md`` (Markdown) and ``report.json``. With moving objects
it also gives the share of the image on them and each method's error without and with the
ground-truth motion mask."""
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


def dynamic_summary(res) -> dict | None:
    """Share of the image on moving objects (mean/max over steps) and of the points the
    method kept on them (None for a sequence without object ids)."""
    if res.dynamic_share is None:
        return None
    return {"image_share_mean": float(np.mean(res.dynamic_share)), "image_share_max": float(np.max(res.dynamic_share)),
            "points_on_movers_mean": float(np.mean(res.dynamic_points)),
            "points_on_movers_max": float(np.max(res.dynamic_points))}


def error_summary(ev, shape: dict, res) -> dict:
    """The numbers the without/with motion mask comparison shows for one run."""
    return {"ape_trans_rmse": ev.ape.trans.rmse, "ape_rot_rmse_deg": ev.ape.rot_deg.rmse,
            "rpe_trans_rmse": ev.rpe.trans.rmse, "rpe_rot_rmse_deg": ev.rpe.rot_deg.rmse,
            "egomotion_rmse": dict(zip(EGO_COLUMNS, ev.egomotion.rmse.tolist())),
            "end_point_drift": shape["end_point_drift"], "dynamic": dynamic_summary(res),
            "failed_steps": len(res.failed)}


def mask_comparison_markdown(rows: dict[str, dict[str, dict]]) -> str:
    """Per method: the error without and with the ground-truth motion mask."""
    lines = ["| method | motion mask | APE trans RMSE | RPE trans RMSE | RPE rot RMSE (deg) | W RMSE | β RMSE (deg) "
             "| kept points on movers (mean / max) |", "|---|---|---|---|---|---|---|---|"]
    for m, by in rows.items():
        for label in ("without", "with"):
            e = by[label]
            d = e["dynamic"] or {}
            lines.append(f"| {m} | {label} | {e['ape_trans_rmse']:.5f} | {e['rpe_trans_rmse']:.5f} | "
                         f"{e['rpe_rot_rmse_deg']:.4f} | {e['egomotion_rmse']['W']:.5f} | "
                         f"{e['egomotion_rmse']['beta_deg']:.4f} | "
                         f"{100 * d.get('points_on_movers_mean', float('nan')):.1f} % / "
                         f"{100 * d.get('points_on_movers_max', float('nan')):.1f} % |")
    return "\n".join(lines) + "\n"


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
    mask_dynamic_gt: bool = False
    plots: bool = True
    rmse_rows: dict = field(default_factory=lambda: {PAPER_ROW: dict(PAPER_TABLE1_RMSE)})
    methods: dict = field(default_factory=dict)
    sections: list = field(default_factory=list)
    mask_rows: dict = field(default_factory=dict)   # method -> {"without": ..., "with": ...} (moving objects)

    def add_method(self, name: str, label: str, ev, shape: dict, res, summary: list[str], files: dict,
                   failed_line: str | None) -> None:
        """One method's results: its evaluation ``ev``, ``shape_errors``, the VO result ``res``."""
        rmse = dict(zip(EGO_COLUMNS, ev.egomotion.rmse.tolist()))
        self.rmse_rows[f"{label} (ours)"] = rmse
        self.methods[name] = {"egomotion_rmse": rmse, "ape_trans_rmse": ev.ape.trans.rmse,
                              "ape_rot_rmse_deg": ev.ape.rot_deg.rmse, "rpe_trans_rmse": ev.rpe.trans.rmse,
                              "rpe_rot_rmse_deg": ev.rpe.rot_deg.rmse, **shape, "fps": res.fps,
                              "failed_steps": [[k, why] for k, why in res.failed],
                              "dynamic": dynamic_summary(res),
                              "report": {k: str(v) for k, v in files.items()}}
        self.sections += [f"## {label}", "", "```", *summary, "```", "",
                          f"{shape_line(shape)}; {res.fps:.1f} frames/s; details: [{name}/summary.md]({name}/summary.md)",
                          ""]
        if failed_line:
            self.sections += [f"**{failed_line}**", ""]
        if self.plots:
            self.sections += [f"![{name} trajectory]({name}/trajectories.png) ![{name} egomotion]({name}/egomotion.png)",
                              ""]

    def add_mask_comparison(self, name: str, without: dict, with_mask: dict) -> None:
        """One method's :func:`error_summary` without and with the ground-truth motion mask."""
        self.mask_rows[name] = {"without": without, "with": with_mask}
        self.methods[name]["motion_mask_comparison"] = self.mask_rows[name]

    def _dynamic_lines(self) -> list[str]:
        if not self.mask_rows:
            return []
        d = next(iter(self.mask_rows.values()))["without"]["dynamic"] or {}
        return ["## Moving objects", "",
                f"Share of the image on objects that move in a step: mean "
                f"{100 * d.get('image_share_mean', float('nan')):.1f} %, max "
                f"{100 * d.get('image_share_max', float('nan')):.1f} %. Each method without and with the "
                "ground-truth motion mask (keypoints on moving objects dropped before estimation); the last "
                "column is the share of the points a method kept (its inliers) that lie on moving objects.", "",
                mask_comparison_markdown(self.mask_rows)]

    def markdown(self) -> str:
        W, H = self.resolution
        lines = [f"# Stereo VO report: {self.root.name}", "",
                 f"Sequence `{self.root}`, frames {self.frames[0]}..{self.frames[1]}, left camera; "
                 f"K f = {self.K[0, 0]:g} px, baseline {self.baseline_m:g}, {W}x{H}.", "",
                 "## Per-frame egomotion RMSE (the SESGen paper's Table 1 measure)", "",
                 "RMSE over frames of the estimated minus true frame-to-frame motion (U V W: scene units per frame; "
                 "α β γ: degrees per frame), ours beside the values the paper reports for its own scene.", "",
                 rmse_table_markdown(self.rmse_rows), *self._dynamic_lines(), *self.sections]
        return "\n".join(lines)

    def as_json(self) -> dict:
        out = {"input": str(self.root), "frames": list(self.frames), "gt_depth": self.gt_depth,
               "gt_flow": self.gt_flow, "mask_dynamic_gt": self.mask_dynamic_gt,
               "paper_table1_rmse": PAPER_TABLE1_RMSE, "methods": self.methods}
        if self.mask_rows:
            d = next(iter(self.mask_rows.values()))["without"]["dynamic"] or {}
            out["dynamic_image_share"] = {"mean": d.get("image_share_mean"), "max": d.get("image_share_max")}
        return out
