"""Work other than renders as Ray tasks: plain Python functions chained by their results.

A verification study exports every variant and runs every system on it; each is a
function call that runs a child process. :class:`TaskGraph` submits them all at once as
Ray tasks, a task's inputs being the results of others (:class:`After`): Ray itself holds a
task back until what it needs is done, spreads the ready ones over the cluster's CPUs and
runs a task again when its worker dies (``max_retries``). No second scheduler: the driver
only waits for results and reports them as they come (``on_result``), one at a time.

A function that fails for an expected reason returns a result saying so (a system that
crashed is a result, not an error); an exception is a bug or a lost task, reported as a
:class:`TaskError` result (the tasks that needed it get their own TaskError).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Optional

from .cluster import Cluster

WAIT_S = 0.5
RETRIES = 2            # a task whose worker died runs again (it resumes: every task's output is atomic)


@dataclass(frozen=True)
class After:
    """An argument that is the result of the task ``key``."""
    key: str


@dataclass
class TaskError:
    """A task that raised (or was lost more than ``RETRIES`` times)."""
    key: str
    message: str


class TaskGraph:
    def __init__(self, cluster: Cluster):
        self.cluster, self.ray = cluster, cluster.ray
        self.refs: dict[str, Any] = {}
        self._remotes: dict = {}

    def add(self, key: str, fn: Callable, *args, num_cpus: float = 1.0) -> str:
        """Submit ``fn(*args)`` now; an :class:`After` argument is the result of that task."""
        if key in self.refs:
            raise ValueError(f"task {key!r} added twice")
        if fn not in self._remotes:
            self._remotes[fn] = self.ray.remote(fn)
        real = [self.refs[a.key] if isinstance(a, After) else a for a in args]
        self.refs[key] = self._remotes[fn].options(num_cpus=num_cpus, max_retries=RETRIES).remote(*real)
        return key

    def run(self, on_result: Optional[Callable[[str, Any], None]] = None) -> dict:
        """Wait for every task; ``on_result(key, result)`` as each ends (a TaskError if it
        raised). Ctrl-C cancels what is still running (their child processes go with their
        workers) and re-raises."""
        pending = {ref: key for key, ref in self.refs.items()}
        results: dict = {}
        try:
            while pending:
                ready, _ = self.ray.wait(list(pending), num_returns=1, timeout=WAIT_S)
                for ref in ready:
                    key = pending.pop(ref)
                    try:
                        res = self.ray.get(ref)
                    except Exception as e:  # noqa: BLE001 - a bug or a lost task: a result of its own
                        text = [ln for ln in str(e).strip().splitlines() if ln.strip()]
                        res = TaskError(key, text[-1].strip() if text else type(e).__name__)
                    results[key] = res
                    if on_result is not None:
                        on_result(key, res)
        except KeyboardInterrupt:
            for ref in pending:
                try:
                    self.ray.cancel(ref, force=True)
                except Exception:  # noqa: BLE001
                    pass
            raise
        return results
