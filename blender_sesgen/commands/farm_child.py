"""``python -m blender_sesgen.commands.farm_child render ...``: the command line, bound to the
life of the process that started it (a farm task in a Ray worker; ``farm.child`` says how)."""
from __future__ import annotations

import os
import signal
import sys

from ..contract.cli import EXIT_INTERRUPTED, forget_caught_interrupt
from ..farm.child import PARENT_ENV, bind_to_parent, restore_interrupts
from ..render.interrupt import StopRequest


def main(argv=None) -> int:
    """A SIGINT (the farm's cancel) that comes while this process starts is recorded, not raised
    where it lands: a KeyboardInterrupt raised in the middle of the command's imports came out
    as an ImportError (numpy's, exit 1) or, caught, as a process killed by SIGINT at exit (-2),
    which a farm reads as a lost render and retries. Asked once the command line is loaded
    (exit 130, nothing written); a render then takes one that comes later from here (its
    ``deferred_interrupts`` keeps the request: it stops before its first frame), any other
    command gets Python's Ctrl-C back."""
    argv = sys.argv[1:] if argv is None else list(argv)
    early = StopRequest()
    try:
        parent = os.environ.get(PARENT_ENV)
        bind_to_parent(int(parent) if parent else os.getppid())
        restore_interrupts(early)
        from .main import main as cli_main
    except KeyboardInterrupt:   # a second SIGINT (stop at once), before the command began
        early.requested = True
    if early.requested:         # interrupted before the command began: nothing was written
        print("interrupted", file=sys.stderr)
        forget_caught_interrupt()   # (a KeyboardInterrupt caught in an import's exec: 130, not SIGINT)
        return EXIT_INTERRUPTED
    if argv[:1] != ["render"]:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    return cli_main(argv)


if __name__ == "__main__":
    sys.exit(main())
