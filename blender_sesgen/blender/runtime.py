"""Running Blender from Python: which scene is current, and Blender's own console output."""
from __future__ import annotations

import contextlib
import os
import re
import sys
import tempfile

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


# Cycles' lines when it looks for a GPU backend whose library this machine lacks (CUDA's
# wrangler on every machine without an NVIDIA driver): expected on a CPU render, not news
BACKEND_PROBE_NOISE = re.compile(rb"\b[A-Z]+EW initialization failed\b")


@contextlib.contextmanager
def probing_devices():
    """Around a call that makes Cycles enumerate its devices (``get_devices*``, the denoiser
    enum, which asks for OptiX): the C library writes to the process's stdout/stderr file
    descriptors, so both are captured at the fd level and written back afterwards without
    the backend-loading lines (:data:`BACKEND_PROBE_NOISE`); every other line -- a real
    error -- still reaches its stream."""
    streams = []
    for stream in (sys.stdout, sys.stderr):
        try:
            fd = stream.fileno()
        except (AttributeError, OSError, ValueError):
            continue
        stream.flush()
        streams.append((fd, os.dup(fd), tempfile.TemporaryFile()))
    try:
        for fd, _, capture in streams:
            os.dup2(capture.fileno(), fd)
        yield
    finally:
        for fd, saved, capture in streams:
            os.dup2(saved, fd)
            os.close(saved)
            capture.seek(0)
            kept = [line for line in capture.read().splitlines(keepends=True) if not BACKEND_PROBE_NOISE.search(line)]
            capture.close()
            if kept:
                os.write(fd, b"".join(kept))
