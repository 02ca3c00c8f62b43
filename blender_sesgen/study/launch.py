"""``python -m blender_sesgen.study.launch WORKDIR -- COMMAND...``: start a system under
test the way a study runs it, then become it (``exec``).

- bound to the life of the process that started it (``farm.child.bind_to_parent``: a study
  killed at any moment takes its systems along);
- Ctrl-C and SIGTERM back to their defaults (a Ray worker blocks them for its children);
- the dataset's permissions hold even for root: the capabilities that bypass file
  permissions (CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH, CAP_FOWNER) are dropped from the
  bounding set before ``exec``, so a system running as root cannot write into a read-only
  dataset either (Linux; elsewhere permissions bind every user but root anyway);
- the current folder is WORKDIR.
"""
from __future__ import annotations

import os
import sys

_PR_CAPBSET_DROP = 24
_DAC_CAPS = (1, 2, 3)   # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH, CAP_FOWNER


def drop_permission_overrides() -> bool:
    """Drop the capabilities that bypass file permissions (root only; True if dropped)."""
    if not sys.platform.startswith("linux") or os.geteuid() != 0:
        return False
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        return all(libc.prctl(_PR_CAPBSET_DROP, cap, 0, 0, 0) == 0 for cap in _DAC_CAPS)
    except (OSError, AttributeError):
        return False


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    if len(args) < 3 or args[1] != "--":
        print("usage: python -m blender_sesgen.study.launch WORKDIR -- COMMAND...", file=sys.stderr)
        return 2
    from ..farm.child import PARENT_ENV, bind_to_parent, restore_interrupts
    parent = os.environ.pop(PARENT_ENV, None)
    bind_to_parent(int(parent) if parent else os.getppid())
    restore_interrupts()
    drop_permission_overrides()
    os.chdir(args[0])
    try:
        os.execvp(args[2], args[2:])
    except OSError as e:
        print(f"error: cannot run {args[2]}: {e.strerror or e}", file=sys.stderr)
        return 127


if __name__ == "__main__":
    sys.exit(main())
