"""``python -m blender_sesgen`` / ``sesgen``: check and render SES scripts.

Each subcommand lives in its own module (``add_arguments(parser)``, ``run(args) -> int``),
imported only when its command runs (bpy is heavy); exit codes as ``contract.cli`` says
(:class:`SesgenError` -> one line, exit 2; script errors as ``file:line:col: error: ...``).
"""
from __future__ import annotations

import sys

from .contract.cli import dispatch
from .errors import ScriptError, SesgenError

PROG = "sesgen"   # the installed command, the one the docs use
DESCRIPTION = ("Synthetic stereo egomotion sequences with exact ground truth, rendered by Blender Cycles. "
               "sesgen is the command pip installs; python -m blender_sesgen runs the same.")
# command -> (module relative to this package, one-line help)
COMMANDS = {
    "check": (".check", "validate a script and print a summary of its scene, rig and motion"),
    "render": (".render_cli", "render a script to a stereo multilayer-EXR sequence with ground truth"),
    "verify": (".verify_cli", "check every file of a render against its manifest; bad frames are re-rendered by --resume"),
    "farm": (".farm.cli", "render many scenes in chunks of frames as Ray tasks, on this machine or a cluster"),
    "generate": (".generate_cli", "write N varied scene scripts from a scene generator, and their dataset index"),
    "study": (".study.cli", "a verification study: vary one thing, run every VO on every variant, report where it breaks"),
}


def _describe(e: BaseException) -> str:
    """The error's line: a script error (and a study file's, ``whole_line``) names its place itself."""
    return str(e) if isinstance(e, ScriptError) or getattr(e, "whole_line", False) else f"error: {e}"


def main(argv: list[str] | None = None) -> int:
    return dispatch(argv, prog=PROG, description=DESCRIPTION, commands=COMMANDS, package=__package__,
                    user_errors=(SesgenError,), describe=_describe)


if __name__ == "__main__":
    sys.exit(main())
