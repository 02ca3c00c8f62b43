"""``results.json`` (format ``sesgen-study-results/3``): every run, its aggregates, the
breaking points; and ``study compare`` (pure: numpy and the standard library).

- A **run** is ``ok`` when the system exited 0 within its timeout and its trajectory was
  usable (``vo_reference.study.evaluate``); otherwise it ``failed``, with the reason, the
  exit code and the tail of its stderr.
- **Aggregates** pool a design point's runs over trials and world seeds, per system: the
  number of runs and of failures, and per metric the mean, spread (sample standard
  deviation; 0 for one value), min and max of the runs that did not fail. A measure that
  some of those runs lack (``n_missing``: ``ape_rot_rmse_deg`` where the run's alignment left
  the rotation free, ``alignment_ill_posed``; the translations of a monocular run whose Sim(3)
  fit does not fix the scale, ``scale_ill_posed``; the KITTI metric on a path under 100 m; a
  value that was not a finite number) has no mean there: the others would be a selected subset
  (format 2; format 1 averaged them). ``definitions``: what the runs' values mean (the
  alignment, the evaluation's version; format 3).
- The **breaking point** of a factor for a system (one-factor-at-a-time designs): the first
  level, in the order the study file lists them, at which at least half the runs fail or
  the mean error exceeds max(``break_multiple`` times the base's, ``BREAK_FLOOR``) by more than
  ``break_sigmas`` times the spread of that difference, sqrt(std_level^2 + (break_multiple *
  std_base)^2), the stds over trials and world seeds. The floor (per metric, format 3) keeps a
  base of 0 or of rounding from making any error a breaking point. With one run per point the
  spread is 0 and the rule is the plain multiple; a level above the multiple but within the
  spread is marked ``within_spread`` (not broken: its scatter does not separate it from the
  base's); a level whose values mean something else than the base's (``redefined``) is not
  compared, and said.
- **compare** OLD NEW: per factor, level and system, NEW is *worse* when it fails more
  often, or when its mean error exceeds OLD's by more than ``sigmas`` times the larger of
  the two spreads (and by more than 1e-9 relative: a deterministic system run twice is
  unchanged); *better* the other way round; *unmeasured* when either has no mean though its
  runs did not fail (a measure missing from its runs: not a regression, but said), when the
  two means are of different definitions (another alignment), or when only one study has the
  level or system (a renamed system, a new level: listed, not skipped). Two studies evaluated by
  different evaluation versions are refused (an error): every figure may have moved.
"""
from __future__ import annotations

import math
from collections import defaultdict
from typing import Optional

import numpy as np

FORMAT = "sesgen-study-results/3"      # 2: n_missing, alignment_ill_posed, rotation_sigma_deg, ape_rot_origin_rmse_deg;
# 3: break_floor, a cell's definitions and n_scale_ill_posed, the study's evaluation_versions
# The least error that can break, per metric (its unit): a level breaks only above max(break_multiple x
# the base's, this). Without it a base of 0 -- a perfect system, a tracking loss of 0 -- or of rounding
# (1e-9) makes any error above it a breaking point. Well under any VO's error on the example studies
# (APE 2-20 cm, RPE rotation 0.04-0.2 deg a frame), well above a trajectory file's rounding; the tracking
# loss's: more than 1 frame in 20 lost.
BREAK_FLOOR = {"ape_trans_rmse": 1e-3, "ape_rot_rmse_deg": 0.01, "ape_rot_origin_rmse_deg": 0.01,
               "rpe_trans_rmse": 1e-3, "rpe_rot_rmse_deg": 0.01, "rpe_trans_per_m": 1e-3, "kitti_t_err_pct": 0.1,
               "kitti_r_err_deg_per_100m": 0.1, "tracking_loss": 0.05, "coverage": 0.0}
# Measures that no alignment touches (rotations relative to the first pose or frame to frame): the
# same definition whatever a run's alignment was.
ALIGNMENT_FREE = ("ape_rot_origin_rmse_deg", "rpe_rot_rmse_deg", "kitti_r_err_deg_per_100m", "coverage")
METRIC_KEYS = ("ape_trans_rmse", "ape_rot_rmse_deg", "ape_rot_origin_rmse_deg", "rpe_trans_rmse", "rpe_rot_rmse_deg",
               "rpe_trans_per_m", "kitti_t_err_pct", "kitti_r_err_deg_per_100m", "tracking_loss", "coverage")
REL_TOL = 1e-9
# Measures per frame, and the factors that change how far a frame moves (the step along the same
# path): across their levels a steady error per metre reads as a trend of the per-frame figure (rig
# speed 3x: 3x the RPE a frame; frame rate 2x: half), so a breaking point there says so.
PER_FRAME = ("rpe_trans_rmse", "rpe_rot_rmse_deg")
STEP_FACTORS = ("frame_rate", "rig_speed")


def stats(values) -> dict:
    """Mean, spread, min, max of ``values``; none when any is missing (None, not finite):
    ``n_missing`` says how many (a subset would be a selection, module docstring)."""
    values = list(values)
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    missing = len(values) - int(v.size)
    if v.size == 0 or missing:
        return {"n": int(v.size), "n_missing": missing, "mean": None, "std": None, "min": None, "max": None}
    return {"n": int(v.size), "n_missing": 0, "mean": float(v.mean()), "std": float(v.std(ddof=1)) if v.size > 1
            else 0.0, "min": float(v.min()), "max": float(v.max())}


def run_record(variant, system, trial: int, run: dict, metrics: Optional[dict], folder: str) -> dict:
    """One run as results.json lists it (``run``: its run.json, ``metrics``: its metrics.json)."""
    failure = run.get("error")
    m = metrics or {}
    if failure is None and metrics is None:
        failure = "not evaluated"
    if failure is None and not m.get("ok"):
        failure = m.get("failure") or "not evaluated"
    keep = {k: m[k] for k in (*METRIC_KEYS, "alignment", "alignment_ill_posed", "rotation_sigma_deg", "scale",
                              "scale_ambiguity", "scale_ill_posed", "evaluation_version", "non_finite",
                              "lost_frames", "jumps", "n_paired", "n_frames", "est_xyz", "frames", "gt_path_length_m")
            if k in m}
    for k in METRIC_KEYS:          # NaN is not JSON, and not a number to average: missing
        if isinstance(keep.get(k), float) and not math.isfinite(keep[k]):
            keep[k] = None
    return {"variant": variant.name, "key": variant.key, "point": variant.point, "world_seed": variant.seed,
            "system": system.name, "trial": trial, "status": "ok" if failure is None else "failed",
            "failure": failure, "rc": run.get("rc"), "timed_out": bool(run.get("timed_out")),
            "wall_s": run.get("wall_s"), "stderr_tail": run.get("stderr_tail") or [], "dir": folder,
            "metrics": keep}


def definition(run: dict, metric: str) -> str:
    """What a run's ``metric`` means: the alignment it was measured after (the first word of the
    record's ``alignment``: se3, sim3; session 20 and before also origin, origin+scale on a straight
    path) -- none for the measures no alignment touches -- and the evaluation's version."""
    m = run.get("metrics") or {}
    how = "" if metric in ALIGNMENT_FREE else str(m.get("alignment") or "?").split()[0] + ", "
    v = m.get("evaluation_version")
    return how + (f"evaluation {v}" if v is not None else "evaluation <= 2")


def aggregate(runs: list, metric: str) -> dict:
    """{(point label, system): aggregate} over the runs (module docstring)."""
    from .design import label
    groups = defaultdict(list)
    for r in runs:
        groups[(label(r["point"]), r["system"])].append(r)
    out = {}
    for key, rs in groups.items():
        ok = [r for r in rs if r["status"] == "ok"]
        out[key] = {"point": rs[0]["point"], "system": key[1], "n": len(rs), "n_failed": len(rs) - len(ok),
                    "n_ill_posed": sum(bool(r["metrics"].get("alignment_ill_posed")) for r in ok),
                    "n_scale_ill_posed": sum(bool(r["metrics"].get("scale_ill_posed")) for r in ok),
                    "definitions": sorted({definition(r, metric) for r in ok}),
                    "metrics": {m: stats([r["metrics"].get(m) for r in ok]) for m in METRIC_KEYS}}
    return out


def _cell(agg: Optional[dict], metric: str) -> dict:
    if agg is None:
        return {"n": 0, "n_failed": 0, "mean": None, "std": None}
    s = agg["metrics"][metric]
    return {"n": agg["n"], "n_failed": agg["n_failed"], "mean": s["mean"], "std": s["std"], "min": s["min"],
            "max": s["max"], "n_missing": s.get("n_missing", 0), "n_ill_posed": agg.get("n_ill_posed", 0),
            "n_scale_ill_posed": agg.get("n_scale_ill_posed", 0), "definitions": agg.get("definitions")}


def _unmeasured(c: dict) -> bool:
    """Runs that did not fail, but no mean: the measure is missing from (some of) them."""
    return c["n"] > c["n_failed"] and c["mean"] is None


def unmeasured_reason(c: dict, metric: str) -> str:
    why = f"{metric} missing from {c.get('n_missing', 0)} of {c['n'] - c['n_failed']} runs"
    if metric == "ape_rot_rmse_deg" and c.get("n_ill_posed"):
        why += (f" ({c['n_ill_posed']} aligned by a fit that leaves its rotation free: a short or nearly straight "
                "path; read ape_rot_origin_rmse_deg, the rotation drift from the first pose, or rpe_rot_rmse_deg)")
    if c.get("n_scale_ill_posed") and metric not in ALIGNMENT_FREE and metric != "ape_rot_rmse_deg":
        why += (f" ({c['n_scale_ill_posed']} monocular run(s) whose Sim(3) fit does not fix the scale: the "
                "estimate barely moves against its noise or does not follow the path; read a rotation measure)")
    return why


def _redefined(a: dict, b: dict, names=("the base", "here")) -> str:
    """Why two cells' means are of different definitions ('' when they are not, or not recorded)."""
    da, db = a.get("definitions"), b.get("definitions")
    if not da or not db or da == db:
        return ""
    return f"measured under different definitions ({names[0]}: {'; '.join(da)}, {names[1]}: {'; '.join(db)})"


def _n_ok(c: dict) -> int:
    return c["n"] - c["n_failed"]


def _failed(c: dict) -> bool:
    return c["n"] > 0 and 2 * c["n_failed"] >= c["n"]


def curves_and_breaks(study, aggs: dict, metric: str) -> tuple[dict, dict, dict]:
    """(curves {factor: {system: [cell per level]}}, base {system: cell}, breaking points)."""
    from .design import label
    base = {s.name: _cell(aggs.get(("base", s.name)), metric) for s in study.systems}
    curves, breaks = {}, {}
    if study.design.kind != "oat":
        return curves, base, breaks
    mult, k = study.evaluation.break_multiple, study.evaluation.break_sigmas
    floor = BREAK_FLOOR.get(metric, 0.0)
    for f in study.factors:
        curves[f.name], breaks[f.name] = {}, {}
        for s in study.systems:
            b = base[s.name]
            cells, found = [], None
            for lv in f.levels:
                c = _cell(aggs.get((label({f.name: lv}), s.name)), metric)
                why, c["within_spread"] = None, False
                redefined = _redefined(b, c) if c["mean"] is not None and b["mean"] is not None else ""
                if redefined:          # a switch of definition is not the system's: not compared
                    c["redefined"] = redefined
                if _failed(c):
                    why = f"{c['n_failed']} of {c['n']} runs failed"
                elif c["mean"] is not None and b["mean"] is not None and not redefined \
                        and c["mean"] > max(mult * b["mean"], floor):
                    margin = k * math.hypot(c["std"] or 0.0, mult * (b["std"] or 0.0))
                    c["margin"] = margin
                    if c["mean"] - max(mult * b["mean"], floor) > margin:
                        bar = (f"{mult:g} x the base's {b['mean']:.3g} ± {b['std'] or 0:.2g}" if mult * b["mean"] >= floor
                               else f"the floor {floor:g} ({mult:g} x the base's {b['mean']:.3g} is below it)")
                        why = (f"{metric} {c['mean']:.3g} ± {c['std'] or 0:.2g} > {bar}"
                               + (f" by more than {k:g} spread(s)" if margin > 0 else ""))
                    else:
                        c["within_spread"] = True
                c["broken"] = why is not None
                if why and found is None:
                    found = {"level": lv, "reason": why}
                cells.append(c)
            if _failed(b):
                found = {"level": "base", "reason": f"fails at the base ({b['n_failed']} of {b['n']} runs)"}
            curves[f.name][s.name] = cells
            gaps = [("the base", b)] * _unmeasured(b) + [(str(lv), c) for lv, c in zip(f.levels, cells) if _unmeasured(c)]
            moved = [(str(lv), c) for lv, c in zip(f.levels, cells) if c.get("redefined") and not c["broken"]]
            if found is None and (gaps or moved):   # no break found, but not every level was measured: say so
                why = []
                if gaps:
                    total = {k: sum(c.get(k, 0) for _, c in gaps)
                             for k in ("n", "n_failed", "n_missing", "n_ill_posed", "n_scale_ill_posed")}
                    why.append(f"not measured at {', '.join(w for w, _ in gaps)}: " + unmeasured_reason(total, metric))
                if moved:
                    why.append(f"not compared with the base at {', '.join(w for w, _ in moved)}: {moved[0][1]['redefined']}")
                found = {"level": None, "unmeasured": True, "reason": "; ".join(why)}
            if found is None:
                near = [lv for lv, c in zip(f.levels, cells) if c["within_spread"]]
                found = {"level": None, "reason": f"holds up to {f.levels[-1]}" + (
                    f" (above {mult:g} x the base's but within the spread at {', '.join(map(str, near))})"
                    if near else "")}
            if metric in PER_FRAME and getattr(f.factor, "name", None) in STEP_FACTORS:
                found["per_frame"] = (f"{metric} is per frame and {f.name} changes the frame's step: a steady error "
                                      "per metre reads as a trend of it" + (" (rpe_trans_per_m does not)"
                                                                           if metric == "rpe_trans_rmse" else ""))
                found["reason"] += f" — note: {found['per_frame']}"
            breaks[f.name][s.name] = found
    return curves, base, breaks


def results(study, plan, runs: list, controls: dict, cost: dict) -> dict:
    """The whole results.json document."""
    metric = study.evaluation.metric
    aggs = aggregate(runs, metric)
    curves, base, breaks = curves_and_breaks(study, aggs, metric)
    w = study.world
    base_scenes = {}
    factors = []
    for f in study.factors:
        bl = None
        try:
            if not base_scenes:
                from ..ses.parser import parse_text
                v0 = plan.base_of(study.world.seeds[0])
                base_scenes[0] = parse_text(v0.script, "<base>", "/")
            bl = f.factor.base_level(base_scenes[0])
        except Exception:  # noqa: BLE001 - the base level is a label for the plots only
            bl = None
        if isinstance(bl, float) and bl == int(bl) and all(isinstance(x, int) for x in f.levels):
            bl = int(bl)
        factors.append({"name": f.name, "unit": f.unit, "doc": f.factor.doc, "stage": f.factor.stage,
                        "levels": list(f.levels), "base_level": bl, "options": f.options})
    variants = []
    for v in plan.variants:
        variants.append({"name": v.name, "label": v.label, "point": v.point, "world_seed": v.seed, "key": v.key,
                         "render_key": v.render_key, "stage": v.stage, "developed": v.developed,
                         "render": f"renders/{v.key}", "control": controls.get(v.key) if v.controlled else None})
    return {
        "format": FORMAT,
        "study": {"name": study.name, "description": study.description, "file": str(study.path),
                  "world": {"script": str(w.script) if w.script else None, "generator": w.generator,
                            "options": w.options, "frames": w.frames,
                            "resolution": list(w.resolution) if w.resolution else None, "quality": w.quality,
                            "samples": w.samples, "set": w.set},
                  "seeds": list(w.seeds),
                  "design": {"kind": study.design.kind, "samples": study.design.samples, "seed": study.design.seed},
                  "metric": metric, "break_multiple": study.evaluation.break_multiple,
                  "break_floor": BREAK_FLOOR.get(metric, 0.0),
                  "evaluation_versions": sorted({r["metrics"]["evaluation_version"] for r in runs
                                                 if (r.get("metrics") or {}).get("evaluation_version") is not None}),
                  "break_sigmas": study.evaluation.break_sigmas,
                  "min_coverage": study.evaluation.min_coverage, "jump_factor": study.evaluation.jump_factor,
                  "regression_sigmas": study.evaluation.regression_sigmas},
        "factors": factors,
        "systems": [{"name": s.name, "builtin": s.builtin, "cmd": list(s.cmd), "layout": s.layout,
                     "format": s.format, "trials": s.trials, "mono": s.mono, "timeout_s": s.timeout_s}
                    for s in study.systems],
        "variants": variants,
        "runs": runs,
        "points": [{"label": k[0], **v} for k, v in sorted(aggs.items())],
        "curves": curves,
        "base": base,
        "breaking_points": breaks,
        "cost": cost,
    }


# --- compare ---------------------------------------------------------------------------------

def _cells(doc: dict) -> dict:
    """{(factor, level, system): cell} of a results document (the base as factor '(base)')."""
    out = {}
    for s, c in (doc.get("base") or {}).items():
        out[("(base)", "", s)] = c
    for f in doc.get("factors", []):
        for s, cells in (doc.get("curves", {}).get(f["name"]) or {}).items():
            for lv, c in zip(f["levels"], cells):
                out[(f["name"], str(lv), s)] = c
    if not doc.get("curves"):
        metric = doc["study"]["metric"]
        for p in doc.get("points", []):
            m = p["metrics"][metric]
            out[("(point)", p["label"], p["system"])] = {"n": p["n"], "n_failed": p["n_failed"], "mean": m["mean"],
                                                         "std": m["std"], "n_missing": m.get("n_missing", 0),
                                                         "n_ill_posed": p.get("n_ill_posed", 0),
                                                         "n_scale_ill_posed": p.get("n_scale_ill_posed", 0),
                                                         "definitions": p.get("definitions")}
    return out


def _versions(doc: dict) -> "set | None":
    """The evaluation versions of a document's runs; None where it does not record them (before format 3)."""
    v = (doc.get("study") or {}).get("evaluation_versions")
    if v is None:
        return None if any((r.get("metrics") or {}) for r in doc.get("runs", [])) else set()
    return set(v)


def _version_text(v) -> str:
    return "not recorded (written before format 3)" if v is None else ", ".join(map(str, sorted(v)))


def compare(old: dict, new: dict, sigmas: float = 1.0) -> list[dict]:
    """One row per (factor, level, system) in either: ``verdict`` worse | better | same | unmeasured
    (module docstring); two evaluation versions: a SesgenError."""
    from ..errors import SesgenError
    for d, which in ((old, "OLD"), (new, "NEW")):
        if not str(d.get("format", "")).startswith("sesgen-study-results/"):
            raise SesgenError(f"{which}: not a study's results.json (format {d.get('format')!r})")
    if old["study"]["metric"] != new["study"]["metric"]:
        raise SesgenError(f"the two studies measure different errors ({old['study']['metric']} and "
                         f"{new['study']['metric']})")
    vo, vn = _versions(old), _versions(new)
    if vo != vn and vo != set() and vn != set():
        raise SesgenError("the two studies were evaluated by different definitions (OLD: "
                          f"{_version_text(vo)}, NEW: {_version_text(vn)}): their figures cannot be told apart from "
                          "the change; run OLD's study again with this code (its runs are evaluated again, not run) "
                          "and compare its new results.json")
    a, b = _cells(old), _cells(new)
    rows = []
    for key in [k for k in a if k in b]:
        o, n = a[key], b[key]
        fo = o["n_failed"] / o["n"] if o["n"] else 0.0
        fn = n["n_failed"] / n["n"] if n["n"] else 0.0
        verdict, why = "same", ""
        redefined = _redefined(o, n, ("OLD", "NEW")) if o["mean"] is not None and n["mean"] is not None else ""
        if fn == fo and redefined:      # two definitions' values: no verdict on the system from them
            verdict, why = "unmeasured", f"{redefined}: not comparable"
        elif fn == fo and (_unmeasured(o) or _unmeasured(n)):
            verdict = "unmeasured"
            why = "; ".join(f"{w}: {unmeasured_reason(c, old['study']['metric'])}"
                            for w, c in (("OLD", o), ("NEW", n)) if _unmeasured(c))
        elif fn > fo:
            verdict, why = "worse", f"fails {n['n_failed']}/{n['n']} (was {o['n_failed']}/{o['n']})"
        elif fn < fo:
            verdict, why = "better", f"fails {n['n_failed']}/{n['n']} (was {o['n_failed']}/{o['n']})"
        elif o["mean"] is not None and n["mean"] is not None:
            spread = max(o["std"] or 0.0, n["std"] or 0.0)
            margin = sigmas * spread + REL_TOL * max(1.0, abs(o["mean"]))
            if n["mean"] > o["mean"] + margin:
                verdict = "worse"
            elif n["mean"] < o["mean"] - margin:
                verdict = "better"
            why = f"{o['mean']:.4g} ± {o['std'] or 0:.2g} -> {n['mean']:.4g} ± {n['std'] or 0:.2g}"
            if verdict != "same" and spread == 0.0 and _n_ok(o) == 1 == _n_ok(n):
                why += " (one run each: no spread to judge by; more trials or world seeds give one)"
        rows.append({"factor": key[0], "level": key[1], "system": key[2], "verdict": verdict, "detail": why})
    for key, only in [(k, "OLD") for k in a if k not in b] + [(k, "NEW") for k in b if k not in a]:
        rows.append({"factor": key[0], "level": key[1], "system": key[2], "verdict": "unmeasured",
                     "detail": f"only in {only}: the other study has no such level or system (nothing to compare)"})
    return rows
