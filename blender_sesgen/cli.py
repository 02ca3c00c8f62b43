"""``python -m blender_sesgen`` / ``sesgen``: check and render SES scripts.

Each subcommand lives in its own module exposing ``add_arguments(parser)`` and
``run(args) -> int``; modules are imported only when their command runs (bpy is heavy).
Expected failures (:class:`SesgenError`) print one line on stderr and exit 2.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys

from .errors import ScriptError, SesgenError

# command -> (module relative to this package, one-line help)
COMMANDS = {
    "check": (".check", "validate a script and print a summary of its scene, rig and motion"),
    "render": (".render_cli", "render a script to a stereo multilayer-EXR sequence with ground truth"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m blender_sesgen",
        description="Synthetic stereo egomotion sequences with exact ground truth, rendered by Blender Cycles.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module, help_text) in COMMANDS.items():
        try:
            mod = importlib.import_module(module, __package__)
        except ModuleNotFoundError as e:  # a command whose module is not in this build yet
            if e.name != f"{__package__}{module}":
                raise
            continue
        p = sub.add_parser(name, help=help_text, description=help_text)
        mod.add_arguments(p)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    module = importlib.import_module(COMMANDS[args.command][0], __package__)
    try:
        return int(module.run(args) or 0)
    except SesgenError as e:
        print(str(e) if isinstance(e, ScriptError) else f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into a reader that stopped early (e.g. `| head`)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
