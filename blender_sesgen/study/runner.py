"""Run a whole study (``study run STUDY.toml --out DIR``; docs/studies.md).

::

    DIR/study.toml                  the study file as run
    DIR/plan.json                   every variant, its script's key, what is rendered and developed
    DIR/scripts/<key>.ses           the scripts (content-addressed: SHA-256 of script + render options)
    DIR/renders/<key>/              render folders (Cycles, or developed from another's EXRs)
    DIR/exports/<key>/<layout>/     the datasets the systems read (data/: read-only), done.json
    DIR/runs/<key>/<system>-<hash>/t<k>/   run.json, the trajectory, stdout/stderr, work/, metrics.json
    DIR/evaluate.json, controls.json      the evaluation's job and the ground-truth controls
    DIR/results.json, report.html   the results (versioned schema) and the report

Steps, on a local Ray or a cluster (``--address``): the distinct renders as farm tasks
(``farm.driver.Farm``: chunks, retries, verification); the sensor-only variants developed
from them (``render --reuse-exr``, farm tasks too); every export and every trial of every
system as Ray tasks chained by their results (``farm.tasks.TaskGraph``); then the
evaluation and the report (``vo_reference study ...``, child processes). With ``--no-ray``,
and whenever nothing is left to render, export or run, the same tasks run from this process
(``farm.local``) and no Ray is started.

Every step's output is content-addressed and written atomically, so a study killed at any
moment resumes where it stopped when the same command runs again: renders resume frame by
frame (nothing is rendered twice), finished exports and runs are taken as they are, and
only new trajectories are evaluated. A changed study file reuses whatever is still valid.
"""
from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Optional, Sequence

from ..contract import atomic
from ..contract.cli import EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_OK
from ..contract.progress import Progress
from ..errors import SesgenError
from .spec import Study, StudyError
from .systems import set_read_only
from .variants import Plan, make_plan, render_options

MARKER = "plan.json"


def vo_command(study: Study) -> list[str]:
    return list(study.vo) or [sys.executable, "-m", "vo_reference"]


def system_dir(s) -> str:
    digest = hashlib.sha256(json.dumps([list(s.cmd), s.layout, s.format, s.env], sort_keys=True).encode())
    return f"{s.name}-{digest.hexdigest()[:8]}"


def est_name(fmt: str) -> str:
    return "est.csv" if fmt == "euroc" else "est.txt"


def check_layouts(study, vo: Sequence[str]) -> None:
    """Every system's layout must be one ``vo_reference`` exports (asked once, as a child
    process: ``vo_reference study layouts``); StudyError naming the system's key."""
    try:
        proc = subprocess.run([*vo, "study", "layouts"], capture_output=True, text=True, timeout=300,
                              stdin=subprocess.DEVNULL)
        layouts = json.loads(proc.stdout)["layouts"]
    except (OSError, ValueError, KeyError, subprocess.TimeoutExpired) as e:
        raise SesgenError(f"cannot run vo_reference ({' '.join(vo)} study layouts: {e}); a study needs it: "
                          "pip install 'blender-sesgen[vo]', or set study.vo in the study file") from None
    for i, s in enumerate(study.systems):
        if s.layout not in layouts:
            raise StudyError(f"{study.path}: error: systems[{i}].layout: {s.layout!r} is not a layout "
                             f"vo_reference exports ({', '.join(layouts)})")


def check_folder(out: Path, study_file: Optional[Path] = None) -> None:
    """A study folder: new, empty, a study's (it has plan.json), or holding only the study
    file itself (as the add-on writes it)."""
    if out.exists() and not out.is_dir():
        raise SesgenError(f"--out {out}: exists and is not a folder")
    own = {Path(study_file).resolve()} if study_file is not None else set()
    if out.is_dir() and any(p.resolve() not in own for p in out.iterdir()) and not (out / MARKER).is_file():
        raise SesgenError(f"--out {out}: a folder that holds something else than a study (no {MARKER}); "
                         "choose a new or empty folder")


class StudyRun:
    """One ``study run`` (see the module docstring)."""

    def __init__(self, study: Study, out, *, address: Optional[str] = None, num_cpus: Optional[int] = None,
                 progress: str = "auto", chunk: int = 50, retries: int = 2, rerun=(), stream=None,
                 no_ray: bool = False):
        self.study, self.out = study, Path(out).absolute()
        self.address, self.num_cpus = address, num_cpus
        self.no_ray = bool(no_ray)           # every task from this process (farm.local), no Ray started
        if self.no_ray and address is not None:
            raise SesgenError("--no-ray runs on this machine alone: leave out --address")
        self._prepared: dict = {}            # key -> FarmScene prepared by _work_left
        self.mode, self.chunk, self.retries = progress, int(chunk), int(retries)
        self.stream = stream if stream is not None else sys.stderr
        self.vo = vo_command(study)
        self.env = dict(os.environ)          # the systems' environment, on Ray too (not a worker's, before ray.init)
        self.rerun = set(rerun)              # systems whose finished runs are run again
        self.render_failed: dict = {}        # key -> why
        self.frames_rendered = 0             # by Cycles, in this run
        self.frames_developed = 0            # by the camera chain alone, on reused EXRs
        self.render_wall_s = 0.0
        self.failures: list[str] = []        # what went wrong with the study itself (exit 1)

    def say(self, text: str) -> None:
        if self.mode != "off":
            print(text, file=self.stream, flush=True)

    # --- the whole run ------------------------------------------------------------------------
    def prepare(self) -> Plan:
        """The plan and its scripts in the folder (nothing else is touched)."""
        check_folder(self.out, self.study.path)
        plan = make_plan(self.study, self.out / "scripts")
        check_layouts(self.study, self.vo)
        for sub in ("scripts", "renders"):
            (self.out / sub).mkdir(parents=True, exist_ok=True)
        self._hold_folder()
        for folder in (self.out / "renders").iterdir():   # left read-only by a study killed while its systems ran
            if folder.is_dir() and not folder.stat().st_mode & 0o200:   # (os.access: always for root)
                set_read_only(folder, False)
        for key, text in [*plan.renders.items(), *((k, t) for k, (t, _) in plan.develops.items())]:
            path = self.out / "scripts" / f"{key}.ses"
            if not path.is_file() or path.read_text(encoding="utf-8") != text:
                atomic.write_text(path, text)
        if self.study.path != (self.out / "study.toml").resolve():
            atomic.write_bytes(self.out / "study.toml", self.study.path.read_bytes())
        atomic.write_json(self.out / MARKER, plan.to_json())
        return plan

    def _hold_folder(self) -> None:
        """One study run per folder: an exclusive ``flock`` on ``DIR/.study.lock`` for as long
        as this process lives (the kernel drops it however the process ends)."""
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX
            return
        self._lock = open(self.out / ".study.lock", "a+")
        try:
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise SesgenError(f"--out {self.out}: another `study run` is writing into it; wait for it to end "
                              "or stop it (it resumes when run again)") from None

    def run(self) -> int:
        from ..render.interrupt import sigterm_as_interrupt
        with sigterm_as_interrupt():     # SIGTERM stops a study as Ctrl-C does: consistent, resumable
            return self._run()

    def _run(self) -> int:
        t0 = time.monotonic()
        plan = self.prepare()
        s = self.study
        self.say(f"sesgen study {s.name}: {len(plan.variants)} variant(s) ({len(s.world.seeds)} world seed(s)), "
                 f"{len(plan.renders)} render(s), {len(plan.develops)} developed from another's EXRs, "
                 f"{len(s.systems)} system(s), {sum(x.trials for x in s.systems)} run(s) per variant -> {self.out}")
        self._forget_reruns(plan)
        if self.address is None and (self.no_ray or not self._work_left(plan)):
            from ..farm.local import LocalCluster
            if not self.no_ray:
                self.say("study: nothing left to render, export or run: Ray not started")
            cluster = LocalCluster(self.num_cpus)
        else:
            from ..farm.cluster import Cluster
            ours = signal.getsignal(signal.SIGTERM)
            cluster = Cluster(self.address, num_cpus=self.num_cpus).start()
            if threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGTERM, ours)   # ray.init put in its own: an abort with a stack dump
        try:
            if self.address is not None:
                cluster.check_shared(self.out, [self.out / "scripts" / f"{k}.ses" for k in plan.renders])
            self.say(f"study: {cluster.describe()}")
            t_r = time.monotonic()
            self.render(cluster, plan)
            self.develop(cluster, plan)
            self.render_wall_s = time.monotonic() - t_r
            self.tasks(cluster, plan)
        finally:
            cluster.stop()
        self.evaluate(plan)
        wall = time.monotonic() - t0
        doc = self.write_results(plan, wall)
        self.report()
        self.summary(doc)
        return EXIT_FAILURE if self.failures else EXIT_OK

    # --- renders --------------------------------------------------------------------------------
    def _farm(self, cluster, scenes: list, chunk: int, developed: bool = False):
        from ..farm.driver import Farm
        from ..farm.work import auto_cpus_per_task, frame_ranges
        good = [sc for sc in scenes if sc.error is None]
        for sc in scenes:   # a folder that cannot be rendered (held by a live writer, ...) fails the study
            if sc.error is not None:
                self.render_failed[sc.name] = sc.error
                self.failures.append(f"render {sc.name}: {sc.error}")
        if not good:
            return
        cpus, _ = cluster.totals()
        cpt = auto_cpus_per_task(cpus, sum(len(frame_ranges(sc.pending, chunk)) for sc in good))
        farm = Farm(cluster, good, chunk=chunk, retries=self.retries, cpus_per_task=cpt, gpus_per_task=0.0,
                    threads=max(1, int(cpt)), forwarded=[], progress_mode=self.mode, stream=self.stream)
        result = farm.run()
        if developed:
            self.frames_developed += result.frames_rendered
        else:
            self.frames_rendered += result.frames_rendered
        if result.interrupted:
            raise KeyboardInterrupt
        for st in result.failed:
            self.render_failed[st.scene.name] = st.failed or "not finished"
            self.failures.append(f"render {st.scene.name}: {st.failed}")

    def _scene(self, key: str, options, args=()):
        from ..farm.work import FarmScene, prepare_scene
        if key in self._prepared:          # by _work_left, just before
            return self._prepared.pop(key)
        sc = FarmScene(name=key, script=self.out / "scripts" / f"{key}.ses", out=self.out / "renders" / key,
                       args=list(args))
        return prepare_scene(sc, options)

    def render(self, cluster, plan: Plan) -> None:
        options = render_options(self.study)
        scenes = [self._scene(k, options, plan.render_args) for k in plan.renders]
        todo = sum(len(sc.pending) for sc in scenes if sc.error is None)
        self.say(f"study: renders: {len(scenes)} ({todo} frame(s) to render, the rest done)")
        self._farm(cluster, scenes, self.chunk)

    def develop(self, cluster, plan: Plan) -> None:
        if not plan.develops:
            return
        options = render_options(self.study)
        scenes = []
        for key, (_, base) in plan.develops.items():
            if base in self.render_failed:
                self.render_failed[key] = f"its base render {base} failed"
                continue
            where = str(self.out / "renders" / base)
            scenes.append(self._scene(key, replace(options, reuse_exr=where),
                                      [*plan.render_args, "--reuse-exr", where]))
        self.say(f"study: {len(scenes)} sensor-stage variant(s) developed from their base renders' EXRs "
                 "(the camera chain only)")
        big = max((len(sc.plan.frames) for sc in scenes if sc.plan is not None), default=1)
        self._farm(cluster, scenes, big, developed=True)

    # --- exports and system runs ------------------------------------------------------------------
    def run_dir(self, key: str, system, trial: int) -> Path:
        return self.out / "runs" / key / system_dir(system) / f"t{trial}"

    def _forget_reruns(self, plan: Plan) -> None:
        """``--rerun``: a new version of a system behind the same command runs again."""
        from .systems import remove_tree
        for v in plan.variants:
            for s in self.study.systems:
                if s.name in self.rerun:
                    for t in range(s.trials):
                        remove_tree(self.run_dir(v.key, s, t))

    def _work_left(self, plan: Plan) -> bool:
        """Whether a render, a development, an export or a system run is left to do (a
        folder that cannot be rendered counts: the farm records why). Without, the study
        needs no Ray: the farm verifies the finished renders and the task graph gathers the
        finished tasks' records in this process (``farm.local``)."""
        options = render_options(self.study)
        for key in plan.renders:
            sc = self._prepared[key] = self._scene(key, options, plan.render_args)
            if sc.error is not None or sc.pending:
                return True
        for key, (_, base) in plan.develops.items():
            where = str(self.out / "renders" / base)
            sc = self._prepared[key] = self._scene(key, replace(options, reuse_exr=where),
                                                   [*plan.render_args, "--reuse-exr", where])
            if sc.error is not None or sc.pending:
                return True
        from .work import export_done
        for v in plan.variants:
            render_dir = str(self.out / "renders" / v.key)
            for s in self.study.systems:
                if not export_done(self.out / "exports" / v.key / s.layout, render_dir) or \
                        any(not (self.run_dir(v.key, s, t) / "run.json").is_file() for t in range(s.trials)):
                    return True
        return False

    def tasks(self, cluster, plan: Plan) -> None:
        from ..farm.tasks import After, TaskGraph
        from .work import export_variant, run_trial
        graph = TaskGraph(cluster)
        labels = {}
        seen = set()
        for v in plan.variants:
            if v.key in seen or v.key in self.render_failed:
                continue
            seen.add(v.key)
            render_dir = str(self.out / "renders" / v.key)
            frames = self._frames(v.key)
            for layout in sorted({s.layout for s in self.study.systems}):
                ek = f"export/{v.key}/{layout}"
                graph.add(ek, export_variant, self.vo, render_dir, str(self.out / "exports" / v.key / layout), layout)
                labels[ek] = f"export {layout} {v.name}"
            for s in self.study.systems:
                for t in range(s.trials):
                    rk = f"run/{v.key}/{s.name}/{t}"
                    graph.add(rk, run_trial, After(f"export/{v.key}/{s.layout}"), list(s.cmd), self.vo,
                              str(self.run_dir(v.key, s, t)), t, frames, s.timeout_s, dict(s.env), est_name(s.format),
                              self.env)
                    labels[rk] = f"{s.name} trial {t} on {v.name}"
        if not graph.refs:
            return
        self.say(f"study: {len(graph.refs)} task(s): exports and system runs")
        renders = [self.out / "renders" / k for k in sorted(seen)]
        for folder in renders:             # the ground truth, read-only to the systems (as their datasets)
            set_read_only(folder)
        try:
            self._run_graph(graph, labels)
        finally:
            for folder in renders:
                set_read_only(folder, False)

    def _run_graph(self, graph, labels: dict) -> None:
        from ..farm.tasks import TaskError
        with Progress(len(graph.refs), "study", mode=self.mode, stream=self.stream, unit="task",
                      every_line=True) as bar:
            def done(key, res):
                if isinstance(res, TaskError):
                    self.failures.append(f"{labels[key]}: {res.message}")
                    text = f"ERROR {res.message}"
                elif key.startswith("export/"):
                    text = "ok" if res.get("ok") else f"FAILED: {res.get('error')}"
                    if not res.get("ok"):
                        self.failures.append(f"{labels[key]}: {res.get('error')}")
                else:
                    text = (f"exit {res.get('rc')}, {res.get('wall_s', 0):.1f} s" if not res.get("error")
                            else f"FAILED: {res['error']}")
                bar.update(detail=f"{labels[key]}: {text}", task=key)
            graph.run(done)

    def _frames(self, key: str) -> int:
        try:
            return int(json.loads((self.out / "renders" / key / "manifest.json").read_text())["frames"])
        except (OSError, ValueError, KeyError):
            return 0

    # --- evaluation, results, report ----------------------------------------------------------------
    def evaluate(self, plan: Plan) -> None:
        runs, seen = [], set()
        for v in plan.variants:
            for s in self.study.systems:
                for t in range(s.trials):
                    rd = self.run_dir(v.key, s, t)
                    if rd in seen:
                        continue
                    seen.add(rd)
                    rec = _read(rd / "run.json")
                    if rec is not None and rec.get("rc") == 0 and not rec.get("timed_out") and not rec.get("error"):
                        runs.append({"run_dir": str(rd), "gt": str(self.out / "renders" / v.key), "est": rec["est"],
                                     "format": s.format, "mono": s.mono})
        controls, seen = [], set()
        for v in plan.variants:
            base = plan.base_of(v.seed)
            if v.controlled and v.key not in seen and v.key != base.key and v.key not in self.render_failed \
                    and base.key not in self.render_failed:
                seen.add(v.key)
                controls.append({"key": v.key, "variant": str(self.out / "renders" / v.key),
                                 "base": str(self.out / "renders" / base.key)})
        ev = self.study.evaluation
        job = {"settings": {"min_coverage": ev.min_coverage, "jump_factor": ev.jump_factor}, "runs": runs,
               "controls": controls, "controls_out": str(self.out / "controls.json")}
        atomic.write_json(self.out / "evaluate.json", job)
        self.say(f"study: evaluating {len(runs)} run(s), {len(controls)} ground-truth control(s)")
        self._vo(["study", "evaluate", str(self.out / "evaluate.json"), "--progress",
                  "plain" if self.mode in ("auto", "bar") else self.mode], "evaluation")

    def _vo(self, args: list[str], what: str) -> bool:
        proc = subprocess.run([*self.vo, *args], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                              stderr=None if self.mode != "off" else subprocess.DEVNULL, text=True)
        if proc.returncode != 0:
            self.failures.append(f"{what}: {' '.join(self.vo)} {args[0]} {args[1]} exited with {proc.returncode}")
            self.say(f"study: the {what} failed (exit code {proc.returncode})")
            return False
        return True

    def collect_runs(self, plan: Plan) -> list[dict]:
        from .results import run_record
        from .work import export_failure
        out = []
        for v in plan.variants:
            for s in self.study.systems:
                for t in range(s.trials):
                    rd = self.run_dir(v.key, s, t)
                    if v.key in self.render_failed:
                        run = {"error": f"the variant could not be rendered: {self.render_failed[v.key]}"}
                    else:
                        run = _read(rd / "run.json")
                        why = export_failure(self.out / "exports" / v.key / s.layout)
                        if run is None:
                            run = {"error": f"the dataset could not be exported: {why}" if why else "did not run"}
                    metrics = _read(rd / "metrics.json") if run.get("error") is None else None
                    out.append(run_record(v, s, t, run, metrics, str(rd.relative_to(self.out))))
        return out

    def write_results(self, plan: Plan, wall_s: float) -> dict:
        from .results import results
        controls = _read(self.out / "controls.json") or {}
        cost = {"variants": len(plan.variants), "distinct_scripts": len({v.key for v in plan.variants}),
                "renders": len(plan.renders), "developed": len(plan.develops),
                "renders_saved": len(plan.variants) - len(plan.renders),
                "frames_rendered": self.frames_rendered, "frames_developed": self.frames_developed,
                "render_wall_s": round(self.render_wall_s, 2),
                "wall_s": round(wall_s, 2), "render_share": self.render_wall_s / wall_s if wall_s > 0 else 0.0}
        doc = results(self.study, plan, self.collect_runs(plan), controls, cost)
        atomic.write_json(self.out / "results.json", doc)
        return doc

    def report(self) -> None:
        self._vo(["study", "report", str(self.out)], "report")

    def summary(self, doc: dict) -> None:
        runs = doc["runs"]
        failed = [r for r in runs if r["status"] != "ok"]
        print(f"study {self.study.name}: {len(runs)} run(s), {len(failed)} failed; "
              f"{doc['cost']['renders']} render(s), {doc['cost']['developed']} developed, "
              f"{doc['cost']['frames_rendered']} frame(s) rendered in this run")
        for f, per in doc.get("breaking_points", {}).items():
            for s, b in per.items():
                lv = b["level"]
                print(f"  breaking point {f} / {s}: {'none' if lv is None else lv} ({b['reason']})")
        bad = [v for v in doc["variants"] if v.get("control") and not v["control"].get("identical")]
        if bad:
            print(f"  WARNING: {len(bad)} controlled variant(s) with ground truth different from their base: "
                  + ", ".join(v["name"] for v in bad))
        for f in self.failures:
            print(f"  problem: {f}", file=sys.stderr)
        if (self.out / "report.html").is_file():
            print(f"report: {self.out / 'report.html'}")


def _read(path: Path) -> Optional[dict]:
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def run_study(study: Study, out, **kw) -> int:
    """Run ``study`` into ``out``; the exit code (0 done, 1 a step of the study itself failed,
    130 interrupted: run again to continue)."""
    from ..farm.cluster import ClusterStartError
    try:
        return StudyRun(study, out, **kw).run()
    except ClusterStartError as e:
        print(f"error: {e}; {out} is consistent: run the same command again", file=sys.stderr)
        return EXIT_FAILURE
    except KeyboardInterrupt:
        print(f"interrupted: {out} is consistent; run the same command again to continue", file=sys.stderr)
        return EXIT_INTERRUPTED
