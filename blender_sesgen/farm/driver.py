"""The farm's scheduling loop: chunks as Ray tasks, retries, one progress line across all
tasks, verification of every finished folder, and the summary.

- Chunks are submitted scene after scene (early scenes finish early), a window of about two
  per slot in flight, so that a retry goes to the front of the queue.
- A chunk whose render is lost (exit 1, killed by a signal, its worker or node gone) is run
  again, up to ``retries`` times; it resumes where the lost one stopped. A user error
  (exit 2: a bad script, a folder holding something else) is not retried: its scene fails
  with the error line, its other chunks are cancelled, the other scenes go on.
- When every chunk of a scene has ended, a verify task takes the completion logs into the
  manifest and checks every frame against its checksum (``verify --quick``); frames still
  missing or bad are rendered again (within the same retry budget).
- A scene whose auto-exposure still has to be metered (``AUTOEXPOSURE``, no metering in its
  folder yet) starts with its last chunk alone (a render meters the frames before its last,
  so the last chunk's pass holds every frame any other chunk needs); the others are held until
  that chunk has written a frame (the metering is then in the manifest, where every other
  chunk reads it) or has ended: the metering pass runs once per scene, not once per chunk.
- Progress: every render prints ``--progress json`` events; each ``progress`` event (a frame
  written) counts one frame of the farm's total, and the verify step corrects the count.
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from typing import Optional, Sequence

from ..contract.progress import Progress
from .chunk import INTERRUPT_GRACE_S, task as chunk_task, verify_task
from .cluster import Cluster
from .work import FarmScene, Outcome, describe_exit, error_line, frame_ranges, outcome_of, render_args

WAIT_S = 0.5
RESOURCES_EVERY_S = 5.0


@dataclass
class Chunk:
    scene: FarmScene
    a: int
    b: int
    attempt: int = 0
    serial: int = 0           # set when submitted: tells tries of the same chunk apart

    @property
    def key(self) -> str:
        return f"{self.scene.name}[{self.a}:{self.b}]"

    @property
    def task_id(self) -> str:
        """The key of this try of the chunk (messages of an earlier, lost try may still arrive)."""
        return f"{self.key}#{self.serial}"


@dataclass
class SceneState:
    scene: FarmScene
    open_chunks: int = 0
    repairs: int = 0
    counted: int = 0                    # frames the progress has counted for this scene
    failed: Optional[str] = None        # why it failed
    user_error: bool = False
    complete: bool = False
    missing: list = field(default_factory=list)
    held: list = field(default_factory=list)     # chunks waiting for the last chunk's metering


@dataclass
class FarmResult:
    states: list
    retried: int
    frames_rendered: int
    wall_s: float
    interrupted: bool = False

    @property
    def complete(self) -> list:
        return [s for s in self.states if s.complete]

    @property
    def failed(self) -> list:
        return [s for s in self.states if not s.complete]


class Farm:
    """One farm run over prepared scenes (``FarmScene`` with plan and pending frames)."""

    def __init__(self, cluster: Cluster, scenes: Sequence[FarmScene], *, chunk: int, retries: int,
                 cpus_per_task: float, gpus_per_task: float, threads: int, forwarded: Sequence[str],
                 progress_mode: str = "auto", stream=None):
        self.cluster, self.ray = cluster, cluster.ray
        self.states = [SceneState(s) for s in scenes]
        self.chunk, self.retries = int(chunk), int(retries)
        self.cpus, self.gpus, self.threads = float(cpus_per_task), float(gpus_per_task), int(threads)
        self.forwarded = list(forwarded)
        self.progress_mode, self.stream = progress_mode, stream
        self.queue: deque[Chunk] = deque()
        self.running: dict = {}            # ObjectRef -> Chunk
        self.verifying: dict = {}          # ObjectRef -> SceneState
        self.writers: dict = {}            # task id -> (host, pid) of its render
        self.rendering: set = set()        # task ids of the chunks whose render has started
        self.live_ids: set = set()         # task ids submitted and not ended
        self.retried = 0
        self.frames_rendered = 0
        self.interrupted = False
        self._window, self._window_t = 2, -1e9
        self._serial = 0
        self._remote = self.ray.remote(chunk_task)
        self._verify = self.ray.remote(verify_task)
        self.inbox = None

    # --- the run ------------------------------------------------------------------------
    def run(self) -> FarmResult:
        t0 = time.monotonic()
        self.inbox = _make_inbox(self.ray, self.cluster.here())
        for st in self.states:
            if st.scene.error:
                st.failed, st.user_error = st.scene.error, True
                continue
            ranges = frame_ranges(st.scene.pending, self.chunk)
            st.open_chunks = len(ranges)
            chunks = [Chunk(st.scene, a, b) for a, b in ranges]
            if st.scene.meters:   # the last chunk meters every frame the others need
                chunks, st.held = chunks[-1:], chunks[:-1]
            self.queue.extend(chunks)
            if not ranges:
                self._submit_verify(st)
        total = sum(len(st.scene.pending) for st in self.states if not st.scene.error)
        self.bar = Progress(total, "farm", mode=self.progress_mode, stream=self.stream, unit="frame")
        status = "ok"
        try:
            with self.bar:
                try:
                    self._loop()
                except KeyboardInterrupt:
                    self.interrupted = True
                    status = "interrupted"
                    self._stop_all()
                    raise
        except KeyboardInterrupt:
            pass
        return FarmResult(self.states, self.retried, self.frames_rendered, time.monotonic() - t0,
                          interrupted=status == "interrupted")

    def _loop(self) -> None:
        ray = self.ray
        while self.queue or self.running or self.verifying:
            window = self._slots_window()
            while self.queue and len(self.running) < window:
                self._submit(self.queue.popleft())
            refs = list(self.running) + list(self.verifying)
            ready, _ = ray.wait(refs, num_returns=1, timeout=WAIT_S)
            if ready:
                ready, _ = ray.wait(refs, num_returns=len(refs), timeout=0)
            self._drain()
            for ref in ready:
                if ref in self.running:
                    self._chunk_ended(ref, self.running.pop(ref))
                elif ref in self.verifying:
                    self._verified(ref, self.verifying.pop(ref))

    # --- submitting ---------------------------------------------------------------------
    def _slots_window(self) -> int:
        now = time.monotonic()
        if now - self._window_t > RESOURCES_EVERY_S:
            cpus, gpus = self.cluster.totals()
            slots = cpus // self.cpus if self.cpus > 0 else 1
            if self.gpus > 0:
                slots = min(slots, gpus // self.gpus)
            self._window, self._window_t = max(2, 2 * int(slots)), now
        return self._window

    def _submit(self, c: Chunk) -> None:
        self._serial += 1
        c.serial = self._serial
        args = render_args(c.scene, c.a, c.b, self.threads, self.forwarded)
        opts = {"num_cpus": self.cpus, "max_retries": 0}
        if self.gpus > 0:
            opts["num_gpus"] = self.gpus
        ref = self._remote.options(**opts).remote(args, c.task_id, str(c.scene.out), self.inbox, str(c.scene.script))
        self.running[ref] = c
        self.live_ids.add(c.task_id)

    def _submit_verify(self, st: SceneState) -> None:
        ref = self._verify.options(num_cpus=0, max_retries=1).remote(str(st.scene.out))
        self.verifying[ref] = st

    # --- progress -----------------------------------------------------------------------
    def _drain(self) -> None:
        try:
            messages = self.ray.get(self.inbox.take.remote(), timeout=30)
        except Exception:  # noqa: BLE001 - progress is best effort; results come through the tasks
            return
        by_name = {st.scene.name: st for st in self.states}
        for msg in messages:
            key = msg.get("key", "")
            if msg.get("kind") == "started":
                self.writers[key] = (msg["host"], int(msg["pid"]))
                if key in self.live_ids:
                    self.rendering.add(key)
            elif msg.get("kind") == "event" and msg["event"].get("event") == "progress":
                st = by_name.get(key.rsplit("[", 1)[0])
                if st is not None and st.failed is None:
                    self._release_held(st)
                    st.counted += 1
                    self.frames_rendered += 1
                    ev = msg["event"]
                    self.bar.update(detail=self._detail_text(f"{key.split('#')[0]} frame {ev.get('frame')}"),
                                    scene=st.scene.name, frame=ev.get("frame"), wall_s=ev.get("wall_s"))

    def _detail_text(self, last: str = "") -> str:
        failed = sum(1 for st in self.states if st.failed)
        rendering = len(self.rendering)
        parts = [f"{rendering} rendering", f"{len(self.running) - rendering + len(self.queue)} waiting"]
        if self.retried:
            parts.append(f"{self.retried} retried")
        if failed:
            parts.append(f"{failed} failed")
        return ", ".join(parts) + (f"; {last}" if last else "")

    # --- results ------------------------------------------------------------------------
    def _release_held(self, st: SceneState) -> None:
        """The scene's metering is in its folder (a frame was written) or its last chunk
        ended (at worst each held chunk meters for itself, as without holding)."""
        if st.held and st.failed is None:
            self.queue.extend(st.held)
            st.held = []

    def _chunk_ended(self, ref, c: Chunk) -> None:
        st = self._state(c.scene)
        self._release_held(st)
        self.rendering.discard(c.task_id)
        self.live_ids.discard(c.task_id)
        try:
            res = self.ray.get(ref)
            rc, why = res["rc"], describe_exit(res["rc"])
            # killed by a signal, the signal is why: a traceback among its last lines is not
            # (CI under load once read "BrokenPipeError" there for a render the test SIGKILLed)
            line = error_line(res.get("tail", [])) if rc >= 0 else None
        except Exception as e:  # noqa: BLE001 - the worker or its node is gone, or the task was cancelled
            res, rc = None, None
            why, line = f"task lost ({type(e).__name__})", _last_line(e)
            self._release_lost(c)
        if st.failed is not None:
            return
        outcome = Outcome.LOST if res is None else outcome_of(rc)
        if outcome is Outcome.OK:
            st.open_chunks -= 1
            if st.open_chunks == 0:
                self._submit_verify(st)
            return
        if outcome is Outcome.USER_ERROR:
            self._fail(st, line or f"{c.key}: {why}", user_error=True)
            return
        if outcome is Outcome.INTERRUPTED and self.interrupted:
            return
        if c.attempt < self.retries:
            self.retried += 1
            self.bar.note(f"farm: {c.key} lost ({why}{': ' + line if line else ''}); "
                          f"retry {c.attempt + 1} of {self.retries}")
            self.queue.appendleft(Chunk(c.scene, c.a, c.b, c.attempt + 1))
        else:
            self._fail(st, f"{c.key}: {why} after {self.retries} retries" + (f": {line}" if line else ""))

    def _verified(self, ref, st: SceneState) -> None:
        try:
            res = self.ray.get(ref)
        except Exception as e:  # noqa: BLE001
            self._fail(st, f"{st.scene.name}: verification failed: {_last_line(e)}",
                       user_error="being rendered by" in str(e))
            return
        missing = list(res["missing"])
        # correct the count: what the folder holds now, whatever the events said
        done_now = len(st.scene.pending) - len([k for k in missing if k in set(st.scene.pending)])
        if done_now != st.counted:
            self.bar.update(done_now - st.counted)
            st.counted = done_now
        folder = list(res.get("folder") or [])
        if not missing and not folder:
            st.complete = True
            return
        bad = "; ".join([why for _, why in res["bad"][:3]] + folder[:3])
        if st.repairs >= self.retries:
            self._fail(st, f"{st.scene.name}: {len(missing)} frame(s) still missing or bad after {self.retries} "
                           f"retries{': ' + bad if bad else ''}")
            return
        st.repairs += 1
        self.retried += 1
        self.bar.note(f"farm: {st.scene.name}: {len(missing)} frame(s) missing or bad after its chunks"
                      f"{' (' + bad + ')' if bad else ''}; rendering again")
        # a render --resume writes the folder's own files again, even with no frame to render
        ranges = frame_ranges(missing, self.chunk) or [(0, 1)]
        st.open_chunks = len(ranges)
        for a, b in reversed(ranges):
            self.queue.appendleft(Chunk(st.scene, a, b, attempt=st.repairs))

    def _fail(self, st: SceneState, why: str, user_error: bool = False) -> None:
        st.failed, st.user_error = why, user_error
        self.bar.note(f"farm: {st.scene.name} failed: {why}")
        self.queue = deque(c for c in self.queue if c.scene is not st.scene)
        for ref, c in list(self.running.items()):
            if c.scene is st.scene:
                self.ray.cancel(ref)

    def _release_lost(self, c: Chunk) -> None:
        """The worker of ``c`` is gone: its render died with it (child.py); drop the lock it
        left so that the retry may run on any host at once."""
        writer = self.writers.pop(c.task_id, None)
        if writer is None:
            return
        host, pid = writer
        if host == _hostname() and _alive(pid):
            return
        try:
            from ..render.folder import OutputFolder
            OutputFolder(c.scene.out).drop_lock_of(host, pid)
        except Exception:  # noqa: BLE001 - the retry's render takes a stale lock over itself
            pass

    def _state(self, scene: FarmScene) -> SceneState:
        return next(st for st in self.states if st.scene is scene)

    def _stop_all(self) -> None:
        """Ctrl-C: every running render gets SIGINT (stops between views, its folder
        consistent); whatever has not stopped after the grace period is killed."""
        self.queue.clear()
        refs = list(self.running) + list(self.verifying)
        for ref in refs:
            try:
                self.ray.cancel(ref)
            except Exception:  # noqa: BLE001
                pass
        try:
            self.ray.wait(refs, num_returns=len(refs), timeout=INTERRUPT_GRACE_S + 5)
        except KeyboardInterrupt:
            pass
        for ref in refs:
            try:
                self.ray.cancel(ref, force=True)
            except Exception:  # noqa: BLE001
                pass


def _make_inbox(ray, strategy=None):
    """The actor that collects the tasks' progress messages, on the driver's node (a worker
    node lost must not take the farm's progress with it)."""
    @ray.remote(num_cpus=0)
    class Inbox:
        """Where tasks drop their progress messages; the driver takes them in batches."""

        def __init__(self):
            self.messages = []

        def put(self, msg):
            self.messages.append(msg)

        def take(self):
            out, self.messages = self.messages, []
            return out

    return (Inbox.options(scheduling_strategy=strategy) if strategy is not None else Inbox).remote()


def _last_line(e: BaseException) -> str:
    text = [ln for ln in str(e).strip().splitlines() if ln.strip()]
    return text[-1].strip() if text else type(e).__name__


def _hostname() -> str:
    import socket
    return socket.gethostname()


def _alive(pid: int) -> bool:
    import os
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
