"""The farm without Ray (blender_sesgen/farm/local.py): the task graph's and the farm driver's
scheduling on threads of this process -- inputs before the tasks that take them, CPUs shared,
errors passed on, cancel of a queued and of a running task -- with real child processes."""
from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest

from blender_sesgen.farm.local import LocalCluster, LocalRay, TaskCancelledError
from blender_sesgen.farm.tasks import After, TaskError, TaskGraph


def _sleep_child(seconds: float, log: list, name: str, lock: threading.Lock) -> str:
    with lock:
        log.append(("start", name, time.monotonic()))
    subprocess.run([sys.executable, "-c", f"import time; time.sleep({seconds})"], check=True)
    with lock:
        log.append(("end", name, time.monotonic()))
    return name


def _concat(a: str, b: str) -> str:
    return a + b


def _boom(_x=None):
    raise ValueError("boom in a task")


def test_a_task_graph_runs_inputs_first_and_keeps_to_its_cpus():
    log, lock = [], threading.Lock()
    graph = TaskGraph(LocalCluster(num_cpus=2))
    for name in "abc":
        graph.add(name, _sleep_child, 0.3, log, name, lock)
    graph.add("ab", _concat, After("a"), After("b"))
    graph.add("abc", _concat, After("ab"), After("c"))
    seen = []
    results = graph.run(lambda key, res: seen.append(key))
    assert results["abc"] == "abc" and results["ab"] == "ab"
    assert seen.index("ab") > max(seen.index("a"), seen.index("b")) and seen[-1] == "abc"
    running, most = 0, 0                       # never more than 2 children at once on 2 CPUs
    for kind, _, _ in sorted(log, key=lambda e: (e[2], e[0] == "start")):
        running += 1 if kind == "start" else -1
        most = max(most, running)
    assert most == 2


def test_an_error_reaches_the_tasks_that_need_its_result():
    graph = TaskGraph(LocalCluster(num_cpus=2))
    graph.add("bad", _boom)
    graph.add("after", _concat, After("bad"), "x")
    graph.add("fine", _concat, "x", "y")
    res = graph.run()
    assert isinstance(res["bad"], TaskError) and "boom in a task" in res["bad"].message
    assert isinstance(res["after"], TaskError) and "boom in a task" in res["after"].message
    assert res["fine"] == "xy"


def _run_child(seconds: float, started: threading.Event, box: dict) -> int:
    proc = subprocess.Popen([sys.executable, "-c", f"import time; time.sleep({seconds})"])
    box["proc"] = proc
    started.set()
    try:
        return proc.wait(timeout=seconds + 30)
    except BaseException:                      # cancelled: its child goes with it (as the farm's tasks do)
        proc.kill()
        proc.wait()
        raise


def test_cancel_stops_a_queued_task_and_interrupts_a_running_one():
    ray = LocalRay(1)
    started, box = threading.Event(), {}
    running = ray.remote(_run_child).remote(60, started, box)
    queued = ray.remote(_concat).remote("never", "run")          # waits for the only CPU
    assert started.wait(30)
    ray.cancel(queued)
    with pytest.raises(TaskCancelledError):
        ray.get(queued, timeout=5)
    t0 = time.monotonic()
    ray.cancel(running)
    with pytest.raises(TaskCancelledError):
        ray.get(running, timeout=30)
    assert time.monotonic() - t0 < 20 and box["proc"].poll() is not None
    ready, left = ray.wait([ray.remote(_concat).remote("a", "b")], num_returns=1, timeout=30)
    assert len(ready) == 1 and not left and ray.get(ready[0]) == "ab"   # the CPU is free again


def test_the_farms_progress_inbox_runs_its_calls_one_at_a_time():
    from blender_sesgen.farm.driver import _make_inbox
    ray = LocalRay(2)
    box = _make_inbox(ray)                       # the farm driver's actor, as the farm makes it
    threads = [threading.Thread(target=lambda i=i: [box.put.remote((i, k)) for k in range(200)]) for i in range(4)]
    got = []
    for t in threads:
        t.start()
    while any(t.is_alive() for t in threads):
        got += ray.get(box.take.remote())
    got += ray.get(box.take.remote())
    assert sorted(got) == [(i, k) for i in range(4) for k in range(200)]


_PARKED_SCENE = """\
CAMERA resolution 64 48 focal 44 baseline 0.1 near 0.1 far 100
START position 0 1 3
QUAD id 1 texture 4 vertices -2 0 -2  2 0 -2  2 0 4  -2 0 4
CUBOID id 3 texture 1 position -0.8 0.4 -0.5 dim 0.8 0.8 0.8
""" + "EGO 0.02 0 0.1 0 1 0\n" * 400


def test_a_local_cancel_as_the_render_starts_stops_it(tmp_path):
    """The local farm cancels a running task by raising KeyboardInterrupt in its thread, which
    could land between the render's start and the code that stops it: the task ended cancelled
    without stopping its render, which the kernel then killed (SIGKILL: PR_SET_PDEATHSIG follows
    the thread that started it) with its lock left on the frames. run_chunk now takes a local
    cancel as a flag it asks. The task is parked right after its render started
    (``chunk._after_spawn_hook``) and cancelled there: the render must be stopped as a Ctrl-C'd
    render (exit 130, its lock released) and gone, the task's answer saying it was cancelled."""
    from blender_sesgen.farm import chunk
    script = tmp_path / "parked.ses"
    script.write_text(_PARKED_SCENE)
    out = tmp_path / "parked" / "s"
    out.parent.mkdir()
    args = ["render", str(script), "--out", str(out), "--frames", "0:400", "--progress", "json",
            "--threads", "1", "--samples", "16"]
    spawned, go, box = threading.Event(), threading.Event(), {}

    def park(proc):
        box["proc"] = proc
        spawned.set()
        assert go.wait(60)
    ray = LocalRay(1)
    chunk._after_spawn_hook = park
    try:
        ref = ray.remote(chunk.task).remote(args, "s[0:400]#parked", str(out), None, str(script))
        assert spawned.wait(60), "the task never started its render"
        ray.cancel(ref)
        time.sleep(0.5)           # an interrupt raised in the thread lands in the parked hook
        go.set()
        try:
            res = ray.get(ref, timeout=120)
        except TaskCancelledError:
            res = None
    finally:
        chunk._after_spawn_hook = None
    proc = box["proc"]
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail(f"the render {proc.pid} lives on after its task was cancelled ({res})")
    assert not list((out / ".sesgen").glob("lock-*")), f"the stopped render left its lock ({res})"
    assert res is not None and res["cancelled"] and res["rc"] == 130, res


def _note(box: dict, name: str) -> str:
    box[name] = True
    return name


def test_a_cancel_as_a_dispatched_task_starts_stops_it(monkeypatch):
    """The farm cancels a failed scene's tasks once (Ray repeats a cancel by itself; this
    runner does not). A task whose CPU has just been freed is taken off the queue, then its
    thread started: the driver, woken by the task that ended (a chunk's user error), cancels
    in between. The task must not run (the old code found it neither queued nor running, did
    nothing, and the chunk rendered its whole range)."""
    import types
    from blender_sesgen.farm import local
    ray = LocalRay(1)
    box, refs = {}, {}

    class Starting(threading.Thread):
        def start(self):
            if self.name.endswith("_note") and "late" not in refs:
                refs["late"] = None
                ray.cancel(refs["b"])        # the driver's cancel, between the dequeue and the start
            super().start()
    monkeypatch.setattr(local, "threading", types.SimpleNamespace(Thread=Starting, Lock=threading.Lock))
    gate = threading.Event()
    a = ray.remote(lambda: gate.wait(30)).remote()
    refs["b"] = ray.remote(_note).remote(box, "b")       # queued behind a on the only CPU
    gate.set()
    assert ray.get(a, timeout=30) is True
    with pytest.raises(TaskCancelledError):
        ray.get(refs["b"], timeout=30)
    assert "b" not in box, "the cancelled task ran"


def test_a_cancel_as_a_task_returns_neither_loses_its_end_nor_the_runner(monkeypatch):
    """A cancel that comes after a task's body has returned, before its result is settled: the
    old runner raised KeyboardInterrupt in the task's thread there, out of the bookkeeping that
    settles the result and frees its CPUs: ``get`` waited forever and no task started again."""
    ray = LocalRay(1)
    finish = ray._finish
    gate = threading.Event()

    def cancelled_first(t, settle):
        if t.ref is a:
            ray.cancel(t.ref)
            time.sleep(0.1)                   # where an interrupt raised in this thread lands
        finish(t, settle)
    monkeypatch.setattr(ray, "_finish", cancelled_first)
    a = ray.remote(lambda: gate.wait(30)).remote()
    gate.set()
    try:
        assert ray.get(a, timeout=10) is True
    except TaskCancelledError:
        pass
    assert ray.get(ray.remote(_concat).remote("c", "d"), timeout=10) == "cd"
