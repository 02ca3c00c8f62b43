"""Ray for the farm: start a local Ray or join a cluster, read its resources, check that
every node sees the farm's files, and leave nothing behind.

- No address: a local Ray with this machine's CPUs (and GPUs), no dashboard, a small object
  store (tasks exchange only small dicts), usage statistics off unless the environment says
  otherwise; :meth:`Cluster.stop` ends every process it started.
- ``--address auto`` or ``HOST:PORT``: the cluster's head (its GCS address, as printed by
  ``ray start --head``). Workers import blender_sesgen from where this driver does (the
  folder is put on their PYTHONPATH) unless it is installed there; ROOT and the scripts
  must be on a filesystem every node mounts at the same path -- :meth:`Cluster.check_shared`
  proves it before anything is rendered.
"""
from __future__ import annotations

import logging
import os
import secrets
import socket
import sys
from pathlib import Path
from typing import Optional, Sequence

from ..errors import SesgenError
from ..render.plan import generator_version
from .chunk import WORKER_SETUP

LOCAL_OBJECT_STORE_BYTES = 128 * 1024 * 1024
PROBE_TIMEOUT_S = 120.0
CONNECT_TIMEOUT_S = 10.0


class ClusterStartError(RuntimeError):
    """A local Ray that did not start (its temporary folder unusable, or its raylet or GCS
    timed out on an overloaded machine): a failure of the run, not of the user's input --
    one line, exit 1; nothing was rendered, so the same command may be run again."""


def import_ray():
    try:
        import ray
    except ImportError:
        raise SesgenError("farm needs Ray: pip install 'blender-sesgen[farm]' (ray 2.60)") from None
    return ray


def local_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def package_root() -> Path:
    """The folder holding the blender_sesgen package this driver runs."""
    return Path(__file__).resolve().parents[2]


def _probe(probe_path: str, token: str, paths: list) -> dict:
    """Run on one node: what it sees of the farm's files and of blender_sesgen."""
    version = generator_version()   # the node's own blender_sesgen (this module is imported there)
    seen = ""
    try:
        seen = Path(probe_path).read_text(encoding="utf-8")
    except OSError:
        pass
    return {"host": socket.gethostname(), "root_ok": seen == token,
            "missing": [p for p in paths if not os.path.isfile(p)],
            "version": version, "python": sys.version.split()[0]}


def _check_reachable(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """HOST:PORT must accept a connection (Ray itself would retry for many minutes)."""
    if address == "auto" or "://" in address:
        return
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit() or not host:
        raise SesgenError(f"--address {address}: expected auto or HOST:PORT (the head's address, "
                          "as `ray start --head` prints it)")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s).close()
    except OSError as e:
        raise SesgenError(f"--address {address}: no Ray head answers there ({e.strerror or e}); "
                          "start one with `ray start --head`") from None


class Cluster:
    """A connection to Ray for one farm run (see the module docstring)."""

    def __init__(self, address: Optional[str] = None, num_cpus: Optional[int] = None):
        self.address = address
        self.num_cpus = num_cpus
        self.ray = import_ray()
        self.started_local = False
        self.runtime_env: Optional[dict] = None

    def start(self) -> "Cluster":
        ray = self.ray
        if self.address is None:
            os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
            try:
                ray.init(address="local", num_cpus=self.num_cpus or local_cpus(), include_dashboard=False,
                         log_to_driver=False, logging_level=logging.ERROR,
                         object_store_memory=LOCAL_OBJECT_STORE_BYTES, runtime_env=dict(WORKER_SETUP))
            except Exception as e:  # noqa: BLE001 - Ray raises bare Exceptions (a node that timed out) and OSErrors
                try:
                    ray.shutdown()  # whatever part of it did start
                except Exception:  # noqa: BLE001 - nothing more to end
                    pass
                why = (str(e).strip().splitlines() or [type(e).__name__])[0].rstrip(".")
                raise ClusterStartError(f"cannot start a local Ray: {why}") from None
            self.started_local = True
            return self
        _check_reachable(self.address)
        pythonpath = os.pathsep.join([str(package_root())] + [p for p in os.environ.get("PYTHONPATH", "").split(
            os.pathsep) if p])
        self.runtime_env = {"env_vars": {"PYTHONPATH": pythonpath}, **WORKER_SETUP}
        try:
            ray.init(address=self.address, log_to_driver=False, logging_level=logging.ERROR,
                     runtime_env=self.runtime_env)
        except (ConnectionError, RuntimeError, ValueError) as e:
            raise SesgenError(f"--address {self.address}: cannot join a Ray cluster there ({e})") from None
        return self

    def stop(self) -> None:
        if self.ray.is_initialized():
            self.ray.shutdown()

    def __enter__(self) -> "Cluster":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # --- resources ----------------------------------------------------------------------
    def alive_nodes(self) -> list[dict]:
        return [n for n in self.ray.nodes() if n.get("Alive")]

    def totals(self) -> tuple[float, float]:
        """(CPUs, GPUs) of the whole cluster now."""
        r = self.ray.cluster_resources()
        return float(r.get("CPU", 0.0)), float(r.get("GPU", 0.0))

    def largest_node(self) -> tuple[float, float]:
        """(CPUs, GPUs) of the largest node: a task may not ask for more."""
        nodes = self.alive_nodes() or [{"Resources": {}}]
        return (max(float(n["Resources"].get("CPU", 0.0)) for n in nodes),
                max(float(n["Resources"].get("GPU", 0.0)) for n in nodes))

    def describe(self) -> str:
        cpus, gpus = self.totals()
        where = "local Ray" if self.started_local else f"Ray cluster {self.address}"
        return (f"{where}: {len(self.alive_nodes())} node(s), {cpus:g} CPU(s)"
                + (f", {gpus:g} GPU(s)" if gpus else ""))

    def here(self):
        """A scheduling strategy that keeps an actor on this driver's node (if it can)."""
        from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy
        return NodeAffinitySchedulingStrategy(node_id=self.ray.get_runtime_context().get_node_id(), soft=True)

    # --- the shared filesystem ------------------------------------------------------------
    def check_shared(self, root: Path, scripts: Sequence[Path]) -> None:
        """Every node must see ROOT (a file written here now) and every script, at the same
        paths, and run the same blender_sesgen version; SesgenError naming the node if not."""
        from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy
        ray = self.ray
        root.mkdir(parents=True, exist_ok=True)
        token = secrets.token_hex(16)
        probe = root / f".sesgen-farm-probe-{token[:8]}"
        probe.write_text(token, encoding="utf-8")
        try:
            remote = ray.remote(_probe)
            refs = {}
            for n in self.alive_nodes():
                strategy = NodeAffinitySchedulingStrategy(node_id=n["NodeID"], soft=False)
                refs[n.get("NodeManagerAddress", n["NodeID"])] = remote.options(
                    num_cpus=0, scheduling_strategy=strategy, max_retries=0).remote(
                    str(probe), token, [str(s) for s in scripts])
            problems = []
            for addr, ref in refs.items():
                try:
                    r = ray.get(ref, timeout=PROBE_TIMEOUT_S)
                except Exception as e:  # noqa: BLE001 - a node that cannot even import us
                    problems.append(f"node {addr}: the check did not run ({type(e).__name__}: "
                                    f"{str(e).strip().splitlines()[-1] if str(e).strip() else ''})")
                    continue
                if not r["root_ok"]:
                    problems.append(f"node {addr} ({r['host']}) cannot see {root}")
                if r["missing"]:
                    problems.append(f"node {addr} ({r['host']}) cannot see {len(r['missing'])} script(s), "
                                    f"e.g. {r['missing'][0]}")
                if r["version"] != generator_version():
                    problems.append(f"node {addr} ({r['host']}) runs blender_sesgen {r['version']}, "
                                    f"this driver {generator_version()}")
        finally:
            probe.unlink(missing_ok=True)
        if problems:
            raise SesgenError("--out must be on a filesystem every node mounts at the same path, with the scripts "
                              "and the same blender-sesgen: " + "; ".join(problems))
