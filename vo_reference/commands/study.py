"""``python -m vo_reference study evaluate JOB.json`` and ``python -m vo_reference study
report DIR``: the evaluation and the report of a verification study (run by
``python -m blender_sesgen study run``; docs/studies.md).

The job file (written by the study) lists the runs to evaluate -- ``{"settings":
{"min_coverage", "jump_factor"}, "runs": [{"run_dir", "gt", "est", "format", "mono"}],
"controls": [{"key", "variant", "base"}], "controls_out": PATH}`` -- and each run's record
goes to ``RUN_DIR/metrics.json`` (skipped when it is there for the same trajectory file and
settings and the same ``EVALUATION_VERSION``: a resumed study evaluates only what is new, and
every run again when the record's definition changed).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from blender_sesgen.contract.progress import Progress, add_progress_argument, progress_mode

from ..errors import VoError


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="study_command", metavar="STEP", required=True)
    e = sub.add_parser("evaluate", help="evaluate every run a job file lists (metrics.json beside each run)")
    e.add_argument("job", metavar="JOB.json", help="the job file a study writes (study-folder/evaluate.json)")
    add_progress_argument(e)
    r = sub.add_parser("report", help="write DIR/report.html from DIR/results.json")
    r.add_argument("folder", metavar="DIR", help="a study folder (study run --out DIR)")
    sub.add_parser("layouts", help="the export layouts, as JSON (what a study's systems may read)")


def run(args: argparse.Namespace) -> int:
    if args.study_command == "layouts":
        from ..exporters.driver import EXPORTERS
        print(json.dumps({"layouts": list(EXPORTERS)}))
        return 0
    if args.study_command == "report":
        from ..study.report import write_report
        print(f"report: {write_report(args.folder)}")
        return 0
    return evaluate(args)


def _read_json(path: Path):
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise VoError(f"{path}: cannot read ({e})") from None


def evaluate(args: argparse.Namespace) -> int:
    from ..evaluate.report import write_json
    from ..io.render import RenderSequence
    from ..io.trajectory import read_render_poses
    from ..study.evaluate import EVALUATION_VERSION, evaluate_run, ground_truth_identical, sha256_file

    job = _read_json(Path(args.job))
    settings = job.get("settings") or {}
    runs, controls = job.get("runs") or [], job.get("controls") or []
    out_path = Path(job["controls_out"]) if job.get("controls_out") else None
    done_controls = _read_json(out_path) if out_path is not None and out_path.is_file() else {}
    gts: dict = {}
    with Progress(len(runs) + len(controls), "study evaluate", mode=progress_mode(args), unit="run") as bar:
        for r in runs:
            metrics_path = Path(r["run_dir"]) / "metrics.json"
            est = Path(r["est"])
            sha = sha256_file(est) if est.is_file() else None
            if metrics_path.is_file():
                old = _read_json(metrics_path)
                if old.get("settings") == settings and old.get("est_sha256") == sha and old.get("gt") == r["gt"] \
                        and old.get("evaluation_version") == EVALUATION_VERSION:
                    bar.update(detail=f"{r['run_dir']} (done)")
                    continue
            if r["gt"] not in gts:
                gts[r["gt"]] = (read_render_poses(r["gt"]), RenderSequence(r["gt"]).rate_hz)
            gt, rate = gts[r["gt"]]
            rec = evaluate_run(gt, est, r["format"], mono=bool(r.get("mono")), rate_hz=rate,
                               min_coverage=float(settings.get("min_coverage", 0.5)),
                               jump_factor=float(settings.get("jump_factor", 5.0)))
            rec.update(settings=settings, est_sha256=sha, gt=r["gt"], evaluation_version=EVALUATION_VERSION)
            write_json(metrics_path, rec)
            bar.update(detail=f"{r['run_dir']}: {'ok' if rec['ok'] else rec['failure']}")
        for c in controls:
            if c["key"] not in done_controls:
                done_controls[c["key"]] = ground_truth_identical(RenderSequence(c["variant"]), RenderSequence(c["base"]))
                if out_path is not None:
                    write_json(out_path, done_controls)
            bar.update(detail=f"control {c['key']}: {'identical' if done_controls[c['key']].get('identical') else 'DIFFERS'}")
    return 0
