"""Plots of a mono VO run: all trajectories together (ours, OpenCV's, ground truth) and the
per-frame errors. matplotlib is imported only here."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..evaluate.plots import pyplot, save_figure

COLOURS = {"ground truth": "tab:green", "ours": "tab:red", "OpenCV": "tab:blue"}


def plot_paths(paths: dict[str, np.ndarray], path, title: str = "") -> Path:
    """Positions (N, 3) per name; top view x–z and side view z–y (the ground plane of a
    forward-looking OpenCV camera's world is x–z)."""
    plt = pyplot()
    fig, axs = plt.subplots(1, 2, figsize=(12, 5.5))
    for name, P in paths.items():
        P = np.asarray(P)
        kw = dict(color=COLOURS.get(name), lw=1.5 if name == "ground truth" else 1.0, label=name)
        axs[0].plot(P[:, 0], P[:, 2], "-", **kw)
        axs[1].plot(P[:, 2], P[:, 1], "-", **kw)
    first = next(iter(paths.values()))
    axs[0].plot(first[0, 0], first[0, 2], "ko", ms=4, label="start")
    axs[0].set(xlabel="x (m)", ylabel="z (m)", title="top view")
    axs[0].set_aspect("equal", adjustable="datalim")
    axs[1].set(xlabel="z (m)", ylabel="y (m)", title="side view")
    for ax in axs:
        ax.grid(True, alpha=0.3)
    axs[0].legend(loc="best")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)


def plot_frame_series(series: dict[str, np.ndarray], path, title: str = "") -> Path:
    """One panel per named per-frame series (frames 1..N−1), skipping all-nan ones."""
    plt = pyplot()
    series = {k: np.asarray(v, float) for k, v in series.items() if np.isfinite(np.asarray(v, float)).any()}
    n = max(1, len(series))
    fig, axs = plt.subplots(n, 1, figsize=(10, 2.2 * n), sharex=True, squeeze=False)
    for ax, (name, v) in zip(axs[:, 0], series.items()):
        ax.plot(np.arange(1, len(v) + 1), v, ".-", lw=0.8, ms=3)
        ax.set_ylabel(name, fontsize=8)
        ax.grid(True, alpha=0.3)
    axs[-1, 0].set_xlabel("frame")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)
