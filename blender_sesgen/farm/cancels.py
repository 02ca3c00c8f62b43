"""A running task's cancel as a flag the task asks, for tasks run by threads of this process
(farm.local, the task runner without Ray). A cancel raised as KeyboardInterrupt in the task's
thread lands wherever the thread is: between a render's start and the code that stops it, the
task ended cancelled and its render was left to the kernel (farm.chunk.run_chunk). Within
``cancels_polled`` a cancel only sets the flag, which the task asks (``cancel_asked``)."""
from __future__ import annotations

import contextlib
import threading


class TaskCancel:
    """One running task's cancel: ``asked`` once cancelled; ``polled`` while the task asks it
    (the runner then raises nothing in its thread); ``in_body`` while the task's own code runs
    (the only place an interrupt may land); ``lock`` held by both while they decide."""

    def __init__(self):
        self.asked = threading.Event()
        self.polled = False
        self.in_body = False
        self.lock = threading.Lock()


_RUNNING: dict[int, TaskCancel] = {}   # thread id -> the cancel of the task it runs


@contextlib.contextmanager
def running(cancel: TaskCancel):
    """This thread runs the task whose cancel is ``cancel``, for the block."""
    _RUNNING[threading.get_ident()] = cancel
    try:
        yield
    finally:
        _RUNNING.pop(threading.get_ident(), None)


def cancel_asked() -> bool:
    """Whether the task this thread runs was cancelled (False outside one)."""
    cancel = _RUNNING.get(threading.get_ident())
    return cancel is not None and cancel.asked.is_set()


@contextlib.contextmanager
def cancels_polled():
    """Within the block a cancel of this thread's task only sets its flag (see the module's
    docstring). Outside a task run by a thread of this process: nothing."""
    cancel = _RUNNING.get(threading.get_ident())
    if cancel is None:
        yield
        return
    with cancel.lock:
        cancel.polled = True
    try:
        yield
    finally:
        with cancel.lock:
            cancel.polled = False
