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
import sys

from .contract.cli import EXIT_FAILURE, EXIT_OK
from .errors import SesgenError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("out", metavar="OUT", help="a render folder (with manifest.json)")
    p.add_argument("--quick", action="store_true", help="check structure and checksums, do not decode pixels")
    p.add_argument("--dry-run", action="store_true", help="name the bad frames, change nothing")
    p.add_argument("--quiet", action="store_true", help="print only the bad frames")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .contract.manifest import MANIFEST
    from .output import OutputFolder
    folder = OutputFolder(args.out)
    if not (Path(args.out) / MANIFEST).is_file():
        raise SesgenError(f"{args.out}: no render here (no manifest.json)")
    bad = folder.verify(full=not args.quick)
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
    return EXIT_FAILURE if bad else EXIT_OK
