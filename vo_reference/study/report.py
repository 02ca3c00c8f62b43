"""A verification study's report: one self-contained HTML page (plots embedded as PNG data
URIs, no script, nothing fetched) from the study folder's ``results.json``.

Sections: what was run and what it cost; the ground-truth controls; per factor the error
against the level for every system (mean and spread over trials and world seeds, failed
runs marked), a strip of each level's first frame, each run's trajectory seen from above;
the breaking-point table; every run with its alignment, failure and the tail of its stderr.
A measure missing from a point's runs (the APE rotation where the fit leaves the rotation
free, ``alignment_ill_posed``; a monocular run's translations where its Sim(3) fit does not fix
the scale, ``scale_ill_posed``) is shown as not measured, never as a number; in the plots as ○
on the axis (× at the top: failed), and the text under each plot counts them: no point vanishes.
"""
from __future__ import annotations

import base64
import html
import io
import json
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from ..evaluate.plots import pyplot

COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")


def _png(fig, dpi: int = 100) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    pyplot().close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _img(uri: str, alt: str) -> str:
    return f'<img src="{uri}" alt="{html.escape(alt)}">'


def _fmt(x, digits: int = 4) -> str:
    if x is None:
        return "—"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return html.escape(str(x))


def _xs(levels) -> tuple[list, list, bool]:
    """Plot positions of levels: their values when numeric, else 0, 1, 2, ..."""
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in levels)
    return (list(levels) if numeric else list(range(len(levels)))), [str(v) for v in levels], numeric


def _world_size(w: dict) -> str:
    """The base world's frames, image size and quality as the study file set them."""
    res = w.get("resolution")
    size = ("the script's size" if not res else f"{res[1]:g} × the script's size" if res[0] == "scale"
            else f"{res[1]} × {res[2]} px")
    frames = "every frame" if w.get("frames") is None else f"the first {w['frames']} frames"
    return f"{frames}, {size}, {w.get('quality') or 'the script’s quality'}"


def factor_plot(factor: dict, curves: dict, base: dict, systems: list, metric: str) -> str:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.2, 3.6))
    levels = factor["levels"]
    xs, names, numeric = _xs(levels)
    top = 0.0
    for i, s in enumerate(systems):
        rows = curves.get(s["name"], [])
        c = COLOURS[i % len(COLOURS)]
        x = [xs[j] for j, r in enumerate(rows) if r["mean"] is not None]
        y = [r["mean"] for r in rows if r["mean"] is not None]
        e = [r["std"] or 0.0 for r in rows if r["mean"] is not None]
        if y:
            ax.errorbar(x, y, yerr=e, color=c, marker="o", ms=4, capsize=3, label=s["name"])
            top = max(top, max(np.add(y, e)))
        b = base.get(s["name"]) or {}
        if b.get("mean") is not None:
            ax.axhline(b["mean"], color=c, lw=0.8, ls=":")
            if b.get("std"):          # the base's own spread: what a level must clear to count
                ax.axhspan(b["mean"] - b["std"], b["mean"] + b["std"], color=c, alpha=0.08, lw=0)
    top = top or 1.0
    gaps = False
    for i, s in enumerate(systems):
        rows = curves.get(s["name"], [])
        fx = [xs[j] for j, r in enumerate(rows) if r["n_failed"] and r["n_failed"] * 2 >= r["n"]]
        if fx:
            ax.plot(fx, [top * 1.08] * len(fx), "x", color=COLOURS[i % len(COLOURS)], ms=9, mew=2)
        ux = [xs[j] for j, r in enumerate(rows) if r["mean"] is None and r["n"] > r["n_failed"]]
        if ux:               # ran, but the measure is missing: an open circle on the axis, not a value
            gaps = True
            ax.plot(ux, [0.0] * len(ux), "o", color=COLOURS[i % len(COLOURS)], mfc="none", ms=8, mew=1.5,
                    clip_on=False)
    if factor.get("base_level") is not None and numeric and isinstance(factor["base_level"], (int, float)):
        ax.axvline(factor["base_level"], color="0.6", lw=0.8, ls="--")
    if not numeric:
        ax.set_xticks(xs, names)
    return _finish(ax, fig, factor, metric, "mean ± spread (trials × world seeds); × = failed; dotted, band: the base ± "
                   "its spread" + ("; ○ on the axis = not measured" if gaps else ""))


def _finish(ax, fig, factor: dict, metric: str, title: str) -> str:
    """Axes labelled with the factor (and its unit) and the error; the figure as a PNG URI."""
    ax.set_xlabel(f"{factor['name']} ({factor['unit']})")
    ax.set_ylabel(metric)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    ax.set_title(title, fontsize=8)
    return _png(fig)


def frame_strip(images: list, titles: list) -> str:
    """The images side by side (one above the other when they are wide, as KITTI's)."""
    plt = pyplot()
    n = len(images)
    h, w = images[0].shape[:2]
    if w > 2 * h:
        fig, axes = plt.subplots(n, 1, figsize=(7.0, n * (7.0 * h / w + 0.3)))
    else:
        fig, axes = plt.subplots(1, n, figsize=(min(2.6 * n, 16), 2.6 * h / w + 0.4))
    for ax, im, t in zip(np.atleast_1d(axes), images, titles):
        ax.imshow(im)
        ax.set_title(t, fontsize=8)
        ax.axis("off")
    return _png(fig)


def _unplotted(c: dict) -> str:
    """'failed' (at least half the runs: × at the top), 'unmeasured' (ran, but no mean: ○ on the
    axis) or '' (a value) for a cell or point aggregate."""
    if c.get("n") and 2 * c.get("n_failed", 0) >= c["n"]:
        return "failed"
    if c.get("mean") is None and c.get("n", 0) > c.get("n_failed", 0):
        return "unmeasured"
    return ""


def scatter_plot(factor: dict, points: list, systems: list, metric: str) -> str:
    """Every design point's mean error against this factor's level (grid and Latin-hypercube
    designs: the other factors vary too); points without a value are not dropped: × at the top
    (failed), ○ on the axis (not measured), each with a legend entry and its count."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.2, 3.6))
    xs, names, numeric = _xs(factor["levels"])
    where = dict(zip(map(str, factor["levels"]), xs))
    rows = []
    for i, s in enumerate(systems):
        for p in points:
            if p["system"] == s["name"] and factor["name"] in p["point"] and str(p["point"][factor["name"]]) in where:
                cell = {"n": p["n"], "n_failed": p["n_failed"], **((p.get("metrics") or {}).get(metric) or {})}
                rows.append((i, s["name"], where[str(p["point"][factor["name"]])], cell))
    values = [c["mean"] for _, _, _, c in rows if c.get("mean") is not None]
    top = max(values) if values else 1.0
    for i, s in enumerate(systems):
        colour = COLOURS[i % len(COLOURS)]
        mine = [(x, c) for j, _, x, c in rows if j == i]
        xy = [(x, c["mean"]) for x, c in mine if c.get("mean") is not None]
        if xy:
            ax.plot(*zip(*xy), "o", color=colour, ms=5, label=s["name"])
        fx = [x for x, c in mine if _unplotted(c) == "failed"]
        if fx:
            ax.plot(fx, [top * 1.08] * len(fx), "x", color=colour, ms=9, mew=2, clip_on=False,
                    label=f"{s['name']}: failed ({len(fx)})")
        ux = [x for x, c in mine if _unplotted(c) == "unmeasured"]
        if ux:
            ax.plot(ux, [0.0] * len(ux), "o", color=colour, mfc="none", ms=8, mew=1.5, clip_on=False,
                    label=f"{s['name']}: not measured ({len(ux)})")
    if not numeric:
        ax.set_xticks(xs, names)
    return _finish(ax, fig, factor, metric, "every point of the design (the other factors vary too); × = failed, "
                   "○ on the axis = not measured")


def plot_note(groups: list, metric: str, what: str = "point") -> str:
    """The HTML sentence under a plot: per system, how many of its cells (``groups``: [(system,
    [cell, ...])]) the plot shows without a value, and why -- so that none vanishes unsaid."""
    parts = []
    for name, cells in groups:
        cells = [c for c in cells if c]
        failed = sum(_unplotted(c) == "failed" for c in cells)
        gaps = [c for c in cells if _unplotted(c) == "unmeasured"]
        bits = []
        if gaps:
            free = sum(c.get("n_ill_posed", 0) for c in gaps)
            scale = sum(c.get("n_scale_ill_posed", 0) for c in gaps)
            bits.append(f"{len(gaps)} of {len(cells)} {what}s not measured (○ on the axis: {metric} missing from "
                        f"{sum(c.get('n_missing', 0) for c in gaps)} run(s)"
                        + (f", {free} with the rotation free" if free and metric == "ape_rot_rmse_deg" else "")
                        + (f", {scale} with the mono scale not fixed" if scale else "") + ")")
        if failed:
            bits.append(f"{failed} of {len(cells)} {what}s failed (× at the top)")
        if bits:
            parts.append(f"{html.escape(name)}: {'; '.join(bits)}")
    return f"<p class='note'>Without a value in the plot — {'. '.join(parts)}.</p>" if parts else ""


def trajectory_grid(rows: list, systems: list) -> str:
    """``rows``: (level title, gt xyz, {system: [est xyz of each trial, or None]}) per level."""
    plt = pyplot()
    fig, axes = plt.subplots(len(rows), len(systems), figsize=(2.4 * len(systems) + 0.4, 2.2 * len(rows)),
                             squeeze=False)
    for r, (title, gt, est) in enumerate(rows):
        # from above: the SES world's ground plane (x, z; y is up), the longer extent across
        a, b = (2, 0) if np.ptp(gt[:, 2]) > np.ptp(gt[:, 0]) else (0, 2)
        for c, s in enumerate(systems):
            ax = axes[r, c]
            ax.plot(gt[:, a], gt[:, b], "k-", lw=1.2, label="ground truth")
            trials = est.get(s["name"]) or []
            for e in trials:
                if e is not None and len(e):
                    ax.plot(e[:, a], e[:, b], "-", color=COLOURS[c % len(COLOURS)], lw=1, alpha=0.8)
            failed = sum(e is None for e in trials)
            if failed:
                ax.text(0.5, 0.5, "failed" if failed == len(trials) else f"{failed} of {len(trials)} failed",
                        transform=ax.transAxes, ha="center", color="red")
            ax.set_aspect("equal", adjustable="datalim")
            ax.tick_params(labelsize=6)
            ax.set_xlabel("xyz"[a] + " (m)", fontsize=6)
            if r == 0:
                ax.set_title(s["name"], fontsize=8)
            if c == 0:
                ax.set_ylabel(title, fontsize=8)
    return _png(fig)


class Report:
    def __init__(self, folder):
        self.root = Path(folder)
        path = self.root / "results.json"
        try:
            self.r = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as e:
            raise VoError(f"{path}: cannot read the study's results ({e})") from None
        if not str(self.r.get("format", "")).startswith("sesgen-study-results/"):
            raise VoError(f"{path}: not a study's results (format {self.r.get('format')!r})")
        self.variants = {v["name"]: v for v in self.r["variants"]}
        self.systems = self.r["systems"]
        self.metric = self.r["study"]["metric"]

    def first_frame(self, variant: dict):
        from ..io.render import RenderSequence
        try:
            return RenderSequence(self.root / variant["render"]).image_rgb(0, "left")
        except (VoError, OSError):
            return None

    def gt_xyz(self, variant: dict) -> np.ndarray:
        from ..io.trajectory import read_render_poses
        try:
            return read_render_poses(self.root / variant["render"]).positions
        except VoError:
            return np.zeros((0, 3))

    def runs_of(self, variant: str, system: str) -> list:
        return sorted((r for r in self.r["runs"] if r["variant"] == variant and r["system"] == system),
                      key=lambda r: r["trial"])

    def est_xyz(self, run) -> "np.ndarray | None":
        if run is None or run["status"] != "ok":
            return None
        m = run.get("metrics") or {}
        return np.array(m["est_xyz"]) if m.get("est_xyz") else None

    def variant_at(self, factor: str, level, seed) -> "dict | None":
        for v in self.r["variants"]:
            if v["world_seed"] == seed and v["point"] == {factor: level}:
                return v
        return None

    def html(self) -> str:
        r = self.r
        st = r["study"]
        out = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(st['name'])}</title>",
               f"<style>{CSS}</style></head><body>",
               f"<h1>Study: {html.escape(st['name'])}</h1>"]
        if st.get("description"):
            out.append(f"<p>{html.escape(st['description'])}</p>")
        out.append(self.overview())
        out.append(self.controls())
        seed0 = st["seeds"][0]
        for f in r["factors"]:
            out.append(self.factor_section(f, seed0))
        if st["design"]["kind"] != "oat":
            out.append(self.points_section())
        out.append(self.breaking_points())
        out.append(self.runs_table())
        out.append("</body></html>")
        return "\n".join(out)

    def overview(self) -> str:
        st, c = self.r["study"], self.r.get("cost", {})
        w = st["world"]
        world = w.get("script") or f"generator {w.get('generator')} {w.get('options') or ''}"
        rows = [("world", world), ("world seeds", ", ".join(map(str, st["seeds"]))),
                ("frames, size, quality", _world_size(w)),
                ("design", st["design"]["kind"] + (f" ({st['design']['samples']} samples, seed {st['design']['seed']})"
                                                   if st["design"]["kind"] == "lhs" else "")),
                ("metric", f"{self.metric}; broken: {self.broken_rule()}"),
                ("systems", "; ".join(f"{s['name']} ({s.get('builtin') or 'command'}, {s['layout']}, {s['format']}"
                                      f"{', mono' if s['mono'] else ''}, {s['trials']} trial(s))" for s in self.systems)),
                ("variants", f"{c.get('variants')} ({c.get('distinct_scripts')} distinct scripts)"),
                ("renders", f"{c.get('renders')} rendered, {c.get('developed')} developed from another render's EXRs "
                            f"(sensor stage only), {c.get('renders_saved')} saved"),
                ("frames rendered (this run)", c.get("frames_rendered")),
                ("wall time (this run)", f"{c.get('wall_s', 0):.1f} s, rendering {c.get('render_wall_s', 0):.1f} s "
                                         f"({c.get('render_share', 0):.0%})"),
                ("runs", f"{len(self.r['runs'])}, {sum(1 for x in self.r['runs'] if x['status'] != 'ok')} failed")]
        free = [x for x in self.r["runs"] if x["status"] == "ok" and (x.get("metrics") or {}).get("alignment_ill_posed")]
        if free:
            rows.append(("APE rotation", f"not measured in {len(free)} of {len(self.r['runs'])} runs: their path is too "
                                         "short or straight for the SE(3)/Sim(3) fit to fix its rotation (the roll "
                                         "about the path is free; the runs' alignment column gives the fit's 1σ), so "
                                         "ape_rot_rmse_deg would measure the fit, not the system. Read there "
                                         "ape_rot_origin_rmse_deg (every run: the rotation error after putting the first "
                                         "poses together, the drift from the start) or rpe_rot_rmse_deg (frame to frame)"))
        unscaled = [x for x in self.r["runs"] if x["status"] == "ok" and (x.get("metrics") or {}).get("scale_ill_posed")]
        if unscaled:
            rows.append(("mono scale", f"not fixed in {len(unscaled)} of {len(self.r['runs'])} runs: the Sim(3) fit's scale "
                                       "ambiguity is 0.1 or more (the estimate barely moves against its noise, or does "
                                       "not follow the path), so their translations — APE, RPE, per metre, KITTI, the "
                                       "tracking loss's jumps — are not measured. Their rotations are"))
        return "<h2>Overview</h2><table>" + "".join(
            f"<tr><th>{html.escape(k)}</th><td>{_fmt(v)}</td></tr>" for k, v in rows) + "</table>"

    def controls(self) -> str:
        checked = [v for v in self.r["variants"] if v.get("control")]
        if not checked:
            return ""
        bad = [v for v in checked if not v["control"].get("identical")]
        text = (f"<h2>Controlled variants</h2><p>{len(checked) - len(bad)} of {len(checked)} variants whose factors "
                "change only the image or the sensor have ground truth (poses, depth and object ids of every frame "
                "and view) byte-identical to their base.</p>")
        if bad:
            text += "<table><tr><th>variant</th><th>difference</th></tr>" + "".join(
                f"<tr><td>{html.escape(v['name'])}</td><td>{html.escape(str(v['control'].get('difference')))}</td></tr>"
                for v in bad) + "</table>"
        return text

    def factor_section(self, f: dict, seed0) -> str:
        name = f["name"]
        out = [f"<h2>Factor {html.escape(name)} ({html.escape(f['unit'])})</h2>",
               f"<p>{html.escape(f.get('doc') or '')} — stage <b>{html.escape(f['stage'])}</b>; levels "
               f"{', '.join(map(str, f['levels']))}; the base: {_fmt(f.get('base_level'))}.</p>"]
        curves = self.r.get("curves", {}).get(name)
        if curves is not None:
            out.append(_img(factor_plot(f, curves, self.r.get("base", {}), self.systems, self.metric),
                            f"{self.metric} against {name}"))
            out.append(plot_note([(s["name"], [(self.r.get("base") or {}).get(s["name"]), *(curves.get(s["name"]) or [])])
                                  for s in self.systems], self.metric))
            out.append(self.curve_table(f, curves))
        elif self.r.get("points"):
            out.append(_img(scatter_plot(f, self.r["points"], self.systems, self.metric),
                            f"{self.metric} against {name} at every point"))
            out.append(plot_note([(s["name"], [{"n": p["n"], "n_failed": p["n_failed"], "n_ill_posed": p.get("n_ill_posed", 0),
                                                "n_scale_ill_posed": p.get("n_scale_ill_posed", 0),
                                                **((p.get("metrics") or {}).get(self.metric) or {})}
                                               for p in self.r["points"] if p["system"] == s["name"]])
                                  for s in self.systems], self.metric))
        images, titles, rows = [], [], []
        base = next((v for v in self.r["variants"] if v["world_seed"] == seed0 and not v["point"]), None)
        for lv in [None, *f["levels"]]:
            v = base if lv is None else self.variant_at(name, lv, seed0)
            if v is None:
                continue
            title = "base" if lv is None else f"{lv}"
            im = self.first_frame(v)
            if im is not None:
                images.append(im)
                titles.append(title)
            rows.append((title, self.gt_xyz(v), {s["name"]: [self.est_xyz(r) for r in self.runs_of(v["name"], s["name"])]
                                                 for s in self.systems}))
        if images:
            out.append(f"<h3>First frame of each level (world seed {seed0})</h3>")
            out.append(_img(frame_strip(images, titles), f"first frames of {name}"))
        if rows and all(len(g) for _, g, _ in rows):
            out.append(f"<h3>Trajectories from above (world seed {seed0}, every trial; black: ground truth)</h3>")
            out.append(_img(trajectory_grid(rows, self.systems), f"trajectories of {name}"))
        return "\n".join(out)

    def curve_table(self, f: dict, curves: dict) -> str:
        head = "".join(f"<th>{html.escape(s['name'])}</th>" for s in self.systems)
        body = []
        base = self.r.get("base", {})
        cells = "".join(f"<td>{_cell(base.get(s['name']))}</td>" for s in self.systems)
        body.append(f"<tr><td>base ({_fmt(f.get('base_level'))})</td>{cells}</tr>")
        for j, lv in enumerate(f["levels"]):
            cells = "".join(f"<td>{_cell((curves.get(s['name']) or [None] * len(f['levels']))[j])}</td>"
                            for s in self.systems)
            body.append(f"<tr><td>{html.escape(str(lv))}</td>{cells}</tr>")
        return f"<table><tr><th>level</th>{head}</tr>{''.join(body)}</table>"

    def points_section(self) -> str:
        pts = self.r.get("points", [])
        names = [f["name"] for f in self.r["factors"]]
        head = "".join(f"<th>{html.escape(n)}</th>" for n in names) + "<th>system</th><th>n</th><th>failed</th>" \
            f"<th>{html.escape(self.metric)}</th>"
        rows = []
        for p in pts:
            m = (p.get("metrics") or {}).get(self.metric) or {}
            rows.append("<tr>" + "".join(f"<td>{_fmt(p['point'].get(n))}</td>" for n in names)
                        + f"<td>{html.escape(p['system'])}</td><td>{p['n']}</td><td>{p['n_failed']}</td>"
                        f"<td>{_cell({'n': p['n'], 'n_failed': p['n_failed'], 'n_ill_posed': p.get('n_ill_posed'), **m})}</td></tr>")
        return f"<h2>Every point of the design</h2><table><tr>{head}</tr>{''.join(rows)}</table>"

    def breaking_points(self) -> str:
        bp = self.r.get("breaking_points") or {}
        if not bp:
            return ""
        head = "".join(f"<th>{html.escape(s['name'])}</th>" for s in self.systems)
        rows = []
        for f in self.r["factors"]:
            cells = []
            for s in self.systems:
                b = bp.get(f["name"], {}).get(s["name"]) or {}
                lv = b.get("level")
                cells.append(f"<td>{'—' if lv is None else html.escape(str(lv)) + ' ' + html.escape(f['unit'])}"
                             f"<br><small>{html.escape(b.get('reason') or '')}</small></td>")
            rows.append(f"<tr><td>{html.escape(f['name'])}</td>{''.join(cells)}</tr>")
        return ("<h2>Breaking points</h2><p>The first level (in the order given) at which "
                f"{self.broken_rule()}; — : none within the levels. Errors as mean ± spread (sample standard "
                f"deviation over trials and world seeds).</p><table><tr><th>factor</th>{head}</tr>{''.join(rows)}</table>")

    def broken_rule(self) -> str:
        st = self.r["study"]
        mult, k, floor = st["break_multiple"], st.get("break_sigmas", 0.0), st.get("break_floor")
        spread = (f" by more than {k:g} × the spread of the difference (√(σ² + ({mult:g} σ_base)²))" if k else "")
        least = f" and {floor:g} (the least error that breaks: a base of 0 does not make every error a break)" \
            if floor else ""
        return f"the mean error exceeds {mult:g} × the base's{least}{spread}, or at least half the runs fail"

    def runs_table(self) -> str:
        rows = []
        for run in self.r["runs"]:
            m = run.get("metrics") or {}
            fail = html.escape(run.get("failure") or "")
            tail = run.get("stderr_tail") or []
            det = (f"<details><summary>stderr</summary><pre>{html.escape(chr(10).join(tail))}</pre></details>"
                   if tail and run["status"] != "ok" else "")
            rows.append(f"<tr><td>{html.escape(run['variant'])}</td><td>{html.escape(run['system'])}</td>"
                        f"<td>{run['trial']}</td><td class='{run['status']}'>{run['status']}</td>"
                        f"<td>{_metric(m, self.metric)}</td><td>{_fmt(m.get('rpe_trans_rmse'))}</td>"
                        f"<td>{_alignment(m)}</td><td>{_fmt(m.get('ape_rot_origin_rmse_deg'))}</td>"
                        f"<td>{_fmt(m.get('tracking_loss'))}</td><td>{_fmt(run.get('wall_s'), 3)}</td>"
                        f"<td>{fail}{det}</td></tr>")
        return ("<h2>Every run</h2><table><tr><th>variant</th><th>system</th><th>trial</th><th>status</th>"
                f"<th>{html.escape(self.metric)}</th><th>rpe_trans_rmse</th><th>alignment</th><th>APE rotation from the "
                "first pose (deg)</th><th>tracking loss</th><th>wall s</th>"
                f"<th>failure</th></tr>{''.join(rows)}</table>")


def _metric(m: dict, metric: str) -> str:
    """A run's measure; where it is missing, why (the rotation a fit leaves free)."""
    if m.get(metric) is None and metric == "ape_rot_rmse_deg" and m.get("alignment_ill_posed"):
        origin = m.get("ape_rot_origin_rmse_deg")
        return ("— <small>(not measured: the fit leaves the rotation free" +
                (f"; from the first pose {origin:.3g}°" if origin is not None else "") + ")</small>")
    if m.get(metric) is None and m.get("scale_ill_posed"):
        amb = m.get("scale_ambiguity")
        return ("— <small>(not measured: the Sim(3) fit does not fix the scale" +
                (f", ambiguity {amb:.2g}" if amb is not None else "") + ")</small>")
    if m.get(metric) is None and metric in (m.get("non_finite") or []):
        return "— <small>(not a finite number)</small>"
    return _fmt(m.get(metric))


def _alignment(m: dict) -> str:
    how = html.escape(str(m.get("alignment") or "—"))
    sigma = m.get("rotation_sigma_deg")
    if sigma is not None:
        how += f" <small>(rotation ±{sigma:.3g}°{', free: APE rotation not measured' if m.get('alignment_ill_posed') else ''})</small>"
    elif m.get("alignment_ill_posed"):
        how += " <small>(rotation free: a straight path; APE rotation not measured)</small>"
    if "scale_ambiguity" in m or m.get("scale_ill_posed"):
        amb = m.get("scale_ambiguity")
        how += (f" <small>(scale {_fmt(m.get('scale'))}, ambiguity {'∞' if amb is None else f'{amb:.2g}'}"
                f"{', not fixed: translations not measured' if m.get('scale_ill_posed') else ''})</small>")
    return how


def _cell(c) -> str:
    if not c:
        return "—"
    if c.get("mean") is None and c.get("n", 0) > c.get("n_failed", 0):
        s = (f"not measured <small>(missing from {c.get('n_missing', 0)} run(s){'; rotation free' if c.get('n_ill_posed') else ''}"
             f"{'; mono scale not fixed' if c.get('n_scale_ill_posed') else ''})</small>")
    else:
        one = c.get("n", 0) - c.get("n_failed", 0) == 1     # a spread of one value is not a spread of 0
        s = (f"{_fmt(c.get('mean'))} " + ("<small>(1 run: no spread)</small>" if one else f"± {_fmt(c.get('std'))}")
             if c.get("mean") is not None else "failed")
    if c.get("n_failed"):
        s += f" <small>({c['n_failed']}/{c['n']} failed)</small>"
    if c.get("broken"):
        s = f"<b>{s}</b>"
    if c.get("redefined"):
        s += f" <small>(not compared with the base: {html.escape(c['redefined'])})</small>"
    return s


CSS = """body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #ccc;padding:3px 7px;font-size:13px;
text-align:left;vertical-align:top}th{background:#f3f3f3}img{max-width:100%}.failed{color:#c00;font-weight:bold}
.ok{color:#070}pre{font-size:11px;white-space:pre-wrap;max-width:600px}h2{border-bottom:1px solid #ddd}"""


def write_report(folder) -> Path:
    """Write ``FOLDER/report.html`` from ``FOLDER/results.json``; its path."""
    page = Report(folder).html()
    return atomic.write_text(Path(folder) / "report.html", page)
