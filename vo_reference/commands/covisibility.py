"""``python -m vo_reference covisibility RENDER``: place-recognition and loop-closure ground
truth (the covisibility of every pair of frames) written into the render folder."""
from __future__ import annotations

import argparse

from blender_sesgen.contract.progress import Progress, add_progress_argument, progress_mode
from blender_sesgen.contract.timing import FRAMES_HELP, frame_range

from ..errors import VoError


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ..groundtruth.covisibility import CovisibilityParams as P
    p.add_argument("render_dir", metavar="RENDER", help="render folder (with manifest.json); writes RENDER/covisibility/")
    p.add_argument("--stride", type=int, default=P.stride, metavar="S",
                   help=f"sample every S-th pixel in x and y (default {P.stride}; 1 = every pixel)")
    p.add_argument("--threshold", type=float, default=P.threshold, metavar="C",
                   help=f"write the pairs where either frame sees at least this share of itself in the other "
                        f"(default {P.threshold})")
    p.add_argument("--loop-threshold", type=float, default=P.loop_threshold, metavar="C",
                   help=f"loop closures: the later frame sees at least this share of itself in the earlier "
                        f"(default {P.loop_threshold})")
    p.add_argument("--min-gap", type=float, default=P.min_gap_s, metavar="S",
                   help=f"loop closures: at least S seconds apart (default {P.min_gap_s:g})")
    p.add_argument("--rtol", type=float, default=P.rtol, help=f"depth test's relative tolerance (default {P.rtol:g})")
    p.add_argument("--view", default="left", choices=("left", "right"))
    p.add_argument("--frames", metavar="A:B", help=f"only {FRAMES_HELP}, or several such ranges separated by commas (stretches "
                        "around loop closures: 0:60,823:883); default all")
    add_progress_argument(p)


def run(args: argparse.Namespace) -> int:
    from blender_sesgen.contract.errors import ContractError

    from ..io.render import RenderSequence
    from ..groundtruth.covisibility import CovisibilityParams, compute_covisibility, write_covisibility
    params = CovisibilityParams(stride=args.stride, rtol=args.rtol, threshold=args.threshold,
                                loop_threshold=args.loop_threshold, min_gap_s=args.min_gap, view=args.view)
    seq = RenderSequence(args.render_dir)
    try:
        ranges = args.frames.split(",") if args.frames else [None]
        frames = sorted({k for r in ranges for k in frame_range(r, seq.num_frames, 1)})
    except ContractError as e:
        raise VoError(str(e)) from None
    with Progress(2 * len(frames), "covisibility", mode=progress_mode(args), unit="step") as bar:
        cov = compute_covisibility(seq, params, frames, progress=lambda n: bar.update(n))
    out = write_covisibility(args.render_dir, cov)
    lc = cov.loop_closures
    print(f"covisibility: {len(frames)} frames, {len(cov.pairs)} pairs with c >= {params.threshold:g}, "
          f"{len(lc)} loop-closure pairs (c >= {params.loop_threshold:g}, >= {params.min_gap_s:g} s apart) -> {out}")
    for a, b, m0, m1 in _runs(lc):
        print(f"  queries {a}-{b} find frames {m0}-{m1}")
    return 0


def _runs(lc):
    """Loop-closure pairs grouped into runs of consecutive query frames: (first, last query,
    lowest, highest match)."""
    out = []
    for q, m in lc:
        if out and q - out[-1][1] <= 1:
            a, _, m0, m1 = out[-1]
            out[-1] = (a, q, min(m0, m), max(m1, m))
        else:
            out.append((q, q, m, m))
    return out
