"""``python -m blender_sesgen verify OUT``: check a render folder against its manifest.

The manifest first: its seal must match it (a manifest edited afterwards -- K, baseline,
poses, checksums -- is reported and nothing else is trusted), ``scene.ses`` must be the
script rendered (its SHA-256), the trajectories, lens tables and IMU streams what was
written. Then every frame recorded complete: each file the manifest lists for it (EXRs,
display PNGs, sensor images) exists, lies whole in its file, holds the channels the
manifest names, matches the SHA-256 recorded when it was written, and (unless ``--quick``)
decodes. Bad frames are named and recorded as not rendered, so that ``render --resume``
renders them again (``--dry-run`` only names them); ``--resume`` also writes the folder's
own files again. Exit 0 when all is good, 1 when something is wrong, 2 on bad input.
"""
from __future__ import annotations

import argparse
import contextlib
import sys

from .contract.cli import EXIT_FAILURE, EXIT_OK
from .contract.progress import Progress, add_progress_argument, progress_mode
from .errors import SesgenError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("out", metavar="OUT", help="a render folder (with manifest.json)")
    p.add_argument("--quick", action="store_true", help="check structure and checksums, do not decode pixels")
    p.add_argument("--dry-run", action="store_true", help="name the bad frames, change nothing")
    add_progress_argument(p)


def _not_rendered(out) -> str:
    """How many frames of the sequence are not rendered (complete) yet, as a line."""
    from .contract.errors import ContractError
    from .contract.manifest import Manifest
    try:
        m = Manifest.read(out)
    except ContractError:  # a manifest verify found wrong: already said
        return ""
    todo = m.frames - sum(bool(c) for c in m.frames_complete)
    if not todo:
        return f"verify {out}: all {m.frames} frames of the sequence are rendered"
    return f"verify {out}: {todo} of the sequence's {m.frames} frames not rendered yet (render --resume renders them)"


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .contract.manifest import MANIFEST
    from .output import OutputFolder
    folder = OutputFolder(args.out)
    if not (Path(args.out) / MANIFEST).is_file():
        raise SesgenError(f"{args.out}: no render here (no manifest.json)")
    args.quiet = progress_mode(args) == "off"   # -q is --progress off: no progress, no summary unless wrong
    with contextlib.ExitStack() as stack:
        bar = []   # the report starts with the first frame checked, when their number is known

        def tick(i: int, n: int) -> None:
            if not bar:
                bar.append(stack.enter_context(Progress(n, "verify", mode=progress_mode(args), unit="frame")))
            bar[0].update()
        bad = folder.verify(full=not args.quick, progress=tick)
    for k, why in bad:
        print(why if k is None else f"frame {k}: {why}")
    frames = sorted({k for k, _ in bad if k is not None})
    if frames and not args.dry_run:
        folder.mark_incomplete(frames)
    if not args.quiet or bad:
        state = ("the manifest, its files and all frames recorded complete are good" if not bad else
                 f"{len(bad)} problem(s)" + (f", {len(frames)} bad frame(s)" if frames else "")
                 + ("" if args.dry_run else f"{'; recorded as not rendered' if frames else ''}: "
                                            "render again with --resume"))
        print(f"verify {args.out}: {state}", file=sys.stderr if bad else sys.stdout)
    line = "" if args.quiet else _not_rendered(args.out)
    if line:
        print(line)
    return EXIT_FAILURE if bad else EXIT_OK
