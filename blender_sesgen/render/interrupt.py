"""Ctrl-C that works while Cycles renders (pure: signal + stdlib).

Cycles runs the render in C and only calls back into Python now and then; a KeyboardInterrupt
raised in such a callback is printed and swallowed by Blender, and the render carries on.
So, for the length of a render, SIGINT (and SIGTERM) only *record* the request; the render
loop asks :attr:`StopRequest.requested` between views and stops cleanly there: the frame in
progress is dropped (its temporary files removed), every completed frame stays, the folder
is resumable, and the command exits 130. Around a farm or a study (renders in child processes),
:func:`sigterm_as_interrupt` makes SIGTERM a Ctrl-C.
"""
from __future__ import annotations

import contextlib
import signal
import threading


class StopRequest:
    def __init__(self):
        self.requested = False
        self.signal_name = ""

    def __call__(self, signum, frame):
        if self.requested and signum == signal.SIGINT:  # a second Ctrl-C: stop at once
            raise KeyboardInterrupt
        self.requested = True
        self.signal_name = signal.Signals(signum).name


@contextlib.contextmanager
def deferred_interrupts():
    """Within the block, SIGINT/SIGTERM set ``StopRequest.requested`` instead of raising
    (main thread only; elsewhere nothing changes and ``requested`` stays False)."""
    stop = StopRequest()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    saved = {s: signal.signal(s, stop) for s in (signal.SIGINT, signal.SIGTERM)}
    before = saved[signal.SIGINT]
    if isinstance(before, StopRequest) and before.requested:   # asked before the block (a farm's render child
        stop.requested, stop.signal_name = True, before.signal_name   # records a cancel while it starts)
    try:
        yield stop
    finally:
        for s, handler in saved.items():
            signal.signal(s, handler)


@contextlib.contextmanager
def sigterm_as_interrupt():
    """SIGTERM stops a farm or a study like Ctrl-C: every render stops between views (main thread)."""
    def handler(signum, frame):
        raise KeyboardInterrupt
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    saved = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, saved)
