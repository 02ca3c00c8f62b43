"""``python -m vo_reference`` / ``vo-reference``: export, VO, evaluation.

Each subcommand lives in its own module (``add_arguments(parser)``, ``run(args) -> int``),
imported only when its command runs; exit codes as ``blender_sesgen.contract.cli`` says
(:class:`VoError` -> one line, exit 2).
"""
from __future__ import annotations

import sys

from blender_sesgen.contract.cli import dispatch

from .errors import VoError

PROG = "vo-reference"   # the installed command, the one the docs use
DESCRIPTION = ("Reference visual odometry, ground-truth products and evaluation for sesgen renders and real datasets. "
               "vo-reference is the command pip installs; python -m vo_reference runs the same.")
# command -> (module relative to this package, one-line help)
COMMANDS = {
    "export": (".products.export_cli", "export a render folder to a dataset layout (KITTI, TUM, EuRoC, a ROS 2 bag, "
                                     "COLMAP, nerfstudio, SLAM settings, ...: --to lists them all)"),
    "evaluate": (".evaluate.cli", "evaluate an estimated trajectory against ground truth (APE, RPE, KITTI)"),
    "evaluate-disparity": (".evaluate.disparity_cli", "evaluate an estimated disparity map (EPE, bad-N, D1)"),
    "covisibility": (".products.covisibility_cli", "place-recognition / loop-closure ground truth: the "
                                                    "covisibility of every pair of frames of a render"),
    "evaluate-slam": (".evaluate.slam_cli", "evaluate a SLAM system's keyframe trajectory (APE, KITTI, consistency "
                                            "at loop closures) and loop-closure detections (precision, recall)"),
    "stereo-vo": (".stereo.cli", "run the reference stereo VO (SESGen paper / accurate) on a render or KITTI folder"),
    "run": (".stereo.run_cli", "one-shot: stereo VO (both methods) + evaluation + plots on a render or KITTI folder with ground truth"),
    "mono-vo": (".mono.cli", "run the classic monocular VO pipeline (8-point RANSAC, E, PnP)"),
    "study": (".study.cli", "a verification study's evaluation and HTML report (run by `sesgen study run`)"),
}


def main(argv: list[str] | None = None) -> int:
    return dispatch(argv, prog=PROG, description=DESCRIPTION, commands=COMMANDS, package=__package__,
                    user_errors=(VoError,))


if __name__ == "__main__":
    sys.exit(main())
