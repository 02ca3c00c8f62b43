"""``python -m vo_reference export RENDER_DIR --to TARGET OUT``: dataset layouts of a render.

Targets come from :data:`vo_reference.products.exports.EXPORTERS` (add one line there to
add a target).
"""
from __future__ import annotations

import argparse

from blender_sesgen.contract.progress import add_progress_argument, progress_mode
from blender_sesgen.contract.timing import FRAMES_HELP

from ..errors import VoError
from .exports import EXPORTERS, export


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("render_dir", metavar="RENDER_DIR", help="render folder (with manifest.json)")
    parser.add_argument("out", metavar="OUT", help="output folder (created; an earlier export there is replaced whole; a failed export leaves nothing)")
    parser.add_argument("--to", dest="target", required=True, choices=list(EXPORTERS), metavar="TARGET",
                        help="layout: " + "; ".join(f"{n}: {h}" for n, (_, h) in EXPORTERS.items()))
    parser.add_argument("--noise", type=float, metavar="SIGMA", default=None,
                        help="Gaussian noise sigma in 8-bit grey levels for the 8-bit images "
                             "(default: the script's NOISE from the manifest; 0 = clean)")
    parser.add_argument("--seed", type=int, default=None, metavar="S",
                        help="noise seed (default: the manifest's, else 0)")
    parser.add_argument("--frames", default=None, metavar="A:B",
                        help=f"source {FRAMES_HELP}; the output is renumbered from 0")
    parser.add_argument("--sequence", default=None, metavar="NAME",
                        help="the render's slot in a dataset tree of several sequences: kitti-odometry "
                             "NN (default 00), sceneflow SPLIT/LETTER/NNNN (default TRAIN/A/0000), "
                             "tartanair-v2 ENV/Data_DIFF/PNNN (default sesgen/Data_easy/P000), sintel "
                             "SCENE (default sesgen), tartanair / vkitti2 a sub-folder of OUT (default: "
                             "OUT itself); other sequences in OUT are left alone")
    parser.add_argument("--opt", action="append", default=[], metavar="KEY=VALUE",
                        help="target-specific option (repeatable)")
    parser.add_argument("--undistort", action="store_true",
                        help="a render with a distorting LENS: write pinhole images and ground truth (depth, "
                             "disparity, flow, ids, masks recomputed for the pinhole camera). Needed by every "
                             "layout without a lens model (all but euroc, rosbag, bayer, cityscapes)")
    add_progress_argument(parser)


def run(args: argparse.Namespace) -> int:
    extra = {}
    for item in args.opt:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise VoError(f"--opt {item!r}: expected KEY=VALUE")
        extra[key.strip()] = value.strip()
    if args.noise is None and args.seed is None:
        noise = "manifest"
    else:
        from ..io.render import RenderSequence
        seq_noise = RenderSequence(args.render_dir).noise
        sigma = args.noise if args.noise is not None else (seq_noise[0] if seq_noise else 0.0)
        seed = args.seed if args.seed is not None else (seq_noise[1] if seq_noise else 0)
        if sigma < 0:
            raise VoError(f"--noise {sigma}: sigma must be >= 0")
        noise = (sigma, seed) if sigma > 0 else None
    out = export(args.render_dir, args.target, args.out, frames=args.frames, noise=noise,
                 progress=progress_mode(args), extra=extra, sequence=args.sequence, undistort=args.undistort)
    print(f"exported {args.render_dir} -> {out} ({args.target})")
    return 0
