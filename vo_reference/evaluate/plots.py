"""PNG plots of evaluation results (matplotlib, Agg backend; imported only when plotting).

Each function takes plain results (Trajectory, arrays, result dataclasses), writes one PNG
and returns its path.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.trajectory import Trajectory

AXES = "xyz"


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend (matplotlib is imported on first use)."""
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    return plt


def save_figure(fig, path, dpi: int = 120) -> Path:
    """Write ``fig`` as PNG (creating the folder) and close it; shared by the mono plots."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    pyplot().close(fig)
    return path


def view_axes(positions: np.ndarray) -> tuple[tuple[int, int], tuple[int, int]]:
    """Two pairs of axis indices: the two axes of largest extent, and the largest together with
    the smallest (for a camera moving over a ground plane: the ground plane, then the height)."""
    order = np.argsort(-np.ptp(positions, axis=0), kind="stable")
    return (int(order[0]), int(order[1])), (int(order[0]), int(order[2]))


def plot_trajectories(gt: Trajectory, est: Trajectory, path, title: str = "",
                      labels=("ground truth", "estimate")) -> Path:
    """Ground truth vs estimate in two planes side by side (cf. SESGen paper, Fig. 8): the plane
    of the path's two largest extents, and the largest with the smallest. Each panel is titled
    by the axes it shows -- which of them is up depends on the data's world (SES: y; KITTI's
    camera world: -y; TUM: z)."""
    plt = pyplot()
    g, e = gt.positions, est.positions
    first, second = view_axes(g)
    fig, axs = plt.subplots(1, 2, figsize=(12, 5.5))
    for ax, (i, j), note in ((axs[0], first, " (the largest extents)"), (axs[1], second, "")):
        ax.plot(g[:, i], g[:, j], "-", color="tab:green", lw=1.5, label=labels[0])
        ax.plot(e[:, i], e[:, j], "-", color="tab:red", lw=1.0, label=labels[1])
        ax.plot(g[0, i], g[0, j], "ko", ms=4, label="start")
        ax.set_xlabel(f"{AXES[i]} (m)")
        ax.set_ylabel(f"{AXES[j]} (m)")
        ax.set_title(f"{AXES[i]}–{AXES[j]} plane{note}")
        if ax is axs[0]:  # the second keeps free scales so small extents (height) stay visible
            ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
    axs[0].legend(loc="best")
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)


def plot_errors(errors: dict, path, x=None, xlabel: str = "frame", title: str = "") -> Path:
    """One panel per named error series, e.g. ``{"APE translation (m)": e_t, "APE rotation (deg)": e_r}``."""
    plt = pyplot()
    fig, axs = plt.subplots(len(errors), 1, figsize=(10, 2.6 * len(errors)), sharex=True, squeeze=False)
    for ax, (name, e) in zip(axs[:, 0], errors.items()):
        e = np.asarray(e, dtype=float)
        xs = np.arange(e.size) if x is None else np.asarray(x)
        ax.plot(xs, e, lw=0.8)
        rmse = float(np.sqrt(np.mean(e**2))) if e.size else float("nan")
        ax.axhline(rmse, color="tab:orange", ls="--", lw=0.8, label=f"rmse {rmse:.4g}")
        ax.set_ylabel(name)
        ax.legend(loc="upper right")
        ax.grid(True, alpha=0.3)
    axs[-1, 0].set_xlabel(xlabel)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)


def plot_kitti_errors(kitti, path, title: str = "") -> Path:
    """The devkit's four curves: t_err and r_err vs segment length and vs speed."""
    plt = pyplot()
    fig, axs = plt.subplots(2, 2, figsize=(11, 7.5))
    for col, (curve, key, xlabel) in enumerate(((kitti.by_length, "length_m", "path length (m)"),
                                               (kitti.by_speed, "speed_mps", "speed (km/h)"))):
        x = np.asarray(curve[key], dtype=float) * (3.6 if key == "speed_mps" else 1.0)
        for row, (ykey, ylabel) in enumerate((("t_err_pct", "translation error (%)"),
                                              ("r_err_deg_per_100m", "rotation error (deg/100 m)"))):
            ax = axs[row, col]
            ax.plot(x, curve[ykey], "o-", color="tab:blue")
            ax.set_xlabel(xlabel)
            ax.set_ylabel(ylabel)
            ax.set_ylim(bottom=0)
            ax.grid(True, alpha=0.3)
    fig.suptitle(title or f"KITTI odometry: t_err {kitti.t_err_pct:.4f} %, "
                          f"r_err {kitti.r_err_deg_per_100m:.4f} deg/100 m")
    return save_figure(fig, path)


def plot_egomotion(table, path, title: str = "") -> Path:
    """Per-frame egomotion components, ground truth vs estimate (six panels)."""
    plt = pyplot()
    names = ("U", "V", "W", "α (deg)", "β (deg)", "γ (deg)")
    fig, axs = plt.subplots(3, 2, figsize=(11, 8), sharex=True)
    for c, ax in enumerate(axs.T.ravel()):
        ax.plot(table.frames, table.gt[:, c], "-", color="tab:green", lw=1.2, label="ground truth")
        ax.plot(table.frames, table.est[:, c], "-", color="tab:red", lw=0.9, label="estimate")
        ax.set_ylabel(names[c])
        ax.set_title(f"RMSE {table.rmse[c]:.4g}", fontsize=9)
        ax.grid(True, alpha=0.3)
    axs[0, 0].legend(loc="best")
    for ax in axs[-1]:
        ax.set_xlabel("frame k (motion k → k+1)")
    fig.suptitle(title or f"egomotion per frame ({table.param})")
    return save_figure(fig, path)


def plot_disparity_error(gt_px: np.ndarray, est_px: np.ndarray, path, max_err_px: float = 5.0,
                         title: str = "") -> Path:
    """Ground truth, estimate and |error| clipped at ``max_err_px`` (black: no ground truth /
    no estimate; a missing estimate where the ground truth exists shows as the maximum error)."""
    import matplotlib
    from .disparity import disparity_error_map
    plt = pyplot()
    gt = np.asarray(gt_px, dtype=float)
    est = np.asarray(est_px, dtype=float)
    err = disparity_error_map(gt, est)
    err[np.isfinite(gt) & (gt > 0) & ~np.isfinite(est)] = max_err_px
    gt_show = np.where(np.isfinite(gt) & (gt > 0), gt, np.nan)
    fig, axs = plt.subplots(1, 3, figsize=(15, 4))
    vmax = float(np.nanmax(gt_show)) if np.isfinite(gt_show).any() else 1.0
    for ax, img, name, cmap, vm in ((axs[0], gt_show, "ground truth (px)", "magma", vmax),
                                    (axs[1], est, "estimate (px)", "magma", vmax),
                                    (axs[2], err, "|error| (px)", "inferno", max_err_px)):
        cm = matplotlib.colormaps[cmap].copy()
        cm.set_bad("black")
        im = ax.imshow(img, cmap=cm, vmin=0, vmax=vm, interpolation="nearest")
        ax.set_title(name)
        ax.axis("off")
        fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)


def plot_evaluation(ev, out_dir, title: str = "") -> dict:
    """All trajectory plots of a :class:`TrajectoryEvaluation` into ``out_dir``; {name: path}."""
    out = Path(out_dir)
    files = {"trajectories": plot_trajectories(ev.gt, ev.est_aligned, out / "trajectories.png",
                                               title or f"alignment: {ev.alignment.method}")}
    files["ape"] = plot_errors({"APE translation (m)": ev.ape.trans_errors_m,
                                "APE rotation (deg)": ev.ape.rot_errors_deg}, out / "ape.png",
                               title="absolute pose error per pose")
    unit = "frames" if ev.rpe.delta_unit == "f" else "m"
    files["rpe"] = plot_errors({"RPE translation (m)": ev.rpe.trans_errors_m,
                                "RPE rotation (deg)": ev.rpe.rot_errors_deg}, out / "rpe.png",
                               x=ev.rpe.pairs[:, 1], xlabel="frame (end of pair)",
                               title=f"relative pose error, delta {ev.rpe.delta:g} {unit}")
    if ev.kitti is not None and ev.kitti.by_length["length_m"].size:
        files["kitti"] = plot_kitti_errors(ev.kitti, out / "kitti_errors.png")
    if ev.egomotion is not None:
        files["egomotion"] = plot_egomotion(ev.egomotion, out / "egomotion.png")
    return files
