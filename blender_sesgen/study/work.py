"""The bodies of a study's tasks (pure: the standard library): export a variant's render,
run one trial of one system on it. The runner submits them as Ray tasks
(``farm.tasks.TaskGraph``); each is resumable on its own -- its result is a JSON file
written last and atomically, found and returned at once by a rerun -- and runs its child
process through :mod:`.launch` (bound to the task's life).
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Optional

from ..contract import atomic
from . import systems

DONE = "done.json"
FAILED = "failed.json"
# A trajectory over this size is not read: a pose line is at most ~400 bytes in any format
# (EuRoC's 17 columns), so 4 KiB a frame leaves room for 10 poses a frame; reading a 100 MB
# KITTI file to say "4369066 poses for 10 frames" took the evaluation 95 s and 3.7 GB.
TRAJECTORY_BYTES_PER_FRAME = 4096
TRAJECTORY_BYTES_SLACK = 1 << 20


def export_failure(out_dir) -> Optional[str]:
    """Why the export in ``out_dir`` failed the last time it ran (None: it did not fail)."""
    rec = _read(Path(out_dir) / FAILED)
    return None if rec is None else rec.get("error")


def _read(path: Path) -> Optional[dict]:
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def export_done(out_dir, render_dir: str) -> Optional[dict]:
    """The record of the finished export of ``render_dir`` in ``out_dir`` (None: not done)."""
    done = _read(Path(out_dir) / DONE)
    return done if done is not None and done.get("render") == str(render_dir) else None


def export_variant(vo: list, render_dir: str, out_dir: str, layout: str) -> dict:
    """``vo_reference export RENDER OUT --to LAYOUT`` into a fresh ``out_dir/data``, then
    made read-only; ``out_dir/done.json`` records it (and is returned by a rerun)."""
    out = Path(out_dir)
    done = export_done(out, render_dir)
    if done is not None:
        return done
    data = out / "data"
    systems.remove_tree(data)
    out.mkdir(parents=True, exist_ok=True)
    cmd = [*vo, "export", render_dir, str(data), "--to", layout, "--progress", "off"]
    t0 = time.monotonic()
    from .launch import command
    proc = subprocess.run(command(out, cmd),
                          stdin=subprocess.DEVNULL, capture_output=True, text=True, errors="replace")
    rec = {"render": render_dir, "layout": layout, "dataset": str(data), "wall_s": round(time.monotonic() - t0, 3),
           "ok": proc.returncode == 0}
    if proc.returncode != 0:
        lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
        errs = [ln for ln in lines if "error" in ln.lower()]
        rec["error"] = (errs or lines or [f"exit code {proc.returncode}"])[-1]
        atomic.write_json(out / FAILED, rec)   # for the results; not done: a rerun tries again
        return rec
    (out / FAILED).unlink(missing_ok=True)
    rec["sequence"] = str(systems.dataset_folder(data))
    systems.set_read_only(data)
    atomic.write_json(out / DONE, rec)
    return rec


def run_trial(export: dict, cmd: list, vo: list, run_dir: str, trial: int, frames: int, timeout_s: float,
              env: dict, est_name: str, base_env: Optional[dict] = None) -> dict:
    """One trial of one system on an exported dataset; ``run_dir/run.json`` records how it
    ended (and is returned by a rerun). A failed export is this run's failure. ``base_env``:
    the environment the study started in (a Ray worker's adds Ray's own variables and
    OMP_NUM_THREADS; the system gets the study's on every path)."""
    rd = Path(run_dir)
    done = _read(rd / "run.json")
    if done is not None:
        return done
    rd.mkdir(parents=True, exist_ok=True)
    est = rd / est_name
    est.unlink(missing_ok=True)
    (rd / "metrics.json").unlink(missing_ok=True)     # a record of a trajectory no longer there
    if not isinstance(export, dict) or not export.get("ok"):
        why = export.get("error") if isinstance(export, dict) else getattr(export, "message", str(export))
        return {"rc": None, "timed_out": False, "error": f"the dataset could not be exported: {why}",
                "est": str(est), "export_failed": True}
    values = {"dataset": export["dataset"], "sequence": export["sequence"], "out": str(est),
              "workdir": str(rd / "work"), "trial": trial, "frames": frames, "python": sys.executable}
    argv = systems.expand(cmd, values, vo)
    rec = systems.run(argv, rd, timeout_s, env, base_env)
    rec.update(est=str(est), trial=trial, est_bytes=est.stat().st_size if est.is_file() else None)
    limit = TRAJECTORY_BYTES_PER_FRAME * max(int(frames), 0) + TRAJECTORY_BYTES_SLACK
    if rec.get("error") is None and (rec["est_bytes"] or 0) > limit:
        rec["error"] = (f"wrote a trajectory of {rec['est_bytes']} bytes for {frames} frame(s) "
                        f"(more than {limit}: not read)")
    atomic.write_json(rd / "run.json", rec)
    return rec
