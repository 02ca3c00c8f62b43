"""``python -m vo_reference``: export, VO, evaluation.

Each subcommand lives in its own module exposing ``add_arguments(parser)`` and
``run(args) -> int``, imported only when needed. :class:`VoError` -> one line, exit 2.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys

from .errors import VoError

# command -> (module relative to this package, one-line help)
COMMANDS = {
    "export": (".products.export_cli", "export a render folder to KITTI / TUM / PNG dataset layouts"),
    "evaluate": (".evaluate.cli", "evaluate an estimated trajectory against ground truth (APE, RPE, KITTI)"),
    "evaluate-disparity": (".evaluate.disparity_cli", "evaluate an estimated disparity map (EPE, bad-N, D1)"),
    "stereo-vo": (".stereo.cli", "run the reference stereo VO (SESGen paper / accurate) on a render or KITTI folder"),
    "run": (".stereo.run_cli", "one-shot: stereo VO (both methods) + evaluation + plots on a render or KITTI folder with ground truth"),
    "mono-vo": (".mono.cli", "run the classic monocular VO pipeline (8-point RANSAC, E, PnP)"),
}


def build_parser(commands=None) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m vo_reference",
        description="Reference visual odometry, ground-truth products and evaluation for sesgen renders and real datasets.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module, help_text) in (commands or COMMANDS).items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        try:
            importlib.import_module(module, __package__).add_arguments(p)
        except ModuleNotFoundError as e:  # a command whose module is not there yet
            if not (e.name or "").startswith(__package__):
                raise
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser()
    args = parser.parse_args(argv)
    module = importlib.import_module(COMMANDS[args.command][0], __package__)
    try:
        return int(module.run(args) or 0)
    except VoError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into a reader that stopped early (e.g. `| head`)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
