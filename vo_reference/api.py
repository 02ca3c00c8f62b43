"""The stable Python API of vo_reference (docs/api.md): what user scripts may import.

Everything named in ``__all__`` keeps its name and meaning across releases; the modules
behind it are internal and may move. No Blender needed::

    from vo_reference import api as vo

    seq = vo.open_sequence("out/room")                  # a render folder or a KITTI folder
    d = vo.disparity(seq, 0, "left")                    # float32 px, NaN where nothing was hit
    res = vo.run_stereo_vo(seq, "accurate")
    ev = vo.evaluate_trajectory(vo.ground_truth(seq), res.trajectory, align="origin")

Errors are :class:`VoError` (one line, the command-line tools exit 2 on them).
"""
from __future__ import annotations

from blender_sesgen.contract.timing import frame_range

from .errors import VoError
from .evaluate import (ape, disparity_metrics, evaluate_trajectory, kitti_metric, rpe,
                       summary_lines)
from .io.kitti import KittiSequence
from .io.render import RenderSequence
from .io.sequence import Sequence, open_sequence
from .io.trajectory import Trajectory, read_trajectory, write_kitti, write_tum
from .groundtruth.dense import DenseFlow, dense_flow, disparity_change
from .groundtruth.disparity import (disparity_from_depth, read_disparity, sequence_disparity as disparity,
                                 write_disparity)
from .exporters.driver import EXPORTERS, export, register_exporter
from .groundtruth.flow import (Flow, read_flo, read_kitti_flow_png, sequence_flow as optical_flow,
                            sequence_stereo_occlusion as stereo_occlusion, write_flo, write_kitti_flow_png)
from .groundtruth.scene_flow import SceneFlow, motion_mask, sequence_scene_flow as scene_flow
from .stereo.pipeline import METHODS as STEREO_METHODS
from .stereo.pipeline import VoResult, run_stereo_vo

__all__ = [
    "VoError",
    # sequences
    "Sequence", "open_sequence", "RenderSequence", "KittiSequence", "frame_range", "ground_truth",
    # products
    "disparity", "disparity_from_depth", "read_disparity", "write_disparity",
    "optical_flow", "Flow", "stereo_occlusion", "dense_flow", "DenseFlow", "disparity_change",
    "scene_flow", "SceneFlow", "motion_mask",
    "read_flo", "write_flo", "read_kitti_flow_png", "write_kitti_flow_png",
    "export", "EXPORTERS", "register_exporter",
    # VO
    "run_stereo_vo", "VoResult", "STEREO_METHODS",
    # trajectories and evaluation
    "Trajectory", "read_trajectory", "write_kitti", "write_tum",
    "evaluate_trajectory", "summary_lines", "ape", "rpe", "kitti_metric", "disparity_metrics",
]


def ground_truth(seq: Sequence, view: str = "left") -> Trajectory:
    """The sequence's ground-truth poses of ``view`` with its timestamps (VoError without)."""
    T = seq.T_world_cam(view)
    if T is None:
        raise VoError(f"{seq!r} has no ground-truth poses")
    return Trajectory(T, seq.timestamps_s)
