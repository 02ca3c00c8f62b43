"""The farm without Ray: the part of Ray's task API that the farm's driver and a study's task
graph use -- remote functions and actors, ``wait``, ``get``, ``cancel`` -- run by threads of
this process (``study run --no-ray``, and a study with nothing left to render or run, which
then starts no Ray at all).

Every task's work is a child process (a render, an export, a system under test), so threads
run tasks side by side as Ray's workers do: a task starts when the tasks whose results it
takes have ended and its CPUs are free (``num_cpus`` of at most ``cpus``; 0 starts at once).
A task whose input task raised raises the same error, as on Ray. ``cancel`` stops a task
that has not started; a running one gets a KeyboardInterrupt in its thread, as a Ray worker
gets it from a cancel (the farm's and the study's task bodies stop their child process on
it). What Ray adds and this does not: other machines, and retries of a lost worker (a thread
is not lost: when this process dies, its children die with it, ``farm.child``).
"""
from __future__ import annotations

import ctypes
import threading
import time
from concurrent.futures import FIRST_COMPLETED, Future, wait as wait_futures
from typing import Any, Callable, Optional

from .cancels import TaskCancel, running


class TaskCancelledError(RuntimeError):
    """``get`` of a task that was cancelled."""


class Ref:
    """A task's result to come (Ray's ObjectRef)."""

    def __init__(self, label: str):
        self.future: Future = Future()
        self.label = label
        self.thread: Optional[threading.Thread] = None
        self.cancel = TaskCancel()   # a running task's cancel (farm.cancels)

    def __repr__(self) -> str:
        return f"Ref({self.label})"


class _Task:
    def __init__(self, ref: Ref, fn: Callable, args: tuple, cpus: float):
        self.ref, self.fn, self.args, self.cpus = ref, fn, args, cpus

    def ready(self) -> bool:
        return all(a.future.done() for a in self.args if isinstance(a, Ref))


class _Remote:
    """``ray.remote(fn)``: ``.options(num_cpus=...).remote(*args)`` submits a call."""

    def __init__(self, pool: "LocalRay", fn: Callable, num_cpus: float = 1.0):
        self.pool, self.fn, self.num_cpus = pool, fn, num_cpus

    def options(self, num_cpus: Optional[float] = None, **_ignored) -> "_Remote":
        return _Remote(self.pool, self.fn, self.num_cpus if num_cpus is None else num_cpus)

    def remote(self, *args) -> Ref:
        return self.pool.submit(self.fn, args, self.num_cpus)


class _ActorClass:
    """``ray.remote(cls)``: ``.remote(*args)`` makes an actor whose method calls run one at a time."""

    def __init__(self, cls: type):
        self.cls = cls

    def options(self, **_ignored) -> "_ActorClass":
        return self

    def remote(self, *args, **kw) -> "_Actor":
        return _Actor(self.cls(*args, **kw))


class _Actor:
    def __init__(self, obj: Any):
        self._obj, self._lock = obj, threading.Lock()

    def __getattr__(self, name: str):
        method = getattr(self._obj, name)
        lock = self._lock

        class _Method:
            @staticmethod
            def remote(*args, **kw) -> Ref:
                ref = Ref(name)
                with lock:
                    try:
                        ref.future.set_result(method(*args, **kw))
                    except Exception as e:  # noqa: BLE001 - the caller's get raises it, as on Ray
                        ref.future.set_exception(e)
                return ref

        return _Method


class LocalRay:
    """The subset of the ``ray`` module the farm uses, on ``cpus`` CPUs of this process."""

    def __init__(self, cpus: float):
        self.cpus = float(cpus)
        self._free = self.cpus
        self._queue: list[_Task] = []
        self._lock = threading.Lock()
        self._open = True

    # --- ray's module functions ----------------------------------------------------------
    def remote(self, *fn, num_cpus: float = 1.0, **_ignored):
        """``remote(fn)``, ``remote(cls)``, or ``remote(num_cpus=...)`` as a decorator."""
        if not fn:
            return lambda f: self.remote(f, num_cpus=num_cpus)
        return _ActorClass(fn[0]) if isinstance(fn[0], type) else _Remote(self, fn[0], num_cpus)

    def wait(self, refs: list, num_returns: int = 1, timeout: Optional[float] = None) -> tuple[list, list]:
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            done = [r for r in refs if r.future.done()]
            left = None if deadline is None else deadline - time.monotonic()
            if len(done) >= num_returns or (left is not None and left <= 0):
                ready = done[:num_returns]
                return ready, [r for r in refs if r not in ready]
            wait_futures([r.future for r in refs if not r.future.done()], timeout=left,
                         return_when=FIRST_COMPLETED)

    def get(self, ref: Ref, timeout: Optional[float] = None):
        return ref.future.result(timeout)

    def cancel(self, ref: Ref, force: bool = False) -> None:
        with self._lock:
            queued = next((t for t in self._queue if t.ref is ref), None)
            if queued is not None:
                self._queue.remove(queued)
        if queued is not None:
            ref.future.set_exception(TaskCancelledError(f"task {ref.label} cancelled"))
            self._dispatch()
        elif not ref.future.done():
            # asked first: a task taken off the queue whose thread has not started yet sees it
            # as it starts (``_run``; the farm cancels a failed scene's tasks once -- Ray repeats
            # a cancel, this runner does not -- and such a task rendered its whole chunk); the
            # interrupt only while the task's body runs (not after it returned, where it broke
            # the settling of its result: ``get`` waited forever, its CPUs never freed)
            with ref.cancel.lock:   # (held while raising: the task cannot enter cancels_polled between)
                ref.cancel.asked.set()
                if ref.cancel.in_body and not ref.cancel.polled:
                    _raise_in(ref.thread, KeyboardInterrupt)

    def is_initialized(self) -> bool:
        return self._open

    def shutdown(self) -> None:
        """Cancel what has not started (running tasks end with their child processes)."""
        self._open = False
        with self._lock:
            queued, self._queue = self._queue, []
        for t in queued:
            t.ref.future.set_exception(TaskCancelledError(f"task {t.ref.label} cancelled: shut down"))

    # --- scheduling --------------------------------------------------------------------
    def submit(self, fn: Callable, args: tuple, num_cpus: float) -> Ref:
        ref = Ref(getattr(fn, "__name__", "task"))
        task = _Task(ref, fn, args, min(float(num_cpus), self.cpus))
        for a in args:
            if isinstance(a, Ref):
                a.future.add_done_callback(lambda _f: self._dispatch())
        with self._lock:
            self._queue.append(task)
        self._dispatch()
        return ref

    def _dispatch(self) -> None:
        """Start every queued task whose inputs are done and whose CPUs are free, in order."""
        start = []
        with self._lock:
            for t in list(self._queue):
                if t.ready() and t.cpus <= self._free:
                    self._queue.remove(t)
                    self._free -= t.cpus
                    start.append(t)
        for t in start:
            t.ref.thread = threading.Thread(target=self._run, args=(t,), name=f"sesgen-task-{t.ref.label}",
                                            daemon=True)
            t.ref.thread.start()

    def _run(self, t: _Task) -> None:
        try:
            failed = next((a.future.exception() for a in t.args if isinstance(a, Ref) and a.future.exception()),
                          None)
            if failed is not None:
                raise failed
            cancel = t.ref.cancel
            with running(cancel):
                with cancel.lock:
                    if cancel.asked.is_set():   # cancelled before it started
                        raise KeyboardInterrupt
                    cancel.in_body = True
                try:
                    result = t.fn(*[a.future.result() if isinstance(a, Ref) else a for a in t.args])
                finally:   # (an interrupt decided before this lands here at the latest: still in the try)
                    with cancel.lock:
                        cancel.in_body = False
        except BaseException as e:  # noqa: BLE001 - a KeyboardInterrupt here is this task's cancel
            error = TaskCancelledError(f"task {t.ref.label} cancelled") if isinstance(e, KeyboardInterrupt) else e
            self._finish(t, lambda: t.ref.future.set_exception(error))
        else:
            self._finish(t, lambda: t.ref.future.set_result(result))

    def _finish(self, t: _Task, settle: Callable[[], None]) -> None:
        with self._lock:
            self._free += t.cpus
        settle()
        self._dispatch()


def _raise_in(thread: threading.Thread, exc: type) -> None:
    """Raise ``exc`` in ``thread`` at its next Python instruction (CPython)."""
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread.ident), ctypes.py_object(exc))


class LocalCluster:
    """:class:`farm.cluster.Cluster`'s interface over :class:`LocalRay` (this machine, no Ray)."""

    address = None
    runtime_env = None
    started_local = False

    def __init__(self, num_cpus: Optional[int] = None):
        from .cluster import local_cpus
        self.num_cpus = num_cpus
        self.ray = LocalRay(num_cpus or local_cpus())

    def start(self) -> "LocalCluster":
        return self

    def stop(self) -> None:
        self.ray.shutdown()

    def __enter__(self) -> "LocalCluster":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def totals(self) -> tuple[float, float]:
        return self.ray.cpus, 0.0

    def largest_node(self) -> tuple[float, float]:
        return self.totals()

    def alive_nodes(self) -> list[dict]:
        return [{"Alive": True, "NodeID": "local", "Resources": {"CPU": self.ray.cpus}}]

    def describe(self) -> str:
        return f"this process, no Ray: {self.ray.cpus:g} CPU(s)"

    def here(self):
        return None
