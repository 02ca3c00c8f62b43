"""One call for the whole trajectory evaluation: associate → align → APE, RPE, KITTI, egomotion."""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

from ..errors import VoError
from ..io.trajectory import Trajectory
from .align import Alignment, align as align_trajectory, fixes_rotation
from .ape import APEResult, ape
from .associate import associate, needs_association
from .egomotion import EgomotionTable, egomotion_table
from .kitti import KittiResult, kitti_metric
from .rpe import RPEResult, rpe


@dataclass(frozen=True)
class TrajectoryEvaluation:
    """Everything measured; ``gt``/``est`` are the associated pairs, ``est_aligned`` after alignment."""

    gt: Trajectory
    est: Trajectory
    est_aligned: Trajectory
    alignment: Alignment
    ape: APEResult
    rpe: RPEResult
    kitti: Optional[KittiResult] = None
    egomotion: Optional[EgomotionTable] = None
    n_gt_input: int = 0
    n_est_input: int = 0

    def metrics(self) -> dict:
        """Flat JSON-ready dict: the headline keys first, then the full statistics."""
        m = {
            "ape_trans_rmse": self.ape.trans.rmse,
            "ape_rot_rmse_deg": self.ape.rot_deg.rmse,
            "rpe_trans_rmse": self.rpe.trans.rmse,
            "rpe_rot_rmse_deg": self.rpe.rot_deg.rmse,
            # se3/sim3: the fit leaves its rotation free (summary_lines' note): ape_rot_rmse_deg measures the fit
            "alignment_ill_posed": not fixes_rotation(self.alignment, self.ape.rot_deg.rmse),
        }
        if self.kitti is not None:
            m["kitti_t_err_pct"] = self.kitti.t_err_pct
            m["kitti_r_err_deg_per_100m"] = self.kitti.r_err_deg_per_100m
        if self.alignment.method in ("sim3", "scale"):
            m["scale"] = self.alignment.scale
        m.update({
            "n_poses": len(self.gt), "n_gt_input": self.n_gt_input, "n_est_input": self.n_est_input,
            "gt_path_length_m": self.gt.path_length(),
            "alignment": self.alignment.as_dict(),
            "ape": self.ape.as_dict(),
            "rpe": self.rpe.as_dict(),
        })
        if self.kitti is not None:
            m["kitti"] = self.kitti.as_dict()
        if self.egomotion is not None:
            m["egomotion"] = self.egomotion.as_dict()
        return m


@dataclass(frozen=True)
class EvaluationOptions:
    """How :func:`evaluate_trajectory` pairs, aligns and measures (defaults as evo's).

    Poses are associated by timestamp (``max_diff_s`` after shifting the estimate by
    ``offset_s``, as evo) unless both already pair up one-to-one (same timestamps) or
    ``by_index`` (pose k with pose k; needs equal lengths — for files without timestamps such
    as KITTI's). ``align``: none|origin|se3|sim3|scale, on the first ``n_align`` poses (-1 =
    all). RPE: pairs ``delta`` apart in ``delta_unit`` (f frames, m metres), consecutive or
    ``all_pairs``. ``kitti``: the KITTI devkit metric (``kitti_frame_period_s`` between
    frames). ``egomotion``: the SESGen paper's per-frame table (``ego_param``: twist|rotvec).
    """
    align: str = "se3"
    n_align: int = -1
    delta: float = 1
    delta_unit: str = "f"
    all_pairs: bool = False
    kitti: bool = False
    egomotion: bool = False
    max_diff_s: float = 0.01
    offset_s: float = 0.0
    kitti_frame_period_s: float = 0.1
    ego_param: str = "twist"
    by_index: bool = False


def evaluate_trajectory(gt: Trajectory, est: Trajectory, options: Optional[EvaluationOptions] = None,
                        **overrides) -> TrajectoryEvaluation:
    """Evaluate ``est`` against ``gt`` with ``options`` (fields may also be given as keywords).

    APE and RPE use the aligned estimate (as evo); the KITTI metric uses the *unaligned*
    associated estimate (as the devkit, which needs a common first frame) unless ``align`` is
    ``sim3``/``scale``, where the scale is applied; the egomotion table uses the aligned one.
    """
    o = replace(options or EvaluationOptions(), **overrides)
    n_gt, n_est = len(gt), len(est)
    if o.by_index:
        if n_gt != n_est:
            raise VoError(f"cannot pair poses by index: ground truth has {n_gt} poses, estimate {n_est} "
                          "(give timestamps, e.g. TUM format)")
        est = Trajectory(est.T_world_cam, gt.timestamps_s)
    elif needs_association(gt, est):
        gt, est = associate(gt, est, o.max_diff_s, o.offset_s)
    if len(gt) < 2:
        raise VoError(f"only {len(gt)} associated pose(s): nothing to evaluate")
    est_aligned, alignment = align_trajectory(est, gt, o.align, o.n_align)
    k = None
    if o.kitti:
        est_k = est
        if alignment.method in ("sim3", "scale"):
            T = est.T_world_cam.copy()
            T[:, :3, 3] *= alignment.scale
            est_k = Trajectory(T, est.timestamps_s)
        k = kitti_metric(gt, est_k, frame_period_s=o.kitti_frame_period_s)
    return TrajectoryEvaluation(
        gt=gt, est=est, est_aligned=est_aligned, alignment=alignment,
        ape=ape(gt, est_aligned),
        rpe=rpe(gt, est_aligned, o.delta, o.delta_unit, o.all_pairs),
        kitti=k,
        egomotion=egomotion_table(gt, est_aligned, o.ego_param) if o.egomotion else None,
        n_gt_input=n_gt, n_est_input=n_est)


def summary_lines(ev: TrajectoryEvaluation) -> list[str]:
    """A short human-readable table of the headline numbers."""
    a, r = ev.ape, ev.rpe
    unit = "frames" if r.delta_unit == "f" else "m"
    al = ev.alignment
    fitted = al.method in ("se3", "sim3")
    rows = [
        f"poses: {len(ev.gt)} associated (gt {ev.n_gt_input}, est {ev.n_est_input}); "
        f"gt path {ev.gt.path_length():.3f} m; alignment {al.method}"
        + (f", scale {al.scale:.6f}" if al.method in ("sim3", "scale") else "")
        + (f", its rotation fixed to ±{al.rotation_sigma_deg:.2g}°" if fitted else ""),
        "",
        f"{'metric':<28}{'rmse':>12}{'mean':>12}{'median':>12}{'std':>12}{'min':>12}{'max':>12}",
    ]

    def row(name, s):
        rows.append(f"{name:<28}{s.rmse:>12.6f}{s.mean:>12.6f}{s.median:>12.6f}{s.std:>12.6f}{s.min:>12.6f}{s.max:>12.6f}")

    row("APE translation (m)", a.trans)
    row("APE rotation (deg)", a.rot_deg)
    pairs = "all pairs" if r.all_pairs else "consecutive"
    row(f"RPE trans (m) d={r.delta:g}{unit[0]}", r.trans)
    row(f"RPE rot (deg) d={r.delta:g}{unit[0]}", r.rot_deg)
    rows.append(f"(RPE: delta {r.delta:g} {unit}, {pairs}, {len(r.pairs)} pairs)")
    if not fixes_rotation(al, a.rot_deg.rmse):
        rows.append(f"note: on this short or nearly straight path the {al.method} fit fixes its rotation only to "
                    f"±{al.rotation_sigma_deg:.2g}°, about the APE rotation it yields: that figure measures the fit, "
                    "not the estimate (--align origin compares from a common first pose)")
    if ev.kitti is not None:
        rows += ["", f"KITTI odometry: t_err {ev.kitti.t_err_pct:.4f} %   r_err "
                     f"{ev.kitti.r_err_deg_per_100m:.4f} deg/100 m   ({ev.kitti.n_segments} segments)"]
    if ev.egomotion is not None:
        e = ev.egomotion
        rows += ["", f"egomotion RMSE ({e.param}): " + "  ".join(
            f"{c}={v:.5f}" for c, v in zip(("U", "V", "W", "α°", "β°", "γ°"), e.rmse))]
    return rows
