"""Fuzz campaign: many mutants of every reader's input and of the SES scripts, each run in a
worker process so that a crash (a signal), a hang (the timeout) or a memory blow-up is
counted instead of ending the campaign; plus injected faults: in the file system (a FIFO,
a device, a folder, an empty or an oversized file where a file is expected) and in exports
(SIGINT or SIGKILL at a random instant, a full disk at a random write: ``ExportTrials``).

The targets and mutations are tests/fuzz_targets.py's (the CI test runs the same with a few
examples each; tests/ on PYTHONPATH): the readers' inputs, render folders damaged file by file (``verify`` must
see every change), hostile model files and HDRIs (what ``check`` passes decodes to finite
numbers), farm and generate indexes. Outcomes per target: ``ok`` (read, exit 0, or an
interrupted export that left one whole export), ``user-error`` (exit 2, one line),
``finding`` (a traceback, another exit code, a user error of several lines, a broken
promise), ``crash`` (the worker died), ``hang`` (no answer within --timeout s).

    PYTHONPATH=tests python bench/fuzz_campaign.py --mutants 2000 --heavy 300 --parser 30000 --exports 300 [--seed 1] [--json out.json]

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

HEAVY = {"manifest", "exr", "kitti-calib", "kitti-folder-poses",   # each mutant runs VO or a whole verify:
         "render-exr-verify", "render-display-png", "render-manifest-seal", "render-scene-ses", "render-imu-csv",
         "scripts-index"}                                             # fewer of them


# --- the worker ---------------------------------------------------------------------------------

def _worker(conn, name: str, folder: str):
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))  # a blow-up is a MemoryError, not the OOM killer
    import fuzz_targets as ft
    folder = Path(folder)
    if name in EXPORT_FAULTS:
        trials = ExportTrials(folder)
        return _serve(conn, lambda job: trials.run(name, *job))
    if name == "parser":
        from blender_sesgen.errors import SesgenError
        from blender_sesgen.ses import parse_bytes
        scenes = [p.read_bytes() for p in sorted((REPO / "scenes").glob("*.ses"))]

        def parse(job):
            index, ops = job
            data = ft.mutate(scenes[index % len(scenes)], ops)
            try:
                parse_bytes(data, source="fuzz.ses", base_dir=str(REPO / "scenes"))
                return "ok", ""
            except SesgenError as e:
                return ("user-error", "") if "\n" not in str(e) else ("finding", f"multi-line error {e!s:.300}")
        return _serve(conn, parse)
    target = ft.TARGETS[name]
    path, seed = ft.setup_target(target, folder)

    def mutant(job):
        kind, payload = job
        if kind == "fault":
            ft.restore(path, seed)
            outcome = _fault(target, folder, path, payload)
            ft.restore(path, seed)
        else:
            ops, json_seed = payload
            outcome = ft.run_mutant(target, folder, path, seed, ops,
                                    random.Random(json_seed) if json_seed is not None else None)
        return outcome, ""
    _serve(conn, mutant)


def _serve(conn, answer) -> None:
    """Answer the driver's jobs until it sends None: ``answer(job)``, or the exception it
    raised as a finding."""
    conn.send("ready")
    while True:
        job = conn.recv()
        if job is None:
            return
        try:
            conn.send(answer(job))
        except BaseException as e:  # noqa: BLE001 - a finding
            conn.send(("finding", _where(e)))


def _where(e: BaseException) -> str:
    tb = traceback.extract_tb(e.__traceback__)
    last = tb[-1] if tb else None
    at = f" at {Path(last.filename).name}:{last.lineno}" if last else ""
    return f"{type(e).__name__}: {str(e)[:200]}{at}".replace("\n", " | ")


FAULTS = ("fifo", "folder", "dev-zero", "empty", "oversized", "dangling-symlink")


# --- exports interrupted at random instants -------------------------------------------------------

EXPORT_FAULTS = ("export-sigint", "export-kill", "export-enospc")
# layouts and their options: folders replaced whole and trees whose slot spans 1, 2, 4 or 7 units
LAYOUTS = (("png", ()), ("colmap", ()), ("kitti-odometry", ()), ("sceneflow", ()),
           ("tartanair", ("--sequence", "P001")), ("vkitti2", ("--sequence", "Scene01/clone")), ("sintel", ()))


class ExportTrials:
    """An earlier export A (of render r1) in OUT; an export B (of render r2) started in a forked
    process and interrupted -- SIGINT or SIGKILL after a random delay, or a full disk
    (``OSError(ENOSPC)``) at a random write. Afterwards OUT must hold exactly A or exactly B
    (after :func:`atomic.recover`, the next access, for a kill), no temporary file or folder
    of ours may be left anywhere, and the render must be untouched; an interrupted export
    exits 130 (0 if it had finished), a full disk exits 1 and leaves A."""

    def __init__(self, folder: Path):
        from synthetic_render import plane_scene
        self.folder = folder
        self.r1 = plane_scene(folder / "r1", frames=3)
        self.r2 = plane_scene(folder / "r2", frames=2, step_m=0.3)
        self.r2_tree = _tree(self.r2)
        self.refs, self.seconds = {}, {}
        for layout, args in LAYOUTS:
            for tag, render in (("A", self.r1), ("B", self.r2)):
                out = folder / "ref" / layout / tag / "OUT"
                t0 = time.perf_counter()
                assert _export(render, layout, out, args) == 0, (layout, tag)
                self.seconds[layout] = time.perf_counter() - t0
                self.refs[layout, tag] = _tree(out)
        self.n = 0

    def run(self, how: str, layout: str, fraction: float) -> tuple[str, str]:
        import shutil
        import signal
        from blender_sesgen.contract import atomic
        args = dict(LAYOUTS)[layout]
        self.n += 1
        place = self.folder / f"trial-{self.n}"
        out = place / "OUT"
        shutil.copytree(self.folder / "ref" / layout / "A" / "OUT", out)
        writes = max(1, int(fraction * 40))
        pid = os.fork()
        if pid == 0:  # the export, in a child of its own
            code = 98
            try:  # (a SIGINT before the command begins: interrupted, nothing written)
                signal.signal(signal.SIGINT, signal.default_int_handler)
                if how == "export-enospc":
                    real, count = atomic.write_bytes, [0]

                    def full(path, data, durable=False):
                        count[0] += 1
                        if count[0] >= writes:
                            raise OSError(28, os.strerror(28))
                        return real(path, data, durable)
                    atomic.write_bytes = full
                with open(os.devnull, "w") as null:
                    os.dup2(null.fileno(), 1)
                    os.dup2(null.fileno(), 2)
                code = _export(self.r2, layout, out, args)
            except KeyboardInterrupt:
                code = 130
            finally:
                os._exit(code)
        if how != "export-enospc":
            time.sleep(fraction * 1.3 * self.seconds[layout])
            try:
                os.kill(pid, signal.SIGINT if how == "export-sigint" else signal.SIGKILL)
            except ProcessLookupError:
                pass
        _, status = os.waitpid(pid, 0)
        rc = os.waitstatus_to_exitcode(status)
        if how == "export-kill":
            atomic.recover(out)           # the next access finishes or removes it
        got = _tree(out) if out.exists() else None
        a, b = self.refs[layout, "A"], self.refs[layout, "B"]
        problems = []
        if got not in (a, b):
            problems.append("OUT is neither the earlier export nor the new one")
        if how == "export-sigint" and (rc not in (0, 130) or (rc == 0 and got != b)):
            problems.append(f"exit {rc}")
        if how == "export-kill" and rc not in (0, -9):
            problems.append(f"exit {rc}")
        if how == "export-enospc" and (rc not in (0, 1) or got != (a if rc == 1 else b)):
            problems.append(f"exit {rc} with a full disk")
        left = _leftovers(self.folder)
        if left:
            problems.append(f"left {left[:2]}")
        if self.n % 25 == 0 and _tree(self.r2) != self.r2_tree:
            problems.append("the render changed")
        shutil.rmtree(place, ignore_errors=True)
        if problems:
            return "finding", f"{layout} {how} at {fraction:.3f}: " + "; ".join(problems)
        return "ok", "earlier kept" if got == a else "new one whole"


def _export(render: Path, layout: str, out: Path, args) -> int:
    import contextlib
    import io
    from vo_reference.commands.main import main
    with contextlib.redirect_stdout(io.StringIO()):
        return main(["export", str(render), str(out), "--to", layout, "--progress", "off", *args])


def _tree(root: Path) -> dict:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in filenames:
            p = Path(dirpath) / name
            out[p.relative_to(root).as_posix()] = p.read_bytes()
    return out


def _leftovers(folder: Path) -> list[str]:
    from blender_sesgen.contract import atomic
    return [os.path.join(d, n) for d, dirs, files in os.walk(folder) for n in dirs + files
            if atomic.is_temp_name(n) or atomic.is_transaction_name(n)]


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
        self._start()

    def _start(self):
        import shutil
        if getattr(self, "folder", None):
            shutil.rmtree(self.folder, ignore_errors=True)
        self.folder = tempfile.mkdtemp(prefix=f"fuzz-{self.name}-")   # a fresh fixture: a crash may leave a FIFO
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
        import shutil
        shutil.rmtree(self.folder, ignore_errors=True)


def campaign(names, mutants: int, heavy: int, parser: int, seed: int, timeout: float, faults: bool,
             exports: int = 0):
    import fuzz_targets as ft
    rows, findings = [], []
    for name in names:
        count = parser if name == "parser" else exports if name in EXPORT_FAULTS else heavy if name in HEAVY \
            else mutants
        if count <= 0:
            continue
        rng = random.Random(f"{seed}-{name}")
        worker = Worker(name, timeout)
        tally = {k: 0 for k in ("ok", "user-error", "finding", "crash", "hang")}
        t0 = time.perf_counter()
        jobs = []
        for i in range(count):
            if name in EXPORT_FAULTS:
                jobs.append((LAYOUTS[i % len(LAYOUTS)][0], rng.random()))
                continue
            if name == "parser":
                jobs.append((rng.randrange(1000), ft.random_ops(rng, text=True)))
            else:
                target = ft.TARGETS[name]
                json_seed = rng.randrange(2**32) if target.json_doc and rng.random() < 0.5 else None
                jobs.append(("mutant", (ft.random_ops(rng, target.text), json_seed)))
        plain = name != "parser" and name not in EXPORT_FAULTS
        if faults and plain:
            jobs += [("fault", f) for f in FAULTS]
        n_faults = len(FAULTS) if faults and plain else count if name in EXPORT_FAULTS else 0
        ends: dict[str, int] = {}
        for job in jobs:
            outcome, detail = worker.run(job)
            tally[outcome] += 1
            if outcome not in ("ok", "user-error"):
                findings.append({"target": name, "outcome": outcome, "detail": detail, "job": repr(job)})
                # printed at once: a campaign stopped early still shows what it found
                print(f"<!-- FINDING {name}: {outcome}: {detail} | job: {job!r} -->", flush=True)
            elif name in EXPORT_FAULTS:
                ends[detail] = ends.get(detail, 0) + 1
        worker.close()
        if ends:
            print(f"<!-- {name}: " + ", ".join(f"{k} {v}" for k, v in sorted(ends.items())) + " -->", flush=True)
        rows.append({"target": name, "mutants": 0 if name in EXPORT_FAULTS else count, "faults": n_faults, **tally,
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
    p.add_argument("--exports", type=int, default=200,
                   help="interrupted exports per kind (SIGINT, SIGKILL, full disk), over the layouts (default 200)")
    p.add_argument("--targets", default="all", help="comma-separated target names, or 'all' (parser included)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--timeout", type=float, default=60.0, help="seconds per mutant before it counts as a hang")
    p.add_argument("--no-faults", action="store_true", help="no file-system fault injection")
    p.add_argument("--json", metavar="OUT.json", help="write the table and the findings as JSON")
    args = p.parse_args(argv)
    names = ["parser", *ft.TARGETS, *EXPORT_FAULTS] if args.targets == "all" else \
        [n.strip() for n in args.targets.split(",")]
    unknown = [n for n in names if n != "parser" and n not in ft.TARGETS and n not in EXPORT_FAULTS]
    if unknown:
        p.error(f"unknown targets {unknown} (have parser, {', '.join([*ft.TARGETS, *EXPORT_FAULTS])})")
    print("| " + " | ".join(COLUMNS) + " |")
    print("|" + "---|" * len(COLUMNS))
    rows, findings = campaign(names, args.mutants, args.heavy, args.parser, args.seed, args.timeout,
                              not args.no_faults, args.exports)
    total = {c: sum(r[c] for r in rows) for c in COLUMNS[1:]}
    print(_row({"target": "**total**", **{k: (round(v, 1) if isinstance(v, float) else v) for k, v in total.items()}}))
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "findings": findings}, indent=1))
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
