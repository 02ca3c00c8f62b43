"""Who is writing into a render folder: one lock file per running render and its frames.

``.sesgen/lock-<host>-<pid>.json`` holds the writer's host, pid, frame range, start time,
scene hash and settings; it is created (and every check of the others is made) under a
short ``flock`` on ``.sesgen/mutex``, so two renders starting together cannot both pass. A
lock is stale, and taken over, when its process is gone (same host) or when its file has not
been touched for ``STALE_LOCK_S`` (another host; ``contract.writers`` judges, for readers too).
The writer touches it with each completed frame and, between frames, a child process does every ``HEARTBEAT_S`` while the writer lives
and has completed a frame within ``HUNG_RENDER_S`` (``heartbeat``): a slow frame keeps its lock,
a killed writer's goes stale ``STALE_LOCK_S`` after its death, a hung one's
``HUNG_RENDER_S + STALE_LOCK_S`` after its last frame.
"""
from __future__ import annotations

import contextlib
import os
import re
import socket
import time
from pathlib import Path
from typing import Optional

from ..contract import atomic
from ..contract.writers import LOCK_GLOB, read_lock, stale as _stale

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: the lock files still guard, without the mutex
    fcntl = None

# contract.writers.STALE_LOCK_S: a lock of another host not refreshed for this long is taken over
HEARTBEAT_S = 60.0    # how often a live writer's heartbeat touches its lock between frames
HUNG_RENDER_S = 6 * 3600.0   # no frame completed for this long: the heartbeat stops (a hung render)


class FolderLocks:
    """The locks of one state folder (``OUT/.sesgen``)."""

    def __init__(self, state: Path):
        self.state = Path(state)
        self.writer = f"{_safe(socket.gethostname())}-{os.getpid()}"
        self.path: Optional[Path] = None            # our own lock, while held
        self._heartbeat = None                      # heartbeat.Heartbeat, while held

    @contextlib.contextmanager
    def mutex(self):
        """Exclusive for the length of the block, across processes (and hosts, where the
        shared filesystem supports flock)."""
        self.state.mkdir(parents=True, exist_ok=True)
        with open(self.state / "mutex", "a+") as f:
            if fcntl is not None:
                fcntl.flock(f.fileno(), fcntl.LOCK_EX)
            try:
                yield
            finally:
                if fcntl is not None:
                    fcntl.flock(f.fileno(), fcntl.LOCK_UN)

    def live(self) -> list[dict]:
        """Locks of running writers (call under :meth:`mutex`); stale ones are removed."""
        live = []
        for path in sorted(self.state.glob(LOCK_GLOB)):
            info, host, pid = read_lock(path) or (None, "", -1)
            if info is None or _stale(host, pid, path):
                path.unlink(missing_ok=True)
                continue
            info["path"] = path
            live.append(info)
        return live

    def live_writers(self) -> set[str]:
        """Writer names (``host-pid``) of the lock files present."""
        return {p.stem.replace("lock-", "", 1) for p in self.state.glob(LOCK_GLOB)}

    def live_pids(self) -> set[int]:
        return {int(w.rsplit("-", 1)[-1]) for w in self.live_writers() if w.rsplit("-", 1)[-1].isdigit()}

    def refuse_conflicts(self, frames: tuple[int, int], scene_sha256: str, settings_key: str, where) -> None:
        """SesgenError naming the holder if a live writer holds frames overlapping ``first..last``
        or renders another scene or other settings here (call under :meth:`mutex`)."""
        from ..errors import SesgenError
        first, last = frames
        for other in self.live():
            same_plan = other.get("scene_sha256") == scene_sha256 and other.get("settings") == settings_key
            overlap = not (last < other["frames"][0] or first > other["frames"][1])
            if overlap or not same_plan:
                since = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(other.get("started", 0)))
                raise SesgenError(
                    f"--out {where}: being rendered by pid {other['pid']} on {other['host']} "
                    f"(frames {other['frames'][0]}..{other['frames'][1]}, since {since}"
                    f"{'' if same_plan else ', another scene or other settings'}); "
                    "wait for it to finish, or render into another folder")

    def take(self, frames: tuple[int, int], scene_sha256: str, settings_key: str, where) -> None:
        """Our lock on frames ``first..last``; SesgenError if a live writer conflicts."""
        first, last = frames
        with self.mutex():
            self.refuse_conflicts(frames, scene_sha256, settings_key, where)
            self.path = self.state / f"lock-{self.writer}.json"
            atomic.write_json(self.path, {"host": socket.gethostname(), "pid": os.getpid(), "frames": [first, last],
                                          "started": time.time(), "scene_sha256": scene_sha256,
                                          "settings": settings_key})
        from .heartbeat import Heartbeat
        self._heartbeat = Heartbeat(self.path, HEARTBEAT_S, HUNG_RENDER_S)

    def touch(self) -> None:
        """Show that the holder is alive and not hung: a frame was completed (other hosts judge
        staleness by the file's time; the heartbeat keeps it fresh until the next frame)."""
        if self.path is not None:
            os.utime(self.path)
            if self._heartbeat is not None:
                self._heartbeat.progress()

    def drop_dead(self, host: str, pid: int) -> bool:
        """Remove the lock of writer ``pid`` on ``host``, known to be dead by the caller (a
        render farm whose task saw the render killed or lost its worker), at once instead of
        after ``STALE_LOCK_S``. True if there was one."""
        if not self.state.is_dir():
            return False
        path = self.state / f"lock-{_safe(host)}-{int(pid)}.json"
        with self.mutex():
            existed = path.is_file()
            path.unlink(missing_ok=True)
        return existed

    def drop(self) -> None:
        """Remove our lock, then end its heartbeat (which exits by itself once the lock is gone
        or this process is: an interrupt while it ends leaves no lock behind)."""
        heartbeat, self._heartbeat = self._heartbeat, None
        try:
            if self.path is not None:
                self.path.unlink(missing_ok=True)
                self.path = None
        finally:
            if heartbeat is not None:
                heartbeat.stop()


def _safe(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.]", "_", text) or "host"
