"""Trajectory and disparity evaluation with the definitions of evo and the KITTI devkit.

Public API (numpy arrays or :class:`~vo_reference.io.trajectory.Trajectory` in, dataclasses out)::

    from vo_reference.evaluate import (evaluate_trajectory, associate, align, umeyama,
                                       ape, rpe, kitti_metric, egomotion, egomotion_table,
                                       disparity_metrics)
    from vo_reference.evaluate.plots import plot_trajectories, plot_errors, plot_kitti_errors
    from vo_reference.evaluate.report import write_report

Plots need matplotlib and are imported only from ``vo_reference.evaluate.plots``.
See docs/evaluation.md for the definitions and conventions.
"""
from .align import METHODS as ALIGN_METHODS, Alignment, align, apply_alignment, umeyama
from .ape import APEResult, ape
from .associate import associate, matching_time_indices
from .disparity import disparity_error_map, disparity_errors, disparity_metrics
from .egomotion import EgomotionTable, egomotion, egomotion_table
from .kitti import KittiResult, kitti_metric, trajectory_distances
from .rpe import RPEResult, rpe, rpe_pairs
from .stats import ErrorStats
from .trajectory_eval import EvaluationOptions, TrajectoryEvaluation, evaluate_trajectory, summary_lines

__all__ = [
    "ALIGN_METHODS", "Alignment", "align", "apply_alignment", "umeyama",
    "APEResult", "ape", "associate", "matching_time_indices",
    "disparity_error_map", "disparity_errors", "disparity_metrics",
    "EgomotionTable", "egomotion", "egomotion_table",
    "KittiResult", "kitti_metric", "trajectory_distances",
    "RPEResult", "rpe", "rpe_pairs", "ErrorStats",
    "EvaluationOptions", "TrajectoryEvaluation", "evaluate_trajectory", "summary_lines",
]
