"""The body of one farm task: render one chunk of one scene in a subprocess (stdlib only).

:func:`run_chunk` runs the render command (``work.render_argv``) with ``--progress json``,
relays every JSON event it prints to ``report`` (the farm's progress across tasks) and keeps
its other output lines for the failure report. It returns a plain dict (picklable, the
task's result): the exit status, the host and pid of the render, the output tail.

If the render dies by a signal (SIGKILL, the OOM killer) its lock on the frames stays
behind; this process knows it is dead and removes it, so that the retry -- on any host --
can take the frames at once. If the task itself is cancelled (Ray's KeyboardInterrupt in the
worker, or its cancel flag) the render gets SIGINT and stops between views like a Ctrl-C'd
render; a task cancelled before its render started ends cancelled (KeyboardInterrupt).
"""
from __future__ import annotations

import contextlib
import json
import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
from collections import deque
from pathlib import Path
from typing import Callable, Optional

from .cancels import cancel_asked, cancels_polled
from .child import PARENT_ENV
from .work import ERROR_TAIL

INTERRUPT_GRACE_S = 60.0   # after SIGINT, how long a render may take to finish its view


POLL_S = 0.2               # how often a task watching its render asks whether it was cancelled


def run_chunk(argv: list[str], key: str, out: str, report: Optional[Callable[[dict], None]] = None,
              env: Optional[dict] = None, cancelled: Callable[[], bool] = lambda: False) -> dict:
    """Run one chunk's render ``argv`` (the key names the chunk in reports; ``out`` is its
    render folder) and return its result dict (see the module docstring). ``cancelled()``:
    Ray's cancel flag, for a cancel whose interrupt was not raised (it came before the task
    could take it).

    A cancel is taken at whatever instant it comes. In the main thread (a Ray task) SIGINT --
    the KeyboardInterrupt of Ray's cancel -- only records the request for the length of the
    call; the task asks that record and ``cancelled()`` before it starts the render (a cancel
    by then: KeyboardInterrupt, no render) and every POLL_S while it runs (its output is read
    by a thread), and stops it (``_stop``). An interrupt raised where it came (Python's
    handler) once landed between the render's start and the ``try`` that stops it, or in the
    stop before its SIGINT: the task ended cancelled and its render, whose parent lives on,
    rendered the whole folder; and a task blocked reading a render that printed nothing
    (loading Blender, building a scene) took a cancel only at the next line."""
    send = report or (lambda msg: None)
    host = socket.gethostname()
    t0 = time.monotonic()
    proc_env = dict(os.environ if env is None else env)
    proc_env[PARENT_ENV] = str(os.getpid())
    proc_env.setdefault("PYTHONUNBUFFERED", "1")
    tail: deque[str] = deque(maxlen=ERROR_TAIL)
    frames_done = 0

    def take(line: str) -> None:
        nonlocal frames_done
        event = _event(line)
        if event is None:
            if line.strip():
                tail.append(line.rstrip("\n"))
            return
        if event.get("event") == "progress":
            frames_done += 1
        send({"kind": "event", "key": key, "event": event})

    with _recorded_interrupts() as interrupt:
        def stop_asked() -> str:
            return "interrupt" if interrupt.requested else "cancel flag" if cancelled() else ""

        if stop_asked():   # cancelled before its render: nothing to stop (Ray: TaskCancelledError)
            raise KeyboardInterrupt
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, errors="replace", env=proc_env)
        lines, rc, why, eof = _read_lines(proc), None, "", False
        _after_spawn(proc)   # (before the ``try`` that stops it: a cancel here must not be lost)
        try:
            send({"kind": "started", "key": key, "host": host, "pid": proc.pid})
            why = stop_asked()
            while not (why or eof):
                try:
                    line = lines.get(timeout=POLL_S)
                except queue.Empty:
                    if proc.poll() is not None:   # ended, its output held open by another process
                        break
                    why = stop_asked()
                    continue
                eof = line is _EOF
                if not eof:
                    take(line)
                    why = stop_asked()
            while not why:
                try:
                    rc = proc.wait(POLL_S)
                    break
                except subprocess.TimeoutExpired:
                    why = stop_asked()
        except KeyboardInterrupt:   # an interrupt raised in the task's thread all the same (another caller's)
            why = "interrupt"
        if why:
            rc = _stop(proc)
        for line in () if eof else _drain(lines):   # what it printed as it stopped (a frame it finished)
            take(line)
        if rc is not None and rc < 0:   # killed: it cannot release its lock, we know it is dead
            _drop_lock(out, host, proc.pid)
    return {"key": key, "rc": rc, "host": host, "pid": proc.pid, "tail": list(tail),
            "frames_done": frames_done, "wall_s": round(time.monotonic() - t0, 3), "cancelled": bool(why),
            "stopped_by": why}


# A test's hook (None: nothing): called with the render's Popen as soon as it has started, in the
# task's process -- tests/test_farm_ray.py and tests/test_farm_local.py park a task there and cancel it.
_after_spawn_hook: Optional[Callable[[subprocess.Popen], None]] = None


def _after_spawn(proc: subprocess.Popen) -> None:
    if _after_spawn_hook is not None:
        _after_spawn_hook(proc)


_EOF = object()   # the end of a render's output, in its queue of lines


class _Interrupts:
    requested = False


@contextlib.contextmanager
def _recorded_interrupts():
    """SIGINT sets ``requested`` instead of raising, within the block (main thread; in another
    thread -- farm.local's tasks -- a cancel likewise only sets the task's flag, which
    ``_cancel_requested`` asks, instead of raising KeyboardInterrupt there: farm.cancels)."""
    rec = _Interrupts()
    if threading.current_thread() is not threading.main_thread():
        with cancels_polled():
            yield rec
        return

    def record(signum, frame) -> None:
        rec.requested = True
    saved = signal.signal(signal.SIGINT, record)
    try:
        yield rec
    finally:   # (None: a handler not set from Python, which cannot be put back; Python's then)
        signal.signal(signal.SIGINT, signal.default_int_handler if saved is None else saved)


def _read_lines(proc: subprocess.Popen) -> "queue.Queue":
    """The render's output lines, read by a thread (_EOF at its end) so that the task is never
    blocked on a render that prints nothing, and the render never on a full pipe while it stops."""
    lines: queue.Queue = queue.Queue()

    def pump() -> None:
        try:
            for line in proc.stdout:
                lines.put(line)
        except (OSError, ValueError):   # closed under it
            pass
        finally:
            proc.stdout.close()
            lines.put(_EOF)
    threading.Thread(target=pump, name=f"sesgen-render-{proc.pid}-output", daemon=True).start()
    return lines


def _drain(lines: "queue.Queue", wait_s: float = 2.0):
    """The lines still to come once the render has ended, up to its end of output (or ``wait_s``
    without a line: another process still holds its output open)."""
    while True:
        try:
            line = lines.get(timeout=wait_s)
        except queue.Empty:
            return
        if line is _EOF:
            return
        yield line


def _event(line: str) -> Optional[dict]:
    s = line.strip()
    if not (s.startswith("{") and s.endswith("}")):
        return None
    try:
        ev = json.loads(s)
    except ValueError:
        return None
    return ev if isinstance(ev, dict) and "event" in ev else None


def _stop(proc: subprocess.Popen) -> Optional[int]:
    """SIGINT to the render, then wait for it to end (its exit 130) for up to
    INTERRUPT_GRACE_S; killed after that. Further interrupts while it stops are Ray's: Ray
    repeats a cancel every ``cancellation_retry_ms`` (2 s) until the task ends, so under load
    a render still loading Blender got a second one and was killed (exit -9, its chunk retried)."""
    deadline = time.monotonic() + INTERRUPT_GRACE_S
    proc.send_signal(signal.SIGINT)
    while True:
        try:
            return proc.wait(max(deadline - time.monotonic(), 0.0))
        except subprocess.TimeoutExpired:
            proc.kill()
            return proc.wait()
        except KeyboardInterrupt:   # a repeated cancel: the render is already stopping
            continue


def _drop_lock(out: str, host: str, pid: int) -> None:
    try:
        from ..render.folder import OutputFolder
        OutputFolder(Path(out)).drop_lock_of(host, pid)
    except Exception as e:  # noqa: BLE001 - the retry still takes a stale lock over (same host) or waits
        print(f"sesgen farm: could not remove the lock of killed render {pid}: {e}", file=sys.stderr)


def task(args: list[str], key: str, out: str, inbox=None, scene: Optional[str] = None) -> dict:
    """The Ray task: the render command ``args`` (``work.render_args``) run by this node's
    Python through :mod:`.child`, reporting to the driver's inbox actor (one message per
    event, fire and forget). A node that cannot see the scene or ROOT (not on a shared
    filesystem) answers as a user error, without starting Blender."""
    unseen = [p for p in (scene, str(Path(out).parent)) if p and not os.path.exists(p)]
    if unseen:
        return {"key": key, "rc": 2, "host": socket.gethostname(), "pid": 0, "frames_done": 0, "wall_s": 0.0,
                "cancelled": False,
                "tail": [f"error: node {socket.gethostname()} cannot see {unseen[0]}: ROOT and the scripts must be "
                         "on a filesystem every node mounts at the same path"]}
    report = None
    if inbox is not None:
        def report(msg: dict) -> None:
            inbox.put.remote(msg)
    sigint_raises()
    return run_chunk([sys.executable, "-m", "blender_sesgen.commands.farm_child", *args], key, out, report,
                     cancelled=_cancel_requested)


# The farm's Ray workers run sigint_raises() as they start (farm.cluster's ray.init).
WORKER_SETUP = {"worker_process_setup_hook": "blender_sesgen.farm.chunk.sigint_raises"}


def sigint_raises() -> None:
    """SIGINT raises KeyboardInterrupt in this Ray worker, as in a worker of a Ray started in the
    foreground; run by every task and, as they start, by the farm's workers (``WORKER_SETUP``).
    Ray cancels a running task by raising KeyboardInterrupt in its worker's main thread, which
    does nothing while SIGINT is ignored -- as it is in every worker of a Ray started by a
    process that ignores it (a farm or a test run started in the background: a shell's ``&``
    ignores SIGINT): the render then rendered to its end and exited 0. And Ray's own deferral of
    a cancel while a task deserialises its arguments calls the saved handler -- then
    ``Handlers.SIG_IGN`` -- and fails with TypeError instead of cancelling. The handler is kept
    after the task (restoring "ignored" raced a late cancel the same way); a cancel that came
    before it is seen by :func:`_cancel_requested`."""
    if threading.current_thread() is threading.main_thread() and \
            signal.getsignal(signal.SIGINT) in (signal.SIG_IGN, signal.SIG_DFL, None):
        signal.signal(signal.SIGINT, signal.default_int_handler)


def _cancel_requested() -> bool:
    """Whether Ray was asked to cancel this task (its flag; also set when the interrupt itself
    was lost because SIGINT was still ignored), or farm.local to cancel the task this thread
    runs (farm.cancels). False outside a task."""
    if cancel_asked():
        return True
    ray = sys.modules.get("ray")    # never imported here, nor started: get_runtime_context() would start a Ray
    if ray is None or not ray.is_initialized():
        return False
    try:
        return bool(ray.get_runtime_context().is_canceled())
    except Exception:  # noqa: BLE001 - not a Ray worker (a driver's thread: farm.local)
        return False


def verify_task(out: str) -> dict:
    """The Ray task run when every chunk of a folder has ended: the completion logs taken
    into the manifest, then every frame recorded complete checked against its checksum
    (``verify --quick``), and the folder's own files (the manifest's seal, scene.ses, the
    trajectories...); bad frames are recorded as not rendered. Returns the frames still to
    render and what was wrong (``bad`` per frame, ``folder`` for the folder's own files)."""
    from ..contract.errors import ContractError
    from ..contract.manifest import Manifest
    from ..render.folder import OutputFolder
    folder = OutputFolder(Path(out))
    try:
        folder.consolidate()
    except ContractError as e:   # a manifest edited since (its seal): a chunk's --resume writes it again
        return {"out": out, "missing": [], "bad": [], "folder": [str(e)], "frames": 0}
    bad = folder.verify(full=False)
    frames = sorted({k for k, _ in bad if k is not None})
    if frames:
        folder.mark_incomplete(frames)
    m = Manifest.read(Path(out))
    missing = [k for k in range(m.frames) if not m.frames_complete[k]]
    return {"out": out, "missing": missing, "bad": [[k, why] for k, why in bad if k is not None],
            "folder": [why for k, why in bad if k is None], "frames": m.frames}
