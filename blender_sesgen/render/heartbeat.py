"""A live writer's lock kept fresh between its frames, by a small child process (stdlib only).

Another host judges a render folder's lock by its file's time (``contract.writers.STALE_LOCK_S``): a
lock not touched for that long is taken over, its completion log and temporaries removed as
a dead writer's. The writer touches its lock with every completed frame, so a frame slower
than ``STALE_LOCK_S`` (a big scene, a single-threaded farm chunk, a 4K final) lost its lock
while it rendered. A thread cannot keep it fresh: a Python thread beside bpy crashed Blender
(``sealer``'s docstring). So :class:`Heartbeat` starts this file as a child process (the same
interpreter, ``-I``, no package import) that touches the lock every ``every`` seconds while
its stdin pipe from the writer is open:

- the writer dies (kill -9 included): the pipe's only write end closes, the child reads EOF
  and exits (and if a fork of the writer held the pipe open, the child sees its parent change
  and exits all the same); the lock then goes stale ``STALE_LOCK_S`` later, as before;
- the writer hangs (a render that never returns): each completed frame writes one byte into
  the pipe (:meth:`Heartbeat.progress`); once ``limit`` seconds pass without one the child
  stops touching (it stays, so a frame that completes after all takes up the touching
  again), and the lock goes stale ``STALE_LOCK_S`` later: a hung writer holds its frames for
  at most ``limit + STALE_LOCK_S`` on other hosts (on its own host a lock lives as long as
  its process does: ``contract.writers.stale``);
- the lock file is gone (dropped, or taken over by another writer as stale): the child exits
  without creating it.

Without a Python interpreter to run it (inside Blender ``sys.executable`` may be Blender
itself: never start a second Blender) or without ``select`` on pipes (Windows) there is no
heartbeat: the lock is touched once per frame, as before.
"""
from __future__ import annotations

import os
import select
import subprocess
import sys
import time
from pathlib import Path
from typing import Optional


def _python_interpreter() -> bool:
    return os.path.basename(sys.executable or "").lower().startswith("python")


class Heartbeat:
    """``hb = Heartbeat(lock_path, every, limit)``; ``hb.progress()`` per frame; ``hb.stop()``."""

    def __init__(self, lock: Path, every: float, limit: float):
        self._proc: Optional[subprocess.Popen] = None
        if os.name != "posix" or not _python_interpreter():
            return
        try:
            self._proc = subprocess.Popen([sys.executable, "-I", str(Path(__file__).resolve()), str(lock),
                                           repr(float(every)), repr(float(limit))],
                                          stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL,   # never holds the writer's output open
                                          start_new_session=True)   # Ctrl-C reaches the writer only
        except OSError:
            self._proc = None

    @property
    def pid(self) -> Optional[int]:
        return None if self._proc is None else self._proc.pid

    def progress(self) -> None:
        """A frame was completed: the writer is not hung."""
        if self._proc is not None:
            try:
                self._proc.stdin.write(b".")
                self._proc.stdin.flush()
            except (OSError, ValueError):   # the child is gone: the per-frame touch remains
                self.stop()

    def stop(self) -> None:
        proc, self._proc = self._proc, None
        if proc is None:
            return
        try:
            proc.stdin.close()
        except OSError:
            pass
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def serve(lock: str, every: float, limit: float) -> int:
    """The child: touch ``lock`` every ``every`` s while stdin is open, its parent the same
    and a byte came on stdin (or the start) within ``limit`` s."""
    fd = sys.stdin.fileno()
    parent = os.getppid()
    last = time.monotonic()
    while True:
        ready, _, _ = select.select([fd], [], [], every)
        if ready:
            if not os.read(fd, 4096):
                return 0                      # the writer closed the pipe or died
            last = time.monotonic()
        if os.getppid() != parent:
            return 0                          # the writer died; a fork of it holds the pipe
        if time.monotonic() - last <= limit:
            try:
                os.utime(lock)
            except FileNotFoundError:
                return 0                      # dropped, or taken over: never recreate it
            except OSError:
                pass                          # a flaky shared filesystem: try again


if __name__ == "__main__":
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.exit(serve(sys.argv[1], float(sys.argv[2]), float(sys.argv[3])))
