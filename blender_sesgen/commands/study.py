"""``python -m blender_sesgen study run STUDY.toml --out DIR`` and ``study compare OLD NEW``
(docs/studies.md).

Exit codes: ``run``: 0 the study ran (systems that failed are results, in the report), 1 a
step of the study itself failed (a render, an export, the evaluation), 2 a bad study file
(one line: ``file:line:col`` for TOML, else the key), 130 interrupted (run the same command
again: it resumes). ``compare``: 0 no regression, 1 a regression beyond the trials' spread,
2 bad input (a level whose measure is missing from its runs, e.g. the APE rotation on a
path too straight for the fit to fix it, is ``unmeasured``: said, not a regression).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..contract.progress import add_progress_argument, progress_mode

EPILOG = """\
The study file (TOML) names the base world, the factors and their levels, the design and
the systems under test:

  [world]
  script = "scenes/street.ses"        # or: generator = "city", seeds = [1, 2], options = {frames = 20}
  frames = 12                         # the first N frames
  resolution = 0.25                   # or [W, H]: the image size (focal length scaled with it)
  quality = "draft"                   # gt | draft | final | reference (samples = N overrides)

  [factors.exposure_time]             # a factor of the registry (docs/studies.md) ...
  levels = [0.002, 0.01, 0.03]
  [factors.road_wear]                 # ... or a user factor: a statement's tag (or a generator option)
  statement = "MATERIAL"
  match = { name = "old_road" }
  tag = "wear"
  levels = [0.2, 0.8]

  [design]
  kind = "oat"                        # oat (one factor at a time) | grid (two factors) | lhs (+ samples, seed)

  [[systems]]
  builtin = "accurate-stereo"         # paper-stereo | accurate-stereo | opencv-stereo | mono
  [[systems]]
  name = "mine"
  cmd = "python my_vo.py {dataset} {out}"
  layout = "kitti-folder"             # any export layout
  format = "kitti"                    # tum | kitti | euroc: what it writes to {out}
  timeout_s = 120
  trials = 3

Placeholders: {dataset} {sequence} {out} {workdir} {trial} {frames} {python} {vo}.
Factors: sesgen study factors."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.epilog = EPILOG
    sub = p.add_subparsers(dest="study_command", metavar="ACTION", required=True)
    r = sub.add_parser("run", help="run a study: render the variants, run every system, evaluate, report",
                       description="Run a verification study into DIR (resumes when DIR holds the same study).",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("study", metavar="STUDY.toml", help="the study file")
    r.add_argument("--out", required=True, metavar="DIR",
                   help="the study's folder: renders, exports, runs, results.json, report.html")
    r.add_argument("--address", metavar="auto|HOST:PORT",
                   help="join this Ray cluster (DIR on a filesystem every node shares); default: a local Ray")
    r.add_argument("--num-cpus", type=int, metavar="N", help="this machine only: the CPUs it may use (default all)")
    r.add_argument("--no-ray", action="store_true",
                   help="run every task from this process, without Ray (no start-up: for a small study, or where "
                        "Ray is not installed); a study with nothing left to run starts no Ray anyway")
    r.add_argument("--chunk", type=int, default=50, metavar="N",
                   help="frames per render task (default 50: a study's short sequence renders in one task, its "
                        "scene built once)")
    r.add_argument("--retries", type=int, default=2, metavar="K",
                   help="times a lost render task is run again (default 2)")
    r.add_argument("--rerun", metavar="SYSTEM[,SYSTEM]",
                   help="run these systems again (or 'all'): a new version of a system's code keeps its command, "
                        "so its finished runs would otherwise be taken as they are")
    r.add_argument("--plan", action="store_true",
                   help="only check the study file and print its variants and renders (nothing is run)")
    add_progress_argument(r)
    c = sub.add_parser("compare", help="compare two studies' results.json: exit 1 on a regression",
                       description="Per factor, level and system: did NEW get worse than OLD beyond the "
                                   "trials' spread? Exit 1 if so (for CI). 'unmeasured': the measure is missing "
                                   "from the runs of either (ape_rot_rmse_deg where the alignment leaves the "
                                   "rotation free: alignment_ill_posed); said, not a regression.")
    c.add_argument("old", metavar="OLD.json", help="results.json of the earlier run")
    c.add_argument("new", metavar="NEW.json", help="results.json of the new run")
    c.add_argument("--sigmas", type=float, default=None, metavar="K",
                   help="worse means more than K spreads worse (default: NEW's evaluation.regression_sigmas, 1)")
    c.add_argument("--json", metavar="OUT.json", help="also write the comparison as JSON")
    sub.add_parser("factors", help="list the factor registry: name, unit, stage, what it changes")


def run(args: argparse.Namespace) -> int:
    from ..errors import SesgenError
    from ..study.spec import load
    if args.study_command == "factors":
        from ..study.factors import FACTORS
        for f in FACTORS.values():
            print(f"{f.name:<17} {f.unit:<9} {f.stage:<9} {f.doc}")
        return 0
    if args.study_command == "compare":
        return compare(args)
    study = load(args.study)
    if args.chunk < 1 or args.retries < 0:
        raise SesgenError("--chunk must be >= 1 and --retries >= 0")
    if args.plan:
        from ..study.runner import check_folder
        from ..study.variants import make_plan
        from ..study.runner import check_layouts, vo_command
        check_folder(Path(args.out), study.path)
        plan = make_plan(study, Path(args.out).absolute() / "scripts")
        check_layouts(study, vo_command(study))
        for v in plan.variants:
            how = f"developed from {v.render_key}" if v.developed else "rendered"
            print(f"{v.name:<40} {v.stage:<9} {v.key} {how}")
        print(f"{len(plan.variants)} variant(s): {len(plan.renders)} render(s), {len(plan.develops)} developed")
        return 0
    from ..study.runner import run_study
    rerun = [x.strip() for x in (args.rerun or "").split(",") if x.strip()]
    names = [s.name for s in study.systems]
    for name in rerun:
        if name != "all" and name not in names:
            raise SesgenError(f"--rerun {name}: the study has no such system (systems: {', '.join(names)})")
    return run_study(study, args.out, address=args.address, num_cpus=args.num_cpus, progress=progress_mode(args),
                     chunk=args.chunk, retries=args.retries, rerun=names if "all" in rerun else rerun,
                     no_ray=args.no_ray)


def compare(args: argparse.Namespace) -> int:
    from ..contract import atomic
    from ..errors import SesgenError
    from ..study.results import compare as compare_docs
    docs = []
    for p in (args.old, args.new):
        try:
            docs.append(json.loads(Path(p).read_text(encoding="utf-8")))
        except (OSError, ValueError) as e:
            raise SesgenError(f"{p}: cannot read a results.json ({e})") from None
    sigmas = args.sigmas if args.sigmas is not None else float(docs[1].get("study", {}).get("regression_sigmas", 1.0))
    rows = compare_docs(*docs, sigmas=sigmas)
    worse = [r for r in rows if r["verdict"] == "worse"]
    for r in rows:
        mark = {"worse": "WORSE ", "better": "better", "same": "same  ", "unmeasured": "unmeasured"}[r["verdict"]]
        lv = f" = {r['level']}" if r["level"] else ""
        print(f"{mark} {r['factor']}{lv} / {r['system']}: {r['detail']}")
    if args.json:
        atomic.write_json(Path(args.json), {"rows": rows, "regressions": len(worse), "sigmas": sigmas})
    print(f"compare: {len(rows)} comparison(s), {len(worse)} regression(s) beyond {sigmas:g} spread(s)",
          file=sys.stderr)
    return 1 if worse else 0
