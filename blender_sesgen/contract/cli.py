"""The command-line contract both packages keep: subcommands in modules of their own, and
the exit codes.

Exit codes: 0 done; 2 a user error (bad input or arguments: one line on stderr, no
traceback, nothing written); 1 a failure of the work itself; 130 interrupted (Ctrl-C);
141 the reader of our output went away (``| head``).

Each subcommand is a module with ``add_arguments(parser)`` and ``run(args) -> int``,
imported only when its command runs (bpy, OpenCV and friends are heavy).
"""
from __future__ import annotations

import argparse
import errno
import importlib
import os
import sys
from typing import Callable, Optional, Sequence

from .errors import ContractError

EXIT_OK, EXIT_FAILURE, EXIT_USER_ERROR, EXIT_INTERRUPTED, EXIT_BROKEN_PIPE = 0, 1, 2, 130, 141
# failures of the file system, one line each: the disk (exit 1: the same command may work later) ...
SYSTEM_ERRNOS = {errno.ENOSPC: EXIT_FAILURE, errno.EDQUOT: EXIT_FAILURE, errno.EFBIG: EXIT_FAILURE,
                 errno.EIO: EXIT_FAILURE,
                 # ... or a place the user may not write to (exit 2)
                 errno.EROFS: EXIT_USER_ERROR, errno.EACCES: EXIT_USER_ERROR, errno.EPERM: EXIT_USER_ERROR}


def add_report_argument(parser: argparse.ArgumentParser, contents: str, default_text: str = "") -> None:
    """``--report DIR``: the one name of a command's report folder (``contents``: what goes in);
    ``--plot``, its earlier name in some commands, still works but is not shown."""
    parser.add_argument("--report", metavar="DIR",
                        help=f"report folder: {contents}" + (f" (default: {default_text})" if default_text else ""))
    parser.add_argument("--plot", dest="report", metavar="DIR", help=argparse.SUPPRESS)


def build_parser(prog: str, description: str, commands: dict, package: str,
                 only: Optional[str] = None) -> argparse.ArgumentParser:
    """``commands``: {name: (module relative to ``package``, one-line help)}. ``only``: the
    command about to run; the other commands' modules are then not imported (each import
    costs start-up: ``check``'s alone ~0.4 CPU s), their parsers list just their help."""
    parser = argparse.ArgumentParser(prog=prog, description=description)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module, help_text) in commands.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        if only is None or name == only:
            importlib.import_module(module, package).add_arguments(p)
    return parser


def chosen_command(argv: Sequence[str], commands: dict) -> str:
    """The command ``argv`` names (its first word: the top-level parser has no option that
    takes a value), or "" when it names none (``--help``, a typo: argparse then says so)."""
    first = next((a for a in argv if not a.startswith("-")), "")
    return first if first in commands else ""


def forget_caught_interrupt() -> None:
    """Let a caught Ctrl-C end the process with exit code 130. CPython (3.11, run as ``python -m``)
    marks a KeyboardInterrupt that left an ``exec`` of source text -- the class bodies dataclasses
    and namedtuple build, met by a Ctrl-C or SIGTERM during an import -- as unhandled even when a
    caller caught it, and then ends the process by SIGINT instead of our exit code (a study stopped
    by SIGTERM did so ~1 time in 10 under load). Running source text clears that mark: CPython resets
    it before each such run."""
    exec("pass")


def dispatch(argv: Optional[Sequence[str]], *, prog: str, description: str, commands: dict, package: str,
             user_errors: tuple = (), describe: Callable[[BaseException], str] = lambda e: f"error: {e}") -> int:
    """Parse ``argv``, run the chosen command, map failures to the exit codes above.

    ``user_errors``: the package's own user-error exceptions (ContractError is always one);
    ``describe`` turns one into its line on stderr.
    """
    try:
        argv = sys.argv[1:] if argv is None else list(argv)
        parser = build_parser(prog, description, commands, package, only=chosen_command(argv, commands))
        args = parser.parse_args(argv)
        module = importlib.import_module(commands[args.command][0], package)
        code = int(module.run(args) or EXIT_OK)
        if code == EXIT_INTERRUPTED:
            forget_caught_interrupt()
        return code
    except (ContractError, *user_errors) as e:
        print(describe(e), file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        forget_caught_interrupt()
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # output piped into a reader that stopped early (e.g. `| head`)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except OSError as e:
        if e.errno not in SYSTEM_ERRNOS:
            raise
        print(f"error: {e.filename + ': ' if e.filename else ''}{e.strerror}", file=sys.stderr)
        return SYSTEM_ERRNOS[e.errno]
