"""A child process bound to the life of the process that started it (a farm task's render,
run by ``python -m blender_sesgen.commands.farm_child render ...``; a study's VO runs).

When a Ray worker dies (killed, out of memory, its node lost) the render it started must
die with it: an orphaned render would keep its lock on the frames and render them again
beside the retried task. On Linux the kernel sends SIGKILL when the parent goes
(``PR_SET_PDEATHSIG``); elsewhere a thread polls the parent once a second. A render killed
that way leaves a folder that ``--resume`` completes (every frame is written atomically).

It also gives the child back its Ctrl-C: a Ray worker blocks SIGINT, and a child inherits
the blocked signal, so a cancelled task's SIGINT would never arrive; here SIGINT and SIGTERM
are unblocked and back to Python's defaults, and the render stops between views as usual.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import time

PARENT_ENV = "SESGEN_FARM_PARENT_PID"
_PR_SET_PDEATHSIG = 1


def _die():
    os.kill(os.getpid(), signal.SIGKILL)


def bind_to_parent(parent_pid: int) -> str:
    """Arrange to be killed when ``parent_pid`` (our parent) exits; returns how."""
    how = "poll"
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0:
                how = "pdeathsig"
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:   # the parent went before the binding took effect
        _die()
    if how == "poll":
        def watch():
            while True:
                time.sleep(1.0)
                if os.getppid() != parent_pid:
                    _die()
        threading.Thread(target=watch, name="sesgen-farm-parent-watch", daemon=True).start()
    return how


def restore_interrupts(on_sigint=signal.default_int_handler) -> None:
    """SIGINT and SIGTERM back to Python's default handling (SIGINT: ``on_sigint``), then
    unblocked (see the module docstring). In that order: a SIGINT sent while this process
    started (the farm cancelled its task at once) waited, blocked; unblocked, it meets Python's
    handler and stops the render as a Ctrl-C does, instead of an ignoring disposition that
    would drop it."""
    signal.signal(signal.SIGINT, on_sigint)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})

