"""A report folder: ``metrics.json``, the plots and a short ``summary.md``."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from .trajectory_eval import TrajectoryEvaluation, summary_lines


def write_json(path, data: dict) -> Path:
    """JSON with numpy scalars/arrays turned into plain numbers/lists; written atomically."""
    return atomic.write_text(path, json.dumps(data, indent=2, default=_plain) + "\n")


def _plain(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def write_report(out_dir, ev: TrajectoryEvaluation, title: str = "Trajectory evaluation",
                 inputs: dict | None = None, plots: bool = True, extra: dict | None = None) -> dict:
    """Write ``metrics.json``, PNG plots (``plots=True``) and ``summary.md`` into ``out_dir``.

    ``inputs``: e.g. ``{"gt": path, "est": path}`` (recorded in both files); ``extra``: more
    JSON-ready entries merged into ``metrics.json``. Returns ``{name: path}`` of what was written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    metrics = ev.metrics()
    if inputs:
        metrics["inputs"] = {k: str(v) for k, v in inputs.items()}
    if extra:
        metrics.update(extra)
    files = {"metrics": write_json(out / "metrics.json", metrics)}
    if plots:
        from .plots import plot_evaluation
        files.update(plot_evaluation(ev, out))
    lines = [f"# {title}", ""]
    for k, v in (inputs or {}).items():
        lines.append(f"- {k}: `{v}`")
    lines += ["", "```", *summary_lines(ev), "```", ""]
    if ev.egomotion is not None:
        lines += [ev.egomotion.to_markdown(max_rows=40), ""]
    for name, p in files.items():
        if Path(p).suffix == ".png":
            lines.append(f"![{name}]({Path(p).name})")
    lines += ["", "Definitions: docs/evaluation.md (APE/RPE as evo, KITTI as the devkit)."]
    files["summary"] = out / "summary.md"
    atomic.write_text(files["summary"], "\n".join(lines) + "\n")
    return files
