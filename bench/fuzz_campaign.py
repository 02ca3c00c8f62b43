"""Fuzz campaign: many mutants of every reader's input and of the SES scripts, each run in a
worker process so that a crash (a signal), a hang (the timeout) or a memory blow-up is
counted instead of ending the campaign; plus injected file-system faults (a FIFO, a device,
a folder, an empty or an oversized file where a file is expected).

The targets and mutations are tests/fuzz_targets.py's (the CI test runs the same with a few
examples each; tests/ on PYTHONPATH). Outcomes per target: ``ok`` (read, exit 0), ``user-error`` (exit 2, one
line), ``finding`` (a traceback, another exit code, a user error of several lines),
``crash`` (the worker died), ``hang`` (no answer within --timeout s).

    PYTHONPATH=tests python bench/fuzz_campaign.py --mutants 2000 --heavy 300 --parser 30000 [--seed 1] [--json out.json]

Prints a markdown table (docs/reliability.md holds a run's figures) and every finding's
mutation list, so it can be replayed with ``fuzz_targets.run_mutant``.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import random
import sys
import tempfile
import time
import traceback
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

HEAVY = {"manifest", "exr", "kitti-calib", "kitti-folder-poses"}   # each mutant runs VO: fewer of them


# --- the worker ---------------------------------------------------------------------------------

def _worker(conn, name: str, folder: str):
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))  # a blow-up is a MemoryError, not the OOM killer
    import fuzz_targets as ft
    folder = Path(folder)
    if name == "parser":
        from blender_sesgen.errors import SesgenError
        from blender_sesgen.ses import parse_bytes
        scenes = [p.read_bytes() for p in sorted((REPO / "scenes").glob("*.ses"))]
        conn.send("ready")
        while True:
            job = conn.recv()
            if job is None:
                return
            index, ops = job
            data = ft.mutate(scenes[index % len(scenes)], ops)
            try:
                parse_bytes(data, source="fuzz.ses", base_dir=str(REPO / "scenes"))
                conn.send(("ok", ""))
            except SesgenError as e:
                conn.send(("user-error", "") if "\n" not in str(e) else ("finding", f"multi-line error {e!s:.300}"))
            except BaseException as e:  # noqa: BLE001 - a finding
                conn.send(("finding", _where(e)))
    target = ft.TARGETS[name]
    path, seed = ft.setup_target(target, folder)
    conn.send("ready")
    while True:
        job = conn.recv()
        if job is None:
            return
        kind, payload = job
        try:
            if kind == "fault":
                ft.restore(path, seed)
                outcome = _fault(target, folder, path, payload)
                ft.restore(path, seed)
            else:
                ops, json_seed = payload
                outcome = ft.run_mutant(target, folder, path, seed, ops,
                                        random.Random(json_seed) if json_seed is not None else None)
            conn.send((outcome, ""))
        except BaseException as e:  # noqa: BLE001 - a finding
            conn.send(("finding", _where(e)))


def _where(e: BaseException) -> str:
    tb = traceback.extract_tb(e.__traceback__)
    last = tb[-1] if tb else None
    at = f" at {Path(last.filename).name}:{last.lineno}" if last else ""
    return f"{type(e).__name__}: {str(e)[:200]}{at}".replace("\n", " | ")


FAULTS = ("fifo", "folder", "dev-zero", "empty", "oversized", "dangling-symlink")


def _fault(target, folder: Path, path: Path, fault: str) -> str:
    """Replace the target's file by something that is not a readable file, then read."""
    import fuzz_targets as ft
    path.unlink()
    try:
        if fault == "fifo":
            os.mkfifo(path)
        elif fault == "folder":
            path.mkdir()
        elif fault == "dev-zero":
            path.symlink_to("/dev/zero")
        elif fault == "empty":
            path.write_bytes(b"")
        elif fault == "oversized":  # sparse: larger than any reader's limit, costs no disk
            with open(path, "wb") as f:
                f.truncate(5 << 30)
        elif fault == "dangling-symlink":
            path.symlink_to(folder / "does-not-exist")
        ft.EXITS.clear()
        try:
            target.consume(path, folder)
        except ft.USER_ERRORS:
            return "user-error"
        return "user-error" if 2 in ft.EXITS else "ok"
    finally:
        if path.is_dir() and not path.is_symlink():
            path.rmdir()
        elif path.exists() or path.is_symlink():
            path.unlink()


class Worker:
    def __init__(self, name: str, timeout: float):
        self.name, self.timeout = name, timeout
        self.folder = tempfile.mkdtemp(prefix=f"fuzz-{name}-")
        self._start()

    def _start(self):
        self.conn, child = mp.Pipe()
        self.proc = mp.get_context("fork").Process(target=_worker, args=(child, self.name, self.folder), daemon=True)
        self.proc.start()
        if not self.conn.poll(600) or self.conn.recv() != "ready":
            raise RuntimeError(f"worker for {self.name} did not start")

    def run(self, job) -> tuple[str, str]:
        self.conn.send(job)
        if self.conn.poll(self.timeout):
            try:
                return self.conn.recv()
            except EOFError:
                pass
        alive = self.proc.is_alive()
        self.proc.kill()
        self.proc.join()
        outcome = ("hang", f"no answer in {self.timeout:g} s") if alive else \
            ("crash", f"worker died (exit code {self.proc.exitcode})")
        self._start()
        return outcome

    def close(self):
        try:
            self.conn.send(None)
        except (BrokenPipeError, OSError):
            pass
        self.proc.join(5)
        if self.proc.is_alive():
            self.proc.kill()


def campaign(names, mutants: int, heavy: int, parser: int, seed: int, timeout: float, faults: bool):
    import fuzz_targets as ft
    rows, findings = [], []
    for name in names:
        count = parser if name == "parser" else heavy if name in HEAVY else mutants
        if count <= 0:
            continue
        rng = random.Random(f"{seed}-{name}")
        worker = Worker(name, timeout)
        tally = {k: 0 for k in ("ok", "user-error", "finding", "crash", "hang")}
        t0 = time.perf_counter()
        jobs = []
        for _ in range(count):
            if name == "parser":
                jobs.append((rng.randrange(1000), ft.random_ops(rng, text=True)))
            else:
                target = ft.TARGETS[name]
                json_seed = rng.randrange(2**32) if target.json_doc and rng.random() < 0.5 else None
                jobs.append(("mutant", (ft.random_ops(rng, target.text), json_seed)))
        if faults and name != "parser":
            jobs += [("fault", f) for f in FAULTS]
        n_faults = len(FAULTS) if faults and name != "parser" else 0
        for job in jobs:
            outcome, detail = worker.run(job)
            tally[outcome] += 1
            if outcome not in ("ok", "user-error"):
                findings.append({"target": name, "outcome": outcome, "detail": detail, "job": repr(job)})
        worker.close()
        rows.append({"target": name, "mutants": count, "faults": n_faults, **tally,
                     "seconds": round(time.perf_counter() - t0, 1)})
        print(_row(rows[-1]), flush=True)
    return rows, findings


COLUMNS = ("target", "mutants", "faults", "ok", "user-error", "finding", "crash", "hang", "seconds")


def _row(r: dict) -> str:
    return "| " + " | ".join(str(r[c]) for c in COLUMNS) + " |"


def main(argv=None) -> int:
    import fuzz_targets as ft
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--mutants", type=int, default=500, help="mutants per light reader target (default 500)")
    p.add_argument("--heavy", type=int, default=100, help="mutants per target that runs VO (default 100)")
    p.add_argument("--parser", type=int, default=5000, help="mutants of scenes/*.ses for the parser (default 5000)")
    p.add_argument("--targets", default="all", help="comma-separated target names, or 'all' (parser included)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--timeout", type=float, default=60.0, help="seconds per mutant before it counts as a hang")
    p.add_argument("--no-faults", action="store_true", help="no file-system fault injection")
    p.add_argument("--json", metavar="OUT.json", help="write the table and the findings as JSON")
    args = p.parse_args(argv)
    names = ["parser", *ft.TARGETS] if args.targets == "all" else [n.strip() for n in args.targets.split(",")]
    unknown = [n for n in names if n != "parser" and n not in ft.TARGETS]
    if unknown:
        p.error(f"unknown targets {unknown} (have parser, {', '.join(ft.TARGETS)})")
    print("| " + " | ".join(COLUMNS) + " |")
    print("|" + "---|" * len(COLUMNS))
    rows, findings = campaign(names, args.mutants, args.heavy, args.parser, args.seed, args.timeout,
                              not args.no_faults)
    total = {c: sum(r[c] for r in rows) for c in COLUMNS[1:]}
    print(_row({"target": "**total**", **{k: (round(v, 1) if isinstance(v, float) else v) for k, v in total.items()}}))
    for f in findings:
        print(f"FINDING {f['target']}: {f['outcome']}: {f['detail']}\n    job: {f['job']}")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "findings": findings}, indent=1))
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
