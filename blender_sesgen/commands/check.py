"""``python -m blender_sesgen check SCENE.ses``: validate a script and print a summary.

Exit 0 with the summary on stdout; exit 2 with every error as ``file:line:col: error: ...``
on stderr (no traceback) when the script is wrong.
"""
from __future__ import annotations

import argparse
import sys

from ..errors import ScriptError
from ..scene.summary import summary


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("script", metavar="SCENE.ses", help="the SES script to check")


def run(args: argparse.Namespace) -> int:
    from ..ses import parse_file
    try:
        scene = parse_file(args.script)
    except ScriptError as e:
        for err in getattr(e, "errors", (e,)):
            print(err, file=sys.stderr)
        return 2
    print(summary(scene))
    return 0
