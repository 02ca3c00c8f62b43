"""docs/img/study_<NAME>_error.png and _frames.png, and the markdown table of docs/studies.md's
example studies, from a study folder (its results.json and renders).

    python tools/make_study_figures.py out/city_exposure city_exposure
"""
from __future__ import annotations

import argparse
import base64
from pathlib import Path

from vo_reference.study.report import Report, factor_plot, frame_strip

IMG = Path(__file__).resolve().parents[1] / "docs" / "img"


def write_png(uri: str, path: Path) -> None:
    path.write_bytes(base64.b64decode(uri.split(",", 1)[1]))
    print(f"wrote {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path)
    ap.add_argument("name")
    a = ap.parse_args()
    rep = Report(a.folder)
    r = rep.r
    f = r["factors"][0]
    write_png(factor_plot(f, r["curves"][f["name"]], r["base"], rep.systems, rep.metric),
              IMG / f"study_{a.name}_error.png")
    seed = r["study"]["seeds"][0]
    base = next(v for v in r["variants"] if v["world_seed"] == seed and not v["point"])
    shown = [("base", base)] + [(f"{lv} {f['unit']}", rep.variant_at(f["name"], lv, seed)) for lv in f["levels"]]
    images = [(t, rep.first_frame(v)) for t, v in shown if v is not None]
    write_png(frame_strip([im for _, im in images], [t for t, _ in images]), IMG / f"study_{a.name}_frames.png")
    names = [s["name"] for s in rep.systems]
    print(f"\n| {f['name']} ({f['unit']}) | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    rows = [("base", r["base"])] + [(lv, {s: r["curves"][f["name"]][s][i] for s in names})
                                    for i, lv in enumerate(f["levels"])]
    metric = r["study"]["metric"]
    for lv, cells in rows:
        out = []
        point = {} if lv == "base" else {f["name"]: lv}
        for s in names:
            c = cells[s]
            per_seed = ", ".join("×" if x["status"] != "ok" else "not measured" if x["metrics"].get(metric) is None
                                 else f"{x['metrics'][metric]:.2f}"
                                 for x in sorted(r["runs"], key=lambda x: (x["world_seed"], x["trial"]))
                                 if x["system"] == s and x["point"] == point)
            one = c.get("n", 0) - c.get("n_failed", 0) == 1         # one value: no spread, not a spread of 0
            text = (f"{c['mean']:.3f} " + ("(1 run)" if one else f"± {c['std'] or 0:.3f} ({per_seed})")
                    if c["mean"] is not None
                    else "failed" if c.get("n_failed", 0) >= c.get("n", 0) else f"not measured ({per_seed})")
            if c.get("n_failed"):
                text += f" ({c['n_failed']}/{c['n']} failed)"
            out.append(f"**{text}**" if c.get("broken") else text)
        print(f"| {lv} | " + " | ".join(out) + " |")
    print("\nbreaking points:", {s: b for s, b in r["breaking_points"][f["name"]].items()})
    print("cost:", r["cost"])
    print("controls:", [(v["name"], v["control"]) for v in r["variants"] if v.get("control")])


if __name__ == "__main__":
    main()
