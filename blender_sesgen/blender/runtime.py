"""Running Blender from Python: which scene is current, and Blender's own console output."""
from __future__ import annotations

import contextlib
import os
import sys

import bpy


def activate(bscene) -> None:
    """Make ``bscene`` the scene of the window(s): Blender evaluates animation (and the
    render operator picks its frame) from the context scene, even in background mode."""
    wm = bpy.context.window_manager
    for w in (wm.windows if wm is not None else []):
        if w.scene != bscene:
            w.scene = bscene


@contextlib.contextmanager
def quiet_stdout(enabled: bool = True):
    """Silence Blender's C-level stdout (per-tile render lines, importer chatter)."""
    if not enabled:
        yield
        return
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):
        yield
        return
    sys.stdout.flush()
    saved = os.dup(fd)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, fd)
        yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)
        os.close(devnull)
