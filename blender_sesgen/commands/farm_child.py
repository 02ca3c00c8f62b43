"""``python -m blender_sesgen.commands.farm_child render ...``: the command line, bound to the
life of the process that started it (a farm task in a Ray worker; ``farm.child`` says how)."""
from __future__ import annotations

import os
import sys

from ..contract.cli import EXIT_INTERRUPTED
from ..farm.child import PARENT_ENV, bind_to_parent, restore_interrupts


def main(argv=None) -> int:
    try:
        parent = os.environ.get(PARENT_ENV)
        bind_to_parent(int(parent) if parent else os.getppid())
        restore_interrupts()
        from .main import main as cli_main
    except KeyboardInterrupt:   # interrupted before the command began: nothing was written
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return cli_main(sys.argv[1:] if argv is None else argv)


if __name__ == "__main__":
    sys.exit(main())
