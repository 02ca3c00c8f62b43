"""Who is writing into a render folder, as its readers and writers judge it (pure: stdlib).

A running render holds ``.sesgen/lock-<host>-<pid>.json`` (``{"host", "pid", "frames":
[first, last], "started", "scene_sha256", "settings"}``; written by ``render.locks``). A lock
is stale -- its writer is gone -- when its process is gone or has ended unreaped (same host),
or when its file has not been touched for ``STALE_LOCK_S`` (another host: a live writer
touches it with each completed frame, and a heartbeat process between frames,
``render.heartbeat``). :func:`live_locks` is the read-only look a reader takes (an export
refuses frames a live writer is still writing); ``render.locks`` removes stale ones.
"""
from __future__ import annotations

import json
import os
import socket
import time
from pathlib import Path

from .inputs import read_text
from .errors import ContractError

STALE_LOCK_S = 900.0  # a lock of another host not refreshed for this long is taken over
LOCK_GLOB = "lock-*.json"


def zombie(pid: int) -> bool:
    """A process that has ended but not been reaped yet (Linux): a render orphaned by a killed
    farm worker stays one until its new parent reaps it, and it will never release a lock."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read()
    except OSError:
        return False
    state = stat[stat.rfind(b")") + 2:][:1]   # the field after "(comm)", which may hold spaces
    return state in (b"Z", b"X")


def stale(host: str, pid: int, path: Path) -> bool:
    """A lock whose writer is gone: this host and no such process (or a zombie), or not
    refreshed for STALE_LOCK_S (another host)."""
    if host == socket.gethostname():
        if pid == os.getpid():
            return False
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        except PermissionError:
            return False
        return zombie(pid)
    try:
        return time.time() - Path(path).stat().st_mtime > STALE_LOCK_S
    except OSError:
        return True


def read_lock(path: Path):
    """(info dict, host, pid) of a lock file, or None when it is not one (unreadable, torn)."""
    try:   # a regular file of bounded size (a FIFO there must not block)
        info = json.loads(read_text(path, 1 << 16, "lock"))
        return info, str(info["host"]), int(info["pid"])
    except (ContractError, ValueError, KeyError, TypeError):
        return None


def live_locks(root) -> list[dict]:
    """The locks of the writers alive in render folder ``root`` (read only: a stale or torn
    lock is skipped, not removed), each its dict with ``frames`` checked to be [first, last]."""
    from .manifest import STATE_DIR
    state = Path(root) / STATE_DIR
    out = []
    if not state.is_dir():
        return out
    for path in sorted(state.glob(LOCK_GLOB)):
        lock = read_lock(path)
        if lock is None or stale(lock[1], lock[2], path):
            continue
        frames = lock[0].get("frames")
        if isinstance(frames, list) and len(frames) == 2 and all(isinstance(f, int) for f in frames):
            out.append(lock[0])
    return out
