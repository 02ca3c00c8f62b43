"""Sealing frames off the render's critical path, in a worker process (pure: stdlib only).

After Blender has written a frame's EXRs under temporary names, ``output.seal_frame`` reads
each file back, checks it, rewrites it without its wall-clock header fields and hashes it:
~4 % of a ``gt`` frame's CPU time at 640x480 (measured). A :class:`Sealer` runs that for
frame k in one worker process while frame k+1 renders; the rendering process then only
moves the sealed files into place and records the frame (``job.RenderJob.run``).

A process, not a thread: a Python thread running beside bpy crashed Blender (2 of 7 runs of
1000 frames segfaulted inside the thread's own pure-Python code; none of 5 without it), as
bpy is not thread-safe even towards threads that never call it. Not ``multiprocessing``
either: its ``spawn`` re-imports the caller's main script, which would render again in a
user's script without a ``__main__`` guard. The worker is ``python -m blender_sesgen.render.sealer``
(the same interpreter; inside Blender its bundled Python), in its own session so that Ctrl-C
reaches only the rendering process, fed one JSON line per frame and answering one per
frame, in order. If it cannot be started or dies, sealing happens in the rendering process.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import Future
from pathlib import Path
from typing import Callable, Optional

PACKAGE_ROOT = Path(__file__).resolve().parents[2]   # the folder holding the blender_sesgen package


class WorkerGone(RuntimeError):
    """The worker process exited (its frame is sealed in the rendering process instead)."""


def run_here(fn: Callable, *args) -> Future:
    """``fn(*args)`` run now, as a completed Future."""
    f: Future = Future()
    try:
        f.set_result(fn(*args))
    except BaseException as e:  # noqa: BLE001 - handed to .result()
        f.set_exception(e)
    return f


def _python_interpreter() -> bool:
    """Inside Blender ``sys.executable`` is its bundled Python: never start a second Blender."""
    return os.path.basename(sys.executable or "").lower().startswith("python")


class _Answer:
    """The worker's answer for one submitted frame (answers come in submission order)."""

    def __init__(self, sealer: "Sealer"):
        self._sealer = sealer
        self._value = None
        self._done = False

    def result(self):
        while not self._done:
            self._sealer._read_next()
        if isinstance(self._value, BaseException):
            raise self._value
        return self._value


class Sealer:
    """``with Sealer() as s: a = s.submit(k, temps, channels); sums = a.result()``."""

    def __init__(self, enabled: bool = True):
        self._proc: Optional[subprocess.Popen] = None
        self._waiting: list[_Answer] = []
        if enabled and _python_interpreter():
            env = dict(os.environ)
            env["PYTHONPATH"] = os.pathsep.join([str(PACKAGE_ROOT)] + [p for p in sys.path if p])
            try:
                self._proc = subprocess.Popen([sys.executable, "-m", "blender_sesgen.render.sealer"], stdin=subprocess.PIPE,
                                              stdout=subprocess.PIPE, text=True, env=env, start_new_session=True)
            except OSError:
                self._proc = None

    @property
    def in_background(self) -> bool:
        return self._proc is not None

    def submit(self, k: int, written: dict, required_channels: tuple):
        """Seal frame ``k`` (``output.seal_frame``) in the worker, or here without one."""
        from .folder import seal_frame
        if self._proc is not None:
            try:
                line = json.dumps({"k": int(k), "written": {v: str(p) for v, p in written.items()},
                                   "channels": list(required_channels)})
                self._proc.stdin.write(line + "\n")
                self._proc.stdin.flush()
                answer = _Answer(self)
                self._waiting.append(answer)
                return answer
            except (OSError, ValueError):
                self._fail(WorkerGone("the sealing worker exited"))
        return run_here(seal_frame, k, written, tuple(required_channels))

    def _read_next(self) -> None:
        answer = self._waiting.pop(0)
        line = self._proc.stdout.readline() if self._proc is not None else ""
        if not line:
            answer._value, answer._done = WorkerGone("the sealing worker exited"), True
            self._fail(answer._value)
            return
        msg = json.loads(line)
        if "error" in msg:
            from .folder import RenderWriteError
            answer._value = RenderWriteError(msg["error"]) if msg.get("kind") == "write" else RuntimeError(msg["error"])
        else:
            answer._value = msg["sums"]
        answer._done = True

    def _fail(self, error: BaseException) -> None:
        for a in self._waiting:
            a._value, a._done = error, True
        self._waiting = []
        self.close()

    def close(self) -> None:
        proc, self._proc = self._proc, None
        if proc is not None:
            try:
                proc.stdin.close()
            except OSError:
                pass
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()

    def __enter__(self) -> "Sealer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _serve() -> int:
    """The worker: one JSON request per line on stdin, one answer per line on stdout."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from .folder import RenderWriteError, seal_frame
    for line in sys.stdin:
        req = json.loads(line)
        try:
            sums = seal_frame(int(req["k"]), {v: Path(p) for v, p in req["written"].items()}, tuple(req["channels"]))
            out = {"sums": sums}
        except RenderWriteError as e:
            out = {"error": str(e), "kind": "write"}
        except Exception as e:  # noqa: BLE001 - reported to the rendering process
            out = {"error": f"sealing frame {req.get('k')} failed: {type(e).__name__}: {e}"}
        sys.stdout.write(json.dumps(out) + "\n")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(_serve())
