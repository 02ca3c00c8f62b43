"""``python -m blender_sesgen.study.launch WORKDIR -- COMMAND...`` (:func:`command`): start a
system under test the way a study runs it, and stay as its parent until it ends.

- bound to the life of the process that started it: when that one goes (a study or a Ray
  worker killed at any moment), this launcher kills its whole process group -- the system
  and whatever it started (``PR_SET_PDEATHSIG`` reaches only one process, and a system's own
  children would outlive a bound system: until session 21 the system was bound itself, and
  a child it had forked went on writing its trajectory after the study was killed);
- the system's exit is this launcher's: its exit code, or the same signal;
- Ctrl-C and SIGTERM back to their defaults for the system (a Ray worker blocks them for its
  children); the launcher itself outlives a SIGTERM to the group, to report how the system ended;
- the dataset's permissions hold even for root: the capabilities that bypass file
  permissions (CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH, CAP_FOWNER) are dropped from the
  bounding set before ``exec``, so a system running as root cannot write into a read-only
  dataset either (Linux; elsewhere permissions bind every user but root anyway);
- the current folder is WORKDIR.

A process of the system that leaves the group (``setsid``, a daemon) is beyond its reach.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import time

_PR_SET_PDEATHSIG = 1
_PR_CAPBSET_DROP = 24
_DAC_CAPS = (1, 2, 3)   # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH, CAP_FOWNER
_PARENT_GONE = signal.SIGUSR1


def command(workdir, argv) -> list:
    """The command line that launches ``argv`` in ``workdir``: this Python, and this very
    package (not whichever ``blender_sesgen`` the child's path would find: the system's
    environment is the study's, PYTHONPATH unchanged)."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    code = ("import sys; sys.path.insert(0, sys.argv.pop(1)); "
            "from blender_sesgen.study.launch import main; sys.exit(main())")
    return [sys.executable, "-c", code, root, str(workdir), "--", *argv]


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


def _kill_group() -> None:
    os.killpg(os.getpgid(0), signal.SIGKILL)      # this launcher included


def _bind_group_to_parent(parent_pid: int) -> None:
    """Kill the whole process group when ``parent_pid`` (our parent) exits: a signal from
    the kernel on Linux, else a thread polling the parent once a second."""
    def on_signal(signum, frame):
        if os.getppid() != parent_pid:            # not some other sender of the signal
            _kill_group()
    signal.signal(_PARENT_GONE, on_signal)
    bound = False
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            bound = ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(_PARENT_GONE), 0, 0, 0) == 0
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:                # the parent went before the binding took effect
        _kill_group()
    if not bound:
        def watch():
            while os.getppid() == parent_pid:
                time.sleep(1.0)
            _kill_group()
        threading.Thread(target=watch, name="sesgen-launch-parent-watch", daemon=True).start()


def _end_as(status: int) -> int:
    """Exit as the child did: its exit code, or killed by the same signal."""
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        try:
            import resource
            resource.setrlimit(resource.RLIMIT_CORE, (0, 0))   # the system's core is its own
        except (ImportError, ValueError, OSError):
            pass
        signal.signal(sig, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {sig})
        os.kill(os.getpid(), sig)
        return 128 + sig
    return os.waitstatus_to_exitcode(status)


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    if len(args) < 3 or args[1] != "--":
        print("usage: python -m blender_sesgen.study.launch WORKDIR -- COMMAND...", file=sys.stderr)
        return 2
    from ..farm.child import PARENT_ENV, restore_interrupts
    parent = os.environ.pop(PARENT_ENV, None)
    restore_interrupts()                          # unblocked (a Ray worker's children inherit them blocked)
    for sig in (signal.SIGTERM, signal.SIGINT):   # the group's SIGTERM is for the system; we report its end
        signal.signal(sig, lambda *_: None)
    _bind_group_to_parent(int(parent) if parent else os.getppid())
    drop_permission_overrides()
    os.chdir(args[0])
    pid = os.fork()
    if pid == 0:
        try:
            restore_interrupts()
            signal.signal(_PARENT_GONE, signal.SIG_DFL)
            os.execvp(args[2], args[2:])
        except OSError as e:
            print(f"error: cannot run {args[2]}: {e.strerror or e}", file=sys.stderr, flush=True)
        os._exit(127)
    _, status = os.waitpid(pid, 0)
    return _end_as(status)


if __name__ == "__main__":
    sys.exit(main())
